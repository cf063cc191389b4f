// A non-MuJoCo simulator runs through the same observation and mask code as the humanoid.
#include "point_mass_chain.hpp"

#include <maskadapt/core/rng.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/mask/apply.hpp>
#include <maskadapt/mask/sampler.hpp>
#include <maskadapt/sim/observe.hpp>
#include <maskadapt/sim/termination.hpp>

#include <gtest/gtest.h>

using namespace maskadapt;
using maskadapt::testing::PointMassChainSim;

namespace {
/// root → a (0.5 m along +y, left arm) → b (0.4 m further), and root → c (0.8 m down, left leg).
Skeleton small_chain() {
  Skeleton s;
  s.names = {"root", "a", "b", "c"};
  s.parents = {-1, 0, 1, 0};
  s.offsets.resize(3, 4);
  s.offsets << 0, 0, 0, 0,  //
      0, 0.5, 0.4, 0,       //
      0, 0, 0, -0.8;
  s.parts = {BodyPart::Trunk, BodyPart::LeftArm, BodyPart::LeftArm, BodyPart::LeftLeg};
  s.set_xyz_hinges(Matrix3X::Constant(3, 4, -3.0), Matrix3X::Constant(3, 4, 3.0));
  return s;
}

/// Generic code written only against the concept: observations + masked policy inputs of all envs.
template <Simulator S>
MatrixXf observe_masked(const S& sim, std::span<const PartMask> masks) {
  const MatrixXf obs = compute_observations(sim);
  const PartElements pe(observation_parts(sim.skeleton()));
  return policy_input<float>(pe, obs, masks);
}
}  // namespace

TEST(PointMassChain, ServoFollowsTheClosedForm) {
  PointMassChainSim sim(small_chain(), 2, /*kp=*/6.0);
  MatrixXf targets = MatrixXf::Zero(9, 2);
  targets(2, 0) = 1.0f;   // env 0: joint a about z → 1 rad
  targets(4, 1) = -0.5f;  // env 1: joint b about y → −0.5 rad
  for (int k = 0; k < 10; ++k) sim.step(targets);
  const double decay = std::exp(-6.0 * 10.0 / 30.0);
  // a's angle q(t) = 1 − e^{−kp t}; body b sits 0.4 m along a's rotated y axis.
  const double qa = 1.0 - decay;
  const Vec3 pb = Vec3(0, 0.5, 0) + Vec3(-std::sin(qa), std::cos(qa), 0) * 0.4;
  EXPECT_LT((sim.body_states(0).pos.col(2) - pb).norm(), 1e-6);
  EXPECT_NEAR(sim.body_states(0).ang_vel(2, 1), 6.0 * decay, 1e-5);  // q̇ = kp · (target − q)
  EXPECT_EQ(sim.step_stats().control_steps, 10u);
}

TEST(PointMassChain, RunsThroughObservationAndMasks) {
  PointMassChainSim sim(small_chain(), 3);
  KinematicState st = KinematicState::zero(sim.skeleton());
  st.root_pos = Vec3(2, 3, 1);
  st.root_rot = Quat(Eigen::AngleAxisd(0.7, Vec3::UnitZ()));
  st.root_lin_vel = st.root_rot * Vec3(1, 0, 0);  // forward
  for (std::size_t e = 0; e < 3; ++e) sim.reset(e, st);
  MatrixXf targets = MatrixXf::Constant(9, 3, 0.3f);
  sim.step(targets);
  const std::vector<PartMask> masks = {PartMask::none(), PartMask::of(BodyPart::LeftArm),
                                       PartMask::of(BodyPart::LeftLeg) | PartMask::of(BodyPart::Trunk)};
  const MatrixXf in = observe_masked(sim, masks);
  const Index dim = observation_dim(sim.skeleton());
  ASSERT_EQ(dim, 1 + 3 * 3 + 12 * 4);
  ASSERT_EQ(in.rows(), dim + 5);
  const auto parts = observation_parts(sim.skeleton());
  for (int e = 0; e < 3; ++e) {
    for (Index j = 0; j < dim; ++j) {
      const bool masked = masks[static_cast<std::size_t>(e)].has(parts[static_cast<std::size_t>(j)]);
      if (masked) EXPECT_EQ(in(j, e), 0.0f);
      else EXPECT_EQ(in(j, e), in(j, 0));  // identical envs: unmasked values equal env 0's
    }
    for (int p = 0; p < 5; ++p) EXPECT_EQ(in(dim + p, e), masks[static_cast<std::size_t>(e)].has(static_cast<BodyPart>(p)) ? 1.0f : 0.0f);
  }
  // Root height is element 0 and the root glides: height 1 m, forward velocity 1 m/s in heading frame.
  EXPECT_FLOAT_EQ(in(0, 0), 1.0f);
  EXPECT_NEAR(in(ObservationLayout::of(sim.skeleton()).lin_vel, 0), 1.0f, 1e-6);
}

TEST(PointMassChain, WorksWithTheHumanoidSkeletonAndFallDetection) {
  PointMassChainSim sim(humanoid_skeleton(), 1);
  sim.reset(0, humanoid_standing_pose());
  const FallCriteria c = FallCriteria::for_skeleton(sim.skeleton());
  EXPECT_FALSE(has_fallen(c, sim.body_states(0), sim.contacts(0)));
  EXPECT_EQ(compute_observation(sim.skeleton(), sim.body_states(0)).size(), kObservationDim);
  KinematicState lying = humanoid_standing_pose();
  lying.root_pos.z() = 0.03;  // pelvis on the ground
  sim.reset(0, lying);
  EXPECT_TRUE(has_fallen(c, sim.body_states(0), sim.contacts(0)));
  EXPECT_EQ(fallen_envs(sim, c), std::vector<std::uint8_t>{1});
}

TEST(PointMassChain, BatchObservationsMatchPerEnvAndAnyThreadCount) {
  PointMassChainSim sim(small_chain(), 5);
  Rng r(4);
  for (std::size_t e = 0; e < 5; ++e) {
    KinematicState st = KinematicState::zero(sim.skeleton());
    st.root_rot = Quat(Eigen::AngleAxisd(r.uniform(-3, 3), Vec3::UnitZ()));
    for (Index k = 0; k < st.q.size(); ++k) st.q[k] = r.uniform(-1, 1);
    sim.reset(e, st);
  }
  ThreadPool pool(2);
  const MatrixXf a = compute_observations(sim), b = compute_observations(sim, &pool);
  EXPECT_TRUE((a.array() == b.array()).all());
  EXPECT_EQ(a.col(3), compute_observation(sim.skeleton(), sim.body_states(3)));
  MatrixXf wrong(a.rows(), 4);
  EXPECT_THROW(compute_observations(sim, wrong), Error);
}

TEST(PointMassChain, RejectsBadTargetsAndPoses) {
  PointMassChainSim sim(small_chain(), 2);
  MatrixXf t = MatrixXf::Zero(9, 2);
  t(4, 1) = std::numeric_limits<float>::infinity();
  EXPECT_THROW(sim.step(t), Error);
  EXPECT_THROW(sim.step(MatrixXf::Zero(8, 2)), Error);
  KinematicState st = KinematicState::zero(sim.skeleton());
  st.q.resize(4);
  EXPECT_THROW(sim.reset(0, st), Error);
}
