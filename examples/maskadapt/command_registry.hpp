#pragma once
// Subcommands of the `maskadapt` executable register themselves here, so that each group
// (motion, train-base, play, …) lives in its own cmd_*.cpp and main.cpp never changes.
#include <CLI/CLI.hpp>

#include <functional>
#include <string>
#include <vector>

namespace maskadapt::cli {

/// Adds one or more subcommands to the top-level app. Called once at start-up.
using CommandInstaller = std::function<void(CLI::App& app)>;

inline std::vector<CommandInstaller>& command_installers() {
  static std::vector<CommandInstaller> installers;
  return installers;
}

/// `static const bool registered = maskadapt::cli::register_command([](CLI::App& app) { … });`
inline bool register_command(CommandInstaller installer) {
  command_installers().push_back(std::move(installer));
  return true;
}

}  // namespace maskadapt::cli
