#pragma once
/// \file popart.hpp
/// PopArt (van Hasselt et al. 2016, "Learning values across many orders of magnitude"):
/// adaptive target normalisation that Preserves Outputs Precisely while Adaptively Rescaling.
///
/// For K objectives (value heads) the network predicts NORMALISED values n = W h + b (K rows of
/// the last, linear layer). Targets y are tracked per objective with step size β:
///
///     μ ← (1−β)μ + β·mean_batch(y)        ν ← (1−β)ν + β·mean_batch(y²)
///     σ = sqrt(max(ν − μ², σ_min²))
///
/// and when (μ, σ) change to (μ', σ') the last layer is rescaled so the UN-normalised outputs
/// σ·n + μ are unchanged:
///
///     W_k ← W_k · σ_k/σ'_k          b_k ← (σ_k·b_k + μ_k − μ'_k) / σ'_k
///
/// Initial statistics μ = 0, ν = 1 (σ = 1): normalisation starts as the identity.
#include <cmath>
#include <string>

#include <Eigen/Core>

#include "maskadapt/core/error.hpp"
#include "maskadapt/core/types.hpp"
#include "maskadapt/nn/mlp.hpp"

namespace maskadapt::nn {

template <class T = float>
class PopArt {
 public:
  PopArt() = default;
  /// num_objectives K, EMA step size beta ∈ (0, 1], lower bound on σ.
  explicit PopArt(Index num_objectives, double beta = 3e-4, double std_min = 1e-4)
      : mu_(VectorXd::Zero(num_objectives)), nu_(VectorXd::Ones(num_objectives)), beta_(beta), std_min_(std_min) {
    require(num_objectives > 0, "need at least one objective", {{}, std::nullopt, "PopArt.num_objectives"});
    require(beta > 0 && beta <= 1, "beta must be in (0, 1]", {{}, std::nullopt, "PopArt.beta"});
    require(std_min > 0, "std_min must be positive", {{}, std::nullopt, "PopArt.std_min"});
  }

  Index num_objectives() const { return mu_.size(); }
  double beta() const { return beta_; }
  const VectorXd& mean() const { return mu_; }
  /// Running second moment ν.
  const VectorXd& second_moment() const { return nu_; }
  VectorXd stddev() const {
    return (nu_.array() - mu_.array().square()).max(std_min_ * std_min_).sqrt().matrix();
  }

  /// Updates the statistics with targets (K × B) and rescales rows [first_row, first_row + K)
  /// of `weight` (rows × in) and `bias` (rows) so un-normalised outputs are preserved.
  void update(const Eigen::Ref<const MatrixX<T>>& targets, Eigen::Ref<MatrixX<T>> weight, Eigen::Ref<VectorX<T>> bias,
              Index first_row = 0) {
    require(targets.rows() == num_objectives(),
            "targets must have " + std::to_string(num_objectives()) + " rows, got " + std::to_string(targets.rows()),
            {{}, std::nullopt, "PopArt::update.targets"});
    require(weight.rows() == bias.size() && first_row >= 0 && first_row + num_objectives() <= weight.rows(),
            "last layer rows out of range", {{}, std::nullopt, "PopArt::update.weight"});
    if (targets.cols() == 0) return;
    require_finite(targets, "PopArt::update.targets");
    const MatrixXd y = targets.template cast<double>();
    const VectorXd old_mu = mu_, old_sigma = stddev();
    mu_ = (1 - beta_) * mu_ + beta_ * y.rowwise().mean();
    nu_ = (1 - beta_) * nu_ + beta_ * y.array().square().rowwise().mean().matrix();
    rescale_last_layer(old_mu, old_sigma, weight, bias, first_row);
  }

