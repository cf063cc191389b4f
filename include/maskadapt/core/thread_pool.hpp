#pragma once
/// \file thread_pool.hpp
/// A small fixed-size thread pool with a blocking `parallel_for`.
///
/// Work is split into contiguous index ranges; each index is processed exactly once by exactly one
/// thread. As long as the body for index i only writes data owned by i (and draws randomness from
/// a stream derived from i), results are bit-identical for any number of threads.
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
      job_begin_ = begin;
      job_end_ = end;
      pending_.store(workers_.size(), std::memory_order_relaxed);
      error_ = nullptr;
      generation_.fetch_add(1, std::memory_order_release);
    }
    wake_.notify_all();
    run_range(0);
    for (int k = 0; k < kSpinIterations && pending_.load(std::memory_order_acquire) != 0; ++k) cpu_relax();
    std::unique_lock lock(mutex_);
    done_.wait(lock, [this] { return pending_.load(std::memory_order_acquire) == 0; });
    job_ = nullptr;
    if (error_) std::rethrow_exception(error_);
  }

 private:
  void run_range(std::size_t thread_index) {
    const std::size_t n = job_end_ - job_begin_;
    const std::size_t lo = job_begin_ + n * thread_index / num_threads_;
    const std::size_t hi = job_begin_ + n * (thread_index + 1) / num_threads_;
    in_region() = true;
    try {
      for (std::size_t i = lo; i < hi; ++i) (*job_)(i);
      in_region() = false;
    } catch (...) {
      in_region() = false;
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

  void worker_loop(std::size_t thread_index) {
    std::size_t seen = 0;
    for (;;) {
      for (int k = 0; k < kSpinIterations && generation_.load(std::memory_order_acquire) == seen; ++k) cpu_relax();
      {
        std::unique_lock lock(mutex_);
        wake_.wait(lock, [&] { return generation_.load(std::memory_order_acquire) != seen; });
        seen = generation_.load(std::memory_order_acquire);
        if (stop_) return;
      }
      run_range(thread_index);
      if (pending_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
        std::lock_guard lock(mutex_);  // pairs with the caller's predicate check: no lost wake-up
        done_.notify_one();
      }
    }
  }

  static constexpr int kSpinIterations = 1 << 12;

  std::size_t num_threads_ = 1;
  std::vector<std::thread> workers_;
  std::mutex mutex_, run_mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(std::size_t)>* job_ = nullptr;
  std::size_t job_begin_ = 0, job_end_ = 0;
  std::atomic<std::size_t> pending_{0}, generation_{0};
  bool stop_ = false;
  std::exception_ptr error_;
};

}  // namespace maskadapt
