#pragma once
/// \file run_loop.hpp
/// The outer loop of a training run: iteration/minute budget, JSONL log, progress line,
/// periodic + final checkpoints in `run.out_dir`, and a clean stop on request (a signal).
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/collective.hpp>
#include <maskadapt/train/base_trainer.hpp>
#include <maskadapt/train/config.hpp>
#include <maskadapt/train/progress.hpp>

#include <atomic>
#include <filesystem>
#include <iostream>
#include <string>

namespace maskadapt::train {

struct RunOptions {
  bool append_log = false;       ///< continue an existing log.jsonl (resume)
  std::ostream* progress = &std::cout;  ///< nullptr: silent
  /// Checked before every iteration: once true, the run stops there and writes its final
  /// checkpoint, as at the end of its budget (the CLI sets it from SIGINT / SIGTERM, so a run
  /// that is interrupted loses no iteration; examples/maskadapt/stop_signals.hpp).
  const std::atomic<bool>* stop = nullptr;
};

/// A process-wide stop flag for RunOptions::stop (the CLI's signal handler sets it).
inline std::atomic<bool>& stop_requested() {
  static std::atomic<bool> flag{false};
  return flag;
}

/// Trains until `cfg.run.iterations` total iterations (counting those already done by a resumed
/// trainer) or `cfg.run.minutes` of wall time, whichever comes first. Writes
/// `<out>/config.json`, `<out>/log.jsonl`, `<out>/checkpoint.bin` (every checkpoint_every
/// iterations and at the end) and, with `run.keep_checkpoints`, `<out>/checkpoint_<it>.bin`
/// copies of the periodic ones. Returns the last stats.
///
/// A distributed trainer (one with `collective()`, docs/distributed.md): every rank runs this
/// loop; rank 0 decides when to stop (budget, stop request) and tells the others, and only rank
/// 0 writes the config, log, progress line and checkpoint files (saving is collective).
template <class Trainer>
IterationStats run_training(Trainer& trainer, const RunOptions& opt = {}) {
  const BaseTrainConfig& cfg = trainer.config();
  namespace fs = std::filesystem;
  Collective* comm = &single_process();
  if constexpr (requires { trainer.collective(); }) comm = &trainer.collective();
  const bool root = comm->is_root();
  const fs::path out = cfg.run.out_dir;
  JsonlLog log;
  if (root) {
    fs::create_directories(out);
    save_config(cfg, (out / "config.json").string());
    if (opt.append_log) drop_log_lines_after((out / "log.jsonl").string(), trainer.iteration());  // (repeated iterations)
    log = JsonlLog((out / "log.jsonl").string(), opt.append_log);
  }
  std::ostream* progress = root ? opt.progress : nullptr;
  Stopwatch clock;
  const double budget_s = cfg.run.minutes > 0 ? 60.0 * cfg.run.minutes : 0.0;
  const long long start_it = trainer.iteration();
  IterationStats st;
  auto checkpoint = [&](bool keep_copy) {
    trainer.save((out / "checkpoint.bin").string());
    if (keep_copy && cfg.run.keep_checkpoints)
      trainer.save((out / ("checkpoint_" + std::to_string(trainer.iteration()) + ".bin")).string());
  };
  while (true) {
    // 0: go on, 1: stop requested, 2: budget spent (rank 0's clock decides for every rank)
    Bytes decision{0};
    if (opt.stop && opt.stop->load()) decision[0] = 1;
    else if (cfg.run.iterations > 0 && trainer.iteration() >= cfg.run.iterations) decision[0] = 2;
    else if (budget_s > 0 && clock.seconds() >= budget_s) decision[0] = 2;
    if (comm->distributed()) comm->broadcast(decision, 0);
    if (decision[0] == 1) {
      if (progress) *progress << "stop requested: checkpoint at iteration " << trainer.iteration() << std::endl;
      break;
    }
    if (decision[0] == 2) break;
    st = trainer.iterate();
    st.elapsed_s = clock.seconds();
    const double per_it = st.elapsed_s / static_cast<double>(trainer.iteration() - start_it);
    double eta = NAN;
    if (cfg.run.iterations > 0) eta = per_it * static_cast<double>(cfg.run.iterations - trainer.iteration());
    if (budget_s > 0) eta = std::isfinite(eta) ? std::min(eta, budget_s - st.elapsed_s) : budget_s - st.elapsed_s;
    st.eta_s = eta;
    log.write(to_json(st));
    if (progress) *progress << format_progress(st, cfg.run.iterations) << std::endl;
    if (trainer.iteration() % cfg.run.checkpoint_every == 0) checkpoint(true);
  }
  checkpoint(false);
  return st;
}

}  // namespace maskadapt::train
