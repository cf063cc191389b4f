#pragma once
/// \file distributed.hpp
/// The pieces both trainers (base_trainer.hpp, residual_trainer.hpp) use to run as one of K
/// ranks (docs/distributed.md), as free functions over a `Collective`. Rank r steps the global
/// envs [offset, offset + n) (offset = r·n, n envs per rank); samples are stored step-major, the
/// one-process column of env e at step t being t·N_all + e (N_all = K·n) and the rank's own
/// column t·n + (e − offset). Nothing here runs in a one-process run.
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/collective.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/nn/normalizer.hpp>
#include <maskadapt/tasks/imitation.hpp>

#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace maskadapt::train {

/// Where this rank's samples sit among all ranks' (see the file comment); empty: one process.
struct RankLayout {
  Collective* comm = nullptr;  ///< nullptr or one rank: not distributed
  Index envs_here = 0;         ///< n, this rank's envs
  Index offset = 0;            ///< global index of this rank's first env
  bool distributed() const { return comm != nullptr && comm->size() > 1; }
};

/// Checks that every rank has the same env count, network size and seed, and that the ranks'
/// envs add up to `num_envs` (the config's total); returns this rank's env offset (rank · n).
inline Index join_ranks(Collective& comm, Index envs_here, std::int64_t num_params, std::uint64_t seed, Index num_envs) {
  require_same_on_all_ranks(comm, envs_here, "envs per rank (the simulator's num_envs)");
  require_same_on_all_ranks(comm, num_params, "network parameter count");
  require_same_on_all_ranks(comm, static_cast<std::int64_t>(seed), "run.seed");
  require(num_envs == comm.size() * envs_here,
          "env.num_envs is " + std::to_string(num_envs) + " but " + std::to_string(comm.size()) + " ranks with " +
              std::to_string(envs_here) + " envs each step " + std::to_string(comm.size() * envs_here),
          {{}, std::nullopt, "env.num_envs"});
  return comm.rank() * envs_here;
}

/// Gives the task's env e the stream Rng::stream(seed, offset + e) of global env offset + e.
/// keep_states: the envs continue where they are (with a simulator that can save its state;
/// otherwise they are reset); else every env is reset from its new stream.
template <class Task>
void restart_env_streams(Task& task, std::uint64_t seed, Index offset, bool keep_states) {
  auto ts = task.save_state();
  for (std::size_t e = 0; e < ts.rngs.size(); ++e) ts.rngs[e] = Rng::stream(seed, static_cast<std::uint64_t>(offset) + e).state();
  if (!keep_states) ts.sim.clear();  // (load_state then resets every env from its new stream)
  task.load_state(ts);
}

/// Draws and drops `count` standard normals: a rank that samples the action noise of its own
/// envs only skips the other ranks' draws, so the replicated stream stays where one process's is
/// (Rng::normal is sequential: Marsaglia's polar method with its cached second variate).
inline void skip_normals(Rng& rng, Index count) {
  for (Index i = 0; i < count; ++i) (void)rng.normal();
}

/// This rank's columns (into `out`) of a minibatch of one-process sample indices `global`.
inline void my_columns(const std::vector<Index>& global, Index envs_here, Index ranks, Index offset, std::vector<Index>& out) {
  const Index all = envs_here * ranks;
  out.clear();
  for (const Index g : global) {
    const Index t = g / all, e = g % all - offset;
    if (e >= 0 && e < envs_here) out.push_back(t * envs_here + e);
  }
}

/// Sums the gradient buffers `grads` over ranks with one all-reduce (packed into `scratch`).
inline void all_reduce_gradients(Collective& comm, const std::vector<std::span<float>>& grads, std::vector<float>& scratch) {
  std::size_t total = 0;
  for (const auto& g : grads) total += g.size();
  scratch.resize(total);
  std::size_t at = 0;
  for (const auto& g : grads) {
    std::copy(g.begin(), g.end(), scratch.begin() + static_cast<std::ptrdiff_t>(at));
    at += g.size();
  }
  comm.all_reduce_sum(std::span<float>(scratch));
  at = 0;
  for (const auto& g : grads) {
    std::copy(scratch.begin() + static_cast<std::ptrdiff_t>(at), scratch.begin() + static_cast<std::ptrdiff_t>(at + g.size()), g.begin());
    at += g.size();
  }
}

/// The mean over ranks of a per-rank mean taken over equally many samples on every rank.
inline double mean_over_ranks(Collective& comm, double rank_mean) { return all_reduce_sum(comm, rank_mean) / comm.size(); }

