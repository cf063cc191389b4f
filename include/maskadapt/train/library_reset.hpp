#pragma once
/// \file library_reset.hpp
/// Reference state initialisation from a motion library: an episode starts at a (clip, time) pose
/// of the clips, with the observations of the 4 frames before it as the discriminator's history.
/// Free of the simulator (train/motion_sources.hpp, which loads libraries for MuJoCo characters,
/// includes it), so evaluations on any `Simulator` can draw their starts from a library.
#include <maskadapt/core/rng.hpp>
#include <maskadapt/motion/amp_window.hpp>
#include <maskadapt/motion/library.hpp>
#include <maskadapt/motion/observation.hpp>
#include <maskadapt/tasks/imitation.hpp>

#include <memory>

namespace maskadapt::train {

/// Earliest time of a clip an episode may start at: the 4 frames before it are its AMP history (s).
inline constexpr double kEarliestResetTime = (kAmpWindowFrames - 1) * kAmpFrameDt;

/// The reset sample at (clip, time ≥ kEarliestResetTime): the pose plus the observations of the 4
/// frames before it.
inline tasks::ResetSample reset_sample_at(const MotionLibrary& lib, ClipTime ct) {
  tasks::ResetSample r;
  r.pose = lib.state(ct.clip, ct.time);
  const Index d = observation_dim(lib.skeleton());
  VectorXf w(lib.amp_window_dim());
  lib.amp_window(ct.clip, ct.time - kAmpFrameDt, w);  // frames t−5Δ … t−Δ; keep the last 4
  r.history = Eigen::Map<const MatrixXf>(w.data() + d, d, kAmpWindowFrames - 1);
  return r;
}

/// RSI from the library: a (clip, time ≥ 4Δ) pose plus the observations of the 4 frames before it.
inline tasks::ResetSampler library_reset_sampler(std::shared_ptr<const MotionLibrary> lib) {
  return [lib](Rng& rng) { return reset_sample_at(*lib, lib->sample(rng, true, kEarliestResetTime)); };
}

}  // namespace maskadapt::train
