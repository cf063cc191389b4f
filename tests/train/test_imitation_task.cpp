// The imitation task on the tiny analytic simulator (no MuJoCo): RSI, masks, discriminator
// windows, fall termination vs truncation, statistics, and exact state save/restore.
#include "tiny_sim.hpp"

#include <maskadapt/tasks/imitation.hpp>

#include <gtest/gtest.h>

using namespace maskadapt;
using namespace maskadapt::tasks;
using maskadapt::testing::TinyWalkerSim;
using maskadapt::testing::tiny_walker_skeleton;

namespace {
static_assert(Simulator<TinyWalkerSim>);
static_assert(StateSavingSimulator<TinyWalkerSim>);

// Upright reset pose with small random joint angles; no reference history.
ResetSampler upright_sampler(const Skeleton& skel) {
  return [&skel](Rng& rng) {
    ResetSample r;
    r.pose = KinematicState::zero(skel);
    for (Index i = 0; i < r.pose.q.size(); ++i) r.pose.q[i] = rng.uniform(-0.1, 0.1);
    return r;
  };
}

ImitationTaskConfig tiny_task_config() {
  ImitationTaskConfig c;
  c.episode_seconds = 1.0;  // 30 steps
  c.fall = FallCriteria::for_skeleton(tiny_walker_skeleton(), {"l_leg", "r_leg"}, "head", 0.8);
  return c;
}

// Balancing controller: hips' y targets = φ feedback (keeps the pendulum up).
MatrixXf balance_actions(const TinyWalkerSim& sim) {
  MatrixXf a = MatrixXf::Zero(sim.skeleton().num_dofs(), static_cast<Index>(sim.num_envs()));
  for (std::size_t e = 0; e < sim.num_envs(); ++e) {
    const Quat& r = sim.body_states(e).rot[0];
    const Mat3 R = r.toRotationMatrix();
    const double phi = std::atan2(R(0, 2), R(2, 2));
    const double phid = sim.body_states(e).ang_vel(1, 0);
    const float u = static_cast<float>(0.5 * phi + 0.15 * phid);
    a(sim.skeleton().dof_offset(4) + 1, static_cast<Index>(e)) = u;
    a(sim.skeleton().dof_offset(5) + 1, static_cast<Index>(e)) = u;
  }
  return a;
}
}  // namespace

TEST(ImitationTask, ShapesAndMaskedPolicyInput) {
  TinyWalkerSim sim(6);
  ImitationTask task(sim, upright_sampler(sim.skeleton()), tiny_task_config(), 7);
  const Index d = observation_dim(sim.skeleton());
  EXPECT_EQ(task.obs_dim(), d);
  EXPECT_EQ(task.policy_input_dim(), d + 5);
  EXPECT_EQ(task.amp_dim(), 5 * d);
  EXPECT_EQ(task.action_dim(), 15);
  ASSERT_EQ(task.policy_inputs().rows(), d + 5);
  // Masked elements are zero, others equal s; the last 5 rows are the mask bits.
  int masked_envs = 0;
  for (int k = 0; k < 20; ++k) {
    task.step(MatrixXf::Zero(task.action_dim(), 6));
    for (Index e = 0; e < 6; ++e) {
      const PartMask m = task.masks()[static_cast<std::size_t>(e)];
      masked_envs += !m.empty();
      EXPECT_LE(m.count(), 3);
      for (Index j = 0; j < d; ++j) {
        const bool hidden = m.has(task.obs_parts()[static_cast<std::size_t>(j)]);
        EXPECT_EQ(task.policy_inputs()(j, e), hidden ? 0.0f : task.observations()(j, e));
      }
      for (int p = 0; p < 5; ++p) EXPECT_EQ(task.policy_inputs()(d + p, e), m.has(static_cast<BodyPart>(p)) ? 1.0f : 0.0f);
    }
  }
  EXPECT_GT(masked_envs, 60);   // p = 0.8 of 120 env-steps
  EXPECT_LT(masked_envs, 115);
}

