// The `maskadapt` command-line tool: trainers, players, motion import/export, evaluation.
#include "command_registry.hpp"

#include <maskadapt/core/blas_threads.hpp>
#include <maskadapt/core/error.hpp>

#include <cstdlib>
#include <iostream>
#include <string>

#include <unistd.h>  // execv

int main(int argc, char** argv) {
  // OpenBLAS picks its kernels when it loads; where it fell back to an SSE-only family on a CPU
  // with AVX2/AVX-512 (core/blas_threads.hpp: recommended_blas_core), start again with the family
  // set. Once: the restarted process finds OPENBLAS_CORETYPE set. MASKADAPT_KEEP_BLAS_CORE=1
  // keeps OpenBLAS's own choice.
  if (const char* keep = std::getenv("MASKADAPT_KEEP_BLAS_CORE"); !(keep && *keep && *keep != '0')) {
    if (const std::string core = maskadapt::recommended_blas_core(); !core.empty()) {
      std::cerr << "maskadapt: OpenBLAS chose its " << maskadapt::blas_core_name()
                << " kernels (no FMA) on a CPU with " << (core == "SkylakeX" ? "AVX-512" : "AVX2 + FMA")
                << "; restarting with OPENBLAS_CORETYPE=" << core << " (set OPENBLAS_CORETYPE or MASKADAPT_KEEP_BLAS_CORE=1 to choose yourself)\n";
      ::setenv("OPENBLAS_CORETYPE", core.c_str(), 1);
      ::execv("/proc/self/exe", argv);
      std::cerr << "maskadapt: restart failed; continuing with " << maskadapt::blas_core_name() << "\n";
    }
  }
  // The trainers parallelise over envs themselves; OpenBLAS threads would fight them.
  maskadapt::limit_blas_threads(1);
  for (int i = 0; i < argc; ++i) {
    const std::string word = i == 0 ? "maskadapt" : argv[i];
    auto& line = maskadapt::cli::invocation();
    if (i) line += ' ';
    line += word.find_first_of(" \t'\"") == std::string::npos ? word : "'" + word + "'";
  }
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
