#pragma once
/// \file ppo_loss.hpp
/// The PPO loss terms on plain arrays, with their gradients (no networks involved).
///
///  - clipped surrogate (Schulman et al. 2017):
///      L_π = −mean_i min(ρ_i A_i, clip(ρ_i, 1−ε, 1+ε) A_i),   ρ_i = exp(logπ_new − logπ_old)
///    ∂L_π/∂logπ_new,i = −ρ_i A_i / B where the unclipped term is the minimum, 0 where the clipped
///    (constant) term is the minimum;
///  - value loss (optionally clipped around the old value as in PPO2 / rl_games):
///      L_V = mean_i (V_i − R_i)²  or  mean_i max((V_i − R_i)², (V_old,i + clip(V_i − V_old,i, ±ε_v) − R_i)²)
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>

#include <algorithm>
#include <cmath>

namespace maskadapt::rl {

/// Statistics of one surrogate evaluation.
struct SurrogateResult {
  double loss = 0;        ///< L_π
  double approx_kl = 0;   ///< mean((ρ−1) − log ρ), the low-variance KL(old‖new) estimator (≥ 0)
  double clip_frac = 0;   ///< fraction of samples with |ρ − 1| > ε
};

/// Clipped surrogate loss. Writes ∂L_π/∂logπ_new into `grad_log_prob` (1 × B), resized.
/// \param log_prob_new (1 × B)  \param log_prob_old (1 × B)  \param advantages (1 × B)
template <class T>
SurrogateResult clipped_surrogate(const Eigen::Ref<const RowVectorX<T>>& log_prob_new,
                                  const Eigen::Ref<const RowVectorX<T>>& log_prob_old,
                                  const Eigen::Ref<const RowVectorX<T>>& advantages, double clip,
                                  RowVectorX<T>& grad_log_prob) {
  const Index B = log_prob_new.cols();
  require(B > 0 && log_prob_old.cols() == B && advantages.cols() == B, "surrogate: mismatched batch sizes",
          {{}, {}, "clipped_surrogate"});
  require(clip > 0, "surrogate: clip must be positive", {{}, {}, "clip"});
  grad_log_prob.resize(B);
  SurrogateResult r;
  for (Index i = 0; i < B; ++i) {
    const double log_ratio = static_cast<double>(log_prob_new(i)) - static_cast<double>(log_prob_old(i));
    const double rho = std::exp(log_ratio);
    const double a = static_cast<double>(advantages(i));
    const double unclipped = rho * a;
    const double clipped = std::clamp(rho, 1.0 - clip, 1.0 + clip) * a;
    // When ρ is inside the interval both terms agree, so the unclipped branch is the minimum.
    if (unclipped <= clipped) {
      r.loss -= unclipped;
      grad_log_prob(i) = static_cast<T>(-unclipped / static_cast<double>(B));
    } else {
      r.loss -= clipped;
      grad_log_prob(i) = T(0);
    }
    r.approx_kl += (rho - 1.0) - log_ratio;
    if (std::abs(rho - 1.0) > clip) r.clip_frac += 1.0;
  }
  r.loss /= static_cast<double>(B);
  r.approx_kl /= static_cast<double>(B);
  r.clip_frac /= static_cast<double>(B);
  return r;
}

/// Value loss mean over all entries of (K × B) arrays; `clip` ≤ 0 disables clipping.
/// Writes ∂L_V/∂V into `grad_value` (K × B), resized.
template <class T>
double value_loss(const Eigen::Ref<const MatrixX<T>>& value, const Eigen::Ref<const MatrixX<T>>& value_old,
                  const Eigen::Ref<const MatrixX<T>>& target, double clip, MatrixX<T>& grad_value) {
  require(value.size() > 0 && value.rows() == target.rows() && value.cols() == target.cols() &&
              value_old.rows() == value.rows() && value_old.cols() == value.cols(),
          "value loss: mismatched shapes", {{}, {}, "value_loss"});
  const double n = static_cast<double>(value.size());
  grad_value.resize(value.rows(), value.cols());
  double loss = 0;
  for (Index j = 0; j < value.cols(); ++j)
    for (Index k = 0; k < value.rows(); ++k) {
      const double v = value(k, j), r = target(k, j);
      double l = (v - r) * (v - r), g = 2.0 * (v - r) / n;
      if (clip > 0) {
        const double vo = value_old(k, j);
        const double vc = vo + std::clamp(v - vo, -clip, clip);
        const double lc = (vc - r) * (vc - r);
        if (lc > l) {  // the clipped branch wins; its derivative is 0 where the clamp is active
          l = lc;
          g = (std::abs(v - vo) < clip) ? 2.0 * (vc - r) / n : 0.0;
        }
      }
      loss += l;
      grad_value(k, j) = static_cast<T>(g);
    }
  return loss / n;
}

/// Normalises each row of `adv` (K × B) to zero mean and unit standard deviation in place.
/// Rows with (near) zero spread are only centred.
template <class T>
void normalize_rows(MatrixX<T>& adv, double eps = 1e-8) {
  const Index B = adv.cols();
  if (B == 0) return;
  for (Index k = 0; k < adv.rows(); ++k) {
    const double mean = adv.row(k).template cast<double>().mean();
    const double var = (adv.row(k).template cast<double>().array() - mean).square().mean();
    const double inv = 1.0 / (std::sqrt(var) + eps);
    for (Index j = 0; j < B; ++j) adv(k, j) = static_cast<T>((static_cast<double>(adv(k, j)) - mean) * inv);
  }
}

}  // namespace maskadapt::rl
