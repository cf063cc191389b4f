// The stage-1 trainer on the tiny analytic simulator: bit-exact resume (2 + 2 == 4 iterations),
// checkpoint round trip, statistics, and config-driven network sizes.
#include "tiny_sim.hpp"

#include <maskadapt/train/base_trainer.hpp>
#include <maskadapt/train/residual_trainer.hpp>

#include <gtest/gtest.h>
#include "../blas_kernel.hpp"

#include <cstring>
#include <filesystem>

#include <unistd.h>  // getpid: one temp file per process (the BLAS matrix runs this test in parallel)

using namespace maskadapt;
using namespace maskadapt::train;
using maskadapt::testing::TinyWalkerSim;

namespace {

tasks::ResetSampler upright(const Skeleton& skel) {
  return [&skel](Rng& rng) {
    tasks::ResetSample r;
    r.pose = KinematicState::zero(skel);
    for (Index i = 0; i < r.pose.q.size(); ++i) r.pose.q[i] = rng.uniform(-0.1, 0.1);
    return r;
  };
}

// "Motion library" of the tiny walker: a sinusoidal swing of the legs, 5 frames at 30 Hz.
RealWindowSampler swing_windows(const Skeleton& skel) {
  return [&skel](Rng& rng, Eigen::Ref<MatrixXf> out) {
    const Index d = observation_dim(skel);
    for (Index j = 0; j < out.cols(); ++j) {
      const double t0 = rng.uniform(0.0, 2.0);
      for (Index f = 0; f < 5; ++f) {
        const double t = t0 + f / 30.0;
        KinematicState s = KinematicState::zero(skel);
        s.root_pos.z() = TinyWalkerSim::kHeight;
        s.q[Skeleton::dof_offset(4)] = 0.4 * std::sin(4 * t);
        s.q[Skeleton::dof_offset(5)] = -0.4 * std::sin(4 * t);
        s.qd[Skeleton::dof_offset(4)] = 1.6 * std::cos(4 * t);
        s.qd[Skeleton::dof_offset(5)] = -1.6 * std::cos(4 * t);
        const BodyStates b = forward_kinematics(skel, s);
        VectorXf o(d);
        compute_observation(skel, b, o);
        out.block(f * d, j, d, 1) = o;
      }
    }
  };
}

BaseTrainConfig tiny_config() {
  BaseTrainConfig c = cpu_preset();
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

struct TinyRun {
  TinyWalkerSim sim;
  BaseTrainer<TinyWalkerSim> trainer;
  explicit TinyRun(const BaseTrainConfig& c)
      : sim(static_cast<std::size_t>(c.env.num_envs)),
        trainer(sim, upright(sim.skeleton()), swing_windows(sim.skeleton()), c, nullptr,
                FallCriteria::for_skeleton(sim.skeleton(), {"l_leg", "r_leg"}, "head", c.env.termination_height)) {}
};

Checkpoint snapshot(const BaseTrainer<TinyWalkerSim>& t) {
  Checkpoint c;
  t.save(c);
  return c;
}

void expect_bit_identical(const Checkpoint& a, const Checkpoint& b) {
  ASSERT_EQ(a.names(), b.names());
  for (const auto& name : a.names()) {
    const auto& sa = a.section(name);
    const auto& sb = b.section(name);
    ASSERT_EQ(sa.shape, sb.shape) << name;
    ASSERT_EQ(sa.data.size(), sb.data.size()) << name;
    EXPECT_EQ(0, std::memcmp(sa.data.data(), sb.data.data(), sa.data.size())) << "section differs: " << name;
  }
}

// 2 iterations, checkpoint, a fresh trainer (other seed) loads it and runs 2 more: everything
// equals 4 straight iterations, bit for bit, and training really changed the parameters.
void expect_resume_is_bit_exact(const BaseTrainConfig& cfg) {
  TinyRun straight(cfg);
  for (int i = 0; i < 4; ++i) straight.trainer.iterate();

  TinyRun first(cfg);
  for (int i = 0; i < 2; ++i) first.trainer.iterate();
  const auto path = (std::filesystem::temp_directory_path() / ("maskadapt_resume_test_" + std::to_string(::getpid()) + ".ckpt")).string();
  first.trainer.save(path);

  auto other = cfg;
  other.run.seed = 7;  // the resumed trainer starts from different random state; the checkpoint wins
  TinyRun resumed(other);
  const Checkpoint loaded = load_checkpoint(path);
  resumed.trainer.load(loaded);
  EXPECT_EQ(resumed.trainer.iteration(), 2);
  for (int i = 0; i < 2; ++i) resumed.trainer.iterate();
  EXPECT_EQ(resumed.trainer.iteration(), 4);

  const Checkpoint a = snapshot(straight.trainer), b = snapshot(resumed.trainer);
  // config differs by seed only; everything else must be bit-identical
  Checkpoint a2 = a, b2 = b;
  a2.erase("config");
  b2.erase("config");
  expect_bit_identical(a2, b2);
  // and training actually changed the parameters
  TinyRun fresh(cfg);
  EXPECT_NE(snapshot(fresh.trainer).get_vector<float>("actor/params"), a.get_vector<float>("actor/params"));
  std::filesystem::remove(path);
}

}  // namespace

TEST(BaseTrainer, ResumeIsBitExact) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  expect_resume_is_bit_exact(tiny_config());
}

