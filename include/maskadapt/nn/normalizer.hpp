#pragma once
/// \file normalizer.hpp
/// Running mean / variance of feature vectors and input normalisation.
///
/// Statistics are kept in double whatever the feature scalar T, updated batch by batch with the
/// Chan et al. parallel merge (a batch is summarised by its count, mean and M2, then merged), so
/// several workers' normalisers can be merged and give the same statistics as one pass over all
/// the data (up to rounding).
///
///     normalize(x) = clamp((x − mean) / sqrt(var + eps), −clip, clip)      var = M2 / count
///
/// The mean and 1/std in T that normalize() applies are recomputed when the statistics change,
/// not per call, and update() reuses its buffers: neither allocates (the training loop's update
/// path allocates no matrix). Both split large batches over nn::default_pool() (normalize by
/// columns, update by rows), with the same bits for any pool.
#include <cmath>
#include <string>

#include <Eigen/Core>

#include "maskadapt/core/error.hpp"
#include "maskadapt/core/types.hpp"
#include "maskadapt/nn/chunks.hpp"

namespace maskadapt::nn {

template <class T = float>
class RunningNormalizer {
 public:
  RunningNormalizer() = default;
  /// dim features; outputs are clipped to ±clip (≤ 0: no clipping); eps is added to the variance.
  explicit RunningNormalizer(Index dim, double clip = 5.0, double eps = 1e-8)
      : mean_(VectorXd::Zero(dim)), m2_(VectorXd::Zero(dim)), clip_(clip), eps_(eps) {
    require(dim > 0, "dimension must be positive", {{}, std::nullopt, "RunningNormalizer.dim"});
    refresh();
  }

  Index dim() const { return mean_.size(); }
  double count() const { return count_; }
  const VectorXd& mean() const { return mean_; }
  /// Population variance M2 / count (1 before any data, so normalisation starts as identity).
  VectorXd variance() const { return count_ > 0 ? VectorXd(m2_ / count_) : VectorXd::Ones(dim()); }
  /// sqrt(variance + eps).
  VectorXd stddev() const { return (variance().array() + eps_).sqrt().matrix(); }
  const VectorXd& m2() const { return m2_; }
  double clip() const { return clip_; }
  double eps() const { return eps_; }

  /// Adds a batch x (dim × B). Throws (statistics untouched) on a wrong shape or non-finite input.
  /// The batch's mean and M2 are summed column by column in order (double), rows split over
  /// default_pool() for large batches: the same bits for any pool.
  void update(const Eigen::Ref<const MatrixX<T>>& x) {
    require(x.rows() == dim(), "expected " + std::to_string(dim()) + " rows, got " + std::to_string(x.rows()),
            {{}, std::nullopt, "RunningNormalizer::update.x"});
    if (x.cols() == 0) return;
    const Index B = x.cols();
    const double n = static_cast<double>(B);
    bmean_.resize(dim());
    bm2_.resize(dim());
    const bool split = double(dim()) * double(B) >= kMinSplitElements;
    for_each_chunk(default_pool(), dim(), split, [&](Index r0, Index r1) {
      const Index nr = r1 - r0;
      auto mean = bmean_.segment(r0, nr);
      auto m2 = bm2_.segment(r0, nr);
      mean.setZero();
      for (Index j = 0; j < B; ++j) mean += x.col(j).segment(r0, nr).template cast<double>();
      mean /= n;
      m2.setZero();
      for (Index j = 0; j < B; ++j)
        m2.array() += (x.col(j).segment(r0, nr).template cast<double>() - mean).array().square();
    });
    // a NaN or ±inf anywhere in x makes its row's sums non-finite (floats cannot overflow a
    // double sum), so the input scan runs only to name the bad entry
    if (!bmean_.allFinite() || !bm2_.allFinite()) require_finite(x, "RunningNormalizer::update.x");
    merge_stats(n, bmean_, bm2_);
  }

