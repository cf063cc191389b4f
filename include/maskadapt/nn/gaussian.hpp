#pragma once
/// \file gaussian.hpp
/// Diagonal-Gaussian policy head: N(μ, diag(σ²)) with σ = exp(log_std).
///
/// Shapes: mean μ and actions x are (d × B); log_std is either (d × 1) — state-independent,
/// broadcast over the batch (the policy's learned or fixed log-std) — or (d × B).
/// Gradients with respect to a (d × 1) log_std are summed over the batch.
///
///     log p(x)  = Σ_i [ −½((x_i − μ_i)/σ_i)² − log σ_i − ½ log 2π ]
///     ∂/∂μ_i    = (x_i − μ_i)/σ_i²
///     ∂/∂logσ_i = (x_i − μ_i)²/σ_i² − 1
///     H         = Σ_i [ log σ_i + ½(1 + log 2π) ],   ∂H/∂logσ_i = 1
///
/// The backward functions take the upstream gradient ∂L/∂(per-sample value) as a (1 × B) row
/// (e.g. −advantage·ratio/B) and ADD into the outputs.
#include <cmath>
#include <numbers>
#include <string>

#include <Eigen/Core>

#include "maskadapt/core/error.hpp"
#include "maskadapt/core/rng.hpp"
#include "maskadapt/core/types.hpp"

