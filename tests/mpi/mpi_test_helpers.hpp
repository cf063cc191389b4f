#pragma once
// Shared by the distributed-trainer tests (run under mpirun -np 2).
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/collective.hpp>

#include <cstdlib>
#include <string>

namespace maskadapt::testing {

/// Rank 0's checkpoint on every rank (what resuming from the file rank 0 wrote amounts to).
inline Checkpoint on_every_rank(const Checkpoint& c) {
  Bytes b = world().is_root() ? serialize_checkpoint(c) : Bytes{};
  world().broadcast(b, 0);
  return parse_checkpoint(b, "rank 0's checkpoint");
}

/// Where the fault tests (RankFailure.*, run by tests/mpi/rank_failure.cmake) keep their
/// checkpoint; empty when they are not being run by that script.
inline std::string fault_dir() {
  const char* d = std::getenv("MASKADAPT_MPI_FAULT_DIR");
  return d ? d : "";
}

}  // namespace maskadapt::testing
