#pragma once
/// \file base_walks.hpp
/// Walks of a base policy under a simulator, as clips for the text-conditioned generator
/// (tracking/): the histories partial tracking gives it come from the simulated character, not
/// from motion capture (issue 42; `train-generator --base-walks`, `eval-generator --per-source`). Generic over
/// the `Simulator` concept (the CLI and the tests run it on the MuJoCo humanoid).
#include <maskadapt/core/error.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/sim/simulator.hpp>
#include <maskadapt/train/play.hpp>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace maskadapt::train {

/// One rollout per seed of `seconds` (no mask, sampled actions, the initial state from `reset`;
/// train::play_base_policy with PlayOptions::seed = seed), as humanoid clips at 30 Hz labelled
/// "walk forward", "walk" and named "base_rollout_seed<seed>". A rollout in which the humanoid
/// falls is refused naming its seed and the time; so is a simulator whose control rate is not 30 Hz.
template <Simulator Sim>
std::vector<MotionClip> base_policy_walks(Sim& sim, const BasePolicy& policy, const tasks::ResetSampler& reset,
                                          const FallCriteria& fall, double min_head_height,
                                          const std::vector<std::uint64_t>& seeds, double seconds) {
  require(std::isfinite(seconds) && seconds > 0, "base walks: seconds must be > 0", {{}, {}, "seconds"});
  std::vector<MotionClip> out;
  for (const std::uint64_t seed : seeds) {
    PlayOptions opt;
    opt.seconds = seconds;
    opt.seed = seed;
    PlayResult r = play_base_policy(sim, policy, reset, opt, eval::make_rollout(sim.character()), fall, min_head_height);
    require(r.fall_times.empty(), "the base fell in its rollout of seed " + std::to_string(seed) + " at " +
                                      (r.fall_times.empty() ? std::string() : std::to_string(r.fall_times.front())) + " s",
            {{}, {}, "base walks"});
    require(std::abs(r.clip.fps - 30.0) < 1e-3,
            "the generator needs 30 Hz walks; the base runs at " + std::to_string(r.clip.fps) + " Hz", {{}, {}, "base walks"});
    r.clip.fps = 30.0;  // 1 / control_dt, rounded
    r.clip.name = "base_rollout_seed" + std::to_string(seed);
    r.clip.labels = {"walk forward", "walk"};
    out.push_back(std::move(r.clip));
  }
  return out;
}

}  // namespace maskadapt::train
