#pragma once
// SIGINT (Ctrl-C) and SIGTERM (a session or job scheduler ending the process) ask a training run
// to stop cleanly: the iteration in progress finishes, the final checkpoint is written and the
// command exits 0 (train::RunOptions::stop). A second signal ends the process at once.
#include <maskadapt/train/run_loop.hpp>

#include <csignal>

namespace maskadapt::cli {

extern "C" inline void request_training_stop(int sig) {
  if (train::stop_requested().exchange(true)) {  // asked twice: do not wait any longer
    std::signal(sig, SIG_DFL);
    std::raise(sig);
  }
}

/// Installs the handlers and returns the flag to pass as RunOptions::stop.
inline const std::atomic<bool>* stop_training_on_signals() {
  static_assert(std::atomic<bool>::is_always_lock_free, "the signal handler needs a lock-free flag");
  std::signal(SIGINT, request_training_stop);
  std::signal(SIGTERM, request_training_stop);
  return &train::stop_requested();
}

}  // namespace maskadapt::cli
