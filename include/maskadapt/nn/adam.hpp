#pragma once
/// \file adam.hpp
/// Adam / AdamW exactly as torch.optim.Adam / AdamW (non-amsgrad), with global gradient-norm
/// clipping as torch.nn.utils.clip_grad_norm_ and a non-finite-gradient guard.
///
/// One step, t = step_count() + 1, for every parameter θ with gradient g:
///
///     norm = ‖g‖₂ over ALL blocks (before clipping; computed in double)
///     if norm is not finite: return {applied = false}; nothing is changed
///     if max_grad_norm > 0:  g ← g · min(1, max_grad_norm / (norm + 1e-6))   (in place)
///     if weight_decay ≠ 0:   Adam:  g ← g + wd·θ        AdamW (decoupled): θ ← θ·(1 − lr·wd)
///     m ← β₁m + (1−β₁)g ;  v ← β₂v + (1−β₂)g²
///     θ ← θ − (lr / (1−β₁ᵗ)) · m / (√v / √(1−β₂ᵗ) + ε)
///
/// The moments live in each ParameterBlock (adam_m, adam_v), so the optimiser object itself only
/// holds hyper-parameters and the step counter (checkpoint both).
///
/// The parameters are cut into segments of 2,048; both the norm (per-segment sums added in
/// segment order) and the element-wise step run segment-parallel on nn::default_pool() when
/// there are at least kMinSplitElements of them, with the same bits for any pool.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <vector>

#include "maskadapt/core/error.hpp"
#include "maskadapt/core/thread_pool.hpp"
#include "maskadapt/core/types.hpp"
#include "maskadapt/nn/chunks.hpp"
#include "maskadapt/nn/parameter_block.hpp"

namespace maskadapt::nn {

/// PyTorch defaults.
struct AdamConfig {
  double lr = 1e-3;
  double beta1 = 0.9;
  double beta2 = 0.999;
  double eps = 1e-8;
  double weight_decay = 0.0;          ///< L2 (Adam: g += wd·θ) or decoupled (AdamW)
  bool decoupled_weight_decay = false;  ///< true: AdamW semantics
  double max_grad_norm = 0.0;          ///< global clipping threshold; ≤ 0 disables clipping
};

/// What one step did.
struct AdamStepResult {
  bool applied = false;    ///< false: a gradient was NaN/inf; parameters, moments, counter untouched
  double grad_norm = 0.0;  ///< global L2 norm of the gradients BEFORE clipping (may be inf/NaN)
  double clip_scale = 1.0; ///< factor the gradients were multiplied by (1 when not clipped)
  explicit operator bool() const { return applied; }
};

template <class T>
class Adam {
 public:
  explicit Adam(AdamConfig config = {}) : config_(config) { validate(); }

  AdamConfig& config() { return config_; }
  const AdamConfig& config() const { return config_; }
  /// Number of applied steps t (torch's state['step']).
  std::int64_t step_count() const { return step_; }
  void set_step_count(std::int64_t t) { step_ = t; }

  /// One step on `block` using block.grads() (which are clipped in place). Does not zero grads.
  AdamStepResult step(ParameterBlock<T>& block) {
    ParameterBlock<T>* one[1] = {&block};
    return step_impl(one, 1);
  }
  /// One step over several blocks sharing one global gradient norm and one step counter
  /// (e.g. a policy's mean network and its learned log-std).
  AdamStepResult step(std::initializer_list<ParameterBlock<T>*> blocks) {
    std::vector<ParameterBlock<T>*> v(blocks);
    return step_impl(v.data(), v.size());
  }
  AdamStepResult step(const std::vector<ParameterBlock<T>*>& blocks) { return step_impl(blocks.data(), blocks.size()); }

 private:
  void validate() const {
    const ErrorContext c{{}, std::nullopt, "AdamConfig"};
    require(config_.lr >= 0 && std::isfinite(config_.lr), "lr must be finite and >= 0", c);
    require(config_.beta1 >= 0 && config_.beta1 < 1, "beta1 must be in [0, 1)", c);
    require(config_.beta2 >= 0 && config_.beta2 < 1, "beta2 must be in [0, 1)", c);
    require(config_.eps >= 0, "eps must be >= 0", c);
    require(config_.weight_decay >= 0, "weight_decay must be >= 0", c);
  }