  /// The same update from a batch's moments instead of the batch: `batch_mean` = mean_batch(y),
  /// `batch_second_moment` = mean_batch(y²) (K each). A distributed trainer forms them from the
  /// sums of all ranks' targets (train/stage2_learner.hpp).
  void update_from_moments(const VectorXd& batch_mean, const VectorXd& batch_second_moment, Eigen::Ref<MatrixX<T>> weight,
                           Eigen::Ref<VectorX<T>> bias, Index first_row = 0) {
    require(batch_mean.size() == num_objectives() && batch_second_moment.size() == num_objectives(),
            "batch moments must have " + std::to_string(num_objectives()) + " entries", {{}, std::nullopt, "PopArt::update.moments"});
    require(weight.rows() == bias.size() && first_row >= 0 && first_row + num_objectives() <= weight.rows(),
            "last layer rows out of range", {{}, std::nullopt, "PopArt::update.weight"});
    require_finite(batch_mean, "PopArt::update.batch_mean");
    require_finite(batch_second_moment, "PopArt::update.batch_second_moment");
    const VectorXd old_mu = mu_, old_sigma = stddev();
    mu_ = (1 - beta_) * mu_ + beta_ * batch_mean;
    nu_ = (1 - beta_) * nu_ + beta_ * batch_second_moment;
    rescale_last_layer(old_mu, old_sigma, weight, bias, first_row);
  }
  /// Same, on the last layer of `net` (which must have an Identity output activation).
  void update_from_moments(const VectorXd& batch_mean, const VectorXd& batch_second_moment, Mlp<T>& net, Index first_row = 0) {
    require(net.spec().output_activation == Activation::Identity, "PopArt needs a linear (Identity) output layer",
            {{}, std::nullopt, "PopArt::update.net"});
    const Index L = net.num_layers() - 1;
    update_from_moments(batch_mean, batch_second_moment, net.weight(L), net.bias(L), first_row);
  }

  /// Same, on the last layer of `net` (which must have an Identity output activation).
  void update(const Eigen::Ref<const MatrixX<T>>& targets, Mlp<T>& net, Index first_row = 0) {
    require(net.spec().output_activation == Activation::Identity, "PopArt needs a linear (Identity) output layer",
            {{}, std::nullopt, "PopArt::update.net"});
    const Index L = net.num_layers() - 1;
    update(targets, net.weight(L), net.bias(L), first_row);
  }

  /// out = (y − μ)/σ, y and out (K × B).
  void normalize(const Eigen::Ref<const MatrixX<T>>& y, Eigen::Ref<MatrixX<T>> out) const {
    check(y, out, "PopArt::normalize");
    const VectorX<T> m = mu_.cast<T>(), inv = stddev().cwiseInverse().template cast<T>();
    for (Index j = 0; j < y.cols(); ++j) out.col(j) = (y.col(j) - m).cwiseProduct(inv);
  }
  /// out = σ ⊙ n + μ, n and out (K × B).
  void denormalize(const Eigen::Ref<const MatrixX<T>>& n, Eigen::Ref<MatrixX<T>> out) const {
    check(n, out, "PopArt::denormalize");
    const VectorX<T> m = mu_.cast<T>(), s = stddev().template cast<T>();
    for (Index j = 0; j < n.cols(); ++j) out.col(j) = n.col(j).cwiseProduct(s) + m;
  }

  /// Restores statistics (checkpoints).
  void set_state(const VectorXd& mean, const VectorXd& second_moment) {
    require(mean.size() == num_objectives() && second_moment.size() == num_objectives(), "wrong size",
            {{}, std::nullopt, "PopArt.state"});
    require_finite(mean, "PopArt.mean");
    require_finite(second_moment, "PopArt.second_moment");
    mu_ = mean;
    nu_ = second_moment;
  }

 private:
  void check(const Eigen::Ref<const MatrixX<T>>& a, const Eigen::Ref<MatrixX<T>>& out, const char* where) const {
    require(a.rows() == num_objectives() && out.rows() == a.rows() && out.cols() == a.cols(), "shape mismatch",
            {{}, std::nullopt, where});
  }

  /// W_k ← W_k · σ_k/σ'_k, b_k ← (σ_k·b_k + μ_k − μ'_k) / σ'_k for the new statistics.
  void rescale_last_layer(const VectorXd& old_mu, const VectorXd& old_sigma, Eigen::Ref<MatrixX<T>> weight,
                          Eigen::Ref<VectorX<T>> bias, Index first_row) {
    const VectorXd sigma = stddev();
    for (Index k = 0; k < num_objectives(); ++k) {
      const Index r = first_row + k;
      const double ratio = old_sigma[k] / sigma[k];
      weight.row(r) *= static_cast<T>(ratio);
      bias[r] = static_cast<T>((old_sigma[k] * static_cast<double>(bias[r]) + old_mu[k] - mu_[k]) / sigma[k]);
    }
  }

  VectorXd mu_, nu_;
  double beta_ = 3e-4, std_min_ = 1e-4;
};

}  // namespace maskadapt::nn