/// rl::normalize_rows with the mean and deviation of all ranks' columns (every rank holds as many).
inline void normalize_rows_over_ranks(Collective& comm, MatrixXf& adv, double eps = 1e-8) {
  const double count = static_cast<double>(adv.cols()) * comm.size();
  for (Index k = 0; k < adv.rows(); ++k) {
    const double mean = all_reduce_sum(comm, adv.row(k).template cast<double>().sum()) / count;
    const double var = all_reduce_sum(comm, (adv.row(k).template cast<double>().array() - mean).square().sum()) / count;
    const double inv = 1.0 / (std::sqrt(var) + eps);
    for (Index j = 0; j < adv.cols(); ++j) adv(k, j) = static_cast<float>((static_cast<double>(adv(k, j)) - mean) * inv);
  }
}

/// Every rank's batch `x` (rows × its columns) into `running`: the ranks' (count, mean, M2) are
/// gathered and merged in rank order into one batch (Chan), which is merged into the statistics.
inline void merge_normalizer_over_ranks(Collective& comm, const MatrixXf& x, nn::RunningNormalizer<float>& running) {
  nn::RunningNormalizer<float> mine(x.rows());
  mine.update(x);
  std::vector<double> v{mine.count()};
  v.insert(v.end(), mine.mean().data(), mine.mean().data() + x.rows());
  v.insert(v.end(), mine.m2().data(), mine.m2().data() + x.rows());
  nn::RunningNormalizer<float> batch(x.rows()), part(x.rows());
  for (const Bytes& b : comm.all_gather(to_bytes<double>(v))) {
    const auto w = from_bytes<double>(b, "normaliser statistics");
    require(static_cast<Index>(w.size()) == 1 + 2 * x.rows(), "ranks disagree on an input normaliser's size",
            {{}, std::nullopt, "normalizer"});
    part.set_state(w[0], Eigen::Map<const VectorXd>(w.data() + 1, x.rows()),
                   Eigen::Map<const VectorXd>(w.data() + 1 + x.rows(), x.rows()));
    batch.merge(part);
  }
  running.merge(batch);
}

/// Every rank's step-major samples `mine` (rows × n·H) as one (rows × N_all·H) matrix in one
/// process's column order (column t·N_all + global env), on every rank.
inline void gather_step_major(Collective& comm, const MatrixXf& mine, Index envs_here, MatrixXf& out, const char* what) {
  const Index D = mine.rows(), n = envs_here, H = n > 0 ? mine.cols() / n : 0, all = n * comm.size();
  const auto parts = comm.all_gather(to_bytes<float>(std::span<const float>(mine.data(), static_cast<std::size_t>(mine.size()))));
  out.resize(D, all * H);
  for (std::size_t r = 0; r < parts.size(); ++r) {
    require(parts[r].size() == static_cast<std::size_t>(mine.size()) * sizeof(float),
            "rank " + std::to_string(r) + " sent " + what + " of another size", {{}, std::nullopt, what});
    const Eigen::Map<const MatrixXf> w(reinterpret_cast<const float*>(parts[r].data()), D, n * H);
    for (Index t = 0; t < H; ++t) out.middleCols(t * all + static_cast<Index>(r) * n, n) = w.middleCols(t * n, n);
  }
}

/// The same for the per-sample masks (one per column).
inline void gather_step_major(Collective& comm, const std::vector<PartMask>& mine, Index envs_here, std::vector<PartMask>& out) {
  const Index n = envs_here, H = n > 0 ? static_cast<Index>(mine.size()) / n : 0, all = n * comm.size();
  Bytes bits(mine.size());
  for (std::size_t i = 0; i < mine.size(); ++i) bits[i] = mine[i].bits;
  const auto parts = comm.all_gather(bits);
  out.assign(static_cast<std::size_t>(all * H), PartMask::none());
  for (std::size_t r = 0; r < parts.size(); ++r) {
    require(parts[r].size() == mine.size(), "rank " + std::to_string(r) + " sent masks of another count", {{}, std::nullopt, "masks"});
    for (Index t = 0; t < H; ++t)
      for (Index e = 0; e < n; ++e)
        out[static_cast<std::size_t>(t * all + static_cast<Index>(r) * n + e)] = PartMask{parts[r][static_cast<std::size_t>(t * n + e)]};
  }
}

/// Episode counters of an iteration summed over ranks (rank order), on every rank.
inline void sum_episode_stats_over_ranks(Collective& comm, tasks::EpisodeStats& es) {
  double v[7] = {static_cast<double>(es.episodes), static_cast<double>(es.falls), static_cast<double>(es.truncations),
                 es.total_seconds, static_cast<double>(es.steps), static_cast<double>(es.masked_steps),
                 static_cast<double>(es.sim_resets)};
  comm.all_reduce_sum(std::span<double>(v, 7));
  es.episodes = static_cast<long long>(v[0]);
  es.falls = static_cast<long long>(v[1]);
  es.truncations = static_cast<long long>(v[2]);
  es.total_seconds = v[3];
  es.steps = static_cast<long long>(v[4]);
  es.masked_steps = static_cast<long long>(v[5]);
  es.sim_resets = static_cast<long long>(v[6]);
}

