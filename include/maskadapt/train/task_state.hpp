#pragma once
/// \file task_state.hpp
/// The imitation task's resumable state in a checkpoint, shared by the base and residual trainers:
/// per-env RNG streams, discriminator-feature histories, step counters, masks, simulator states
/// (when the simulator can save them) and the current observations, under `<prefix>…`.
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/tasks/imitation.hpp>

#include <cstdint>
#include <string>
#include <vector>

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
        c.get_matrix<float>(prefix + "history/" + std::to_string(e), task.obs_dim(), kAmpWindowFrames));
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

/// Distributed runs (docs/distributed.md): concatenates the task states that K ranks wrote under
/// `prefix` into `parts[0..K)` (rank r's envs 0…n_r−1) into one state of Σ n_r envs under `prefix`
/// in `out`, rank r's env e becoming env (n_0 + … + n_{r−1}) + e. The result has the layout of a
/// single process's task state over all envs.
inline void concat_task_states(const std::vector<Checkpoint>& parts, const std::string& prefix, Checkpoint& out) {
  std::vector<std::int64_t> steps, masks;
  std::vector<MatrixXf> obs;
  Index offset = 0, rows = 0;
  const std::int64_t has_sim = parts.empty() ? 0 : parts[0].get_int(prefix + "has_sim_state");
  auto copy = [&](const Checkpoint& from, const std::string& a, const std::string& b) {
    const CheckpointSection& s = from.section(a);
    out.put_raw(b, s.dtype, s.shape, s.data.data(), s.data.size());
  };
  for (const Checkpoint& p : parts) {
    const auto st = p.get_vector<std::int64_t>(prefix + "steps");
    const auto mk = p.get_vector<std::int64_t>(prefix + "masks", st.size());
    const Index n = st.size();
    require(p.get_int(prefix + "has_sim_state") == has_sim, "ranks disagree on whether simulator states are saved",
            {{}, std::nullopt, prefix + "has_sim_state"});
    for (Index e = 0; e < n; ++e) {
      const std::string from = std::to_string(e), to = std::to_string(offset + e);
      copy(p, prefix + "rng/" + from, prefix + "rng/" + to);
      copy(p, prefix + "history/" + from, prefix + "history/" + to);
      if (has_sim) copy(p, prefix + "sim/" + from, prefix + "sim/" + to);
    }
    steps.insert(steps.end(), st.data(), st.data() + n);
    masks.insert(masks.end(), mk.data(), mk.data() + n);
    obs.push_back(p.get_matrix<float>(prefix + "obs", -1, n));
    rows = obs.back().rows();
    offset += n;
  }
  MatrixXf all(rows, offset);
  Index c = 0;
  for (const auto& o : obs) {
    all.middleCols(c, o.cols()) = o;
    c += o.cols();
  }
  out.put(prefix + "steps", Eigen::Map<const VectorX<std::int64_t>>(steps.data(), offset));
  out.put(prefix + "masks", Eigen::Map<const VectorX<std::int64_t>>(masks.data(), offset));
  out.put(prefix + "obs", all);
  out.put_int(prefix + "has_sim_state", has_sim);
}

/// The inverse for one rank: envs [offset, offset + n) of the task state under `prefix` in `c`,
/// as a state of n envs (indices 0…n−1) under `prefix` in the returned checkpoint, for
/// load_task_state. Throws naming the section when `c` holds fewer envs.
inline Checkpoint slice_task_state(const Checkpoint& c, const std::string& prefix, Index offset, Index n) {
  Checkpoint out;
  auto copy = [&](const std::string& a, const std::string& b) {
    const CheckpointSection& s = c.section(a);
    out.put_raw(b, s.dtype, s.shape, s.data.data(), s.data.size());
  };
  const auto steps = c.get_vector<std::int64_t>(prefix + "steps");
  require(offset >= 0 && offset + n <= steps.size(),
          "the checkpoint's task state has " + std::to_string(steps.size()) + " envs, this rank needs envs " +
              std::to_string(offset) + ".." + std::to_string(offset + n - 1),
          {c.source(), std::nullopt, prefix + "steps"});
  const std::int64_t has_sim = c.get_int(prefix + "has_sim_state");
  for (Index e = 0; e < n; ++e) {
    const std::string from = std::to_string(offset + e), to = std::to_string(e);
    copy(prefix + "rng/" + from, prefix + "rng/" + to);
    copy(prefix + "history/" + from, prefix + "history/" + to);
    if (has_sim) copy(prefix + "sim/" + from, prefix + "sim/" + to);
  }
  out.put(prefix + "steps", steps.segment(offset, n));
  out.put(prefix + "masks", c.get_vector<std::int64_t>(prefix + "masks", steps.size()).segment(offset, n));
  out.put(prefix + "obs", c.get_matrix<float>(prefix + "obs", -1, steps.size()).middleCols(offset, n));
  out.put_int(prefix + "has_sim_state", has_sim);
  return out;
}

}  // namespace maskadapt::train
