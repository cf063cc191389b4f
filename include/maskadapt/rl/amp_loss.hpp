#pragma once
/// \file amp_loss.hpp
/// AMP discriminator objectives and style rewards on plain logits (no networks involved).
///
/// The discriminator outputs a logit d per transition window.
///  - BCE (the method's default, as in ASE/CALM):
///      L = ½·[mean_real −log σ(d)  +  mean_fake −log(1 − σ(d))]
///      reward r = −log(max(1 − σ(d), 1e−4))
///  - LSGAN (the original AMP paper, Peng et al. 2021): targets +1 (real) / −1 (fake)
///      L = ½·[mean_real (d − 1)²  +  mean_fake (d + 1)²]
///      reward r = max(0, 1 − ¼(d − 1)²)
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>

#include <algorithm>
#include <cmath>

namespace maskadapt::rl {

enum class DiscriminatorLoss { BCE, LSGAN };

/// log σ(x), stable for large |x|.
inline double log_sigmoid(double x) { return x >= 0 ? -std::log1p(std::exp(-x)) : x - std::log1p(std::exp(x)); }
inline double sigmoid(double x) { return x >= 0 ? 1.0 / (1.0 + std::exp(-x)) : std::exp(x) / (1.0 + std::exp(x)); }

/// Result of one discriminator objective evaluation over a real and a fake batch.
struct AmpObjective {
  double loss = 0;        ///< L as above
  double real_mean = 0;   ///< mean σ(d) (BCE) or mean d (LSGAN) on real samples
  double fake_mean = 0;   ///< same on fake samples
  double accuracy = 0;    ///< fraction classified correctly (d > 0 ⇔ "real")
};

/// Evaluates the discriminator objective. Writes ∂L/∂d into grad_real (1 × B_r) and
/// grad_fake (1 × B_f), both resized.
template <class T>
AmpObjective amp_objective(DiscriminatorLoss kind, const Eigen::Ref<const RowVectorX<T>>& logit_real,
                           const Eigen::Ref<const RowVectorX<T>>& logit_fake, RowVectorX<T>& grad_real,
                           RowVectorX<T>& grad_fake) {
  const Index nr = logit_real.cols(), nf = logit_fake.cols();
  require(nr > 0 && nf > 0, "discriminator objective needs real and fake samples", {{}, {}, "amp_objective"});
  grad_real.resize(nr);
  grad_fake.resize(nf);
  AmpObjective o;
  double lr = 0, lf = 0;
  for (Index i = 0; i < nr; ++i) {
    const double d = logit_real(i);
    if (kind == DiscriminatorLoss::BCE) {
      lr -= log_sigmoid(d);
      grad_real(i) = static_cast<T>(-0.5 * (1.0 - sigmoid(d)) / nr);  // d/dd −log σ(d) = σ(d) − 1
      o.real_mean += sigmoid(d);
    } else {
      lr += (d - 1) * (d - 1);
      grad_real(i) = static_cast<T>(0.5 * 2.0 * (d - 1) / nr);
      o.real_mean += d;
    }
    o.accuracy += d > 0 ? 1.0 : 0.0;
  }
  for (Index i = 0; i < nf; ++i) {
    const double d = logit_fake(i);
    if (kind == DiscriminatorLoss::BCE) {
      lf -= log_sigmoid(-d);  // −log(1 − σ(d)) = −log σ(−d)
      grad_fake(i) = static_cast<T>(0.5 * sigmoid(d) / nf);
      o.fake_mean += sigmoid(d);
    } else {
      lf += (d + 1) * (d + 1);
      grad_fake(i) = static_cast<T>(0.5 * 2.0 * (d + 1) / nf);
      o.fake_mean += d;
    }
    o.accuracy += d <= 0 ? 1.0 : 0.0;
  }
  o.loss = 0.5 * (lr / nr + lf / nf);
  o.real_mean /= nr;
  o.fake_mean /= nf;
  o.accuracy /= static_cast<double>(nr + nf);
  return o;
}

/// The reward of one logit d (see amp_reward).
template <class T>
T amp_reward_of_logit(DiscriminatorLoss kind, double d) {
  if (kind == DiscriminatorLoss::BCE) return static_cast<T>(-std::log(std::max(1.0 - sigmoid(d), 1e-4)));
  return static_cast<T>(std::max(0.0, 1.0 - 0.25 * (d - 1) * (d - 1)));
}

/// Style reward of each logit (1 × B) → (1 × B).
template <class T>
RowVectorX<T> amp_reward(DiscriminatorLoss kind, const Eigen::Ref<const RowVectorX<T>>& logit) {
  RowVectorX<T> r(logit.cols());
  for (Index i = 0; i < logit.cols(); ++i) r(i) = amp_reward_of_logit<T>(kind, static_cast<double>(logit(i)));
  return r;
}

}  // namespace maskadapt::rl
