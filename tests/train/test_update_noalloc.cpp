// Proves the stage-1 update path (discriminator rewards, GAE, PPO + MI, discriminator steps with
// the gradient penalty, input statistics) allocates no matrix once its buffers have seen the
// rollout's sizes, like the collection path (tests/nn/test_mlp_noalloc.cpp), and that the
// library's real-window sampler does the same. Built as its own executable: Eigen's runtime
// malloc check must be enabled before any Eigen header in every translation unit of the binary,
// and its assertion must work in Release builds.
#define EIGEN_RUNTIME_NO_MALLOC
#include <stdexcept>
#define eigen_assert(x) \
  do { if (!(x)) throw std::runtime_error("Eigen assertion failed: " #x); } while (false)

#include "tiny_sim.hpp"
#include "trainer_test_helpers.hpp"

#include <maskadapt/motion/library.hpp>
#include <maskadapt/humanoid/synthetic.hpp>
#include <maskadapt/train/base_trainer.hpp>

#include <gtest/gtest.h>

using namespace maskadapt;
using namespace maskadapt::train;
using maskadapt::testing::TinyWalkerSim;
using maskadapt::testing::upright;

namespace {

/// Runs f with Eigen's heap allocations forbidden; returns the assertion's text, empty if none.
template <class F>
std::string without_matrix_allocations(F&& f) {
  Eigen::internal::set_is_malloc_allowed(false);
  std::string failure;
  try {
    f();
  } catch (const std::exception& e) {
    failure = e.what();
  }
  Eigen::internal::set_is_malloc_allowed(true);
  return failure;
}

/// Real windows drawn from a fixed bank of random windows (allocates nothing: the sampler's own
/// cost is the library's, tested below).
RealWindowSampler bank_windows(Index dim) {
  auto bank = std::make_shared<MatrixXf>(MatrixXf::Random(dim, 64));
  return [bank](Rng& rng, Eigen::Ref<MatrixXf> out) {
    for (Index j = 0; j < out.cols(); ++j) out.col(j) = bank->col(static_cast<Index>(rng.uniform_int(64)));
  };
}

}  // namespace

TEST(UpdateNoAlloc, CheckIsLive) {
  EXPECT_FALSE(without_matrix_allocations([] {
                 Eigen::MatrixXf m(8, 8);
                 (void)m;
               }).empty());
}

// The objectives of the recipe and its baseline: plain AMP, and masking with the EMA target and
// hidden elements at their mean (the cpu preset). (The other MI modes run their target on the K
// masked columns of each minibatch, and K changes from one minibatch to the next: their K-wide
// buffers are reallocated.)
TEST(UpdateNoAlloc, UpdateFromRolloutAllocatesNoMatrixAfterWarmup) {
  struct Variant {
    const char* name;
    bool masking;
    const char* mi_gradient;
    const char* hidden_value;
  };
  for (const Variant v : {Variant{"amp", false, "both", "zero"}, Variant{"ema_mean", true, "target_ema", "mean"}}) {
#if !defined(MASKADAPT_HAS_BLAS)
    GTEST_SKIP() << "built without EIGEN_USE_BLAS: Eigen's GEMM allocates its blocking buffers";
#endif
    SCOPED_TRACE(v.name);
    BaseTrainConfig c = maskadapt::testing::tiny_walker_config();
    c.mask.enabled = v.masking;
    c.mask.prob = 0.8;
    c.mask.mi_gradient = v.mi_gradient;
    c.mask.hidden_value = v.hidden_value;
    c.net.actor_hidden = {64, 64};  // products large enough to reach OpenBLAS
    c.net.disc_hidden = {64, 32};
    TinyWalkerSim sim(static_cast<std::size_t>(c.env.num_envs));
    const Index amp_dim = kAmpWindowFrames * observation_dim(sim.skeleton());
    BaseTrainer<TinyWalkerSim> trainer(
        sim, upright(sim.skeleton()), bank_windows(amp_dim), c, nullptr,
        FallCriteria::for_skeleton(sim.skeleton(), {"l_leg", "r_leg"}, "head", c.env.termination_height));
    trainer.iterate();  // warm-up: every buffer takes its size, the EMA target is created
    trainer.iterate();
    IterationStats st;
    trainer.update_from_rollout(st);  // (the log's map gets its keys)
    const std::string failure = without_matrix_allocations([&] {
      for (int k = 0; k < 2; ++k) trainer.update_from_rollout(st);
    });
    EXPECT_TRUE(failure.empty()) << failure;
    EXPECT_TRUE(trainer.policy().ac.actor.mean_net.params().allFinite());
  }
}

TEST(UpdateNoAlloc, LibraryRealWindowsAllocateNoMatrixAfterWarmup) {
  MotionLibrary lib(humanoid_skeleton());
  lib.add(synthetic_walk());
  lib.add(synthetic_kick());
  MatrixXf out(lib.amp_window_dim(), 16);
  Rng rng(3);
  lib.sample_amp_windows(rng, out);  // warm-up: this thread's pose buffers take their sizes
  const MatrixXf first = out;
  const std::string failure = without_matrix_allocations([&] {
    for (int k = 0; k < 3; ++k) lib.sample_amp_windows(rng, out);
  });
  EXPECT_TRUE(failure.empty()) << failure;
  EXPECT_TRUE(out.allFinite());
  EXPECT_FALSE(out == first);  // new windows were drawn
}
