// The stage-1 trainer on the tiny analytic simulator: bit-exact resume (2 + 2 == 4 iterations),
// checkpoint round trip, statistics, and config-driven network sizes.
#include "tiny_sim.hpp"
#include "trainer_test_helpers.hpp"

#include <maskadapt/train/base_trainer.hpp>
#include <maskadapt/train/reward_discriminators.hpp>
#include <maskadapt/train/run_loop.hpp>
#include <maskadapt/train/residual_trainer.hpp>

#include <gtest/gtest.h>
#include "../blas_kernel.hpp"

#include <atomic>
#include <cstring>
#include <filesystem>
#include <memory>

#include <unistd.h>  // getpid: one temp file per process (the BLAS matrix runs this test in parallel)

using namespace maskadapt;
using namespace maskadapt::train;
using maskadapt::testing::expect_bit_identical;
using maskadapt::testing::TinyWalkerSim;
using maskadapt::testing::upright;

namespace {

// "Motion library" of the tiny walker: a sinusoidal swing of the legs, windows of F = out.rows() / d
// frames at 30 Hz (the last F of 5).
RealWindowSampler swing_windows(const Skeleton& skel) {
  return [&skel](Rng& rng, Eigen::Ref<MatrixXf> out) {
    const Index d = observation_dim(skel), frames = out.rows() / d;
    for (Index j = 0; j < out.cols(); ++j) {
      const double t0 = rng.uniform(0.0, 2.0);
      for (Index f = 0; f < frames; ++f) {
        const double t = t0 + static_cast<double>(kAmpWindowFrames - frames + f) / 30.0;
        KinematicState s = KinematicState::zero(skel);
        s.root_pos.z() = TinyWalkerSim::kHeight;
        s.q[skel.dof_offset(4)] = 0.4 * std::sin(4 * t);
        s.q[skel.dof_offset(5)] = -0.4 * std::sin(4 * t);
        s.qd[skel.dof_offset(4)] = 1.6 * std::cos(4 * t);
        s.qd[skel.dof_offset(5)] = -1.6 * std::cos(4 * t);
        const BodyStates b = forward_kinematics(skel, s);
        VectorXf o(d);
        compute_observation(skel, b, o);
        out.block(f * d, j, d, 1) = o;
      }
    }
  };
}

BaseTrainConfig tiny_config() { return maskadapt::testing::tiny_walker_config(); }

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

// `train-base --resume CKPT --seed S` forks the run: reseed restarts the trainer's and the envs'
// random streams from S. The fork differs from the plain continuation after one iteration, carries
// the new seed in its config, and is itself bit-exactly resumable.
TEST(BaseTrainer, ReseedForksAResumedRunAndTheForkResumesBitExactly) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  const BaseTrainConfig cfg = tiny_config();
  TinyRun origin(cfg);
  for (int i = 0; i < 2; ++i) origin.trainer.iterate();
  const Checkpoint at2 = snapshot(origin.trainer);

  TinyRun plain(cfg), fork(cfg), fork_straight(cfg);
  plain.trainer.load(at2);
  fork.trainer.load(at2);
  fork_straight.trainer.load(at2);
  fork.trainer.reseed(9);
  fork_straight.trainer.reseed(9);
  plain.trainer.iterate();
  fork.trainer.iterate();
  const Checkpoint p3 = snapshot(plain.trainer), f3 = snapshot(fork.trainer);
  EXPECT_NE(p3.get_vector<float>("actor/params"), f3.get_vector<float>("actor/params"));
  EXPECT_NE(p3.get_vector<std::int64_t>("trainer/rng"), f3.get_vector<std::int64_t>("trainer/rng"));
  EXPECT_EQ(nlohmann::json::parse(f3.get_string("config"))["run"]["seed"], 9);

