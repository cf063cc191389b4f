#pragma once
/// \file rollout_buffer.hpp
/// On-policy rollout storage for one PPO iteration: `horizon × num_envs` samples.
///
/// Every per-sample quantity is a column. Sample (t, env) lives in column `t·num_envs + env`
/// (time-major), so a whole time step is a contiguous block of `num_envs` columns and the
/// collector can write one step with `block(…, step_cols(t))`.
///
/// What is stored and why:
///  - `obs`          the *full, unmasked* observation s — the mask-invariant loss needs it
///                   (target π(·|s, m⁰)) and the critic may see it;
///  - `masks`        the part mask m of each sample;
///  - `policy_input` what the actor actually saw, e.g. [s̄ ; m] with s̄ = (1−m)⊙s;
///  - `actions`, `log_probs` of the behaviour policy;
///  - `values`, `rewards` with one row per objective (several rows for multi-objective /
///                   CML-style training);
///  - `terminated` (failure: no bootstrap) vs `truncated` (time limit: bootstrap with
///                   `final_values`, the value of the last observation before the reset);
///  - `bootstrap_values` the value of the observation after the last step (one column per env);
///  - `amp_windows`  the discriminator input of each transition (unmasked feature windows).
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/nn/chunks.hpp>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <span>
#include <utility>
#include <vector>

namespace maskadapt::rl {

/// Sizes of a rollout buffer. Dimensions that a run does not use may be 0.
struct RolloutSpec {
  Index horizon = 32;          ///< steps per env per iteration (paper: 32)
  Index num_envs = 1;          ///< parallel environments
  Index obs_dim = 0;           ///< full observation s (humanoid: 328)
  Index policy_input_dim = 0;  ///< actor input (humanoid: 328 + 5 mask bits)
  Index action_dim = 0;        ///< action (humanoid: PD targets, one per DoF)
  Index num_objectives = 1;    ///< reward / value rows (1 for AMP; one per discriminator for CML)
  Index amp_dim = 0;           ///< discriminator window features (0: not stored)
};

template <class T = float>
struct RolloutBuffer {
  RolloutSpec spec;
  MatrixX<T> obs;               ///< (obs_dim × H·N) full unmasked observation s
  std::vector<PartMask> masks;  ///< (H·N) part mask of each sample
  MatrixX<T> policy_input;      ///< (policy_input_dim × H·N) what the actor saw
  MatrixX<T> actions;           ///< (action_dim × H·N)
  RowVectorX<T> log_probs;      ///< (1 × H·N) log π_old(a|·)
  MatrixX<T> values;            ///< (num_objectives × H·N) V_old(s_t)
  MatrixX<T> rewards;           ///< (num_objectives × H·N) r_t
  std::vector<std::uint8_t> terminated;  ///< (H·N) 1: episode ended by failure after this step
  std::vector<std::uint8_t> truncated;   ///< (H·N) 1: episode cut by the time limit after this step
  MatrixX<T> final_values;      ///< (num_objectives × H·N) V(s_{t+1}) before reset; read only where truncated
  MatrixX<T> bootstrap_values;  ///< (num_objectives × N) V(s_H) after the last step
  MatrixX<T> amp_windows;       ///< (amp_dim × H·N) discriminator inputs
  MatrixX<T> advantages;        ///< (num_objectives × H·N) filled by compute_gae
  MatrixX<T> returns;           ///< (num_objectives × H·N) filled by compute_gae: A + V_old

  RolloutBuffer() = default;
  explicit RolloutBuffer(const RolloutSpec& s) { resize(s); }

  /// Allocates every array for `s` and zeroes it (flags cleared).
  void resize(const RolloutSpec& s) {
    require(s.horizon > 0 && s.num_envs > 0, "horizon and num_envs must be positive", {{}, {}, "RolloutSpec"});
    require(s.num_objectives > 0, "num_objectives must be positive", {{}, {}, "RolloutSpec.num_objectives"});
    require(s.obs_dim >= 0 && s.policy_input_dim >= 0 && s.action_dim >= 0 && s.amp_dim >= 0,
            "dimensions must be non-negative", {{}, {}, "RolloutSpec"});
    spec = s;
    const Index n = size();
    obs.setZero(s.obs_dim, n);
    masks.assign(static_cast<std::size_t>(n), PartMask::none());
    policy_input.setZero(s.policy_input_dim, n);
    actions.setZero(s.action_dim, n);
    log_probs.setZero(n);
    values.setZero(s.num_objectives, n);
    rewards.setZero(s.num_objectives, n);
    terminated.assign(static_cast<std::size_t>(n), 0);
    truncated.assign(static_cast<std::size_t>(n), 0);
    final_values.setZero(s.num_objectives, n);
    bootstrap_values.setZero(s.num_objectives, s.num_envs);
    amp_windows.setZero(s.amp_dim, n);
    advantages.setZero(s.num_objectives, n);
    returns.setZero(s.num_objectives, n);
  }

