#pragma once
// Shared by the stage-2 trainer tests (tests/tasks_residual, tests/mpi): the tiny walker's
// stage-2 config, a frozen base, looping swing clips as motion sets A and B, the composition
// setups (ours: one mask-conditioned discriminator on blends; cml: one per part group), a toy
// text generator and the walker's fall criteria.
#include "../train/tiny_sim.hpp"

#include <maskadapt/tasks/composition.hpp>
#include <maskadapt/tasks/tracking_task.hpp>
#include <maskadapt/tracking/goals.hpp>
#include <maskadapt/train/residual_trainer.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace maskadapt::testing::stage2 {

using namespace maskadapt::train;
using maskadapt::testing::TinyWalkerSim;

inline tasks::ResetSampler upright(const Skeleton& skel) {
  return [&skel](Rng& rng) {
    tasks::ResetSample r;
    r.pose = KinematicState::zero(skel);
    r.pose.root_pos.z() = TinyWalkerSim::kHeight;
    for (Index i = 0; i < r.pose.q.size(); ++i) r.pose.q[i] = rng.uniform(-0.1, 0.1);
    return r;
  };
}

// A looping clip of the tiny walker: body `b`'s first hinge swings with amplitude `amp`.
inline MotionClip swing(const Skeleton& skel, std::vector<int> bodies, double amp, const std::string& name) {
  MotionClip c;
  c.name = name;
  c.loop = true;
  c.resize(61, skel.num_dofs());
  for (int t = 0; t < 61; ++t) {
    c.root_pos(2, t) = TinyWalkerSim::kHeight;
    for (std::size_t i = 0; i < bodies.size(); ++i)
      c.q(skel.dof_offset(bodies[i]), t) = (i % 2 ? -amp : amp) * std::sin(2 * M_PI * t / 60.0);
  }
  return c;
}

inline ResidualTrainConfig tiny_config(const std::string& task, const std::string& method) {
  ResidualTrainConfig c;
  c.task = task;
  c.method = method;
  c.rl.env.num_envs = 4;
  c.rl.env.episode_seconds = 1.0;
  c.rl.env.termination_height = 0.8;
  c.rl.net.critic_hidden = {16};
  c.rl.net.disc_hidden = {16};
  c.rl.ppo.horizon = 8;
  c.rl.ppo.epochs = 2;
  c.rl.ppo.minibatch_size = 8;
  c.rl.ppo.actor_lr = 1e-3;
  c.rl.disc.batch_size = 8;
  c.rl.disc.replay_size = 64;
  c.rl.run.seed = 5;
  c.residual_hidden = {16};
  c.term_window_s = 0.2;
  return c;
}

inline rl::GaussianActor<float> tiny_base(const Skeleton& skel) {
  rl::ActorCriticConfig ac;
  ac.policy_input_dim = observation_dim(skel) + kNumParts;
  ac.critic_input_dim = observation_dim(skel);
  ac.action_dim = skel.num_dofs();
  ac.actor_hidden = {16, 16};
  ac.init_log_std = -1.0;
  Rng rng(1);
  return rl::GaussianActor<float>(ac, rng);
}

struct Data {
  Skeleton skel = maskadapt::testing::tiny_walker_skeleton();
  MotionLibrary base{skel}, added{skel};
  Data() {
    base.add(swing(skel, {4, 5}, 0.4, "legs_swing"));
    added.add(swing(skel, {2, 3}, 0.8, "arms_swing"));
  }
};

// A generator for the tiny walker: keeps the last history frame and swings the arms.
struct TinyGenerator {
  Skeleton skel = maskadapt::testing::tiny_walker_skeleton();
  const Skeleton& skeleton() const { return skel; }
  Index history_frames() const { return 1; }
  Index future_frames() const { return 4; }
  tracking::Trajectory generate(const tracking::TextCondition& c, const tracking::Trajectory& h, Rng&) const {
    tracking::Trajectory t = tracking::Trajectory::zeros(skel, 4);
    const double a = c.text == "raise arms" ? 0.6 : 0.3;
    for (Index i = 0; i < 4; ++i) {
      t.root_pos.col(i) = h.root_pos.col(0);
      t.root_rot[static_cast<std::size_t>(i)] = h.root_rot[0];
      t.q.col(i) = h.q.col(0);
      t.q(skel.dof_offset(2), i) = a;
      t.q(skel.dof_offset(3), i) = -a;
    }
    tracking::compute_body_positions(skel, t);
    return t;
  }
};

