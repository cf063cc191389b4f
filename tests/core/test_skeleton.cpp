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
  s.set_xyz_hinges(Matrix3X::Constant(3, 3, -3.0), Matrix3X::Constant(3, 3, 3.0));
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

namespace {
// Every body's linear and angular velocity from forward_kinematics against central differences of
// its positions and orientations, the state advanced by ±h along its own velocities (root twist
// and joint rates).
void expect_velocities_match_finite_differences(const Skeleton& s, const KinematicState& st) {
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
  for (int i = 0; i < s.num_bodies(); ++i) {
    const Vec3 v_fd = (bp.pos.col(i) - bm.pos.col(i)) / (2 * h);
    EXPECT_LT((v_fd - b0.lin_vel.col(i)).norm(), 1e-6) << "body " << i;
    const Eigen::AngleAxisd aa(bp.rot[i] * bm.rot[i].conjugate());
    EXPECT_LT((aa.axis() * aa.angle() / (2 * h) - b0.ang_vel.col(i)).norm(), 1e-5) << "body " << i;
  }
}
}  // namespace

TEST(Skeleton, VelocitiesMatchFiniteDifferences) {
  const Skeleton s = chain();
  Rng r(11);
  KinematicState st = KinematicState::zero(s);
  st.root_pos = Vec3(r.normal(), r.normal(), r.normal());
  st.root_rot = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  for (int k = 0; k < 6; ++k) st.q[k] = r.uniform(-1, 1), st.qd[k] = r.uniform(-1, 1);
  st.root_lin_vel = Vec3(0.3, -0.2, 0.1);
  st.root_ang_vel = Vec3(0.5, 0.1, -0.4);
  expect_velocities_match_finite_differences(s, st);
}

TEST(Skeleton, ValidateRejectsBadTopology) {
  Skeleton s = chain();
  s.parents[1] = 2;
  EXPECT_THROW(s.validate(), Error);
}

namespace {
// A 5-body tree with 1, 2, 3 and 1 hinges of random unit axes: root → a → b → c, root → d.
Skeleton mixed(Rng& r) {
  Skeleton s;
  s.names = {"root", "a", "b", "c", "d"};
  s.parents = {-1, 0, 1, 2, 0};
  s.offsets.resize(3, 5);
  for (int i = 0; i < 5; ++i) s.offsets.col(i) = i == 0 ? Vec3::Zero() : Vec3(r.normal(0, 0.3), r.normal(0, 0.3), r.normal(0, 0.3));
  s.parts.assign(5, BodyPart::Trunk);
  auto axis = [&] { return Vec3(r.normal(), r.normal(), r.normal()).normalized(); };
  const int hinges[5] = {0, 1, 2, 3, 1};
  for (int i = 1; i < 5; ++i)
    for (int h = 0; h < hinges[i]; ++h) s.add_hinge(i, axis(), -2.0, 2.0 + h);
  s.validate();
  return s;
}

Mat3 rodrigues(const Vec3& u, double a) {  // R(u, a) = I + sin a [u]× + (1 − cos a) [u]×²
  Mat3 K;
  K << 0, -u.z(), u.y(), u.z(), 0, -u.x(), -u.y(), u.x(), 0;
  return Mat3::Identity() + std::sin(a) * K + (1 - std::cos(a)) * K * K;
}
}  // namespace

TEST(Skeleton, HingeLayoutIsIndexedPerBodyAndPerDof) {
  Rng r(3);
  const Skeleton s = mixed(r);
  EXPECT_EQ(s.num_dofs(), 7);
  const int first[5] = {0, 0, 1, 3, 6}, count[5] = {0, 1, 2, 3, 1};
  for (int i = 0; i < 5; ++i) {
    if (i > 0) {
      EXPECT_EQ(s.dof_offset(i), first[i]) << i;
    }
    EXPECT_EQ(s.num_dofs_of(i), count[i]) << i;
    for (int k = s.dof_offset(i); i > 0 && k < s.dof_offset(i) + s.num_dofs_of(i); ++k) EXPECT_EQ(s.dof_body(k), i);
  }
  EXPECT_EQ(s.lower_limits().size(), 7);
  EXPECT_DOUBLE_EQ(s.dof_upper(5), 4.0);  // c's third hinge
  EXPECT_FALSE(s.has_xyz_hinges(3));
  const Skeleton c = chain();
  EXPECT_EQ(c.num_dofs(), 6);
  EXPECT_EQ(c.dof_offset(2), 3);
  EXPECT_TRUE(c.has_xyz_layout());
  EXPECT_EQ(c.dof_axis(4), Vec3::UnitY());
}