// ppo.actor_lr_schedule = adaptive: the rate follows the minibatch KL (here it must move: the
// tiny problem's steps are far from the 0.01 target), is logged, and is part of the resumed state.
TEST(BaseTrainer, AdaptiveLearningRateMovesAndResumesBitExactly) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  auto cfg = tiny_config();
  cfg.ppo.actor_lr_schedule = "adaptive";
  TinyRun run(cfg);
  const IterationStats st = run.trainer.iterate();
  EXPECT_NE(st.actor_lr, cfg.ppo.actor_lr);
  EXPECT_GE(st.actor_lr, cfg.ppo.adaptive_lr.min_lr);
  EXPECT_LE(st.actor_lr, cfg.ppo.adaptive_lr.max_lr);
  EXPECT_EQ(snapshot(run.trainer).get_double("actor/lr"), st.actor_lr);
  TinyRun fixed(tiny_config());
  EXPECT_EQ(fixed.trainer.iterate().actor_lr, tiny_config().ppo.actor_lr);
  expect_resume_is_bit_exact(cfg);
}

// Normalised actions (net.action_offset mid_range, net.action_scale half_range): resolved from
// the skeleton's limits in closed form, saved with the policy, restored by load_policy, and a
// resume stays bit-exact. Stage 2 refuses such a base with a message naming the section.
TEST(BaseTrainer, NormalisedActionsAreResolvedSavedAndResumed) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  auto cfg = tiny_config();
  cfg.net.action_offset = "mid_range";
  cfg.net.action_scale = "half_range";
  const Skeleton skel = TinyWalkerSim(1).skeleton();
  EXPECT_THROW(action_space_of(cfg, skel.num_dofs()), Error);  // not resolved yet
  resolve_action_space(cfg, skel, nullptr);
  ASSERT_EQ(static_cast<Index>(cfg.net.action_offset_rad.size()), skel.num_dofs());
  for (int b = 1; b < skel.num_bodies(); ++b)
    for (int k = 0; k < 3; ++k) {
      const auto i = static_cast<std::size_t>(Skeleton::dof_offset(b) + k);
      EXPECT_DOUBLE_EQ(cfg.net.action_offset_rad[i], 0.5 * (skel.joint_lower(k, b) + skel.joint_upper(k, b)));
      EXPECT_DOUBLE_EQ(cfg.net.action_scale_rad[i], std::max(0.05, 0.5 * (skel.joint_upper(k, b) - skel.joint_lower(k, b))));
    }
  const auto again = cfg;
  resolve_action_space(cfg, skel, nullptr);  // resolved vectors are kept (a resumed run)
  EXPECT_EQ(cfg.net.action_offset_rad, again.net.action_offset_rad);
  auto mean_pose = tiny_config();
  mean_pose.net.action_offset = "mean_pose";
  EXPECT_THROW(resolve_action_space(mean_pose, skel, nullptr), Error);  // needs the motions

  TinyRun run(cfg);
  run.trainer.iterate();
  const Checkpoint c = snapshot(run.trainer);
  ASSERT_TRUE(c.contains("actor/action_offset"));
  Rng init(1);
  BasePolicy loaded = make_base_policy(cfg, run.trainer.dims(), init);
  load_policy(c, loaded);
  EXPECT_TRUE(loaded.actions.offset == run.trainer.policy().actions.offset);
  EXPECT_TRUE(loaded.actions.scale == run.trainer.policy().actions.scale);
  EXPECT_THROW(load_base_actor(c, observation_dim(skel), skel.num_dofs()), Error);  // stage 2 refuses it
  expect_resume_is_bit_exact(cfg);
}

