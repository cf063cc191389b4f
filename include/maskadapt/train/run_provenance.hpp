#pragma once
/// \file run_provenance.hpp
/// How a training run came about, kept in its checkpoints and carried into exported models:
/// one line per start or resume (date, git commit, command line) and the wall time spent
/// training over all chunks. Both trainers keep one; neither reads it back into training, so it
/// never changes what a resumed run computes.
///
/// Sections:
///   provenance/history        bytes  one line per chunk
///   provenance/train_seconds  f64    training wall time (s), all chunks; NaN = unknown
#include <maskadapt/core/checkpoint.hpp>

#include <cmath>
#include <string>

namespace maskadapt::train {

struct RunProvenance {
  std::string history;       ///< one line per start / resume, each ending in '\n'
  double train_seconds = 0;  ///< wall seconds in the trainer's iterate(), all chunks (NaN: unknown)

  void add(const std::string& line) { history += line + "\n"; }
  void save(Checkpoint& c) const {
    c.put_string("provenance/history", history);
    c.put_double("provenance/train_seconds", train_seconds);
  }
  /// Checkpoints written before these records: the history is unknown, and so is the time.
  void load(const Checkpoint& c) {
    history = c.contains("provenance/history") ? c.get_string("provenance/history")
                                               : std::string("(earlier chunks predate provenance records)\n");
    train_seconds = c.contains("provenance/train_seconds") ? c.get_double("provenance/train_seconds") : NAN;
  }
};

}  // namespace maskadapt::train