  for (int i = 0; i < 2; ++i) fork_straight.trainer.iterate();  // fork, 2 iterations straight
  TinyRun resumed(cfg);                                          // fork, 1 iteration, save, load, 1 more
  resumed.trainer.load(f3);
  resumed.trainer.iterate();
  Checkpoint a = snapshot(fork_straight.trainer), b = snapshot(resumed.trainer);
  a.erase("config");  // (the resumed trainer was built with seed 42: load() keeps the caller's config, as the CLI
  b.erase("config");  //  builds it from the checkpoint's own)
  expect_bit_identical(a, b);
}

// Masking curriculum (mask.warmup_samples / ramp_samples): before the warm-up ends the run is the
// same, bit for bit, as one with mask probability 0 (so a p = 0 run resumed with a warm-up that has
// not ended yet equals one run with that warm-up from the start); afterwards masks are drawn with
// the configured p; and a resume across the switch stays bit-exact.
TEST(BaseTrainer, MaskWarmupIsPlainAmpUntilItEndsThenMasks) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  auto cfg = tiny_config();
  cfg.mask.prob = 1.0;
  cfg.mask.warmup_samples = 64;  // 2 iterations of 4 envs × horizon 8
  TinyRun warm(cfg);
  auto p0 = cfg;
  p0.mask.prob = 0.0;
  p0.mask.warmup_samples = 0;
  TinyRun zero(p0);
  for (int i = 0; i < 2; ++i) {
    const IterationStats a = warm.trainer.iterate(), b = zero.trainer.iterate();
    EXPECT_EQ(a.extra.at("mask_prob"), 0.0);
    EXPECT_EQ(a.mask_fraction, 0.0);
    EXPECT_EQ(a.mi_kl, 0.0);
    EXPECT_EQ(a.policy_loss, b.policy_loss);
  }
  Checkpoint a = snapshot(warm.trainer), b = snapshot(zero.trainer);
  a.erase("config");
  b.erase("config");
  expect_bit_identical(a, b);
  double masked = 0;
  for (int i = 0; i < 8; ++i) {
    const IterationStats st = warm.trainer.iterate();
    EXPECT_EQ(st.extra.at("mask_prob"), 1.0);
    masked = std::max(masked, st.mask_fraction);
  }
  EXPECT_GT(masked, 0.5) << "episodes started after the warm-up must be masked (p = 1)";
  expect_resume_is_bit_exact(cfg);  // resumed at iteration 2 = sample 64, masking from there
}

// mi_gradient = target_ema: no target during the warm-up (the run is plain AMP, as above); where
// masking starts the target is the policy itself, and after each iteration's update it moves
// by τ towards the updated policy; it is checkpointed, and a resume across the fork is bit-exact.
TEST(BaseTrainer, EmaTargetStartsWhereMaskingStartsFollowsThePolicyAndResumes) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  auto cfg = tiny_config();
  cfg.mask.prob = 1.0;
  cfg.mask.warmup_samples = 64;  // 2 iterations
  cfg.mask.hidden_value = "mean";
  cfg.mask.mi_gradient = "target_ema";
  cfg.mask.mi_target_tau = 0.25;
  TinyRun run(cfg);
  for (int i = 0; i < 2; ++i) EXPECT_EQ(run.trainer.iterate().mi_kl, 0.0);
  const Checkpoint before = snapshot(run.trainer);
  EXPECT_FALSE(before.contains("mi_target/params")) << "no target before masking starts";
  const IterationStats st = run.trainer.iterate();
  const Checkpoint after = snapshot(run.trainer);
  ASSERT_TRUE(after.contains("mi_target/params"));
  const VectorXf theta0 = before.get_vector<float>("actor/params"), theta1 = after.get_vector<float>("actor/params");
  const VectorXf expected = 0.75f * theta0 + 0.25f * theta1;
  EXPECT_LT((after.get_vector<float>("mi_target/params") - expected).cwiseAbs().maxCoeff(), 1e-6f);
  EXPECT_GT((theta1 - theta0).cwiseAbs().maxCoeff(), 1e-4f) << "the update moved the policy";
  EXPECT_GT(st.mi_kl, 0.0);
  ASSERT_TRUE(st.extra.count("kl_masked_unmasked")) << "the policy's own masked/unmasked KL is logged beside mi_kl";
  EXPECT_GT(st.extra.at("kl_masked_unmasked"), 0.0);
  // the target starts as the policy itself: before this iteration's update the two are one
  ASSERT_TRUE(st.extra.count("kl_target_unmasked"));
  EXPECT_EQ(st.extra.at("kl_target_unmasked"), 0.0);
  expect_resume_is_bit_exact(cfg);  // checkpoint at iteration 2 (no target), resumed across the fork
  auto later = cfg;
  later.mask.warmup_samples = 0;  // masked from the start: the checkpoint at iteration 2 holds a target
  expect_resume_is_bit_exact(later);
}

