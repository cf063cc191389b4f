// Scene objects on the MuJoCo humanoid (sim/scene.hpp, MujocoHumanoidSim's boxes): what a task
// writes is what MuJoCo simulates and what the library reads back.
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>

#include <gtest/gtest.h>

#include <cmath>

using namespace maskadapt;

namespace {
BoxObject test_box(Vec3 half = Vec3(0.2, 0.2, 0.6)) {
  BoxObject b;
  b.name = "target";
  b.half_size = half;
  b.mass = 5.0;
  return b;
}
Quat yaw_of(double a) { return Quat(Eigen::AngleAxisd(a, Vec3::UnitZ())); }
}  // namespace

TEST(MujocoScene, BoxStateReadBackMatchesTheOneWritten) {
  MujocoHumanoidSim sim(1, 1, humanoid_description(), {test_box()});
  ASSERT_EQ(sim.num_objects(), 1u);
  RigidState s;
  s.pos = Vec3(2.0, 1.0, 3.0);  // in the air: free flight for one control step
  s.rot = yaw_of(0.5);
  s.lin_vel = Vec3(0.5, -0.2, 1.0);
  s.ang_vel = Vec3(0.0, 0.0, 2.0);  // about a principal axis: no gyroscopic terms
  sim.place_object(0, 0, s);
  const RigidState& r0 = sim.object_state(0, 0);
  EXPECT_EQ(r0.pos, s.pos);
  EXPECT_TRUE(r0.rot.coeffs().isApprox(s.rot.coeffs(), 1e-15));
  EXPECT_EQ(r0.lin_vel, s.lin_vel);
  EXPECT_EQ(r0.ang_vel, s.ang_vel);
  // What MuJoCo holds: the free joint's qpos (w, x, y, z) and qvel (body-local angular velocity).
  const int j = mj_name2id(sim.model(), mjOBJ_JOINT, "object_target");
  ASSERT_GE(j, 0);
  const mjtNum* q = sim.data(0)->qpos + sim.model()->jnt_qposadr[j];
  EXPECT_EQ(Vec3(q[0], q[1], q[2]), s.pos);
  EXPECT_NEAR(q[3], s.rot.w(), 1e-15);
  EXPECT_NEAR(q[6], s.rot.z(), 1e-15);

  // One control step of semi-implicit Euler in free flight, k substeps of h:
  //   v = v0 + k·h·g,  x = x0 + k·h·v0 + h²·g·k(k+1)/2,  yaw = yaw0 + ω·k·h.
  sim.step(MatrixXf(humanoid_standing_pose().q.cast<float>()));
  const double h = sim.character().physics_dt, k = sim.character().substeps;
  const Vec3 g(sim.model()->opt.gravity[0], sim.model()->opt.gravity[1], sim.model()->opt.gravity[2]);
  ASSERT_NEAR(g.z(), -9.81, 1e-12);
  const RigidState& r1 = sim.object_state(0, 0);
  EXPECT_TRUE(r1.pos.isApprox(s.pos + k * h * s.lin_vel + h * h * g * k * (k + 1) / 2, 1e-12)) << r1.pos.transpose();
  EXPECT_TRUE(r1.lin_vel.isApprox(s.lin_vel + k * h * g, 1e-12)) << r1.lin_vel.transpose();
  EXPECT_TRUE(r1.ang_vel.isApprox(s.ang_vel, 1e-12)) << r1.ang_vel.transpose();
  EXPECT_NEAR(std::abs(r1.rot.dot(yaw_of(0.5 + 2.0 * k * h))), 1.0, 1e-12);
  for (auto c : sim.object_contacts(0, 0)) EXPECT_EQ(c, 0);  // nothing touched it
}

TEST(MujocoScene, CharacterResetLeavesTheBoxAndSaveLoadIncludesIt) {
  MujocoHumanoidSim a(1, 1, humanoid_description(), {test_box()}), b(1, 1, humanoid_description(), {test_box()});
  RigidState s;
  s.pos = Vec3(1.2, 0.3, 0.6);  // standing on the floor in front of the character
  s.rot = yaw_of(0.3);
  a.place_object(0, 0, s);
  const MatrixXf hold = humanoid_standing_pose().q.cast<float>();
  for (int i = 0; i < 5; ++i) a.step(hold);
  const RigidState before = a.object_state(0, 0);
  a.reset(0, humanoid_standing_pose());
  EXPECT_TRUE(a.object_state(0, 0).pos.isApprox(before.pos, 1e-12));
  b.load_state(0, a.save_state(0));
  for (int i = 0; i < 10; ++i) {
    a.step(hold);
    b.step(hold);
  }
  EXPECT_EQ(a.object_state(0, 0).pos, b.object_state(0, 0).pos);
  EXPECT_EQ(a.object_state(0, 0).rot.coeffs(), b.object_state(0, 0).rot.coeffs());
  EXPECT_NEAR(a.object_state(0, 0).pos.z(), 0.6, 0.01);  // it rests on the floor
  MujocoHumanoidSim plain(1);  // a model without the box refuses the state
  EXPECT_THROW(plain.load_state(0, a.save_state(0)), Error);
}

TEST(MujocoScene, ContactWithTheRightHandIsReportedForThatBody) {
  MujocoHumanoidSim sim(1, 1, humanoid_description(), {test_box(Vec3(0.03, 0.03, 0.03))});
  const BodyStates& st = sim.body_states(0);
  RigidState s;
  // overlapping the outer end of the right hand's box geom (centre 0.085 m, half length 0.085 m along −y)
  s.pos = st.pos.col(hb::RWrist) + st.rot[hb::RWrist] * Vec3(0.0, -0.14, 0.0);
  sim.place_object(0, 0, s);
  sim.step(MatrixXf(humanoid_standing_pose().q.cast<float>()));
  const ContactFlags& c = sim.object_contacts(0, 0);
  ASSERT_EQ(c.size(), static_cast<std::size_t>(sim.skeleton().num_bodies()));
  EXPECT_EQ(c[hb::RWrist], 1);
  for (int b = 0; b < sim.skeleton().num_bodies(); ++b) {
    if (b != hb::RWrist && b != hb::RElbow) {
      EXPECT_EQ(c[static_cast<std::size_t>(b)], 0) << sim.skeleton().names[static_cast<std::size_t>(b)];
    }
  }
  EXPECT_EQ(sim.contacts(0)[hb::RWrist], 0);  // a box is not the ground
}

TEST(MujocoScene, RejectsBadObjectsAndPlacements) {
  EXPECT_THROW(MujocoHumanoidSim(1, 1, humanoid_description(), {test_box(Vec3(0.2, -0.1, 0.5))}), Error);
  BoxObject spaced = test_box();
  spaced.name = "a box";
  EXPECT_THROW(MujocoHumanoidSim(1, 1, humanoid_description(), {spaced}), Error);
  MujocoHumanoidSim sim(2, 1, humanoid_description(), {test_box()});
  RigidState s;
  s.pos = Vec3(1, 0, 0.6);
  EXPECT_THROW(sim.place_object(0, 1, s), Error);  // no object 1
  EXPECT_THROW(sim.place_object(2, 0, s), Error);  // no env 2
  RigidState bad = s;
  bad.pos.x() = NAN;
  EXPECT_THROW(sim.place_object(0, 0, bad), Error);
  bad = s;
  bad.rot = Quat(2, 0, 0, 0);
  EXPECT_THROW(sim.place_object(0, 0, bad), Error);
  EXPECT_EQ(MujocoHumanoidSim(1).num_objects(), 0u);
}
