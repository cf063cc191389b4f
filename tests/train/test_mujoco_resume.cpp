// Bit-exact resume on the MuJoCo humanoid: the simulator's per-env state round trip, and the
// stage-1 trainer's 2 + 2 == 4 iterations with a checkpoint in between (tiny nets, 2 envs).
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>
#include <maskadapt/train/base_trainer.hpp>
#include <maskadapt/motion/bvh.hpp>
#include <maskadapt/humanoid/retarget.hpp>
#include <maskadapt/train/motion_sources.hpp>
#include <maskadapt/train/play.hpp>

#include <gtest/gtest.h>
#include "../blas_kernel.hpp"
#include "trainer_test_helpers.hpp"

#include <cstring>
#include <filesystem>

#include <unistd.h>  // getpid: one temp file per process (the BLAS matrix runs this test in parallel)

using namespace maskadapt;
using namespace maskadapt::train;
using maskadapt::testing::expect_bit_identical;

static_assert(tasks::StateSavingSimulator<MujocoHumanoidSim>, "the MuJoCo humanoid must support exact state save/restore");

namespace {

MatrixXf random_targets(const MujocoHumanoidSim& sim, Rng& rng, double amp = 0.3) {
  MatrixXf t(sim.skeleton().num_dofs(), static_cast<Index>(sim.num_envs()));
  for (Index i = 0; i < t.size(); ++i) t.data()[i] = static_cast<float>(rng.uniform(-amp, amp));
  return t;
}

BaseTrainConfig tiny_config() {
  BaseTrainConfig c;  // the paper's formulation (struct defaults), not the cpu preset's walking recipe
  c.env.num_envs = 2;
  c.env.motions = {"synthetic"};
  c.env.episode_seconds = 0.5;  // a few truncations (and RSI resets) inside 4 iterations
  c.net.actor_hidden = {16};
  c.net.critic_hidden = {16};
  c.net.disc_hidden = {16};
  c.ppo.horizon = 6;
  c.ppo.epochs = 2;
  c.ppo.minibatch_size = 6;
  c.disc.batch_size = 6;
  c.disc.replay_size = 64;
  c.run.seed = 5;
  c.run.threads = 1;
  return c;
}

}  // namespace

TEST(MujocoResume, SavedEnvStateReplaysBitIdentically) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  MujocoHumanoidSim sim(2);
  Rng rng(11);
  for (int k = 0; k < 5; ++k) sim.step(random_targets(sim, rng));
  const std::vector<double> saved = sim.save_state(1);
  const Rng rng_at_save = rng;
  for (int k = 0; k < 4; ++k) sim.step(random_targets(sim, rng));
  const BodyStates after = sim.body_states(1);
  const ContactFlags contacts_after = sim.contacts(1);

  // a different simulator, a different history: loading the state makes the future identical
  MujocoHumanoidSim other(2);
  Rng noise(99);
  for (int k = 0; k < 3; ++k) other.step(random_targets(other, noise));
  other.load_state(1, saved);
  Rng replay = rng_at_save;
  for (int k = 0; k < 4; ++k) other.step(random_targets(other, replay));
  EXPECT_EQ(0, std::memcmp(after.pos.data(), other.body_states(1).pos.data(), sizeof(double) * after.pos.size()));
  EXPECT_EQ(0, std::memcmp(after.lin_vel.data(), other.body_states(1).lin_vel.data(), sizeof(double) * after.lin_vel.size()));
  EXPECT_EQ(contacts_after, other.contacts(1));
}

// Loading a saved state must reproduce it exactly, whatever the trajectory: MuJoCo 2.2.2's
// mj_kinematics renormalises qpos's quaternions in place, and a second normalisation changes the
// last bit on some steps (this is what made 2 + 2 == 4 depend on the BLAS kernel: the kernel
// only decided which trajectory the test followed). 120 steps hit such a step many times over.
TEST(MujocoResume, LoadingASavedStateGivesBackTheSameStateAndBodyStatesOnEveryStep) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  MujocoHumanoidSim sim(1), other(1);
  Rng rng(3);
  int steps_checked = 0;
  for (int k = 0; k < 120; ++k) {
    sim.step(random_targets(sim, rng, 0.6));
    if (sim.step_stats().physics_reset[0]) continue;
    const std::vector<double> saved = sim.save_state(0);
    other.load_state(0, saved);
    ASSERT_EQ(saved, other.save_state(0)) << "save(load(state)) differs after step " << k;
    const BodyStates& a = sim.body_states(0);
    const BodyStates& b = other.body_states(0);
    ASSERT_EQ(0, std::memcmp(a.pos.data(), b.pos.data(), sizeof(double) * a.pos.size())) << "step " << k;
    for (std::size_t i = 0; i < a.rot.size(); ++i)
      ASSERT_EQ(0, std::memcmp(a.rot[i].coeffs().data(), b.rot[i].coeffs().data(), sizeof(double) * 4)) << "step " << k;
    ASSERT_EQ(0, std::memcmp(a.ang_vel.data(), b.ang_vel.data(), sizeof(double) * a.ang_vel.size())) << "step " << k;
    ++steps_checked;
  }
  EXPECT_GT(steps_checked, 100);
  // and the two continue identically
  Rng r1(8), r2(8);
  for (int k = 0; k < 10; ++k) {
    sim.step(random_targets(sim, r1, 0.6));
    other.step(random_targets(other, r2, 0.6));
  }
  EXPECT_EQ(sim.save_state(0), other.save_state(0));
}