TEST(Skeleton, ForwardKinematicsComposesHingesInOrder) {
  // R_world(i) = R_world(parent) · R(axis_1, q_1) · R(axis_2, q_2) · …, checked against
  // Rodrigues' formula; positions against p_parent + R_parent · offset.
  Rng r(4);
  const Skeleton s = mixed(r);
  KinematicState st = KinematicState::zero(s);
  st.root_pos = Vec3(0.1, -0.2, 0.9);
  st.root_rot = Quat(Eigen::AngleAxisd(0.4, Vec3(1, -1, 2).normalized()));
  for (int k = 0; k < s.num_dofs(); ++k) st.q[k] = r.uniform(-2, 2);
  const BodyStates b = forward_kinematics(s, st);
  std::vector<Mat3> R(5);
  std::vector<Vec3> p(5);
  R[0] = st.root_rot.toRotationMatrix();
  p[0] = st.root_pos;
  for (int i = 1; i < 5; ++i) {
    const int par = s.parents[static_cast<std::size_t>(i)];
    Mat3 L = Mat3::Identity();
    for (int k = s.dof_offset(i); k < s.dof_offset(i) + s.num_dofs_of(i); ++k) L = L * rodrigues(s.dof_axis(k), st.q[k]);
    R[static_cast<std::size_t>(i)] = R[static_cast<std::size_t>(par)] * L;
    p[static_cast<std::size_t>(i)] = p[static_cast<std::size_t>(par)] + R[static_cast<std::size_t>(par)] * s.offsets.col(i);
    EXPECT_LT((b.rot[static_cast<std::size_t>(i)].toRotationMatrix() - R[static_cast<std::size_t>(i)]).norm(), 1e-12) << i;
    EXPECT_LT((b.pos.col(i) - p[static_cast<std::size_t>(i)]).norm(), 1e-12) << i;
    EXPECT_LT((joint_rotation(s, i, st.q).toRotationMatrix() - L).norm(), 1e-12) << i;
  }
  // Reversing the order of c's three hinges changes the result (the order matters).
  Skeleton swapped = s;
  swapped.clear_hinges();
  for (int i = 1; i < 5; ++i) {
    const int k0 = s.dof_offset(i), n = s.num_dofs_of(i);
    for (int h = 0; h < n; ++h) {
      const int k = i == 3 ? k0 + n - 1 - h : k0 + h;
      swapped.add_hinge(i, s.dof_axis(k), s.dof_lower(k), s.dof_upper(k));
    }
  }
  KinematicState st2 = st;
  for (int h = 0; h < 3; ++h) st2.q[3 + h] = st.q[5 - h];
  EXPECT_GT(forward_kinematics(swapped, st2).rot[3].angularDistance(b.rot[3]), 1e-3);
}

TEST(Skeleton, XyzJointRotationIsTheGenericOne) {
  Rng r(6);
  const Skeleton s = chain();
  for (int i = 0; i < 100; ++i) {
    VectorXd q(6);
    for (int k = 0; k < 6; ++k) q[k] = r.uniform(-3, 3);
    for (int b = 1; b < 3; ++b)
      EXPECT_EQ(joint_rotation(s, b, q).coeffs(), joint_rotation(q.segment<3>(s.dof_offset(b))).coeffs());
  }
}

TEST(Skeleton, GenericVelocitiesMatchFiniteDifferences) {
  Rng r(12);
  const Skeleton s = mixed(r);
  KinematicState st = KinematicState::zero(s);
  st.root_pos = Vec3(r.normal(), r.normal(), r.normal());
  st.root_rot = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  for (int k = 0; k < s.num_dofs(); ++k) st.q[k] = r.uniform(-1.5, 1.5), st.qd[k] = r.uniform(-2, 2);
  st.root_lin_vel = Vec3(0.3, -0.2, 0.1);
  st.root_ang_vel = Vec3(0.5, 0.1, -0.4);
  expect_velocities_match_finite_differences(s, st);
  const BodyStates b0 = forward_kinematics(s, st);
  // No allocation when `out` is sized: the buffers stay where they are.
  BodyStates out = b0;
  const double* pos = out.pos.data();
  forward_kinematics(s, st, out);
  EXPECT_EQ(out.pos.data(), pos);
}

TEST(Skeleton, ValidateChecksTheHinges) {
  Rng r(8);
  auto message = [](const Skeleton& s) {
    try {
      s.validate();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  auto rebuilt = [&](auto edit) {  // `mixed` with its hinges re-added through edit(body, hinge, axis, lo, hi)
    Rng r2(8);
    Skeleton s = mixed(r2), t = s;
    t.clear_hinges();
    for (int k = 0; k < s.num_dofs(); ++k) {
      Vec3 axis = s.dof_axis(k);
      double lo = s.dof_lower(k), hi = s.dof_upper(k);
      if (edit(s.dof_body(k), k - s.dof_offset(s.dof_body(k)), axis, lo, hi)) t.add_hinge(s.dof_body(k), axis, lo, hi);
    }
    return t;
  };
  EXPECT_EQ(message(rebuilt([](int, int, Vec3&, double&, double&) { return true; })), "");
  EXPECT_NE(message(rebuilt([](int b, int h, Vec3& a, double&, double&) {
              if (b == 2 && h == 1) a *= 1.01;
              return true;
            })).find("unit axis"), std::string::npos);
  EXPECT_NE(message(rebuilt([](int b, int, Vec3&, double& lo, double& hi) {
              if (b == 4) std::swap(lo, hi);
              return true;
            })).find("'d'"), std::string::npos);
  const std::string none = message(rebuilt([](int b, int, Vec3&, double&, double&) { return b != 1; }));
  EXPECT_NE(none.find("'a' has 0 hinges"), std::string::npos) << none;
  Skeleton four = mixed(r);
  four.clear_hinges();
  for (int i = 1; i < 5; ++i)
    for (int h = 0; h < (i == 3 ? 4 : 1); ++h) four.add_hinge(i, Vec3::UnitX(), -1, 1);
  EXPECT_NE(message(four).find("'c' has 4 hinges"), std::string::npos);
  // Hinges go in body order; the root has none.
  Skeleton s = chain();
  EXPECT_THROW(s.add_hinge(1, Vec3::UnitX(), -1, 1), Error);
  EXPECT_THROW(s.add_hinge(0, Vec3::UnitX(), -1, 1), Error);
  try {
    chain().require_xyz_hinges(0, "a test");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("a test needs three hinges about x, y, z on body 'root'"), std::string::npos);
  }
}
