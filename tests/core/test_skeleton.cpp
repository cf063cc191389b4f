#include <maskadapt/core/rng.hpp>
#include <maskadapt/motion/skeleton.hpp>

#include <gtest/gtest.h>

using namespace maskadapt;

namespace {
// A 3-body chain: root → a (0.5 m along x) → b (0.3 m along z of a).
Skeleton chain() {
  Skeleton s;
  s.names = {"root", "a", "b"};
  s.parents = {-1, 0, 1};
  s.offsets.resize(3, 3);
  s.offsets << 0, 0.5, 0, 0, 0, 0, 0, 0, 0.3;
  s.parts = {BodyPart::Trunk, BodyPart::LeftArm, BodyPart::LeftArm};
  s.joint_lower = Matrix3X::Constant(3, 3, -3.0);
  s.joint_upper = Matrix3X::Constant(3, 3, 3.0);
  s.validate();
  return s;
}
}  // namespace

TEST(Skeleton, JointAnglesRoundTrip) {
  Rng r(5);
  for (int i = 0; i < 1000; ++i) {
    const Vec3 a(r.uniform(-3, 3), r.uniform(-1.5, 1.5), r.uniform(-3, 3));
    const Vec3 b = joint_angles_from_rotation(joint_rotation(a));
    ASSERT_LT((joint_rotation(b).toRotationMatrix() - joint_rotation(a).toRotationMatrix()).norm(), 1e-9);
    ASSERT_LT((a - b).norm(), 1e-7);
  }
}

TEST(Skeleton, ForwardKinematicsClosedForm) {
  const Skeleton s = chain();
  KinematicState st = KinematicState::zero(s);
  st.root_pos = Vec3(1, 2, 3);
  st.q[2] = M_PI / 2;  // joint a: rotate about z by 90°
  const BodyStates b = forward_kinematics(s, st);
  EXPECT_LT((b.pos.col(1) - Vec3(1.5, 2, 3)).norm(), 1e-12);
  // b's offset (0, 0, 0.3) is along z, unaffected by a z-rotation of a.
  EXPECT_LT((b.pos.col(2) - Vec3(1.5, 2, 3.3)).norm(), 1e-12);
  st.q[2] = 0;
  st.q[1] = M_PI / 2;  // joint a: rotate about y by 90°: a's z axis → world x
  const BodyStates c = forward_kinematics(s, st);
  EXPECT_LT((c.pos.col(2) - Vec3(1.8, 2, 3)).norm(), 1e-12);
}

TEST(Skeleton, VelocitiesMatchFiniteDifferences) {
  const Skeleton s = chain();
  Rng r(11);
  KinematicState st = KinematicState::zero(s);
  st.root_pos = Vec3(r.normal(), r.normal(), r.normal());
  st.root_rot = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  for (int k = 0; k < 6; ++k) st.q[k] = r.uniform(-1, 1), st.qd[k] = r.uniform(-1, 1);
  st.root_lin_vel = Vec3(0.3, -0.2, 0.1);
  st.root_ang_vel = Vec3(0.5, 0.1, -0.4);
  const double h = 1e-6;
  auto advance = [&](double dt) {
    KinematicState t = st;
    t.root_pos += dt * st.root_lin_vel;
    const Vec3 w = st.root_ang_vel * dt;
    t.root_rot = Quat(Eigen::AngleAxisd(w.norm(), w.normalized())) * st.root_rot;
    t.q += dt * st.qd;
    return forward_kinematics(s, t);
  };
  const BodyStates b0 = forward_kinematics(s, st), bp = advance(h), bm = advance(-h);
  for (int i = 0; i < 3; ++i) {
    const Vec3 v_fd = (bp.pos.col(i) - bm.pos.col(i)) / (2 * h);
    EXPECT_LT((v_fd - b0.lin_vel.col(i)).norm(), 1e-6) << "body " << i;
    const Quat dq = bp.rot[i] * bm.rot[i].conjugate();
    const Eigen::AngleAxisd aa(dq);
    const Vec3 w_fd = aa.axis() * aa.angle() / (2 * h);
    EXPECT_LT((w_fd - b0.ang_vel.col(i)).norm(), 1e-5) << "body " << i;
  }
}

TEST(Skeleton, ValidateRejectsBadTopology) {
  Skeleton s = chain();
  s.parents[1] = 2;
  EXPECT_THROW(s.validate(), Error);
}
