// The `maskadapt` command-line tool: trainers, players, motion import/export, evaluation.
#include "command_registry.hpp"

#include <maskadapt/core/blas_threads.hpp>
#include <maskadapt/core/error.hpp>

#include <iostream>

int main(int argc, char** argv) {
  // The trainers parallelise over envs themselves; OpenBLAS threads would fight them.
  maskadapt::limit_blas_threads(1);
  CLI::App app{"maskadapt: learn physics-based humanoid controllers that adapt parts of the body"};
  app.require_subcommand(1);
  for (auto& install : maskadapt::cli::command_installers()) install(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const maskadapt::Error& e) {
    std::cerr << "maskadapt: error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "maskadapt: unexpected error: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
