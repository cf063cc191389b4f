#pragma once
/// \file tracking_metrics.hpp
/// Partial-tracking metrics: tracking error of the designated bodies, per-episode success and the
/// success rate over many episodes.
///
/// Per frame t with k designated bodies (positions x_{t,b}, targets x*_{t,b}, metres):
///   e_t = (1/k) Σ_b ‖x_{t,b} − x*_{t,b}‖₂                      (mean per-body deviation)
/// Episode tracking error = mean_t e_t. An episode succeeds when no frame deviates by more than
/// the threshold (0.5 m): by default max_t e_t ≤ 0.5 (DeviationMode::MeanOverBodies); with
/// DeviationMode::AnyBody the stricter max_{t,b} ‖x_{t,b} − x*_{t,b}‖ ≤ 0.5 is used.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

namespace maskadapt::eval {

/// Default success threshold (m): an episode fails once the deviation exceeds it.
inline constexpr double kSuccessThreshold = 0.5;

enum class DeviationMode { MeanOverBodies, AnyBody };

/// Mean Euclidean distance (m) between matching columns of (3 × k) `actual` and `target`.
/// Throws on size mismatch, k = 0 or non-finite input.
inline double mean_position_error(const Eigen::Ref<const Matrix3X>& actual, const Eigen::Ref<const Matrix3X>& target) {
  require(actual.cols() == target.cols(),
          "actual has " + std::to_string(actual.cols()) + " bodies, target has " + std::to_string(target.cols()),
          {{}, {}, "target"});
  require(actual.cols() >= 1, "no designated bodies", {{}, {}, "actual"});
  require_finite(actual, "actual");
  require_finite(target, "target");
  return (actual - target).colwise().norm().mean();
}

/// Accumulates one episode frame by frame.
class TrackingEpisode {
 public:
  explicit TrackingEpisode(double threshold = kSuccessThreshold, DeviationMode mode = DeviationMode::MeanOverBodies)
      : threshold_(threshold), mode_(mode) {
    require(std::isfinite(threshold) && threshold > 0.0, "threshold must be finite and > 0", {{}, {}, "threshold"});
  }

  /// Adds one frame: (3 × k) positions of the designated bodies and their targets (m).
  void add_frame(const Eigen::Ref<const Matrix3X>& actual, const Eigen::Ref<const Matrix3X>& target) {
    const double e = mean_position_error(actual, target);
    const double worst = (actual - target).colwise().norm().maxCoeff();
    sum_ += e;
    ++frames_;
    max_mean_ = std::max(max_mean_, e);
    max_body_ = std::max(max_body_, worst);
  }

  std::int64_t frames() const { return frames_; }
  /// Mean over frames of the per-frame mean deviation (m); 0 for an empty episode.
  double mean_error() const { return frames_ ? sum_ / static_cast<double>(frames_) : 0.0; }
  /// Largest per-frame mean deviation (m).
  double max_mean_deviation() const { return max_mean_; }
  /// Largest single-body deviation (m).
  double max_body_deviation() const { return max_body_; }
  /// True when no frame deviated by more than the threshold (per the mode). Throws if empty.
  bool success() const {
    require(frames_ > 0, "success of an episode with no frames is undefined", {{}, {}, "frames"});
    return (mode_ == DeviationMode::AnyBody ? max_body_ : max_mean_) <= threshold_;
  }

 private:
  double threshold_;
  DeviationMode mode_;
  double sum_ = 0.0, max_mean_ = 0.0, max_body_ = 0.0;
  std::int64_t frames_ = 0;
};

/// Aggregate over episodes: success counts and frame-weighted / episode-averaged errors.
struct TrackingSummary {
  std::int64_t episodes = 0;
  std::int64_t successes = 0;
  std::int64_t frames = 0;
  double sum_frame_error = 0.0;    ///< Σ over all frames of e_t (m)
  double sum_episode_error = 0.0;  ///< Σ over episodes of the episode mean error (m)

  void add(const TrackingEpisode& ep) {
    require(ep.frames() > 0, "cannot add an episode with no frames", {{}, {}, "episode"});
    ++episodes;
    successes += ep.success();
    frames += ep.frames();
    sum_frame_error += ep.mean_error() * static_cast<double>(ep.frames());
    sum_episode_error += ep.mean_error();
  }
  /// successes / episodes; 0 when no episode was added.
  double success_rate() const { return episodes ? static_cast<double>(successes) / static_cast<double>(episodes) : 0.0; }
  /// Mean deviation over all frames of all episodes (m).
  double mean_error_per_frame() const { return frames ? sum_frame_error / static_cast<double>(frames) : 0.0; }
  /// Mean of the episodes' mean errors (m).
  double mean_error_per_episode() const {
    return episodes ? sum_episode_error / static_cast<double>(episodes) : 0.0;
  }
  /// Merges another summary (e.g. from another thread or repeat).
  TrackingSummary& operator+=(const TrackingSummary& o) {
    episodes += o.episodes;
    successes += o.successes;
    frames += o.frames;
    sum_frame_error += o.sum_frame_error;
    sum_episode_error += o.sum_episode_error;
    return *this;
  }
};

}  // namespace maskadapt::eval
