#pragma once
// SIGINT (Ctrl-C) and SIGTERM (a session or job scheduler ending the process) ask a training run
// to stop cleanly: the iteration in progress finishes, the final checkpoint is written and the
// command exits 0 (train::RunOptions::stop). A second signal at least a second after the first
// ends the process at once. (Within that second it is the same request delivered twice: `timeout`
// signals the command and then its whole process group, and on a busy machine the handler runs
// between the two, which used to kill the run before its final checkpoint.)
#include <maskadapt/train/run_loop.hpp>

#include <atomic>
#include <csignal>
#include <ctime>

namespace maskadapt::cli {

/// Monotonic nanoseconds (clock_gettime is async-signal-safe).
inline long long signal_clock_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<long long>(t.tv_sec) * 1000000000LL + t.tv_nsec;
}

inline std::atomic<long long>& first_stop_signal_ns() {
  static std::atomic<long long> ns{0};
  return ns;
}

extern "C" inline void request_training_stop(int sig) {
  const long long now = signal_clock_ns();
  if (!train::stop_requested().exchange(true)) {
    first_stop_signal_ns().store(now);
    return;
  }
  if (now - first_stop_signal_ns().load() < 1000000000LL) return;  // the same request, delivered twice
  std::signal(sig, SIG_DFL);  // asked again: do not wait any longer
  std::raise(sig);
}

/// Installs the handlers and returns the flag to pass as RunOptions::stop.
inline const std::atomic<bool>* stop_training_on_signals() {
  static_assert(std::atomic<bool>::is_always_lock_free, "the signal handler needs a lock-free flag");
  std::signal(SIGINT, request_training_stop);
  std::signal(SIGTERM, request_training_stop);
  return &train::stop_requested();
}

}  // namespace maskadapt::cli
