#pragma once
// Subcommands of the `maskadapt` executable register themselves here, so that each group
// (motion, train-base, play, …) lives in its own cmd_*.cpp and main.cpp never changes.
#include <CLI/CLI.hpp>

#include <ctime>
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

/// The command line this process was started with (set by main; words with spaces are quoted).
inline std::string& invocation() {
  static std::string line;
  return line;
}

/// Defined in a source that examples/CMakeLists.txt generates (maskadapt_git_commit_source).
const char* build_commit_id();

/// The git commit the executable was built from ("unknown" outside a git checkout).
inline std::string build_commit() { return build_commit_id(); }

/// The source tree the executable was configured from (models/, configs/, ../shared/data).
/// Defined in a source that cmake/build_paths.cmake generates, not a compile definition: an
/// absolute path of the checkout in the flags would enter the compiler-cache key of every
/// cmd_*.cpp, and a clone in another folder would recompile them all.
std::string source_dir();

/// "2026-12-01T20:15:00Z git 1a2b3c4: maskadapt train-base …" — one line of a run's provenance.
inline std::string provenance_line() {
  char when[32] = "unknown time";
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  if (gmtime_r(&now, &utc)) std::strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return std::string(when) + " git " + build_commit() + ": " + invocation();
}

}  // namespace maskadapt::cli
