// Partial tracking goals: extraction on a known pose, the rotation error / reward, the position
// error, windowed early termination, and the goal buffer over a plug-in generator.
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/tracking/goals.hpp>

#include <gtest/gtest.h>

#include <numbers>

using namespace maskadapt;
using namespace maskadapt::tracking;

namespace {

// A trajectory of the humanoid standing in the T-pose, rotated by `yaw` and moved by `shift`,
// with the left elbow bent by `elbow` radians about its z hinge.
Trajectory pose_trajectory(double yaw, const Vec3& shift, double elbow, Index frames = 3) {
  const Skeleton& skel = humanoid_skeleton();
  Trajectory t = Trajectory::zeros(skel, frames);
  for (Index i = 0; i < frames; ++i) {
    KinematicState s = humanoid_standing_pose();
    s.root_pos += shift;
    s.root_rot = Quat(Eigen::AngleAxisd(yaw, Vec3::UnitZ()));
    s.q[humanoid_skeleton().dof_offset(skel.index_of("L_Elbow")) + 2] = elbow * static_cast<double>(i);
    t.root_pos.col(i) = s.root_pos;
    t.root_rot[static_cast<std::size_t>(i)] = s.root_rot;
    t.q.col(i) = s.q;
  }
  compute_body_positions(skel, t);
  return t;
}

}  // namespace

TEST(Goals, ExtractionOnAKnownPoseIsHeadingInvariant) {
  const Skeleton& skel = humanoid_skeleton();
  const PartMask arms = PartMask::parse("arms");
  const auto bodies = designated_bodies(skel, arms);
  ASSERT_EQ(bodies.size(), 8u);  // shoulder/collar, shoulder, elbow, wrist per side (SMPL order)
  const Index G = goal_dim(skel, arms, 2);
  EXPECT_EQ(G, 2 * 6 * 8);
  const Trajectory a = pose_trajectory(0.0, Vec3::Zero(), 0.5);
  const Trajectory b = pose_trajectory(1.2, Vec3(3, -2, 0), 0.5);
  VectorXf ga(G), gb(G);
  extract_goals(skel, bodies, a, 0, 2, ga);
  extract_goals(skel, bodies, b, 0, 2, gb);
  EXPECT_LT((ga - gb).cwiseAbs().maxCoeff(), 1e-5f);
  // the elbow's z hinge of target frames 1 and 2 is 0.5 and 1.0 rad
  const int elbow = skel.index_of("L_Elbow");
  const auto j = static_cast<Index>(std::find(bodies.begin(), bodies.end(), elbow) - bodies.begin());
  EXPECT_FLOAT_EQ(ga[6 * j + 2], 0.5f);
  EXPECT_FLOAT_EQ(ga[6 * 8 + 6 * j + 2], 1.0f);
  // positions: the elbow of the T-pose sits at its FK position relative to the root, heading frame
  const BodyStates fk = forward_kinematics(skel, humanoid_standing_pose());
  const Vec3 want = fk.pos.col(elbow) - fk.pos.col(0);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(ga[6 * j + 3 + k], want[k], 1e-5);
  // clamped past the end
  VectorXf gl(G);
  extract_goals(skel, bodies, a, 5, 2, gl);
  EXPECT_FLOAT_EQ(gl[6 * j + 2], 1.0f);
  VectorXf wrong(G + 1);
  EXPECT_THROW(extract_goals(skel, bodies, a, 0, 2, wrong), Error);
}

TEST(Goals, RotationErrorAndRewardHaveClosedForms) {
  const Skeleton& skel = humanoid_skeleton();
  const auto bodies = designated_bodies(skel, PartMask::parse("arms"));
  KinematicState s = humanoid_standing_pose();
  s.root_rot = Quat(Eigen::AngleAxisd(0.7, Vec3::UnitZ()));
  const int elbow = skel.index_of("L_Elbow");
  s.q[humanoid_skeleton().dof_offset(elbow) + 1] = 0.3;
  const BodyStates sim = forward_kinematics(skel, s);
  VectorXd target = s.q;
  EXPECT_NEAR(rotation_error_sq(skel, bodies, target, sim), 0.0, 1e-12);
  EXPECT_NEAR(tracking_reward(skel, bodies, target, sim), 1.0, 1e-12);
  target[humanoid_skeleton().dof_offset(elbow) + 1] = 0.3 + 0.4;  // 0.4 rad off on one hinge
  EXPECT_NEAR(rotation_error_sq(skel, bodies, target, sim), 0.16, 1e-9);
  EXPECT_NEAR(tracking_reward(skel, bodies, target, sim), std::exp(-0.16), 1e-9);
  EXPECT_NEAR(tracking_reward(skel, bodies, target, sim, 0.25), std::exp(-0.04), 1e-9);  // the reward scale k
  // a leg error is invisible to the arms' reward
  VectorXd t2 = s.q;
  t2[humanoid_skeleton().dof_offset(skel.index_of("L_Knee"))] += 1.0;
  EXPECT_NEAR(rotation_error_sq(skel, bodies, t2, sim), 0.0, 1e-12);
}

