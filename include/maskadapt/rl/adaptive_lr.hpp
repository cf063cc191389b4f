#pragma once
/// \file adaptive_lr.hpp
/// Adaptive-KL learning rate for PPO's actor (the rule of rsl_rl, used by legged-gym style
/// trainers): after each minibatch, compare the measured KL(π_old ‖ π) on that minibatch with a
/// target, and make the next steps larger or smaller so that each iteration moves the policy by
/// about the target — as large as PPO's trust region allows, whatever the reward scale:
///
///     KL > 2·target   →  lr ← max(lr / factor, min_lr)
///     KL < target / 2 →  lr ← min(lr · factor, max_lr)
///
/// The KL is PPO's approx_kl (rl/ppo_loss.hpp: mean((ρ−1) − log ρ) over the minibatch, an
/// unbiased, non-negative estimator of KL(old ‖ new) from the sampled actions; rsl_rl uses the
/// closed form between the two Gaussians, which needs the old means stored).
#include <maskadapt/core/error.hpp>

#include <algorithm>
#include <cmath>
#include <string>

namespace maskadapt::rl {

struct AdaptiveKlSchedule {
  double desired_kl = 0.01;  ///< target KL per minibatch step (rsl_rl default)
  double factor = 1.5;       ///< multiplicative change per minibatch
  double min_lr = 1e-6;
  double max_lr = 1e-2;

  /// Throws naming the field (`prefix`.…, and `file` when given) unless 0 < desired_kl,
  /// factor > 1 and 0 < min_lr ≤ max_lr, all finite.
  void validate(const std::string& prefix = "adaptive_lr", const std::string& file = {}) const {
    auto ok = [](double x) { return std::isfinite(x) && x > 0; };
    require(ok(desired_kl), "must be finite and > 0", {file, {}, prefix + ".desired_kl"});
    require(std::isfinite(factor) && factor > 1, "must be finite and > 1", {file, {}, prefix + ".factor"});
    require(ok(min_lr), "must be finite and > 0", {file, {}, prefix + ".min_lr"});
    require(ok(max_lr) && max_lr >= min_lr, "must be finite and >= min_lr", {file, {}, prefix + ".max_lr"});
  }
};

/// The learning rate for the next minibatch given the current one and the KL just measured.
/// A non-finite KL (a step that blew up) shrinks the rate; the result is always in [min, max].
inline double adapt_learning_rate(double lr, double kl, const AdaptiveKlSchedule& s) {
  if (!std::isfinite(kl) || kl > 2.0 * s.desired_kl) lr /= s.factor;
  else if (kl < 0.5 * s.desired_kl) lr *= s.factor;
  return std::clamp(lr, s.min_lr, s.max_lr);
}

}  // namespace maskadapt::rl
