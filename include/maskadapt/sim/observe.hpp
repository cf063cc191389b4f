#pragma once
/// \file observe.hpp
/// Observations of every env of any Simulator, as one (obs_dim × num_envs) batch.
#include <maskadapt/core/thread_pool.hpp>
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/sim/simulator.hpp>

namespace maskadapt {

/// out (observation_dim(skeleton) × num_envs): column e = s of env e. Runs on `pool` when given
/// (each column is written by one thread: results do not depend on the thread count).
template <Simulator S>
void compute_observations(const S& sim, Eigen::Ref<MatrixXf> out, ThreadPool* pool = nullptr) {
  const auto n = static_cast<Index>(sim.num_envs());
  require(out.rows() == observation_dim(sim.skeleton()) && out.cols() == n,
          "observation batch is " + std::to_string(out.rows()) + "x" + std::to_string(out.cols()) + ", expected " +
              std::to_string(observation_dim(sim.skeleton())) + "x" + std::to_string(n),
          {{}, {}, "observations"});
  auto one = [&](std::size_t e) {
    compute_observation(sim.skeleton(), sim.body_states(e), out.col(static_cast<Index>(e)));
  };
  for_each_index(pool, sim.num_envs(), one);
}

/// Convenience: returns the batch.
template <Simulator S>
MatrixXf compute_observations(const S& sim, ThreadPool* pool = nullptr) {
  MatrixXf out(observation_dim(sim.skeleton()), static_cast<Index>(sim.num_envs()));
  compute_observations(sim, out, pool);
  return out;
}

}  // namespace maskadapt