namespace maskadapt::nn {

namespace detail {
template <class T>
void check_gaussian_shapes(const Eigen::Ref<const MatrixX<T>>& mean, const Eigen::Ref<const MatrixX<T>>& log_std,
                           const char* where) {
  require(log_std.rows() == mean.rows() && (log_std.cols() == 1 || log_std.cols() == mean.cols()),
          "log_std must be " + std::to_string(mean.rows()) + "x1 or " + std::to_string(mean.rows()) + "x" +
              std::to_string(mean.cols()) + ", got " + std::to_string(log_std.rows()) + "x" +
              std::to_string(log_std.cols()),
          {{}, std::nullopt, std::string(where) + ".log_std"});
}
template <class T>
void check_same_shape(const Eigen::Ref<const MatrixX<T>>& a, Index rows, Index cols, const std::string& field) {
  require(a.rows() == rows && a.cols() == cols,
          "expected " + std::to_string(rows) + "x" + std::to_string(cols) + ", got " + std::to_string(a.rows()) + "x" +
              std::to_string(a.cols()),
          {{}, std::nullopt, field});
}
template <class M> inline auto ls_at(const M& log_std, Index i, Index j) {
  return log_std.cols() == 1 ? log_std(i, 0) : log_std(i, j);
}
}  // namespace detail

/// out (1 × B) = log N(x | μ, σ).
template <class T>
void gaussian_log_prob(const Eigen::Ref<const MatrixX<T>>& mean, const Eigen::Ref<const MatrixX<T>>& log_std,
                       const Eigen::Ref<const MatrixX<T>>& x, Eigen::Ref<RowVectorX<T>> out) {
  detail::check_gaussian_shapes<T>(mean, log_std, "gaussian_log_prob");
  detail::check_same_shape<T>(x, mean.rows(), mean.cols(), "gaussian_log_prob.x");
  require(out.size() == mean.cols(), "out must have B entries", {{}, std::nullopt, "gaussian_log_prob.out"});
  const T half_log_2pi = static_cast<T>(0.5 * std::log(2.0 * std::numbers::pi));
  for (Index j = 0; j < mean.cols(); ++j) {
    T s = 0;
    for (Index i = 0; i < mean.rows(); ++i) {
      const T ls = detail::ls_at(log_std, i, j);
      const T u = (x(i, j) - mean(i, j)) * std::exp(-ls);
      s += T(-0.5) * u * u - ls - half_log_2pi;
    }
    out[j] = s;
  }
}

/// Backward of gaussian_log_prob: given dlogp = ∂L/∂log p (1 × B), ADDS ∂L/∂μ into `dmean`
/// (d × B) and ∂L/∂logσ into `dlog_std` (same shape as log_std). Either output may be null.
/// A non-null output that is empty (size 0) is resized and zeroed first.
template <class T>
void gaussian_log_prob_backward(const Eigen::Ref<const MatrixX<T>>& mean, const Eigen::Ref<const MatrixX<T>>& log_std,
                                const Eigen::Ref<const MatrixX<T>>& x, const Eigen::Ref<const RowVectorX<T>>& dlogp,
                                MatrixX<T>* dmean, MatrixX<T>* dlog_std) {
  detail::check_gaussian_shapes<T>(mean, log_std, "gaussian_log_prob_backward");
  detail::check_same_shape<T>(x, mean.rows(), mean.cols(), "gaussian_log_prob_backward.x");
  require(dlogp.size() == mean.cols(), "dlogp must have B entries", {{}, std::nullopt, "gaussian_log_prob_backward.dlogp"});
  auto prepare = [](MatrixX<T>* g, Index r, Index c, const char* f) {
    if (g == nullptr) return;
    if (g->size() == 0) g->setZero(r, c);
    detail::check_same_shape<T>(*g, r, c, std::string("gaussian_log_prob_backward.") + f);
  };
  prepare(dmean, mean.rows(), mean.cols(), "dmean");
  prepare(dlog_std, log_std.rows(), log_std.cols(), "dlog_std");
  const bool shared = log_std.cols() == 1;
  for (Index j = 0; j < mean.cols(); ++j) {
    const T w = dlogp[j];
    for (Index i = 0; i < mean.rows(); ++i) {
      const T ls = detail::ls_at(log_std, i, j);
      const T inv_var = std::exp(T(-2) * ls);
      const T diff = x(i, j) - mean(i, j);
      if (dmean) (*dmean)(i, j) += w * diff * inv_var;
      if (dlog_std) (*dlog_std)(i, shared ? 0 : j) += w * (diff * diff * inv_var - T(1));
    }
  }
}

/// Entropy of the distribution of column j of log_std: Σ_i logσ_i + d·½(1 + log 2π).
template <class T>
T gaussian_entropy_of_column(const Eigen::Ref<const MatrixX<T>>& log_std, Index j = 0) {
  const T c = static_cast<T>(0.5 * (1.0 + std::log(2.0 * std::numbers::pi)));
  return log_std.col(j).sum() + c * static_cast<T>(log_std.rows());
}

/// Entropy of each distribution: (1 × log_std.cols()) — a single value for a (d × 1) log_std.
template <class T>
RowVectorX<T> gaussian_entropy(const Eigen::Ref<const MatrixX<T>>& log_std) {
  RowVectorX<T> h(log_std.cols());
  for (Index j = 0; j < log_std.cols(); ++j) h[j] = gaussian_entropy_of_column<T>(log_std, j);
  return h;
}

/// Backward of gaussian_entropy: ADDS dH_j (∂L/∂H_j, 1 × log_std.cols()) to every entry of
/// column j of `dlog_std` (resized and zeroed if empty).
template <class T>
void gaussian_entropy_backward(const Eigen::Ref<const MatrixX<T>>& log_std, const Eigen::Ref<const RowVectorX<T>>& dH,
                               MatrixX<T>& dlog_std) {
  require(dH.size() == log_std.cols(), "dH must have one entry per log_std column",
          {{}, std::nullopt, "gaussian_entropy_backward.dH"});
  if (dlog_std.size() == 0) dlog_std.setZero(log_std.rows(), log_std.cols());
  detail::check_same_shape<T>(dlog_std, log_std.rows(), log_std.cols(), "gaussian_entropy_backward.dlog_std");
  for (Index j = 0; j < log_std.cols(); ++j) dlog_std.col(j).array() += dH[j];
}

/// out (d × B) = μ + σ ⊙ ε, ε ~ N(0, I) drawn from `rng` in column-major order (sample j, then
/// dimension i): the same rng state gives the same actions on every platform.
template <class T>
void gaussian_sample(const Eigen::Ref<const MatrixX<T>>& mean, const Eigen::Ref<const MatrixX<T>>& log_std, Rng& rng,
                     Eigen::Ref<MatrixX<T>> out) {
  detail::check_gaussian_shapes<T>(mean, log_std, "gaussian_sample");
  require(out.rows() == mean.rows() && out.cols() == mean.cols(), "out must have the shape of mean",
          {{}, std::nullopt, "gaussian_sample.out"});
  for (Index j = 0; j < mean.cols(); ++j)
    for (Index i = 0; i < mean.rows(); ++i)
      out(i, j) = mean(i, j) + std::exp(detail::ls_at(log_std, i, j)) * static_cast<T>(rng.normal());
}

}  // namespace maskadapt::nn