TEST(ImitationTask, MaskingOffGivesTheNullMaskAndFixedMaskIsKept) {
  TinyWalkerSim sim(4);
  auto cfg = tiny_task_config();
  cfg.masking = false;
  ImitationTask task(sim, upright_sampler(sim.skeleton()), cfg, 1);
  for (int k = 0; k < 10; ++k) {
    task.step(MatrixXf::Zero(task.action_dim(), 4));
    for (auto m : task.masks()) EXPECT_TRUE(m.empty());
    EXPECT_EQ(task.policy_inputs().topRows(task.obs_dim()), task.observations());
  }
  task.set_fixed_mask(PartMask::parse("left_leg,right_leg"));
  task.step(MatrixXf::Zero(task.action_dim(), 4));
  for (auto m : task.masks()) EXPECT_EQ(m, PartMask::parse("legs"));
}

TEST(ImitationTask, WindowsHoldTheLastFiveUnmaskedObservations) {
  TinyWalkerSim sim(3);
  ImitationTask task(sim, upright_sampler(sim.skeleton()), tiny_task_config(), 3);
  const Index d = task.obs_dim();
  std::vector<MatrixXf> seen;
  for (int k = 0; k < 8; ++k) {
    task.step(balance_actions(sim));
    ASSERT_FALSE(task.terminated()[0] || task.truncated()[0]);
    seen.push_back(task.observations());
    if (k < 4) continue;
    for (int f = 0; f < 5; ++f)
      EXPECT_EQ(task.amp_windows().block(f * d, 0, d, 3), seen[static_cast<std::size_t>(k - 4 + f)]) << k << " " << f;
  }
}

TEST(ImitationTask, RandomActionsFallAndBalancedEnvsTruncate) {
  {
    TinyWalkerSim sim(8);
    ImitationTask task(sim, upright_sampler(sim.skeleton()), tiny_task_config(), 11);
    Rng rng(5);
    int terminations = 0;
    for (int k = 0; k < 60; ++k) {
      MatrixXf a = MatrixXf::NullaryExpr(task.action_dim(), 8, [&] { return static_cast<float>(rng.uniform(0.2, 1.0)); });
      task.step(a);
      for (int e = 0; e < 8; ++e) {
        EXPECT_FALSE(task.terminated()[e] && task.truncated()[e]);
        terminations += task.terminated()[e];
        if (task.terminated()[e]) {  // reset happened: episode counter restarts, final obs is the fallen state
          EXPECT_EQ(task.episode_steps()[e], 0);
          EXPECT_NE(task.final_observations().col(e), task.observations().col(e));
        }
      }
    }
    EXPECT_GT(terminations, 8);
    EXPECT_EQ(task.stats().falls, terminations);
    EXPECT_GT(task.stats().mean_length(), 0.0);
    EXPECT_LT(task.stats().mean_length(), 1.0);
  }
  {
    TinyWalkerSim sim(4);
    ImitationTask task(sim, upright_sampler(sim.skeleton()), tiny_task_config(), 11);
    int truncations = 0;
    for (int k = 0; k < 30; ++k) {
      task.step(balance_actions(sim));
      for (int e = 0; e < 4; ++e) {
        EXPECT_FALSE(task.terminated()[e]);
        truncations += task.truncated()[e];
        EXPECT_EQ(task.truncated()[e] != 0, k == 29);  // 1 s limit = 30 steps
      }
    }
    EXPECT_EQ(truncations, 4);
    EXPECT_EQ(task.stats().truncations, 4);
    EXPECT_EQ(task.stats().falls, 0);
    EXPECT_NEAR(task.stats().mean_length(), 1.0, 1e-9);
  }
}

TEST(ImitationTask, ResetHistoryComesFromTheSampler) {
  TinyWalkerSim sim(2);
  const Index d = observation_dim(sim.skeleton());
  ResetSampler sampler = [&](Rng&) {
    ResetSample r;
    r.pose = KinematicState::zero(sim.skeleton());
    r.history = MatrixXf::Constant(d, 4, 0.5f);
    for (int k = 0; k < 4; ++k) r.history.col(k).array() += static_cast<float>(k);
    return r;
  };
  ImitationTask task(sim, sampler, tiny_task_config(), 2);
  task.step(MatrixXf::Zero(task.action_dim(), 2));
  // window after one step: history frames 1..3, reset frame, new frame
  EXPECT_EQ(task.amp_windows().block(0, 0, d, 1), MatrixXf::Constant(d, 1, 1.5f));
  EXPECT_EQ(task.amp_windows().block(2 * d, 0, d, 1), MatrixXf::Constant(d, 1, 3.5f));
  EXPECT_EQ(task.amp_windows().block(4 * d, 0, d, 1), task.observations().col(0));
  ResetSampler bad = [&](Rng&) {
    ResetSample r;
    r.pose = KinematicState::zero(sim.skeleton());
    r.history = MatrixXf::Zero(3, 4);
    return r;
  };
  EXPECT_THROW(ImitationTask(sim, bad, tiny_task_config(), 2), Error);
}

