#pragma once
/// \file gae.hpp
/// Generalised advantage estimation (Schulman et al. 2016) with correct episode boundaries.
///
/// For sample (t, env), with done_t = terminated_t ∨ truncated_t:
///   next_t  = 0                      if terminated_t   (failure: the future is worth nothing)
///           = final_value_t          if truncated_t    (time limit: the episode *would* go on,
///                                                       so bootstrap from V of the last
///                                                       observation before the reset)
///           = V(s_{t+1})             otherwise (bootstrap_values for t = H−1)
///   δ_t     = r_t + γ·next_t − V(s_t)
///   A_t     = δ_t + γλ·(1 − done_t)·A_{t+1}
///   R_t     = A_t + V(s_t)           (the critic's regression target)
/// Each objective row is processed independently. Defaults are the paper's: γ 0.99, λ 0.95.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/rl/rollout_buffer.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

namespace maskadapt::rl {

struct GaeParams {
  double gamma = 0.99;   ///< discount γ (paper 0.99)
  double lambda = 0.95;  ///< GAE λ (paper 0.95)
};

/// Columns are time-major: sample (t, env) is column t·num_envs + env (see RolloutBuffer).
/// \param rewards          (K × H·N)
/// \param values           (K × H·N) V(s_t)
/// \param terminated       (H·N) flags
/// \param truncated        (H·N) flags
/// \param final_values     (K × H·N) V of the last observation, read where truncated
/// \param bootstrap_values (K × N) V(s_H)
/// \param advantages,returns outputs, resized to (K × H·N)
template <class T>
void compute_gae(const GaeParams& p, Index num_envs, const Eigen::Ref<const MatrixX<T>>& rewards,
                 const Eigen::Ref<const MatrixX<T>>& values, const std::vector<std::uint8_t>& terminated,
                 const std::vector<std::uint8_t>& truncated, const Eigen::Ref<const MatrixX<T>>& final_values,
                 const Eigen::Ref<const MatrixX<T>>& bootstrap_values, MatrixX<T>& advantages, MatrixX<T>& returns) {
  require(num_envs > 0 && rewards.cols() % num_envs == 0, "sample count is not a multiple of num_envs",
          {{}, {}, "rewards"});
  const Index K = rewards.rows(), n = rewards.cols(), H = n / num_envs;
  require(values.rows() == K && values.cols() == n, "values must match rewards' shape", {{}, {}, "values"});
  require(final_values.rows() == K && final_values.cols() == n, "final_values must match rewards' shape",
          {{}, {}, "final_values"});
  require(bootstrap_values.rows() == K && bootstrap_values.cols() == num_envs,
          "bootstrap_values must be (objectives × num_envs)", {{}, {}, "bootstrap_values"});
  require(terminated.size() == static_cast<std::size_t>(n) && truncated.size() == static_cast<std::size_t>(n),
          "flag arrays must have one entry per sample", {{}, {}, "terminated/truncated"});
  require(p.gamma >= 0 && p.gamma <= 1 && p.lambda >= 0 && p.lambda <= 1, "gamma and lambda must be in [0, 1]",
          {{}, {}, "GaeParams"});
  require_finite(rewards, "rewards");
  require_finite(values, "values");
  require_finite(bootstrap_values, "bootstrap_values");

  advantages.resize(K, n);
  returns.resize(K, n);
  const double gl = p.gamma * p.lambda;
  for (Index k = 0; k < K; ++k) {
    for (Index e = 0; e < num_envs; ++e) {
      double next_adv = 0.0;
      for (Index t = H - 1; t >= 0; --t) {
        const Index c = t * num_envs + e;
        const bool term = terminated[static_cast<std::size_t>(c)] != 0;
        const bool trunc = truncated[static_cast<std::size_t>(c)] != 0;
        double next_value;
        if (term) next_value = 0.0;
        else if (trunc) {
          next_value = static_cast<double>(final_values(k, c));
          require(std::isfinite(next_value), "non-finite final value at a truncated step", {{}, {}, "final_values"});
        } else if (t == H - 1) next_value = static_cast<double>(bootstrap_values(k, e));
        else next_value = static_cast<double>(values(k, c + num_envs));
        const double v = static_cast<double>(values(k, c));
        const double delta = static_cast<double>(rewards(k, c)) + p.gamma * next_value - v;
        const double adv = delta + ((term || trunc) ? 0.0 : gl * next_adv);
        advantages(k, c) = static_cast<T>(adv);
        returns(k, c) = static_cast<T>(adv + v);
        next_adv = adv;
      }
    }
  }
}

/// Fills `buf.advantages` and `buf.returns` from the buffer's rewards, values and flags.
template <class T>
void compute_gae(RolloutBuffer<T>& buf, const GaeParams& p = {}) {
  compute_gae<T>(p, buf.spec.num_envs, buf.rewards, buf.values, buf.terminated, buf.truncated, buf.final_values,
                 buf.bootstrap_values, buf.advantages, buf.returns);
}

}  // namespace maskadapt::rl
