#pragma once
/// \file chunks.hpp
/// A fixed partition of a matrix side into chunks, run on an optional ThreadPool.
///
/// The big products of an Mlp (W·X, D·Aᵀ, Wᵀ·D of at least kMinChunkedMacs multiply-adds) are
/// split along the longer side of their result into chunks, and each chunk is one
/// single-threaded GEMM plus its element-wise epilogue (bias, activation, derivative) while the
/// chunk is still in cache. The partition depends on the side's
/// length ONLY — never on the number of threads, nor on whether a pool is given — so every result
/// is bit-identical for any pool size, including none.
///
/// Why not let OpenBLAS thread each GEMM: measured on the 2-core Zen 4 machine, OpenBLAS 0.3.21's
/// own two threads reach 61–88% of two cores on the MLP's shapes, while two single-threaded GEMMs
/// on halves of the output reach 83–92% (docs/benchmarks.md). Set OpenBLAS to one thread
/// (`limit_blas_threads(1)`) when you hand a pool to the Mlp, or the two schemes oversubscribe.
#include <algorithm>
#include <cstddef>
#include <utility>

#include "maskadapt/core/thread_pool.hpp"
#include "maskadapt/core/types.hpp"

namespace maskadapt::nn {

/// Number of chunks a side of length n is cut into: n/64 clamped to [1, 8], made even (so two
/// threads get equal shares). Depends on n only.
inline Index num_chunks(Index n) {
  Index c = std::clamp<Index>(n / 64, 1, 8);
  if (c > 1) c &= ~Index(1);
  return c;
}

/// [lo, hi) of chunk i of num_chunks(n); inner boundaries are multiples of 16 (SIMD-friendly).
inline void chunk_range(Index n, Index i, Index& lo, Index& hi) {
  const Index c = num_chunks(n);
  auto boundary = [&](Index k) { return k == 0 ? Index(0) : k == c ? n : (n * k / c) / 16 * 16; };
  lo = boundary(i);
  hi = boundary(i + 1);
}

/// The pool that Mlp passes on this thread use when their workspace or cache names none
/// (nullptr: run on the calling thread). Set it for a region with ScopedPool.
inline ThreadPool*& default_pool() {
  thread_local ThreadPool* pool = nullptr;
  return pool;
}

/// Makes `pool` this thread's default_pool() until the end of the scope (then restores the
/// previous one). Trainers wrap an iteration in one, so every network pass inside — PPO, MI loss,
/// discriminators, critics — runs its chunks on the trainer's pool without being told.
class ScopedPool {
 public:
  explicit ScopedPool(ThreadPool* pool) : previous_(default_pool()) { default_pool() = pool; }
  ~ScopedPool() { default_pool() = previous_; }
  ScopedPool(const ScopedPool&) = delete;
  ScopedPool& operator=(const ScopedPool&) = delete;

 private:
  ThreadPool* previous_;
};

/// Products smaller than this many multiply-adds are not split: one BLAS call (e.g. a batch-1
/// GEMV, ~0.3 M MACs for the paper's first layer) beats chunks plus a pool wake-up (~10–50 µs).
inline constexpr double kMinChunkedMacs = 4.0 * 1024 * 1024;

/// Whether a (rows × inner)·(inner × cols) product is worth splitting (≥ kMinChunkedMacs).
inline bool worth_chunking(Index rows, Index inner, Index cols) {
  return double(rows) * double(inner) * double(cols) >= kMinChunkedMacs;
}

/// A batch-1 product (GEMV) is split over the pool's threads by rows when its weights are at
/// least this large: streaming 1 MB takes ~10 µs per core, the pool's hand-off ~3 µs.
inline constexpr double kMinSplitGemvBytes = 1024.0 * 1024;

/// Calls body(lo, hi) for every chunk of a side of length n — or once for [0, n) when `split` is
/// false: on `pool` when one is given, else in order on the calling thread. Nested inside another
/// parallel_for it runs serially.
template <class Body>
void for_each_chunk(ThreadPool* pool, Index n, bool split, Body&& body) {
  if (!split) {
    if (n > 0) body(Index(0), n);
    return;
  }
  const Index c = num_chunks(n);
  auto run = [&](Index i) {
    Index lo = 0, hi = 0;
    chunk_range(n, i, lo, hi);
    if (hi > lo) body(lo, hi);
  };
  for_each_index(pool, static_cast<std::size_t>(c), [&](std::size_t i) { run(static_cast<Index>(i)); });
}

/// Element-wise or column-wise passes (copies, normalisation, gathers) over at least this many
/// entries are split over the pool: 64 K floats take ~15–30 µs on one core, a hand-off ~3 µs.
inline constexpr double kMinSplitElements = 64.0 * 1024;

/// Calls body(c0, c1) for the column chunks [c0, c1) of a (rows × cols) matrix (for_each_chunk's
/// partition of `cols`) — on `pool` when the matrix holds at least kMinSplitElements entries, else
/// once for [0, cols) on the calling thread. For work whose result in a column depends on that
/// column only, the result is bit-identical for any pool.
template <class Body>
void for_each_column_chunk(ThreadPool* pool, Index rows, Index cols, Body&& body) {
  for_each_chunk(pool, cols, double(rows) * double(cols) >= kMinSplitElements, std::forward<Body>(body));
}

/// Calls body(r0, nr, c0, nc) for the blocks of a (rows × cols) result cut by for_each_chunk along
/// its longer side — the columns when cols > rows, or when they are equal and !rows_on_tie — with
/// the other side whole. One body serves both directions.
template <class Body>
void for_each_block(ThreadPool* pool, Index rows, Index cols, bool split, Body&& body, bool rows_on_tie = false) {
  if (cols > rows || (cols == rows && !rows_on_tie)) {
    for_each_chunk(pool, cols, split, [&](Index lo, Index hi) { body(Index(0), rows, lo, hi - lo); });
  } else {
    for_each_chunk(pool, rows, split, [&](Index lo, Index hi) { body(lo, hi - lo, Index(0), cols); });
  }
}

}  // namespace maskadapt::nn
