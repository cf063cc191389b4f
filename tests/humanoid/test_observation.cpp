#include <maskadapt/core/rng.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/humanoid/observation.hpp>

#include <gtest/gtest.h>

using namespace maskadapt;

namespace {
KinematicState random_state(Rng& r) {
  const Skeleton& s = humanoid_skeleton();
  KinematicState st = KinematicState::zero(s);
  st.root_pos = Vec3(r.uniform(-3, 3), r.uniform(-3, 3), r.uniform(0.5, 1.2));
  st.root_rot = Quat(Eigen::AngleAxisd(r.uniform(-3, 3), Vec3::UnitZ())) *
                Quat(Eigen::AngleAxisd(r.uniform(-0.5, 0.5), Vec3(r.normal(), r.normal(), 0).normalized()));
  for (int i = 1; i < s.num_bodies(); ++i)
    for (int k = 0; k < 3; ++k) st.q[s.dof_offset(i) + k] = r.uniform(s.dof_lower(s.dof_offset(i) + k), s.dof_upper(s.dof_offset(i) + k));
  for (Index k = 0; k < st.qd.size(); ++k) st.qd[k] = r.normal(0, 2);
  st.root_lin_vel = Vec3(r.normal(), r.normal(), r.normal());
  st.root_ang_vel = Vec3(r.normal(), r.normal(), r.normal());
  return st;
}
}  // namespace

TEST(Observation, DimensionsAndLayout) {
  const Skeleton& s = humanoid_skeleton();
  EXPECT_EQ(observation_dim(s), kObservationDim);
  const auto L = ObservationLayout::of(s);
  EXPECT_EQ(L.rot6d, 64);
  EXPECT_EQ(L.lin_vel, 196);
  EXPECT_EQ(L.ang_vel, 262);
  EXPECT_EQ(L.dim, 328);
}

TEST(Observation, KnownPoseMatchesHandComputedValues) {
  const Skeleton& s = humanoid_skeleton();
  KinematicState st = KinematicState::zero(s);
  st.root_pos = Vec3(1.0, 2.0, 0.9);
  st.root_rot = Quat(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()));  // facing world +y
  st.q[humanoid_skeleton().dof_offset(hb::LKnee) + 1] = M_PI / 2;               // left knee flexed 90°
  st.root_lin_vel = Vec3(0, 1, 0);                                    // walking forward at 1 m/s
  st.root_ang_vel = Vec3(0, 0, 0.5);                                  // turning left
  const VectorXf obs = compute_observation(s, forward_kinematics(s, st));
  const auto L = ObservationLayout::of(s);
  auto v3 = [&](Index at) { return Vec3(obs.segment<3>(at).cast<double>()); };
  const double tol = 1e-6;
  EXPECT_NEAR(obs[0], 0.9, tol);
  // Heading removed: the hip offset reads as in the zero pose; knee = hip + knee offset;
  // the ankle offset (−0.040, −0.014, −0.387) is turned by R_y(90°): (x, y, z) → (z, y, −x).
  EXPECT_LT((v3(L.rel_pos + 3 * (hb::LHip - 1)) - Vec3(-0.005, 0.069, -0.094)).norm(), tol);
  EXPECT_LT((v3(L.rel_pos + 3 * (hb::LKnee - 1)) - Vec3(-0.010, 0.104, -0.480)).norm(), tol);
  EXPECT_LT((v3(L.rel_pos + 3 * (hb::LAnkle - 1)) - Vec3(-0.397, 0.090, -0.440)).norm(), tol);
  // Root rotation in its own heading frame is the identity; the shank's is R_y(90°).
  EXPECT_LT((v3(L.rot6d) - Vec3(1, 0, 0)).norm(), tol);
  EXPECT_LT((v3(L.rot6d + 3) - Vec3(0, 1, 0)).norm(), tol);
  EXPECT_LT((v3(L.rot6d + 6 * hb::LKnee) - Vec3(0, 0, -1)).norm(), tol);
  EXPECT_LT((v3(L.rot6d + 6 * hb::LKnee + 3) - Vec3(0, 1, 0)).norm(), tol);
  // World +y velocity is forward (+x) in the heading frame; yaw rate stays about z.
  EXPECT_LT((v3(L.lin_vel) - Vec3(1, 0, 0)).norm(), tol);
  EXPECT_LT((v3(L.ang_vel) - Vec3(0, 0, 0.5)).norm(), tol);
  // Head (Trunk, rigidly above the root): v = v_root + ω × r, r = (0.005, 0, 0.611) in heading frame.
  const Vec3 head_v = Vec3(1, 0, 0) + Vec3(0, 0, 0.5).cross(Vec3(0.005, 0.0, 0.611));
  EXPECT_LT((v3(L.lin_vel + 3 * hb::Head) - head_v).norm(), tol);
}