TEST(ImitationTask, RejectsBadActions) {
  TinyWalkerSim sim(2);
  ImitationTask task(sim, upright_sampler(sim.skeleton()), tiny_task_config(), 2);
  EXPECT_THROW(task.step(MatrixXf::Zero(3, 2)), Error);
  MatrixXf a = MatrixXf::Zero(task.action_dim(), 2);
  a(4, 1) = NAN;
  EXPECT_THROW(task.step(a), Error);
}

TEST(ImitationTask, SavedStateContinuesBitExactly) {
  Rng rng(9);
  std::vector<MatrixXf> actions;
  for (int k = 0; k < 40; ++k)
    actions.push_back(MatrixXf::NullaryExpr(15, 5, [&] { return static_cast<float>(rng.uniform(-0.3, 0.3)); }));
  TinyWalkerSim sim_a(5), sim_b(5);
  ImitationTask a(sim_a, upright_sampler(sim_a.skeleton()), tiny_task_config(), 4);
  for (int k = 0; k < 20; ++k) a.step(actions[static_cast<std::size_t>(k)]);
  const auto st = a.save_state();
  ImitationTask b(sim_b, upright_sampler(sim_b.skeleton()), tiny_task_config(), 99);  // different seed
  b.load_state(st);
  EXPECT_EQ(b.policy_inputs(), a.policy_inputs());
  for (int k = 20; k < 40; ++k) {
    a.step(actions[static_cast<std::size_t>(k)]);
    b.step(actions[static_cast<std::size_t>(k)]);
    ASSERT_EQ(a.policy_inputs(), b.policy_inputs()) << k;
    ASSERT_EQ(a.amp_windows(), b.amp_windows()) << k;
    ASSERT_EQ(a.terminated(), b.terminated());
  }
  TinyWalkerSim sim_c(3);
  ImitationTask c(sim_c, upright_sampler(sim_c.skeleton()), tiny_task_config(), 4);
  EXPECT_THROW(c.load_state(st), Error);
}

// With an action space, step(a) drives the PD targets offset + scale ⊙ a: the same run as
// stepping an identity task with those targets, bit for bit.
TEST(ImitationTask, ActionSpaceMapsActionsToTargets) {
  const Skeleton skel = tiny_walker_skeleton();
  const Index nd = skel.num_dofs();
  ImitationTaskConfig cfg = tiny_task_config();
  cfg.actions.offset = VectorXf::LinSpaced(nd, -0.2f, 0.3f);
  cfg.actions.scale = VectorXf::LinSpaced(nd, 0.5f, 2.0f);
  TinyWalkerSim sim_a(3), sim_b(3);
  ImitationTask<TinyWalkerSim> mapped(sim_a, upright_sampler(skel), cfg, 4);
  ImitationTask<TinyWalkerSim> direct(sim_b, upright_sampler(skel), tiny_task_config(), 4);
  Rng rng(6);
  for (int t = 0; t < 12; ++t) {
    const MatrixXf a = MatrixXf::NullaryExpr(nd, 3, [&] { return static_cast<float>(rng.uniform(-0.3, 0.3)); });
    MatrixXf targets(nd, 3);
    cfg.actions.to_targets(a, targets);
    for (Index j = 0; j < 3; ++j)  // closed form, element by element
      for (Index k = 0; k < nd; ++k) ASSERT_EQ(targets(k, j), cfg.actions.offset[k] + cfg.actions.scale[k] * a(k, j));
    mapped.step(a);
    direct.step(targets);
    ASSERT_TRUE(mapped.observations() == direct.observations()) << "step " << t;
  }
  ImitationTaskConfig bad = tiny_task_config();
  bad.actions.scale = VectorXf::Constant(nd, -1.0f);
  TinyWalkerSim sim_c(1);
  EXPECT_THROW(ImitationTask<TinyWalkerSim>(sim_c, upright_sampler(skel), bad, 1), Error);
  bad.actions.scale = VectorXf::Ones(nd + 1);
  EXPECT_THROW(ImitationTask<TinyWalkerSim>(sim_c, upright_sampler(skel), bad, 1), Error);
}