TEST(BaseTrainer, IterationStatisticsAreFiniteAndConsistent) {
  TinyRun run(tiny_config());
  for (int i = 1; i <= 3; ++i) {
    const IterationStats s = run.trainer.iterate();
    EXPECT_EQ(s.iteration, i);
    EXPECT_EQ(s.samples, 32LL * i);
    for (double v : {s.samples_per_s, s.disc_reward, s.disc_real, s.disc_fake, s.policy_loss, s.value_loss, s.approx_kl,
                     s.clip_frac, s.mi_kl, s.grad_norm, s.time_sim, s.time_inference, s.time_update})
      EXPECT_TRUE(std::isfinite(v));
    EXPECT_GE(s.mi_kl, 0.0);
    EXPECT_GT(s.mask_fraction, 0.5);  // p = 0.8
    EXPECT_GT(s.disc_reward, 0.0);
    EXPECT_GT(s.disc_real, 0.0);
    EXPECT_LT(s.disc_real, 1.0);
    EXPECT_EQ(s.skipped_updates, 0);
  }
}

TEST(BaseTrainer, NoMaskBaselineHasNoMaskedStepsAndNoMiTerm) {
  auto cfg = tiny_config();
  cfg.mask.enabled = false;
  TinyRun run(cfg);
  const auto s = run.trainer.iterate();
  EXPECT_EQ(s.mask_fraction, 0.0);
  EXPECT_EQ(s.mi_kl, 0.0);
}

TEST(BaseTrainer, LoadRejectsAMismatchedCheckpoint) {
  TinyRun a(tiny_config());
  a.trainer.iterate();
  const Checkpoint c = snapshot(a.trainer);
  auto bigger = tiny_config();
  bigger.net.actor_hidden = {32, 16};
  TinyRun b(bigger);
  EXPECT_THROW(b.trainer.load(c), Error);
  auto more_envs = tiny_config();
  more_envs.env.num_envs = 6;
  TinyRun d(more_envs);
  EXPECT_THROW(d.trainer.load(c), Error);
}

TEST(BaseTrainer, DiscriminatorUsesTheGradientPenaltyOnRealSamples) {
  auto cfg = tiny_config();
  cfg.disc.gradient_penalty = 5.0;  // the paper's weight
  TinyRun with(cfg);
  const auto s = with.trainer.iterate();
  EXPECT_GT(s.disc_grad_penalty, 0.0);
  EXPECT_TRUE(std::isfinite(s.disc_loss));
  cfg.disc.gradient_penalty = 0.0;
  TinyRun without(cfg);
  const auto s0 = without.trainer.iterate();
  EXPECT_EQ(s0.disc_grad_penalty, 0.0);
  // same data, same initial networks: only the penalty differs, so the discriminators diverge
  Checkpoint a, b;
  with.trainer.save(a);
  without.trainer.save(b);
  EXPECT_NE(a.get_vector<float>("disc/params"), b.get_vector<float>("disc/params"));
}
