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
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <vector>

#include "maskadapt/core/error.hpp"
#include "maskadapt/core/types.hpp"
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
    double sq = 0.0;
    for (std::size_t k = 0; k < count; ++k) {
      const auto g = blocks[k]->grads();
      for (Index i = 0; i < g.size(); ++i) sq += static_cast<double>(g[i]) * static_cast<double>(g[i]);
    }
    r.grad_norm = std::sqrt(sq);
    if (!std::isfinite(r.grad_norm)) return r;  // leave everything untouched
    if (config_.max_grad_norm > 0) {
      const double coef = config_.max_grad_norm / (r.grad_norm + 1e-6);
      if (coef < 1.0) {
        r.clip_scale = coef;
        for (std::size_t k = 0; k < count; ++k) blocks[k]->grads() *= static_cast<T>(coef);
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
    const bool l2 = config_.weight_decay != 0 && !config_.decoupled_weight_decay;
    const bool decoupled = config_.weight_decay != 0 && config_.decoupled_weight_decay;
    for (std::size_t k = 0; k < count; ++k) {
      auto p = blocks[k]->params();
      const auto g = blocks[k]->grads();
      auto m = blocks[k]->adam_m();
      auto v = blocks[k]->adam_v();
      for (Index i = 0; i < p.size(); ++i) {
        T gi = g[i];
        if (l2) gi += wd * p[i];
        if (decoupled) p[i] *= decay;
        m[i] += (gi - m[i]) * (T(1) - b1);  // torch: exp_avg.lerp_(grad, 1 - beta1)
        v[i] = v[i] * b2 + (T(1) - b2) * gi * gi;
        const T denom = std::sqrt(v[i]) / bc2_sqrt + eps;
        p[i] -= step_size * m[i] / denom;
      }
    }
    r.applied = true;
    return r;
  }

  AdamConfig config_;
  std::int64_t step_ = 0;
};

}  // namespace maskadapt::nn