// `checkpoint compact`: without its replay buffer a checkpoint still resumes — with an empty
// buffer, deterministically (two continuations of the compact file are bit-identical), and not
// the same run as the uninterrupted one (its discriminator saw other fake windows).
TEST(BaseTrainer, CompactedCheckpointResumesDeterministicallyWithAnEmptyReplayBuffer) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  const auto cfg = tiny_config();
  TinyRun first(cfg);
  for (int i = 0; i < 2; ++i) first.trainer.iterate();
  Checkpoint compact = snapshot(first.trainer);
  const std::size_t full_sections = compact.size();
  ASSERT_TRUE(drop_replay_buffer(compact));
  EXPECT_EQ(compact.size(), full_sections - 3);
  EXPECT_FALSE(compact.contains("replay/storage"));
  EXPECT_NE(compact.get_string("provenance/history").find("replay buffer of 64 windows dropped"), std::string::npos);
  EXPECT_FALSE(drop_replay_buffer(compact)) << "nothing left to drop";
  auto continue_from = [&](const Checkpoint& c) {
    auto other = cfg;
    other.run.seed = 9;
    auto run = std::make_unique<TinyRun>(other);
    run->trainer.load(c);
    for (int i = 0; i < 2; ++i) run->trainer.iterate();
    Checkpoint out = snapshot(run->trainer);
    out.erase("config");
    return out;
  };
  const Checkpoint a = continue_from(compact), b = continue_from(compact);
  expect_bit_identical(a, b);
  EXPECT_EQ(a.get_int("replay/size"), 64) << "refilled by the two iterations after the resume";
  for (int i = 0; i < 2; ++i) first.trainer.iterate();
  EXPECT_NE(snapshot(first.trainer).get_vector<float>("disc/params"), a.get_vector<float>("disc/params"));
}

// mask.hidden_value = mean: the actor sees a hidden element as its running mean (0 after
// normalisation) and the mask flags as 0/1; its statistics come from unmasked inputs only (so the
// flag rows' mean stays 0 although every episode is masked); the groups are saved with the policy,
// restored by load_policy, and a resume stays bit-exact.
TEST(BaseTrainer, HiddenValueMeanPutsHiddenElementsAtTheirMean) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  auto cfg = tiny_config();
  cfg.mask.prob = 1.0;
  cfg.mask.hidden_value = "mean";
  TinyRun run(cfg);
  for (int i = 0; i < 2; ++i) run.trainer.iterate();
  const auto& actor = run.trainer.policy().ac.actor;
  const auto& parts = run.trainer.task().obs_parts();
  ASSERT_EQ(actor.hidden_groups.size(), parts.size());
  const Index n = static_cast<Index>(parts.size());
  EXPECT_EQ(actor.normalizer.mean().tail(kNumParts).cwiseAbs().maxCoeff(), 0.0) << "statistics from [s ; 0] only";
  // a column with the legs hidden: those rows read 0, the flags pass through, the rest is normalised
  const PartMask legs = PartMask::parse("legs");
  MatrixXf x = MatrixXf::Random(n + kNumParts, 1);
  x.bottomRows(kNumParts).col(0) = Eigen::Map<const VectorXf>(legs.as_array<float>().data(), kNumParts);
  MatrixXf plain(x.rows(), x.cols()), out;
  actor.normalizer.normalize(x, plain);
  actor.normalize(x, out);
  for (Index i = 0; i < n; ++i) {
    if (legs.has(parts[static_cast<std::size_t>(i)])) EXPECT_EQ(out(i, 0), 0.0f) << i;
    else EXPECT_EQ(out(i, 0), plain(i, 0)) << i;
  }
  EXPECT_EQ(out.bottomRows(kNumParts), x.bottomRows(kNumParts));
  // saved and restored with the policy
  BasePolicy back = run.trainer.policy();
  back.ac.actor.hidden_groups.clear();
  load_policy(snapshot(run.trainer), back);
  EXPECT_EQ(back.ac.actor.hidden_groups, actor.hidden_groups);
  expect_resume_is_bit_exact(cfg);
  // the default (zero) leaves every row to the normaliser
  TinyRun zero(tiny_config());
  EXPECT_TRUE(zero.trainer.policy().ac.actor.hidden_groups.empty());
}