  /// Merges another worker's statistics (Chan et al.); equal to one pass over both data sets.
  void merge(const RunningNormalizer& other) {
    require(other.dim() == dim(), "cannot merge normalisers of different dimensions",
            {{}, std::nullopt, "RunningNormalizer::merge"});
    if (other.count_ > 0) merge_stats(other.count_, other.mean_, other.m2_);
  }

  /// out = clamp((x − mean)/std, ±clip), x and out (dim × B); out may alias x.
  void normalize(const Eigen::Ref<const MatrixX<T>>& x, Eigen::Ref<MatrixX<T>> out) const {
    require(x.rows() == dim() && out.rows() == dim() && out.cols() == x.cols(), "shape mismatch",
            {{}, std::nullopt, "RunningNormalizer::normalize"});
    const T c = static_cast<T>(clip_);
    for_each_column_chunk(default_pool(), x.rows(), x.cols(), [&](Index c0, Index c1) {
      for (Index j = c0; j < c1; ++j) {
        auto o = out.col(j);
        o = (x.col(j) - mean_t_).cwiseProduct(inv_std_t_);
        if (clip_ > 0) o = o.cwiseMax(-c).cwiseMin(c);
      }
    });
  }
  MatrixX<T> normalize(const Eigen::Ref<const MatrixX<T>>& x) const {
    MatrixX<T> out(x.rows(), x.cols());
    normalize(x, out);
    return out;
  }
  /// out = x ⊙ std + mean (inverse of normalize where not clipped).
  void denormalize(const Eigen::Ref<const MatrixX<T>>& x, Eigen::Ref<MatrixX<T>> out) const {
    require(x.rows() == dim() && out.rows() == dim() && out.cols() == x.cols(), "shape mismatch",
            {{}, std::nullopt, "RunningNormalizer::denormalize"});
    const VectorX<T> m = mean_.cast<T>();
    const VectorX<T> s = stddev().template cast<T>();
    for (Index j = 0; j < x.cols(); ++j) out.col(j) = x.col(j).cwiseProduct(s) + m;
  }

  /// Restores statistics (checkpoints): count ≥ 0, mean and m2 of size dim, m2 ≥ 0.
  void set_state(double count, const VectorXd& mean, const VectorXd& m2) {
    require(count >= 0 && std::isfinite(count), "count must be finite and >= 0", {{}, std::nullopt, "RunningNormalizer.count"});
    require(mean.size() == dim() && m2.size() == dim(), "mean/m2 must have " + std::to_string(dim()) + " entries",
            {{}, std::nullopt, "RunningNormalizer.state"});
    require_finite(mean, "RunningNormalizer.mean");
    require_finite(m2, "RunningNormalizer.m2");
    require((m2.array() >= 0).all(), "m2 must be >= 0", {{}, std::nullopt, "RunningNormalizer.m2"});
    count_ = count;
    mean_ = mean;
    m2_ = m2;
    refresh();
  }

 private:
  void merge_stats(double nb, const VectorXd& mb, const VectorXd& m2b) {
    const double na = count_, n = na + nb;
    delta_ = mb - mean_;
    mean_ += delta_ * (nb / n);
    m2_ += m2b + delta_.cwiseProduct(delta_) * (na * nb / n);
    count_ = n;
    refresh();
  }
  /// The T-precision mean and 1/std that normalize() applies (in place: sizes do not change).
  void refresh() {
    mean_t_ = mean_.cast<T>();
    inv_std_t_.resize(dim());
    for (Index i = 0; i < dim(); ++i) {
      const double var = count_ > 0 ? m2_[i] / count_ : 1.0;
      inv_std_t_[i] = static_cast<T>(1.0 / std::sqrt(var + eps_));
    }
  }

  double count_ = 0;
  VectorXd mean_, m2_;
  double clip_ = 5.0, eps_ = 1e-8;
  VectorX<T> mean_t_, inv_std_t_;  ///< (dim) mean and 1/sqrt(var + eps) in T, see refresh()
  VectorXd bmean_, bm2_, delta_;   ///< update()'s batch statistics
};

}  // namespace maskadapt::nn
