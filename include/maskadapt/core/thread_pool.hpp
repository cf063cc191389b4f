#pragma once
/// \file thread_pool.hpp
/// A small fixed-size thread pool with a blocking `parallel_for`.
///
/// Each thread owns one contiguous share of the range (thread t the t-th of num_threads equal
/// parts, so the same data stay in the same core's cache from call to call) and works through it
/// in grains of about 1/8 of a share; a thread that has finished its own share then steals grains
/// from the others' — a slow index (an env that resets or has many contacts) no longer holds up
/// the rest of its thread's share. Each index is processed exactly once by exactly one thread, in
/// no fixed thread. As long as the body for index i only writes data owned by i (and draws
/// randomness from a stream derived from i), results are bit-identical for any number of threads
/// and any schedule.
///
/// Hand-off: a finished worker spins for a short while (kSpinIterations pauses, tens of µs)
/// before it sleeps on the condition variable, and so does the caller waiting for the workers.
/// Back-to-back parallel_for calls (an Mlp's chunked layers) then cost a few µs each instead of
/// a futex wake-up (measured ~50 µs on the 2-core VM); an idle pool sleeps.
///
/// A `parallel_for` issued from inside a body (of any pool) runs serially on the calling thread:
/// nesting never deadlocks, and code that parallelises internally (e.g. Mlp with a pool in its
/// workspace) can be called from per-env work without care.
#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace maskadapt {

class ThreadPool {
 public:
  /// `num_threads` workers including the calling thread; 0 means hardware concurrency.
  explicit ThreadPool(std::size_t num_threads = 0) {
    if (num_threads == 0) num_threads = std::max<std::size_t>(1, std::thread::hardware_concurrency());
    num_threads_ = num_threads;
    shares_ = std::make_unique<Share[]>(num_threads_);
    for (std::size_t t = 1; t < num_threads_; ++t) workers_.emplace_back([this, t] { worker_loop(t); });
  }
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;
  ~ThreadPool() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
      generation_.fetch_add(1, std::memory_order_release);
    }
    wake_.notify_all();
    for (auto& w : workers_) w.join();
  }

  std::size_t num_threads() const { return num_threads_; }

  /// True on a thread that is currently running a parallel_for body.
  static bool in_parallel_region() { return in_region(); }

  /// Calls body(i) for every i in [begin, end); blocks until all calls finished.
  /// The first exception thrown by any call is rethrown here (after all threads stopped).
  void parallel_for(std::size_t begin, std::size_t end, const std::function<void(std::size_t)>& body) {
    if (end <= begin) return;
    if (num_threads_ == 1 || end - begin == 1 || in_region()) {
      for (std::size_t i = begin; i < end; ++i) body(i);
      return;
    }
    std::unique_lock run_lock(run_mutex_);  // one parallel_for at a time
    {
      std::lock_guard lock(mutex_);
      job_ = &body;
      const std::size_t n = end - begin;
      for (std::size_t t = 0; t < num_threads_; ++t) {
        shares_[t].next.store(begin + n * t / num_threads_, std::memory_order_relaxed);
        shares_[t].end = begin + n * (t + 1) / num_threads_;
      }
      job_grain_ = std::max<std::size_t>(1, n / (num_threads_ * kGrainsPerShare));
      pending_.store(workers_.size(), std::memory_order_relaxed);
      error_ = nullptr;
      generation_.fetch_add(1, std::memory_order_release);
    }
    wake_.notify_all();
    run_shares(0);
    for (int k = 0; k < kSpinIterations && pending_.load(std::memory_order_acquire) != 0; ++k) cpu_relax();
    std::unique_lock lock(mutex_);
    done_.wait(lock, [this] { return pending_.load(std::memory_order_acquire) == 0; });
    job_ = nullptr;
    if (error_) std::rethrow_exception(error_);
  }

 private:
  /// One thread's share of the job: the grains [i, i + grain) of [next, end) not yet taken.
  struct alignas(64) Share {
    std::atomic<std::size_t> next{0};
    std::size_t end = 0;
  };

  /// Thread `self` takes the grains of its own share, then those left in the others' (from the
  /// next thread's on), until none is left. After an exception no new grain is started (by any
  /// thread); grains already running finish.
  void run_shares(std::size_t self) {
    in_region() = true;
    try {
      for (std::size_t k = 0; k < num_threads_; ++k) {
        Share& share = shares_[(self + k) % num_threads_];
        for (;;) {
          const std::size_t lo = share.next.fetch_add(job_grain_, std::memory_order_relaxed);
          if (lo >= share.end) break;
          const std::size_t hi = std::min(share.end, lo + job_grain_);
          for (std::size_t i = lo; i < hi; ++i) (*job_)(i);
        }
      }
      in_region() = false;
    } catch (...) {
      in_region() = false;
      for (std::size_t t = 0; t < num_threads_; ++t) shares_[t].next.store(shares_[t].end, std::memory_order_relaxed);
      std::lock_guard lock(mutex_);
      if (!error_) error_ = std::current_exception();
    }
  }

  static bool& in_region() {
    thread_local bool flag = false;
    return flag;
  }

  static void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
    _mm_pause();
#else
    std::this_thread::yield();
#endif
  }

  void worker_loop(std::size_t self) {
    std::size_t seen = 0;
    for (;;) {
      for (int k = 0; k < kSpinIterations && generation_.load(std::memory_order_acquire) == seen; ++k) cpu_relax();
      {
        std::unique_lock lock(mutex_);
        wake_.wait(lock, [&] { return generation_.load(std::memory_order_acquire) != seen; });
        seen = generation_.load(std::memory_order_acquire);
        if (stop_) return;
      }
      run_shares(self);
      if (pending_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
        std::lock_guard lock(mutex_);  // pairs with the caller's predicate check: no lost wake-up
        done_.notify_one();
      }
    }
  }

  static constexpr int kSpinIterations = 1 << 12;
  static constexpr std::size_t kGrainsPerShare = 8;  ///< grain = range / (threads × this), at least 1

  std::size_t num_threads_ = 1;
  std::vector<std::thread> workers_;
  std::mutex mutex_, run_mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(std::size_t)>* job_ = nullptr;
  std::size_t job_grain_ = 1;
  std::unique_ptr<Share[]> shares_;  ///< one per thread, the caller's first
  std::atomic<std::size_t> pending_{0}, generation_{0};
  bool stop_ = false;
  std::exception_ptr error_;
};

/// Calls body(i) for every i in [0, n): on `pool` where one is given (ThreadPool::parallel_for: any
/// order, one thread per index), else in order on the calling thread. The one way this library
/// runs optional per-env or per-sample work in parallel.
template <class Body>
void for_each_index(ThreadPool* pool, std::size_t n, Body&& body) {
  if (pool) {
    pool->parallel_for(0, n, body);
  } else {
    for (std::size_t i = 0; i < n; ++i) body(i);
  }
}

}  // namespace maskadapt