// provenance/history and provenance/train_seconds survive a resume, and a checkpoint without
// them (written before they existed) says so instead of inventing a history or a time.
TEST(BaseTrainer, ProvenanceIsCarriedAcrossResumes) {
  TinyRun first(tiny_config());
  first.trainer.add_provenance("chunk 1");
  first.trainer.iterate();
  const double seconds = first.trainer.train_seconds();
  EXPECT_GT(seconds, 0.0);
  Checkpoint c = snapshot(first.trainer);
  TinyRun second(tiny_config());
  second.trainer.load(c);
  second.trainer.add_provenance("chunk 2");
  EXPECT_EQ(second.trainer.provenance(), "chunk 1\nchunk 2\n");
  EXPECT_EQ(second.trainer.train_seconds(), seconds);
  c.erase("provenance/history");
  c.erase("provenance/train_seconds");
  TinyRun old(tiny_config());
  old.trainer.load(c);
  EXPECT_NE(old.trainer.provenance().find("predate"), std::string::npos);
  EXPECT_TRUE(std::isnan(old.trainer.train_seconds()));
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
// resume stays bit-exact. Stage 2's load_base_actor returns the same action space with the actor.
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
      const auto i = static_cast<std::size_t>(skel.dof_offset(b) + k);
      EXPECT_DOUBLE_EQ(cfg.net.action_offset_rad[i], 0.5 * (skel.dof_lower(skel.dof_offset(b) + k) + skel.dof_upper(skel.dof_offset(b) + k)));
      EXPECT_DOUBLE_EQ(cfg.net.action_scale_rad[i], std::max(0.05, 0.5 * (skel.dof_upper(skel.dof_offset(b) + k) - skel.dof_lower(skel.dof_offset(b) + k))));
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
  const FrozenBase frozen = load_base_actor(c, observation_dim(skel), skel.num_dofs());
  EXPECT_TRUE(frozen.actions.offset == run.trainer.policy().actions.offset);
  EXPECT_TRUE(frozen.actions.scale == run.trainer.policy().actions.scale);
  EXPECT_TRUE(frozen.actor.mean_net.params() == run.trainer.policy().ac.actor.mean_net.params());
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
    // the update's time split: PPO and the discriminator are disjoint parts of the update, the
    // reward pass and the real windows parts of the discriminator's time
    for (double part : {s.time_ppo, s.time_disc, s.time_disc_reward, s.time_disc_real_windows}) EXPECT_GT(part, 0.0);
    EXPECT_LE(s.time_ppo + s.time_disc, s.time_update);
    EXPECT_LE(s.time_disc_reward + s.time_disc_real_windows, s.time_disc);
    EXPECT_EQ(s.extra.count("time_ppo") + s.extra.count("time_disc_reward"), 0u);  // (fields, not extra keys)
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

// disc.window_frames = 2 (the paper's D(s, s′)): the discriminator's input is the last two frames
// of the task's 5-frame window. Its rewards are its logits on exactly those rows of the rollout's
// windows, its real batches are 2-frame windows, its replay buffer holds 2-frame windows, and the
// run resumes bit-exactly and its checkpoint loads back as a base policy with that input.
TEST(BaseTrainer, TwoFrameDiscriminatorSeesTheLastTwoFramesOfTheWindow) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  auto cfg = tiny_config();
  cfg.disc.window_frames = 2;
  TinyWalkerSim sim(static_cast<std::size_t>(cfg.env.num_envs));
  const Index d = observation_dim(sim.skeleton());
  std::vector<Index> real_rows;
  const RealWindowSampler swing = swing_windows(sim.skeleton());
  BaseTrainer<TinyWalkerSim> trainer(
      sim, upright(sim.skeleton()),
      [&](Rng& rng, Eigen::Ref<MatrixXf> out) {
        real_rows.push_back(out.rows());
        swing(rng, out);
      },
      cfg, nullptr, FallCriteria::for_skeleton(sim.skeleton(), {"l_leg", "r_leg"}, "head", cfg.env.termination_height));
  ASSERT_EQ(trainer.disc_dim(), 2 * d);
  ASSERT_EQ(trainer.policy().disc.config().feature_dim, 2 * d);
  ASSERT_EQ(trainer.rollout().amp_windows.rows(), kAmpWindowFrames * d);  // (the task keeps 5 frames)
  const rl::Discriminator<float> before = trainer.policy().disc;            // (the rewards use it; the update then moves it)
  const auto st = trainer.iterate();
  ASSERT_FALSE(real_rows.empty());
  for (Index rows : real_rows) EXPECT_EQ(rows, 2 * d);
  const MatrixXf& windows = trainer.rollout().amp_windows;
  const RowVectorX<float> last_two = before.reward(windows.bottomRows(2 * d));
  EXPECT_NEAR(st.disc_reward, last_two.cast<double>().mean(), 1e-12);
  Checkpoint c;
  trainer.save(c);
  EXPECT_EQ(c.get_matrix<float>("replay/storage", 2 * d, cfg.disc.replay_size).rows(), 2 * d);
  EXPECT_EQ(nlohmann::json::parse(c.get_string("config"))["disc"]["window_frames"], 2);
  const LoadedBasePolicy loaded = load_base_policy(c, trainer.dims());
  EXPECT_EQ(loaded.policy.disc.config().feature_dim, 2 * d);
  EXPECT_EQ(loaded.policy.disc.net().params(), trainer.policy().disc.net().params());
  expect_resume_is_bit_exact(cfg);
  // a 5-frame trainer refuses the 2-frame checkpoint, naming the section
  TinyRun five(tiny_config());
  EXPECT_THROW(five.trainer.load(c), Error);
}