template <class Sim = TinyWalkerSim>
ResidualSetup<Sim> composition_setup(const Data& d, const std::string& method, const std::vector<BodyPart>& obs_parts) {
  ResidualSetup<Sim> s;
  const PartMask arms = PartMask::parse("arms"), legs = PartMask::parse("legs");
  if (method == "ours") {
    s.masks = {arms, legs};
    s.switch_rate = 1.0;
    auto set = std::make_shared<tasks::BlendedMotionSet>(d.base, d.added, s.masks);
    DiscriminatorSource src;
    src.name = "composition";
    src.conditioned = true;
    src.real = [set](Rng& r, Index B, MatrixXf& w, MatrixXf& c) { set->sample_real(r, B, w, c); };
    src.negative = [set](Rng& r, Index B, MatrixXf& w, MatrixXf& c) { set->sample_negative(r, B, w, c); };
    s.discriminators.push_back(src);
  } else {  // cml: fixed region = arms, one discriminator per group
    s.masks = {arms};
    const MotionLibrary* added = &d.added;
    const MotionLibrary* base = &d.base;
    DiscriminatorSource a{"arms", 0.5, tasks::window_rows(obs_parts, arms), false,
                          [added](Rng& r, Index B, MatrixXf& w, MatrixXf&) { w = added->sample_amp_windows(r, static_cast<int>(B)); }, {}};
    DiscriminatorSource b{"rest", 0.5, tasks::window_rows(obs_parts, ~arms), false,
                          [base](Rng& r, Index B, MatrixXf& w, MatrixXf&) { w = base->sample_amp_windows(r, static_cast<int>(B)); }, {}};
    s.discriminators = {a, b};
  }
  return s;
}

inline FallCriteria tiny_fall(const Skeleton& skel) { return FallCriteria::for_skeleton(skel, {"l_leg", "r_leg"}, "head", 0.8); }

inline tasks::TrackingTaskConfig tiny_tracking_config(const Data& d) {
  const PartMask arms = PartMask::parse("arms");
  const MotionLibrary* base = &d.base;
  auto gen = std::make_shared<TinyGenerator>();
  tasks::TrackingTaskConfig t;
  t.designated = arms;
  t.goal_steps = 2;
  t.sample_every = 3;  // a refill happens inside the resumed half
  t.term_window = 4;
  t.term_threshold = 0.5;  // high: the windowed termination fires during these few iterations
  t.refill = [gen, base](Rng& r, tracking::GoalBuffer& b) {
    b.refill(*gen, {"raise arms", "wave hands"},
             [base](Rng& rr) { return tracking::trajectory_from_library(*base, 0, rr.uniform(0.0, 1.0), 1); }, 3, 40, r);
  };
  return t;
}

template <class Sim>
ResidualSetup<Sim> tracking_setup(const Data& d, const Sim& sim, const tasks::TrackingTaskConfig& t) {
  const PartMask arms = PartMask::parse("arms");
  ResidualSetup<Sim> s;
  s.masks = {arms};
  const MotionLibrary* base = &d.base;
  s.discriminators.push_back({"imitation", 0.5, tasks::window_rows(observation_parts(sim.skeleton()), ~arms), false,
                              [base](Rng& r, Index B, MatrixXf& w, MatrixXf&) { w = base->sample_amp_windows(r, static_cast<int>(B)); }, {}});
  s.goal = tasks::TrackingTask(sim.skeleton(), t, static_cast<Index>(sim.num_envs()));
  return s;
}
template <class Sim>
ResidualSetup<Sim> tracking_setup(const Data& d, const Sim& sim) {
  return tracking_setup(d, sim, tiny_tracking_config(d));
}

/// Runs `f` and expects it to throw an Error whose message names `field` (what a bad value of a
/// config field or flag must produce); `what` says which value was tried.
template <class F>
void expect_error_naming(F&& f, const std::string& field, const std::string& what) {
  try {
    f();
    ADD_FAILURE() << what << " was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << what << ": " << e.what();
  }
}

/// A run trained straight for `total` iterations, and the same run saved after `split`, loaded
/// into a fresh trainer and continued to `total` (`make(sim)` builds a trainer on `sim`).
template <class Trainer>
struct ResumedRun {
  std::vector<std::unique_ptr<TinyWalkerSim>> sims;  // (outlive the trainers that hold them)
  std::unique_ptr<Trainer> straight, resumed;
  std::vector<IterationStats> straight_stats, resumed_stats;  ///< resumed: iterations split+1 … total
  Checkpoint at_split;
};
template <class Make>
auto run_and_resume(Make make, int split = 2, int total = 4, Index envs = 4) {
  using Trainer = typename decltype(make(std::declval<TinyWalkerSim&>()))::element_type;
  ResumedRun<Trainer> r;
  for (int i = 0; i < 3; ++i) r.sims.push_back(std::make_unique<TinyWalkerSim>(envs));
  r.straight = make(*r.sims[0]);
  for (int i = 0; i < total; ++i) r.straight_stats.push_back(r.straight->iterate());
  auto first = make(*r.sims[1]);
  for (int i = 0; i < split; ++i) first->iterate();
  first->save(r.at_split);
  r.resumed = make(*r.sims[2]);
  r.resumed->load(r.at_split);
  for (int i = split; i < total; ++i) r.resumed_stats.push_back(r.resumed->iterate());
  return r;
}

}  // namespace maskadapt::testing::stage2
