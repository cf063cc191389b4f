#pragma once
// The training commands under mpirun (docs/distributed.md): how many of the run's envs this rank
// steps, checked once for both train-base and train-residual.
#include <maskadapt/core/collective.hpp>
#include <maskadapt/core/error.hpp>

#include <cstddef>
#include <string>

namespace maskadapt::cli {

/// env.num_envs / ranks, the envs this rank steps; throws naming --envs unless they split evenly.
inline std::size_t envs_per_rank(const Collective& world, long long num_envs) {
  if (world.distributed())
    require(num_envs % world.size() == 0,
            std::to_string(num_envs) + " envs do not split evenly over " + std::to_string(world.size()) +
                " ranks (each rank steps env.num_envs / ranks of them); choose --envs as a multiple of the rank count",
            {{}, std::nullopt, "--envs"});
  return static_cast<std::size_t>(num_envs / world.size());
}

}  // namespace maskadapt::cli