  AdamStepResult step_impl(ParameterBlock<T>* const* blocks, std::size_t count) {
    validate();
    AdamStepResult r;
    const Index total = list_segments(blocks, count);
    ThreadPool* pool = default_pool();
    const bool split = static_cast<double>(total) >= kMinSplitElements;
    // Σ g² per segment (in parallel), then over segments in their order: the same bits for any pool
    segment_sq_.resize(segments_.size());
    for_segments(pool, split, [&](std::size_t i) {
      const Segment& sg = segments_[i];
      segment_sq_[i] = sum_of_squares(blocks[sg.block]->grads().segment(sg.begin, sg.length));
    });
    double sq = 0.0;
    for (const double v : segment_sq_) sq += v;
    r.grad_norm = std::sqrt(sq);
    if (!std::isfinite(r.grad_norm)) return r;  // leave everything untouched
    T clip = T(1);
    if (config_.max_grad_norm > 0) {
      const double coef = config_.max_grad_norm / (r.grad_norm + 1e-6);
      if (coef < 1.0) {
        r.clip_scale = coef;
        clip = static_cast<T>(coef);
      }
    }
    ++step_;
    const double t = static_cast<double>(step_);
    const T b1 = static_cast<T>(config_.beta1), b2 = static_cast<T>(config_.beta2);
    const T step_size = static_cast<T>(config_.lr / (1.0 - std::pow(config_.beta1, t)));
    const T bc2_sqrt = static_cast<T>(std::sqrt(1.0 - std::pow(config_.beta2, t)));
    const T eps = static_cast<T>(config_.eps);
    const T wd = static_cast<T>(config_.weight_decay);
    const T decay = static_cast<T>(1.0 - config_.lr * config_.weight_decay);
    const bool clipped = r.clip_scale != 1.0;
    const bool l2 = config_.weight_decay != 0 && !config_.decoupled_weight_decay;
    const bool decoupled = config_.weight_decay != 0 && config_.decoupled_weight_decay;
    // Element-wise, segment by segment (in parallel: each element's arithmetic is the scalar
    // formula's, in its order, whatever thread runs it), as array expressions (vectorised:
    // std::sqrt in a plain loop is not, because of errno).
    for_segments(pool, split, [&](std::size_t i) {
      const Segment& sg = segments_[i];
      ParameterBlock<T>& block = *blocks[sg.block];
      auto p = block.params().segment(sg.begin, sg.length).array();
      auto g = block.grads().segment(sg.begin, sg.length).array();
      auto m = block.adam_m().segment(sg.begin, sg.length).array();
      auto v = block.adam_v().segment(sg.begin, sg.length).array();
      if (clipped) g *= clip;  // clipped in place, as torch's clip_grad_norm_
      // g_i (+ wd·θ_i before this step's update: Adam's L2), then the moments, then θ
      auto moments_and_step = [&](const auto& gi) {
        m += (gi - m) * (T(1) - b1);  // torch: exp_avg.lerp_(grad, 1 - beta1)
        v = v * b2 + (T(1) - b2) * gi * gi;
        p -= step_size * m / (v.sqrt() / bc2_sqrt + eps);
      };
      if (decoupled) p *= decay;
      if (l2) moments_and_step(g + wd * p);
      else moments_and_step(g);
    });
    r.applied = true;
    return r;
  }

  /// One L1-sized piece of one block: the unit of the parallel loops (and of the norm's sums).
  struct Segment {
    std::size_t block = 0;
    Index begin = 0, length = 0;
  };
  static constexpr Index kSegment = 2048;

  /// Cuts the blocks into segments_ (a partition that depends on the block sizes only) and
  /// returns the number of parameters; reuses the vector's storage, so steps after the first
  /// allocate nothing.
  Index list_segments(ParameterBlock<T>* const* blocks, std::size_t count) {
    segments_.clear();
    Index total = 0;
    for (std::size_t k = 0; k < count; ++k) {
      const Index n = blocks[k]->size();
      total += n;
      for (Index s0 = 0; s0 < n; s0 += kSegment) segments_.push_back({k, s0, std::min(kSegment, n - s0)});
    }
    return total;
  }

  /// body(i) for every segment: on `pool` when `split` (and a pool is given), else in order.
  template <class Body>
  void for_segments(ThreadPool* pool, bool split, Body&& body) const {
    for_each_index(split ? pool : nullptr, segments_.size(), [&](std::size_t i) { body(i); });
  }

  /// Σ gᵢ² in double, in four interleaved partial sums (a fixed order: the same bits on every
  /// call and thread count; one running sum would be a chain of dependent additions).
  template <class Vector>
  static double sum_of_squares(const Vector& g) {
    double lane[4] = {0, 0, 0, 0};
    const Index n = g.size(), n4 = n / 4 * 4;
    for (Index i = 0; i < n4; i += 4)
      for (int k = 0; k < 4; ++k) lane[k] += static_cast<double>(g[i + k]) * static_cast<double>(g[i + k]);
    for (Index i = n4; i < n; ++i) lane[i - n4] += static_cast<double>(g[i]) * static_cast<double>(g[i]);
    return (lane[0] + lane[1]) + (lane[2] + lane[3]);
  }

  AdamConfig config_;
  std::int64_t step_ = 0;
  std::vector<Segment> segments_;    ///< step scratch: the blocks' segments
  std::vector<double> segment_sq_;   ///< step scratch: Σ g² of each segment
};

}  // namespace maskadapt::nn
