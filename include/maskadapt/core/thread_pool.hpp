#pragma once
/// \file thread_pool.hpp
/// A small fixed-size thread pool with a blocking `parallel_for`.
///
/// Work is split into contiguous index ranges; each index is processed exactly once by exactly one
/// thread. As long as the body for index i only writes data owned by i (and draws randomness from
/// a stream derived from i), results are bit-identical for any number of threads.
#include <algorithm>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

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
      ++generation_;
    }
    wake_.notify_all();
    for (auto& w : workers_) w.join();
  }

  std::size_t num_threads() const { return num_threads_; }

  /// Calls body(i) for every i in [begin, end); blocks until all calls finished.
  /// The first exception thrown by any call is rethrown here (after all threads stopped).
  void parallel_for(std::size_t begin, std::size_t end, const std::function<void(std::size_t)>& body) {
    if (end <= begin) return;
    if (num_threads_ == 1 || end - begin == 1) {
      for (std::size_t i = begin; i < end; ++i) body(i);
      return;
    }
    std::unique_lock run_lock(run_mutex_);  // one parallel_for at a time
    {
      std::lock_guard lock(mutex_);
      job_ = &body;
      job_begin_ = begin;
      job_end_ = end;
      pending_ = workers_.size();
      error_ = nullptr;
      ++generation_;
    }
    wake_.notify_all();
    run_range(0);
    std::unique_lock lock(mutex_);
    done_.wait(lock, [this] { return pending_ == 0; });
    job_ = nullptr;
    if (error_) std::rethrow_exception(error_);
  }

 private:
  void run_range(std::size_t thread_index) {
    const std::size_t n = job_end_ - job_begin_;
    const std::size_t lo = job_begin_ + n * thread_index / num_threads_;
    const std::size_t hi = job_begin_ + n * (thread_index + 1) / num_threads_;
    try {
      for (std::size_t i = lo; i < hi; ++i) (*job_)(i);
    } catch (...) {
      std::lock_guard lock(mutex_);
      if (!error_) error_ = std::current_exception();
    }
  }

  void worker_loop(std::size_t thread_index) {
    std::size_t seen = 0;
    for (;;) {
      {
        std::unique_lock lock(mutex_);
        wake_.wait(lock, [&] { return generation_ != seen; });
        seen = generation_;
        if (stop_) return;
      }
      run_range(thread_index);
      {
        std::lock_guard lock(mutex_);
        if (--pending_ == 0) done_.notify_one();
      }
    }
  }

  std::size_t num_threads_ = 1;
  std::vector<std::thread> workers_;
  std::mutex mutex_, run_mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(std::size_t)>* job_ = nullptr;
  std::size_t job_begin_ = 0, job_end_ = 0, pending_ = 0, generation_ = 0;
  bool stop_ = false;
  std::exception_ptr error_;
};

}  // namespace maskadapt