  /// Number of samples H·N.
  Index size() const { return spec.horizon * spec.num_envs; }
  /// Column of sample (t, env).
  Index column(Index t, Index env) const { return t * spec.num_envs + env; }
  /// First column of time step t (the step occupies `num_envs` consecutive columns).
  Index step_begin(Index t) const { return t * spec.num_envs; }

  /// Stores what the behaviour policy saw and did at step t, one column per env: the full
  /// observation (obs_dim × N), the actor input (policy_input_dim × N), the masks (N), the
  /// actions (action_dim × N), their log-probabilities (1 × N) and the values (num_objectives × N).
  template <class Obs, class Input, class Act, class LogP, class Val>
  void record_policy_step(Index t, const Eigen::MatrixBase<Obs>& obs_t, const Eigen::MatrixBase<Input>& input_t,
                          std::span<const PartMask> masks_t, const Eigen::MatrixBase<Act>& actions_t,
                          const Eigen::MatrixBase<LogP>& log_probs_t, const Eigen::MatrixBase<Val>& values_t) {
    const Index c0 = step_begin(t), N = spec.num_envs;
    require(static_cast<Index>(masks_t.size()) == N, "one mask per env expected", {{}, {}, "RolloutBuffer.masks"});
    obs.middleCols(c0, N) = obs_t;
    policy_input.middleCols(c0, N) = input_t;
    std::copy(masks_t.begin(), masks_t.end(), masks.begin() + c0);
    actions.middleCols(c0, N) = actions_t;
    log_probs.segment(c0, N) = log_probs_t;
    values.middleCols(c0, N) = values_t;
  }
};

/// Splits a random permutation of [0, num_samples) into `num_minibatches` minibatches of
/// (nearly) equal size; every sample appears exactly once. Fisher–Yates with `rng`.
inline std::vector<std::vector<Index>> minibatch_indices(Index num_samples, Index num_minibatches, Rng& rng) {
  require(num_samples > 0, "no samples to split into minibatches", {{}, {}, "num_samples"});
  require(num_minibatches > 0 && num_minibatches <= num_samples,
          "num_minibatches must be in [1, num_samples]", {{}, {}, "num_minibatches"});
  std::vector<Index> perm(static_cast<std::size_t>(num_samples));
  std::iota(perm.begin(), perm.end(), Index{0});
  for (Index i = num_samples - 1; i > 0; --i) {
    const auto j = static_cast<Index>(rng.uniform_int(static_cast<std::uint64_t>(i + 1)));
    std::swap(perm[static_cast<std::size_t>(i)], perm[static_cast<std::size_t>(j)]);
  }
  std::vector<std::vector<Index>> out(static_cast<std::size_t>(num_minibatches));
  for (Index b = 0; b < num_minibatches; ++b) {
    const Index lo = num_samples * b / num_minibatches, hi = num_samples * (b + 1) / num_minibatches;
    out[static_cast<std::size_t>(b)].assign(perm.begin() + lo, perm.begin() + hi);
  }
  return out;
}

/// dst.col(j) = src.col(idx[j]) for every j, with `dst` already (rows(src) × idx.size()) — a
/// matrix or a block of one. The indices are checked first; the copies run in column chunks on
/// nn::default_pool() when large (each column is copied by one thread: the same result for any pool).
template <class Src, class Dst>
void copy_columns(const Eigen::MatrixBase<Src>& src, const std::vector<Index>& idx, Dst&& dst) {
  const Index n = static_cast<Index>(idx.size());
  require(dst.rows() == src.rows() && dst.cols() == n, "column copy into a block of the wrong shape",
          {{}, {}, "minibatch columns"});
  for (const Index i : idx) require(i >= 0 && i < src.cols(), "column index out of range", {{}, {}, "minibatch index"});
  nn::for_each_column_chunk(nn::default_pool(), src.rows(), n, [&](Index c0, Index c1) {
    for (Index j = c0; j < c1; ++j) dst.col(j) = src.col(idx[static_cast<std::size_t>(j)]);
  });
}

/// Gathers the columns `idx` of `src` into `dst` (rows(src) × idx.size()); `dst` is resized.
template <class Src, class Dst>
void gather_columns(const Eigen::MatrixBase<Src>& src, const std::vector<Index>& idx, Eigen::MatrixBase<Dst>& dst) {
  dst.derived().resize(src.rows(), static_cast<Index>(idx.size()));
  copy_columns(src, idx, dst.derived());
}

}  // namespace maskadapt::rl
