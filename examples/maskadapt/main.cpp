// The `maskadapt` command-line tool: trainers, players, motion import/export, evaluation.
#include "command_registry.hpp"

#include <maskadapt/core/blas_threads.hpp>
#include <maskadapt/core/collective.hpp>
#include <maskadapt/core/error.hpp>
#ifdef MASKADAPT_HAS_MPI
#include <maskadapt/mpi/collective.hpp>
#endif

#include <cstdlib>
#include <iostream>
#include <memory>
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
#ifdef MASKADAPT_HAS_MPI
  // Started by mpirun / mpiexec / srun: join the job (docs/distributed.md); else MPI stays untouched.
  maskadapt::mpi::Session mpi_session(&argc, &argv);
  std::unique_ptr<maskadapt::mpi::MpiCollective> mpi_world;
  if (mpi_session.active()) {
    mpi_world = std::make_unique<maskadapt::mpi::MpiCollective>();
    maskadapt::world_slot() = mpi_world.get();
  }
  struct Restore {  // (the collective goes before MPI_Finalize)
    ~Restore() { maskadapt::world_slot() = &maskadapt::single_process(); }
  } restore_world;
#endif
  maskadapt::Collective& world = maskadapt::world();
  if (world.distributed() && (argc < 2 || (std::string(argv[1]) != "train-base" && std::string(argv[1]) != "train-residual"))) {
    if (world.is_root())
      std::cerr << "maskadapt: error: " << world.size() << " ranks: only `train-base` and `train-residual` run distributed (under mpirun); start the "
                << (argc >= 2 ? "`" + std::string(argv[1]) + "` command" : std::string("other commands")) << " without mpirun\n";
    return 2;
  }
  // On K ranks an error on one of them stops them all (the others would wait in a collective),
  // with a message that names the rank.
  auto fail = [&](const std::string& what, int code) {
    if (world.distributed())
      world.abort("maskadapt: rank " + std::to_string(world.rank()) + " of " + std::to_string(world.size()) + ": " + what, code);
    std::cerr << "maskadapt: " << what << "\n";
    return code;
  };
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
    return fail(std::string("error: ") + e.what(), 1);
  } catch (const std::exception& e) {
    return fail(std::string("unexpected error: ") + e.what(), 2);
  }
  return 0;
}
