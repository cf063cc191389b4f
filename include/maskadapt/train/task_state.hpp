#pragma once
/// \file task_state.hpp
/// The imitation task's resumable state in a checkpoint, shared by the base and residual trainers:
/// per-env RNG streams, discriminator-feature histories, step counters, masks, simulator states
/// (when the simulator can save them) and the current observations, under `<prefix>…`.
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/tasks/imitation.hpp>

#include <cstdint>
#include <string>

namespace maskadapt::train {

/// Writes `task.save_state()` into `c` under `prefix` (e.g. "task/").
template <class Task>
void save_task_state(Checkpoint& c, const std::string& prefix, const Task& task) {
  const auto ts = task.save_state();
  const auto n = static_cast<Index>(ts.rngs.size());
  VectorX<std::int64_t> steps(n), masks(n);
  for (Index e = 0; e < n; ++e) {
    const auto ue = static_cast<std::size_t>(e);
    Rng r;
    r.set_state(ts.rngs[ue]);
    c.put_rng(prefix + "rng/" + std::to_string(e), r);
    c.put(prefix + "history/" + std::to_string(e), ts.history[ue]);
    if (!ts.sim.empty())
      c.put(prefix + "sim/" + std::to_string(e),
            Eigen::Map<const VectorXd>(ts.sim[ue].data(), static_cast<Index>(ts.sim[ue].size())));
    steps[e] = ts.steps[ue];
    masks[e] = ts.masks[ue];
  }
  c.put(prefix + "steps", steps);
  c.put(prefix + "masks", masks);
  c.put(prefix + "obs", ts.obs);
  c.put_int(prefix + "has_sim_state", ts.sim.empty() ? 0 : 1);
}

/// Restores what save_task_state wrote; every section is read and checked before the task changes.
template <class Task>
void load_task_state(const Checkpoint& c, const std::string& prefix, Task& task) {
  typename Task::State ts;
  const Index n = task.num_envs();
  const auto steps = c.get_vector<std::int64_t>(prefix + "steps", n);
  const auto masks = c.get_vector<std::int64_t>(prefix + "masks", n);
  const bool has_sim = c.get_int(prefix + "has_sim_state") != 0;
  for (Index e = 0; e < n; ++e) {
    ts.rngs.push_back(c.get_rng(prefix + "rng/" + std::to_string(e)));
    ts.history.push_back(
        c.get_matrix<float>(prefix + "history/" + std::to_string(e), task.obs_dim(), tasks::kAmpWindowFrames));
    ts.steps.push_back(steps[e]);
    ts.masks.push_back(static_cast<std::uint8_t>(masks[e]));
    if (has_sim) {
      const VectorXd v = c.get_vector<double>(prefix + "sim/" + std::to_string(e));
      ts.sim.emplace_back(v.data(), v.data() + v.size());
    }
  }
  ts.obs = c.get_matrix<float>(prefix + "obs", task.obs_dim(), n);
  task.load_state(ts);
}

}  // namespace maskadapt::train