TEST(Goals, PositionErrorMeasuresRootRelativeDeviation) {
  const Skeleton& skel = humanoid_skeleton();
  const auto bodies = designated_bodies(skel, PartMask::of(BodyPart::LeftArm));
  const Trajectory t = pose_trajectory(0.4, Vec3(1, 1, 0), 0.0, 1);
  KinematicState s = humanoid_standing_pose();
  s.root_pos += Vec3(-5, 2, 0);  // anywhere in the world
  BodyStates sim = forward_kinematics(skel, s);
  EXPECT_NEAR(position_error(bodies, t, 0, sim), 0.0, 1e-9);
  for (int b : bodies) sim.pos(2, b) += 0.3;  // every arm body 0.3 m higher
  EXPECT_NEAR(position_error(bodies, t, 0, sim), 0.3, 1e-9);
}

TEST(Goals, WindowedTerminationFiresOnTheWindowMean) {
  WindowedTermination w(2, 3, 0.5);
  EXPECT_FALSE(w.push(0, 0.0));  // window not full yet
  EXPECT_FALSE(w.push(0, 0.0));
  EXPECT_TRUE(w.push(0, 1.0));   // mean 1/3 < 0.5
  EXPECT_FALSE(w.push(0, 1.0));  // (0 + 1 + 1)/3
  EXPECT_FALSE(w.push(1, 0.0));  // envs are independent
  w.reset(0);
  EXPECT_FALSE(w.push(0, 0.0));
  EXPECT_THROW(WindowedTermination(1, 0, 0.5), Error);
}

namespace {
// A plug-in generator: continues the history's root in place and bends the left elbow by a
// text-dependent rate per frame.
struct ElbowGenerator {
  const Skeleton& skeleton() const { return humanoid_skeleton(); }
  Index history_frames() const { return 2; }
  Index future_frames() const { return 4; }
  Trajectory generate(const TextCondition& c, const Trajectory& h, Rng& rng) const {
    const double rate = c.text == "wave hands" ? 0.1 : 0.2;
    Trajectory t = Trajectory::zeros(skeleton(), 4);
    const int k = humanoid_skeleton().dof_offset(skeleton().index_of("L_Elbow")) + 2;
    for (Index i = 0; i < 4; ++i) {
      t.root_pos.col(i) = h.root_pos.col(1);
      t.root_rot[static_cast<std::size_t>(i)] = h.root_rot[1];
      t.q.col(i) = h.q.col(1);
      t.q(k, i) = h.q(k, 1) + rate * static_cast<double>(i + 1) + 0.0 * rng.uniform();
    }
    compute_body_positions(skeleton(), t);
    return t;
  }
};
static_assert(TrajectoryGenerator<ElbowGenerator>);
}  // namespace

TEST(Goals, GoalBufferHoldsGeneratedFuturesOfTheRequestedLength) {
  ElbowGenerator g;
  GoalBuffer buf;
  Rng rng(2);
  const GoalBuffer::HistorySource hist = [](Rng&) { return pose_trajectory(0.3, Vec3(1, 0, 0), 0.0, 2); };
  buf.refill(g, {"wave hands", "raise arms"}, hist, 6, 10, rng);
  ASSERT_EQ(buf.trajectories.size(), 6u);
  const int k = humanoid_skeleton().dof_offset(humanoid_skeleton().index_of("L_Elbow")) + 2;
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(buf.trajectories[i].num_frames(), 10);
    const double rate = buf.texts[i] == "wave hands" ? 0.1 : 0.2;
    EXPECT_NEAR(buf.trajectories[i].q(k, 9), rate * 10, 1e-9);  // consumed sequentially, frame after frame
  }
  EXPECT_LT(buf.draw(rng), 6u);
  GoalBuffer empty;
  EXPECT_THROW(empty.draw(rng), Error);
  EXPECT_THROW(buf.refill(g, {}, hist, 1, 1, rng), Error);
}