// Stage 2's reward discriminators with disc.window_frames = 2 (train-residual --disc-frames 2):
// a member that saw the whole 5-frame window sees its last two frames' rows, a part member only
// its rows within those frames; each reward row is the member's reward on exactly those rows, and
// an update step runs on them (real, fake and the replay buffer sized to them).
TEST(RewardDiscriminators, TwoFramesKeepEachMembersRowsOfTheLastTwoFrames) {
  constexpr Index d = 6, W = d * kAmpWindowFrames, n = 40;
  const std::vector<Index> part_rows = {1, 4, d + 1, d + 4, 2 * d + 1, 2 * d + 4, 3 * d + 1, 3 * d + 4, 4 * d + 1, 4 * d + 4};
  auto sampler = [](Rng& r, Index B, MatrixXf& w, MatrixXf& m) {
    w = MatrixXf::NullaryExpr(W, B, [&] { return static_cast<float>(r.normal()); });
    m = MatrixXf::Zero(kNumParts, B);
  };
  BaseTrainConfig rl = tiny_config();
  rl.disc.window_frames = 2;
  rl.disc.batch_size = 16;
  rl.disc.replay_size = 64;
  Rng init(3);
  RewardDiscriminators discs({{"whole", 0.5, {}, false, sampler, {}}, {"part", 0.5, part_rows, true, sampler, {}}}, W, rl,
                             nn::Activation::ReLU, 0.0, init);
  std::vector<Index> last_two(2 * d);
  for (Index r = 0; r < 2 * d; ++r) last_two[static_cast<std::size_t>(r)] = 3 * d + r;
  EXPECT_EQ(discs.sources()[0].rows, last_two);
  EXPECT_EQ(discs.sources()[1].rows, (std::vector<Index>{3 * d + 1, 3 * d + 4, 4 * d + 1, 4 * d + 4}));
  EXPECT_EQ(discs.set().members[0].config().feature_dim, 2 * d);
  EXPECT_EQ(discs.set().members[1].config().feature_dim, 4);
  Rng data(5);
  const MatrixXf windows = MatrixXf::NullaryExpr(W, n, [&] { return static_cast<float>(data.normal()); });
  const std::vector<PartMask> masks(static_cast<std::size_t>(n), PartMask::of(BodyPart::LeftArm));
  MatrixXf rewards(2, n);
  IterationStats st;
  discs.rewards(windows, masks, rewards, true, st);
  EXPECT_EQ(rewards.row(0), discs.set().members[0].reward(windows.bottomRows(2 * d)));
  MatrixXf part(4, n);
  for (Index j = 0; j < n; ++j)
    for (Index r = 0; r < 4; ++r) part(r, j) = windows(discs.sources()[1].rows[static_cast<std::size_t>(r)], j);
  EXPECT_EQ(rewards.row(1), discs.set().members[1].reward(part, tasks::mask_bits(masks)));
  Rng steps(7);
  discs.update(windows, masks, steps, st);
  EXPECT_TRUE(std::isfinite(st.disc_loss));
  MatrixXf after(2, n);
  discs.rewards(windows, masks, after, false, st);
  EXPECT_NE(after.row(0), rewards.row(0));  // (the step moved the whole-window member)
  // five frames: the sources are left as they were
  rl.disc.window_frames = kAmpWindowFrames;
  Rng init5(3);
  RewardDiscriminators five({{"whole", 0.5, {}, false, sampler, {}}, {"part", 0.5, part_rows, true, sampler, {}}}, W, rl,
                            nn::Activation::ReLU, 0.0, init5);
  EXPECT_TRUE(five.sources()[0].rows.empty());
  EXPECT_EQ(five.sources()[1].rows, part_rows);
  EXPECT_EQ(five.set().members[0].config().feature_dim, W);
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

// RunOptions::stop (set by the CLI on SIGINT / SIGTERM): the loop checks it before every
// iteration, runs no further one, and writes its final checkpoint at the iteration reached.
TEST(RunTraining, AStopRequestEndsTheRunWithACheckpointAtTheIterationReached) {
  auto cfg = tiny_config();
  cfg.run.iterations = 1000;
  cfg.run.checkpoint_every = 1000;
  cfg.run.out_dir = (std::filesystem::temp_directory_path() / ("maskadapt_stop_test_" + std::to_string(::getpid()))).string();
  std::filesystem::remove_all(cfg.run.out_dir);
  TinyRun run(cfg);
  for (int i = 0; i < 3; ++i) run.trainer.iterate();
  std::atomic<bool> stop{true};
  run_training(run.trainer, RunOptions{false, nullptr, &stop});
  EXPECT_EQ(run.trainer.iteration(), 3) << "no iteration after the request";
  const Checkpoint c = load_checkpoint(cfg.run.out_dir + "/checkpoint.bin");
  EXPECT_EQ(c.get_int("trainer/iteration"), 3);
  stop = false;  // without a request the same loop runs to its budget
  cfg.run.iterations = 5;
  TinyRun again(cfg);
  run_training(again.trainer, RunOptions{false, nullptr, &stop});
  EXPECT_EQ(again.trainer.iteration(), 5);
  std::filesystem::remove_all(cfg.run.out_dir);
}