TEST(Observation, InvariantToHeadingAndHorizontalPosition) {
  const Skeleton& s = humanoid_skeleton();
  Rng r(3);
  for (int trial = 0; trial < 20; ++trial) {
    const KinematicState a = random_state(r);
    KinematicState b = a;
    const Quat yaw(Eigen::AngleAxisd(r.uniform(-M_PI, M_PI), Vec3::UnitZ()));
    const Vec3 shift(r.uniform(-10, 10), r.uniform(-10, 10), 0.0);
    b.root_pos = yaw * a.root_pos + shift;
    b.root_rot = yaw * a.root_rot;
    b.root_lin_vel = yaw * a.root_lin_vel;
    b.root_ang_vel = yaw * a.root_ang_vel;
    const VectorXf oa = compute_observation(s, forward_kinematics(s, a));
    const VectorXf ob = compute_observation(s, forward_kinematics(s, b));
    ASSERT_LT((oa - ob).cwiseAbs().maxCoeff(), 1e-5) << "trial " << trial;
    // ...but not to a change of height.
    b.root_pos.z() += 0.1;
    EXPECT_NEAR(compute_observation(s, forward_kinematics(s, b))[0] - oa[0], 0.1, 1e-5);
  }
}

TEST(Observation, ElementsBelongToThePartOfTheBodyTheyDescribe) {
  // Perturbing one body's state changes only elements assigned to that body's part.
  const Skeleton& s = humanoid_skeleton();
  const auto parts = observation_parts(s);
  ASSERT_EQ(parts.size(), 328u);
  Rng r(9);
  const BodyStates base = forward_kinematics(s, random_state(r));
  const VectorXf o0 = compute_observation(s, base);
  std::vector<int> touched(328, 0);
  for (int i = 1; i < s.num_bodies(); ++i) {  // root moves everything; checked separately
    BodyStates b = base;
    b.pos.col(i) += Vec3(0.1, -0.2, 0.3);
    b.rot[i] = Quat(Eigen::AngleAxisd(0.3, Vec3(1, 1, 0).normalized())) * b.rot[i];
    b.lin_vel.col(i) += Vec3(0.5, 0.5, -0.5);
    b.ang_vel.col(i) += Vec3(-0.5, 0.5, 0.5);
    const VectorXf o = compute_observation(s, b);
    int changed = 0;
    for (int j = 0; j < 328; ++j)
      if (o[j] != o0[j]) {
        EXPECT_EQ(parts[j], s.parts[i]) << "element " << j << " moved with body " << s.names[i];
        ++changed, touched[j] = 1;
      }
    EXPECT_EQ(changed, 3 + 6 + 3 + 3) << s.names[i];
  }
  // Remaining elements are the root's: height, rotation, velocities (1 + 6 + 3 + 3), all Trunk.
  int root_elems = 0;
  for (int j = 0; j < 328; ++j)
    if (!touched[j]) {
      ++root_elems;
      EXPECT_EQ(parts[j], BodyPart::Trunk) << j;
    }
  EXPECT_EQ(root_elems, 13);
}

TEST(Observation, DoubleAndFloatAgree) {
  const Skeleton& s = humanoid_skeleton();
  Rng r(4);
  const BodyStates b = forward_kinematics(s, random_state(r));
  VectorXd od(328);
  compute_observation<double>(s, b, od);
  EXPECT_LT((od.cast<float>() - compute_observation(s, b)).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(Observation, RejectsBadInput) {
  const Skeleton& s = humanoid_skeleton();
  BodyStates b = forward_kinematics(s, humanoid_standing_pose());
  VectorXf wrong(327);
  EXPECT_THROW(compute_observation(s, b, wrong), Error);
  b.lin_vel(1, 5) = std::numeric_limits<double>::quiet_NaN();
  try {
    compute_observation(s, b);
    FAIL() << "NaN velocity accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "body_states.lin_vel");
  }
  BodyStates small;
  small.resize(3);
  EXPECT_THROW(compute_observation(s, small), Error);
}
