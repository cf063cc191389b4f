#pragma once
/// \file parameter_block.hpp
/// One flat buffer holding a model's parameters, gradients and Adam moments.
///
/// Layout of `storage()` (size 4·n, n = number of parameters):
///
///     [ params (n) | grads (n) | adam_m (n) | adam_v (n) ]
///
/// so a checkpoint of a whole training state is one contiguous copy of `storage()`, an
/// all-reduce of gradients is one contiguous copy of `grads()`, and a parameter broadcast is one
/// contiguous copy of `params()`. `Mlp<T>` owns one ParameterBlock; a learned log-std (or any
/// other free parameter vector) is simply a ParameterBlock of its own, and `Adam::step` accepts a
/// list of blocks so global gradient clipping spans all of them.
#include <cstring>

#include <Eigen/Core>

#include "maskadapt/core/error.hpp"
#include "maskadapt/core/types.hpp"

namespace maskadapt::nn {

template <class T>
class ParameterBlock {
 public:
  using Scalar = T;
  static constexpr Index kSlots = 4;  ///< params, grads, adam_m, adam_v

  ParameterBlock() = default;
  /// n parameters, everything zero.
  explicit ParameterBlock(Index n) : n_(n), storage_(VectorX<T>::Zero(kSlots * n)) {
    require(n >= 0, "parameter count must be non-negative", {{}, std::nullopt, "ParameterBlock"});
  }

  /// Number of parameters n.
  Index size() const { return n_; }

  /// Parameters θ (n).
  Eigen::Map<VectorX<T>> params() { return {storage_.data(), n_}; }
  Eigen::Map<const VectorX<T>> params() const { return {storage_.data(), n_}; }
  /// Gradient accumulator ∂L/∂θ (n). backward() passes ADD into it; call zero_grad() per step.
  Eigen::Map<VectorX<T>> grads() { return {storage_.data() + n_, n_}; }
  Eigen::Map<const VectorX<T>> grads() const { return {storage_.data() + n_, n_}; }
  /// Adam first moment m (n).
  Eigen::Map<VectorX<T>> adam_m() { return {storage_.data() + 2 * n_, n_}; }
  Eigen::Map<const VectorX<T>> adam_m() const { return {storage_.data() + 2 * n_, n_}; }
  /// Adam second moment v (n).
  Eigen::Map<VectorX<T>> adam_v() { return {storage_.data() + 3 * n_, n_}; }
  Eigen::Map<const VectorX<T>> adam_v() const { return {storage_.data() + 3 * n_, n_}; }

  /// The whole buffer (4·n): [params | grads | adam_m | adam_v].
  VectorX<T>& storage() { return storage_; }
  const VectorX<T>& storage() const { return storage_; }

  void zero_grad() { grads().setZero(); }
  /// Zero both Adam moments (e.g. when starting a new optimiser on loaded parameters).
  void reset_optimizer_state() {
    adam_m().setZero();
    adam_v().setZero();
  }

 private:
  Index n_ = 0;
  VectorX<T> storage_;
};

}  // namespace maskadapt::nn
