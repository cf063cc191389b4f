#pragma once
// Shared by the stage-1 trainer tests: the tiny-walker training config and the section-by-section
// bit-identity check of two checkpoints.
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/tasks/imitation.hpp>
#include <maskadapt/train/config.hpp>

#include <gtest/gtest.h>

#include <cstring>

namespace maskadapt::testing {

/// Resets to the zero pose with every joint angle drawn uniformly in ±0.1 rad.
inline tasks::ResetSampler upright(const Skeleton& skel) {
  return [&skel](Rng& rng) {
    tasks::ResetSample r;
    r.pose = KinematicState::zero(skel);
    for (Index i = 0; i < r.pose.q.size(); ++i) r.pose.q[i] = rng.uniform(-0.1, 0.1);
    return r;
  };
}

/// A stage-1 config small enough for the tiny analytic walker (tiny_sim.hpp): 4 envs × horizon 8
/// (32 samples per iteration), 16-unit networks, learning rates large enough to move in a few
/// iterations. It starts from the struct's defaults (the paper's formulation: masking from the
/// first step, λ_MI 1, radians around the zero pose, fixed rate), not from the cpu preset's
/// walking recipe, whose levers (curriculum, EMA target, normalised actions, adaptive rate) each
/// have tests of their own that switch them on.
inline train::BaseTrainConfig tiny_walker_config() {
  train::BaseTrainConfig c;
  c.env.num_envs = 4;
  c.env.episode_seconds = 1.0;
  c.env.termination_height = 0.8;
  c.net.actor_hidden = {16, 16};
  c.net.critic_hidden = {16};
  c.net.disc_hidden = {16};
  c.net.init_log_std = -1.0;
  c.ppo.horizon = 8;
  c.ppo.epochs = 2;
  c.ppo.minibatch_size = 8;
  c.ppo.actor_lr = 1e-3;
  c.ppo.critic_lr = 1e-3;
  c.disc.lr = 1e-3;
  c.disc.batch_size = 8;
  c.disc.replay_size = 64;
  c.run.seed = 42;
  return c;
}

/// Every section of `a` and `b` has the same bytes (provenance/ sections — command lines, wall
/// time — describe the run and are not compared).
inline void expect_bit_identical(const Checkpoint& a, const Checkpoint& b) {
  ASSERT_EQ(a.names(), b.names());
  for (const auto& name : a.names()) {
    if (name.starts_with("provenance/")) continue;
    const auto& sa = a.section(name);
    const auto& sb = b.section(name);
    ASSERT_EQ(sa.shape, sb.shape) << name;
    ASSERT_EQ(sa.data.size(), sb.data.size()) << name;
    EXPECT_EQ(0, std::memcmp(sa.data.data(), sb.data.data(), sa.data.size())) << "section differs: " << name;
  }
}

}  // namespace maskadapt::testing
