// The stage-1 trainer on 2 ranks (mpirun -np 2) against one process, on the tiny analytic walker
// (tests/train/tiny_sim.hpp): 2 ranks × 2 envs follow the training of 1 process × 4 envs (to the
// tolerance below), two runs of the same layout are bit-identical, a 2-rank checkpoint resumes
// bit-exactly on 2 ranks and is refused by another rank count. RankFailure.* run from
// rank_failure.cmake (a rank killed / aborting), not from the mpi.trainer entry.
#include "../train/tiny_sim.hpp"
#include "../train/trainer_test_helpers.hpp"
#include "mpi_test_helpers.hpp"

#include <maskadapt/core/collective.hpp>
#include <maskadapt/train/base_trainer.hpp>

#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include <unistd.h>

using namespace maskadapt;
using namespace maskadapt::train;
using maskadapt::testing::expect_bit_identical;
using maskadapt::testing::on_every_rank;
using maskadapt::testing::TinyWalkerSim;
using maskadapt::testing::upright;

namespace {

// "Motion library" of the tiny walker: a sinusoidal swing of the legs (as tests/train).
RealWindowSampler swing_windows(const Skeleton& skel) {
  return [&skel](Rng& rng, Eigen::Ref<MatrixXf> out) {
    const Index d = observation_dim(skel);
    for (Index j = 0; j < out.cols(); ++j) {
      const double t0 = rng.uniform(0.0, 2.0);
      for (Index f = 0; f < 5; ++f) {
        const double t = t0 + f / 30.0;
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

// 4 envs in all (2 per rank on 2 ranks), horizon 8, minibatches of 8 of the 32 samples.
BaseTrainConfig config() { return maskadapt::testing::tiny_walker_config(); }

struct WalkerRun {
  TinyWalkerSim sim;
  BaseTrainer<TinyWalkerSim> trainer;
  WalkerRun(const BaseTrainConfig& c, Collective& comm)
      : sim(static_cast<std::size_t>(c.env.num_envs / comm.size())),
        trainer(sim, upright(sim.skeleton()), swing_windows(sim.skeleton()), c, nullptr,
                FallCriteria::for_skeleton(sim.skeleton(), {"l_leg", "r_leg"}, "head", c.env.termination_height), &comm) {}
};

/// Collective; rank 0 gets the whole checkpoint.
Checkpoint snapshot(const BaseTrainer<TinyWalkerSim>& t) {
  Checkpoint c;
  t.save(c);
  return c;
}

double max_abs_diff(const VectorXf& a, const VectorXf& b) {
  EXPECT_EQ(a.size(), b.size());
  return a.size() == b.size() ? static_cast<double>((a - b).cwiseAbs().maxCoeff()) : INFINITY;
}

}  // namespace

// 2 ranks × 2 envs and 1 process × 4 envs, 3 iterations: the same training. The ranks sum their
// gradients of one minibatch in rank order after each computed its samples' part with its own
// GEMMs, while one process forms the minibatch's sum in one GEMM, so the float results differ
// in the last bits; over 3 iterations (24 actor/critic steps, 12 discriminator steps) the
// parameters stay within the tolerance below (the figures are printed).
void expect_two_ranks_follow_one_process(const BaseTrainConfig& cfg) {
  WalkerRun dist(cfg, world());
  WalkerRun one(cfg, single_process());
  EXPECT_EQ(dist.sim.num_envs(), 2u);
  EXPECT_EQ(dist.trainer.env_offset(), 2 * world().rank());
  // the envs start where envs 2r, 2r+1 of the one process start
  EXPECT_TRUE(dist.trainer.task().observations() == one.trainer.task().observations().middleCols(dist.trainer.env_offset(), 2));
  double worst = 0;
  for (int it = 0; it < 3; ++it) {
    const IterationStats sd = dist.trainer.iterate();
    const IterationStats so = one.trainer.iterate();
    EXPECT_EQ(sd.samples, so.samples);
    EXPECT_EQ(sd.episodes, so.episodes) << "iteration " << it + 1;
    EXPECT_NEAR(sd.disc_reward, so.disc_reward, 1e-4 * (1 + std::abs(so.disc_reward)));
    EXPECT_NEAR(sd.policy_loss, so.policy_loss, 1e-4 * (1 + std::abs(so.policy_loss)));
    EXPECT_NEAR(sd.value_loss, so.value_loss, 1e-4 * (1 + std::abs(so.value_loss)));
  }
  const Checkpoint d = snapshot(dist.trainer), o = snapshot(one.trainer);
  if (world().is_root()) {
    bool identical = true;
    for (const char* name : {"actor/params", "actor/log_std", "critic/params", "disc/params"}) {
      const VectorXf a = d.get_vector<float>(name), b = o.get_vector<float>(name);
      const double diff = max_abs_diff(a, b);
      worst = std::max(worst, diff / (1e-3 + static_cast<double>(b.cwiseAbs().maxCoeff())));
      identical = identical && diff == 0;
      std::cout << "[ 2 ranks vs 1 process ] " << name << ": max |Δ| = " << diff << " (max |θ| = " << b.cwiseAbs().maxCoeff()
                << ")\n";
    }
    std::cout << "[ 2 ranks vs 1 process ] parameters after 3 iterations: " << (identical ? "bit-identical" : "not bit-identical")
              << ", worst relative difference " << worst << "\n";
    EXPECT_LT(worst, 1e-5);  // measured: 1.5e-7 (float rounding of the reordered sums, not a different training)
    // the task state has the layout of the one process's (4 envs), bit for bit where no network
    // output fed it: the envs' random streams
    for (int e = 0; e < 4; ++e)
      EXPECT_EQ(d.get_vector<std::int64_t>("task/rng/" + std::to_string(e)), o.get_vector<std::int64_t>("task/rng/" + std::to_string(e)));
    EXPECT_EQ(d.get_int("dist/ranks"), world().size());
  }
}

TEST(DistributedTrainer, TwoRanksFollowOneProcessWithFourEnvs) { expect_two_ranks_follow_one_process(config()); }

// The cpu preset's levers: the EMA target of the MI loss (a target pass over each rank's own
// samples), hidden elements at their running mean (normaliser merged over ranks), the adaptive
// actor rate (driven by the all-reduced KL), normalised actions with the bound penalty.
TEST(DistributedTrainer, TwoRanksFollowOneProcessWithTheCpuRecipesLevers) {
  BaseTrainConfig cfg = config();
  cfg.mask.mi_gradient = "target_ema";
  cfg.mask.mi_target_tau = 0.1;
  cfg.mask.hidden_value = "mean";
  cfg.mask.lambda_mi = 0.3;
  cfg.ppo.actor_lr_schedule = "adaptive";
  cfg.ppo.action_bound_weight = 1.0;
  expect_two_ranks_follow_one_process(cfg);
}

// Two runs of the same layout (2 ranks × 2 envs) are bit-identical, every section.
TEST(DistributedTrainer, SameLayoutTwiceIsBitIdentical) {
  const BaseTrainConfig cfg = config();
  WalkerRun a(cfg, world()), b(cfg, world());
  for (int it = 0; it < 3; ++it) {
    a.trainer.iterate();
    b.trainer.iterate();
  }
  const Checkpoint ca = snapshot(a.trainer), cb = snapshot(b.trainer);
  if (world().is_root()) expect_bit_identical(ca, cb);
}

// 2 iterations, checkpoint (rank 0's), 2 ranks load it into trainers built with another seed and
// run 2 more: bit-identical to 4 straight iterations.
TEST(DistributedTrainer, ResumeOnTheSameRanksIsBitExact) {
  const BaseTrainConfig cfg = config();
  WalkerRun straight(cfg, world());
  for (int it = 0; it < 4; ++it) straight.trainer.iterate();
  WalkerRun first(cfg, world());
  for (int it = 0; it < 2; ++it) first.trainer.iterate();
  const Checkpoint at2 = on_every_rank(snapshot(first.trainer));
  auto other = cfg;
  other.run.seed = 7;
  WalkerRun resumed(other, world());
  resumed.trainer.load(at2);
  EXPECT_EQ(resumed.trainer.iteration(), 2);
  for (int it = 0; it < 2; ++it) resumed.trainer.iterate();
  Checkpoint a = snapshot(straight.trainer), b = snapshot(resumed.trainer);
  if (world().is_root()) {
    a.erase("config");
    b.erase("config");
    expect_bit_identical(a, b);
  }
}

// A 2-rank checkpoint is refused by one process, and a one-process checkpoint by 2 ranks, with
// an error that says what to do.
TEST(DistributedTrainer, ACheckpointOfAnotherRankCountIsRefused) {
  const BaseTrainConfig cfg = config();
  WalkerRun dist(cfg, world());
  dist.trainer.iterate();
  const Checkpoint c = on_every_rank(snapshot(dist.trainer));
  WalkerRun one(cfg, single_process());
  try {
    one.trainer.load(c);
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("written by a run of 2 rank(s), this run has 1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("mpirun -np 2"), std::string::npos) << e.what();
  }
  Checkpoint single;
  one.trainer.save(single);
  try {
    dist.trainer.load(single);
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("written by a run of 1 rank(s), this run has 2"), std::string::npos) << e.what();
  }
}

// ---- run by rank_failure.cmake (MASKADAPT_MPI_FAULT_DIR set) ----------------------------------

using maskadapt::testing::fault_dir;

// Rank 1 dies (SIGKILL) after the iteration-2 checkpoint, while rank 0 goes on: the launcher
// stops the job and names the rank; the checkpoint stays.
TEST(RankFailure, KillRankOneAfterACheckpoint) {
  if (fault_dir().empty()) GTEST_SKIP() << "run by tests/mpi/rank_failure.cmake";
  const BaseTrainConfig cfg = config();
  WalkerRun dist(cfg, world());
  for (int it = 0; it < 2; ++it) dist.trainer.iterate();
  dist.trainer.save(fault_dir() + "/checkpoint.bin");
  world().barrier();
  if (world().rank() == 1) ::raise(SIGKILL);
  for (int it = 0; it < 2; ++it) dist.trainer.iterate();  // rank 0 waits in a collective until the job is stopped
  dist.trainer.save(fault_dir() + "/checkpoint.bin");
  FAIL() << "the job should have been stopped";
}

// A rank that finds an error stops the job with a message naming it (what the CLI does with an
// error on one rank: Collective::abort).
TEST(RankFailure, AnErrorOnOneRankAbortsTheJobNamingTheRank) {
  if (fault_dir().empty()) GTEST_SKIP() << "run by tests/mpi/rank_failure.cmake";
  if (world().rank() == 1) world().abort("maskadapt: rank 1 of 2: error: simulated non-finite state");
  world().barrier();
  FAIL() << "the job should have been stopped";
}

// After the failure: the checkpoint on disk loads (checksum) and 2 ranks resume from it.
TEST(RankFailure, TheLastCheckpointResumes) {
  if (fault_dir().empty()) GTEST_SKIP() << "run by tests/mpi/rank_failure.cmake";
  const Checkpoint c = load_checkpoint(fault_dir() + "/checkpoint.bin");
  EXPECT_EQ(c.get_int("trainer/iteration"), 2);
  EXPECT_EQ(c.get_int("dist/ranks"), 2);
  WalkerRun dist(config(), world());
  dist.trainer.load(c);
  EXPECT_EQ(dist.trainer.iterate().iteration, 3);
}
