#pragma once
/// \file replay_buffer.hpp
/// A fixed-capacity FIFO of sample columns (e.g. past agent AMP windows for the discriminator).
///
/// AMP trains the discriminator on fresh agent samples *and* on samples from earlier policies so
/// it does not forget what old failure modes looked like. Once full, new columns overwrite the
/// oldest. Sampling is uniform with replacement over what is stored.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/rl/rollout_buffer.hpp>

#include <vector>

namespace maskadapt::rl {

template <class T = float>
class ReplayBuffer {
 public:
  ReplayBuffer() = default;
  /// \param dim rows of every sample; \param capacity maximal number of stored columns
  ReplayBuffer(Index dim, Index capacity) {
    require(dim > 0 && capacity > 0, "replay buffer dim and capacity must be positive", {{}, {}, "ReplayBuffer"});
    data_.setZero(dim, capacity);
  }

  Index dim() const { return data_.rows(); }
  Index capacity() const { return data_.cols(); }
  Index size() const { return size_; }
  bool empty() const { return size_ == 0; }
  /// Index of the column the next push writes (for checkpoints).
  Index head() const { return head_; }

  /// Appends the columns of `x` (dim × n), overwriting the oldest when full.
  template <class Derived>
  void push(const Eigen::MatrixBase<Derived>& x) {
    require(x.rows() == dim(), "replay buffer push: wrong number of rows", {{}, {}, "ReplayBuffer.push"});
    require_finite(x, "ReplayBuffer.push");
    for (Index j = 0; j < x.cols(); ++j) {
      data_.col(head_) = x.col(j);
      head_ = (head_ + 1) % capacity();
      if (size_ < capacity()) ++size_;
    }
  }

  /// n columns drawn uniformly with replacement into `out` (dim × n). Throws if empty.
  void sample(Index n, Rng& rng, MatrixX<T>& out) const {
    require(size_ > 0, "cannot sample from an empty replay buffer", {{}, {}, "ReplayBuffer.sample"});
    out.resize(dim(), n);
    picked_.resize(static_cast<std::size_t>(n));  // the draws in order, then the copies (on the pool)
    for (Index& i : picked_) i = static_cast<Index>(rng.uniform_int(static_cast<std::uint64_t>(size_)));
    copy_columns(data_, picked_, out);
  }

  /// Stored columns (dim × capacity); only the first `size()` … in ring order starting at
  /// head() − size() are meaningful. For checkpoints.
  const MatrixX<T>& storage() const { return data_; }
  /// Restores a state saved from storage()/size()/head().
  void restore(const MatrixX<T>& storage, Index size, Index head) {
    require(storage.cols() > 0 && size >= 0 && size <= storage.cols() && head >= 0 && head < storage.cols(),
            "inconsistent replay buffer state", {{}, {}, "ReplayBuffer.restore"});
    data_ = storage;
    size_ = size;
    head_ = head;
  }
  void clear() { size_ = 0; head_ = 0; }

 private:
  MatrixX<T> data_;  // (dim × capacity)
  mutable std::vector<Index> picked_;  ///< sample()'s column draws (scratch, reused)
  Index size_ = 0, head_ = 0;
};

}  // namespace maskadapt::rl