/// FNV-1a over the bytes of parameter vectors (a fingerprint of the replicated state).
class ParameterFingerprint {
 public:
  template <class V>
  ParameterFingerprint& add(const V& v) {
    const auto* b = reinterpret_cast<const unsigned char*>(v.data());
    for (std::size_t i = 0; i < static_cast<std::size_t>(v.size()) * sizeof(*v.data()); ++i) h_ = (h_ ^ b[i]) * 1099511628211ULL;
    return *this;
  }
  std::uint64_t value() const { return h_; }

 private:
  std::uint64_t h_ = 1469598103934665603ULL;
};

/// Throws on every rank unless every rank's parameter fingerprint is rank 0's (the ranks take the
/// same steps from the same sums, so their replicated state agrees bit for bit).
inline void require_same_parameters(Collective& comm, std::uint64_t fingerprint, long long iteration) {
  const auto all = all_gather_concat<std::uint64_t>(comm, std::span<const std::uint64_t>(&fingerprint, 1));
  for (std::size_t r = 1; r < all.size(); ++r)  // (every rank sees the same list, so all of them throw)
    require(all[r] == all[0],
            "rank " + std::to_string(r) + "'s network parameters differ from rank 0's at iteration " + std::to_string(iteration) +
                ": the ranks have diverged (no checkpoint written; the last one is kept)",
            {{}, std::nullopt, "dist/parameters"});
}

/// Refuses a checkpoint written by another number of ranks (`dist/ranks`, 1 when absent).
inline void require_same_rank_count(const Checkpoint& c, const Collective& comm) {
  const std::int64_t ranks = c.contains("dist/ranks") ? c.get_int("dist/ranks") : 1;
  require(ranks == comm.size(),
          "the checkpoint was written by a run of " + std::to_string(ranks) + " rank(s), this run has " +
              std::to_string(comm.size()) + "; resume it with the same number of ranks" +
              (ranks > 1 ? " (mpirun -np " + std::to_string(ranks) + ")" : std::string(" (without mpirun)")) +
              ": how the envs are split over ranks is part of the run's state",
          {c.source(), std::nullopt, "dist/ranks"});
}

/// The checkpoint at `path` on every rank: rank 0 reads (and verifies) the file and sends it to
/// the others, so only rank 0 needs the file (collective). An error reading it is thrown on
/// rank 0; a launcher-aware caller then stops the job (Collective::abort).
inline Checkpoint load_checkpoint_on_every_rank(Collective& comm, const std::string& path) {
  if (!comm.distributed()) return load_checkpoint(path);
  Bytes bytes = comm.is_root() ? serialize_checkpoint(load_checkpoint(path)) : Bytes{};
  comm.broadcast(bytes, 0);
  return parse_checkpoint(bytes, path);
}

/// Rank 0's `out` gets every rank's sections of `mine` under "dist/rank/<r>/" (collective;
/// the other ranks' `out` is left as it is). For per-rank state whose layout only its owner
/// knows (a goal task's): `rank_sections` reads it back.
inline void gather_rank_sections(Collective& comm, const Checkpoint& mine, Checkpoint& out) {
  const auto parts = comm.gather(serialize_checkpoint(mine), 0);
  if (!comm.is_root()) return;
  for (std::size_t r = 0; r < parts.size(); ++r) {
    const Checkpoint p = parse_checkpoint(parts[r], "rank " + std::to_string(r) + " state");
    const std::string prefix = "dist/rank/" + std::to_string(r) + "/";
    for (const std::string& name : p.names()) {
      const CheckpointSection& s = p.section(name);
      out.put_raw(prefix + name, s.dtype, s.shape, s.data.data(), s.data.size());
    }
  }
}

/// Rank `rank`'s sections written by gather_rank_sections, under their own names. Throws naming
/// the section when the checkpoint has none for that rank.
inline Checkpoint rank_sections(const Checkpoint& c, int rank) {
  const std::string prefix = "dist/rank/" + std::to_string(rank) + "/";
  Checkpoint out;
  out.set_source(c.source());
  for (const std::string& name : c.names()) {
    if (name.rfind(prefix, 0) != 0) continue;
    const CheckpointSection& s = c.section(name);
    out.put_raw(name.substr(prefix.size()), s.dtype, s.shape, s.data.data(), s.data.size());
  }
  require(!out.names().empty(), "the checkpoint holds no state of rank " + std::to_string(rank), {c.source(), std::nullopt, prefix});
  return out;
}

}  // namespace maskadapt::train