TEST(MujocoResume, LoadStateRejectsMalformedStates) {
  MujocoHumanoidSim sim(1);
  std::vector<double> s = sim.save_state(0);
  auto short_state = s;
  short_state.pop_back();
  EXPECT_THROW(sim.load_state(0, short_state), Error);
  auto nan_state = s;
  nan_state[10] = std::nan("");
  EXPECT_THROW(sim.load_state(0, nan_state), Error);
  EXPECT_THROW(sim.load_state(3, s), Error);
  EXPECT_NO_THROW(sim.load_state(0, s));
}

TEST(MujocoResume, TrainTwoPlusTwoEqualsFourStraight) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  const BaseTrainConfig cfg = tiny_config();
  auto lib = load_motion_library(cfg.env.motions);
  auto make = [&](MujocoHumanoidSim& sim, const BaseTrainConfig& c) {
    return BaseTrainer<MujocoHumanoidSim>(sim, library_reset_sampler(lib), library_window_sampler(lib), c);
  };
  MujocoHumanoidSim sim_a(2);
  auto straight = make(sim_a, cfg);
  for (int i = 0; i < 4; ++i) straight.iterate();

  MujocoHumanoidSim sim_b(2);
  auto first = make(sim_b, cfg);
  for (int i = 0; i < 2; ++i) first.iterate();
  const auto path = (std::filesystem::temp_directory_path() / ("maskadapt_mujoco_resume_" + std::to_string(::getpid()) + ".ckpt")).string();
  first.save(path);

  auto other = cfg;
  other.run.seed = 77;
  MujocoHumanoidSim sim_c(2);
  auto resumed = make(sim_c, other);
  resumed.load(load_checkpoint(path));
  for (int i = 0; i < 2; ++i) resumed.iterate();

  Checkpoint a, b;
  straight.save(a);
  resumed.save(b);
  EXPECT_EQ(a.get_int("task/has_sim_state"), 1);
  a.erase("config");
  b.erase("config");
  expect_bit_identical(a, b);
  std::filesystem::remove(path);
}

// Thread-count independence of the whole stage-1 loop on MuJoCo: the envs, the network passes
// (nn/chunks.hpp) and the updates run on pools of 1, 2 and 3 threads and give the same bits.
// 4 envs and 64-wide nets so that products are chunked and the env loop is really split.
TEST(MujocoResume, TrainingIsBitIdenticalForAnyThreadCount) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  BaseTrainConfig cfg = tiny_config();
  cfg.env.num_envs = 4;
  cfg.net.actor_hidden = {64, 64};
  cfg.net.critic_hidden = {64};
  cfg.net.disc_hidden = {64};
  cfg.ppo.minibatch_size = 12;
  auto lib = load_motion_library(cfg.env.motions);
  auto run = [&](std::size_t threads) {
    ThreadPool pool(threads);
    MujocoHumanoidSim sim(4, pool);
    BaseTrainer<MujocoHumanoidSim> trainer(sim, library_reset_sampler(lib), library_window_sampler(lib, &pool), cfg, &pool);
    for (int i = 0; i < 3; ++i) trainer.iterate();
    Checkpoint c;
    trainer.save(c);
    return c;
  };
  const Checkpoint one = run(1);
  for (std::size_t threads : {2u, 3u}) {
    SCOPED_TRACE(std::to_string(threads) + " threads");
    expect_bit_identical(one, run(threads));
  }
}

TEST(MujocoPlay, ExportedBvhAndRolloutReadBackWithTheLibraryReaders) {
  auto lib = load_motion_library({"synthetic"});
  MujocoHumanoidSim sim(1);
  const Index d = observation_dim(sim.skeleton());
  BaseTrainConfig cfg = tiny_config();
  Rng init(2);
  const BasePolicy policy = make_base_policy(cfg, {d, d + kNumParts, sim.skeleton().num_dofs(), 5 * d}, init);
  PlayOptions opt;
  opt.seconds = 0.5;
  opt.masks = MaskSampler::fixed(PartMask::parse("left_leg,right_leg"));
  const PlayResult r = play_base_policy(sim, policy, library_reset_sampler(lib), opt, eval::make_rollout(sim.character()));
  ASSERT_EQ(r.rollout.num_frames(), 16);
  // the recovered joint angles reproduce MuJoCo's body positions through the library's FK
  double worst = 0;
  for (int t = 0; t < r.clip.num_frames(); ++t) {
    const BodyStates b = forward_kinematics(sim.skeleton(), r.clip.frame(t));
    worst = std::max(worst, (b.pos - r.rollout.positions[static_cast<std::size_t>(t)]).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-6);
  const auto dir = std::filesystem::temp_directory_path() / "maskadapt_mujoco_play";
  std::filesystem::create_directories(dir);
  bvh::write((dir / "p.bvh").string(), clip_to_bvh(r.clip, sim.skeleton()));
  const bvh::Motion m = bvh::read((dir / "p.bvh").string());
  EXPECT_EQ(m.frames.cols(), 16);
  // and imports back onto the humanoid as a clip of the same length whose root follows ours
  const MotionClip back = import_motion((dir / "p.bvh").string());
  ASSERT_EQ(back.num_frames(), 16);
  eval::write_rollout(r.rollout, (dir / "p.json").string());
  const eval::Rollout rb = eval::read_rollout((dir / "p.json").string());
  EXPECT_EQ(rb.num_frames(), 16);
  EXPECT_EQ(rb.masks[5], PartMask::parse("legs"));
  ASSERT_EQ(rb.contacts[0].size(), static_cast<std::size_t>(sim.skeleton().num_bodies()));
  std::filesystem::remove_all(dir);
}
