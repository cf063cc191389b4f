// Retargeting reference-humanoid clips onto the G1 (g1/retarget.hpp, g1/retarget_quality.hpp):
// the box-constrained IK (Jacobian, reachable targets, limits), a standing pose, a shared walk,
// bad input, the G1 clip file. No MuJoCo needed.
#include <maskadapt/g1/retarget_quality.hpp>
#include <maskadapt/humanoid/retarget.hpp>

#include "../build_paths.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <random>

using namespace maskadapt;
using namespace maskadapt::g1;

namespace {

const IkModel& rt_model() {
  static const IkModel m = make_ik_model(g1_description());
  return m;
}

/// A random pose: nominal ± `spread` rad per joint, clamped to the limits.
VectorXd rt_random_pose(std::mt19937_64& rng, double spread) {
  const IkModel& m = rt_model();
  std::uniform_real_distribution<double> u(-spread, spread);
  VectorXd q(kNumJoints);
  for (int j = 0; j < kNumJoints; ++j) q[j] = std::clamp(m.nominal[j] + u(rng), m.lower[j], m.upper[j]);
  return q;
}

Quat rt_random_rot(std::mt19937_64& rng, double max_angle) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> a(-max_angle, max_angle);
  return Quat(Eigen::AngleAxisd(a(rng), Vec3(n(rng), n(rng), n(rng)).normalized()));
}

/// Targets that the G1 reaches exactly: its own features at pose q.
IkTargets rt_targets_of(const VectorXd& q, const Vec3& root, const Quat& rot) {
  IkTargets tg;
  tg.root_pos = root;
  tg.root_rot = rot;
  g1_features(rt_model(), forward_kinematics(g1_description(), root, rot, q), tg.pos, tg.dir);
  return tg;
}

std::string rt_motions_dir(const std::string& sub) {
  std::string base;
  if (const char* e = std::getenv("MASKADAPT_DATA_DIR"); e && *e) base = e;
  if (base.empty()) base = maskadapt::build_paths::default_data_dir();
  const auto dir = std::filesystem::path(base) / "motions" / sub;
  return !base.empty() && std::filesystem::is_directory(dir) ? dir.string() : std::string();
}

/// The humanoid standing with the arms down (shoulder roll ∓1.3 rad), `frames` identical frames.
MotionClip rt_standing_clip(int frames) {
  MotionClip c;
  c.name = "standing";
  c.resize(frames, humanoid_skeleton().num_dofs());
  KinematicState s = humanoid_standing_pose();
  s.q[humanoid_skeleton().dof_offset(hb::LShoulder)] = -1.3;
  s.q[humanoid_skeleton().dof_offset(hb::RShoulder)] = 1.3;
  for (int t = 0; t < frames; ++t) c.set_frame(t, s);
  return c;
}

}  // namespace

TEST(G1Retarget, JacobianMatchesFiniteDifferences) {
  const IkModel& m = rt_model();
  std::mt19937_64 rng(7);
  const VectorXd q = rt_random_pose(rng, 0.8), q_prev = rt_random_pose(rng, 0.8);
  IkTargets tg = rt_targets_of(rt_random_pose(rng, 0.8), Vec3(0.3, -0.2, 0.75), rt_random_rot(rng, 0.5));
  tg.root_rot = rt_random_rot(rng, 0.5);
  const IkWeights w;
  VectorXd r, rp, rm;
  MatrixXd J;
  maskadapt::g1::detail::ik_residual(m, tg, w, q, &q_prev, r, &J);
  double worst = 0;
  for (int j = 0; j < kNumJoints; ++j) {
    VectorXd a = q, b = q;
    a[j] += 1e-6;
    b[j] -= 1e-6;
    maskadapt::g1::detail::ik_residual(m, tg, w, a, &q_prev, rp, nullptr);
    maskadapt::g1::detail::ik_residual(m, tg, w, b, &q_prev, rm, nullptr);
    worst = std::max(worst, ((rp - rm) / 2e-6 - J.col(j)).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-6);
}

TEST(G1Retarget, IkReachesReachableTargets) {
  // 100 random poses within the limits (nominal ± 0.6 rad per joint, clamped), random root
  // orientation; IK from the nominal pose with the default weights (the small pulls towards the
  // nominal pose stay in the cost) recovers every end-effector to 1 mm.
  const IkModel& m = rt_model();
  std::mt19937_64 rng(2024);
  double worst = 0, worst_dir = 0;
  for (int trial = 0; trial < 100; ++trial) {
    const VectorXd q = rt_random_pose(rng, 0.6);
    const IkTargets tg = rt_targets_of(q, Vec3(0.1, -0.3, 0.78), rt_random_rot(rng, 0.4));
    const IkResult r = solve_ik(m, tg, IkWeights{}, m.nominal);
    std::array<Vec3, kNumEffectors> pos;
    std::array<Vec3, kNumDirections> dir;
    g1_features(m, forward_kinematics(g1_description(), tg.root_pos, tg.root_rot, r.q), pos, dir);
    for (int e = 0; e < kNumEffectors; ++e) worst = std::max(worst, (pos[e] - tg.pos[e]).norm());
    for (int k = 0; k < kNumDirections; ++k) worst_dir = std::max(worst_dir, (dir[k] - tg.dir[k]).norm());
    EXPECT_TRUE(r.converged) << "trial " << trial;
  }
  EXPECT_LT(worst, 1e-3) << "worst end-effector error (m)";
  EXPECT_LT(worst_dir, 1e-2) << "worst direction error";
}

TEST(G1Retarget, LimitsHoldForUnreachableTargets) {
  const IkModel& m = rt_model();
  std::mt19937_64 rng(99);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    IkTargets tg;
    tg.root_pos = Vec3(0, 0, 0.8);
    tg.root_rot = rt_random_rot(rng, 3.0);
    for (auto& p : tg.pos) p = 5.0 * Vec3(n(rng), n(rng), n(rng));  // metres away: out of reach
    for (auto& d : tg.dir) d = Vec3(n(rng), n(rng), n(rng)).normalized();
    const IkResult r = solve_ik(m, tg, IkWeights{}, rt_random_pose(rng, 3.0));
    ASSERT_TRUE(r.q.allFinite());
    for (int j = 0; j < kNumJoints; ++j) {
      EXPECT_GE(r.q[j], m.lower[j]) << "joint " << j;
      EXPECT_LE(r.q[j], m.upper[j]) << "joint " << j;
    }
  }
  // A whole clip of random humanoid poses (uniform within the humanoid's limits, wild root
  // orientations): zero violations in the G1 clip.
  const Skeleton& s = humanoid_skeleton();
  MotionClip c;
  c.name = "random";
  c.resize(40, s.num_dofs());
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int t = 0; t < c.num_frames(); ++t) {
    for (int b = 1; b < s.num_bodies(); ++b)
      for (int k = 0; k < 3; ++k)
        c.q(s.dof_offset(b) + k, t) = s.dof_lower(s.dof_offset(b) + k) + u(rng) * (s.dof_upper(s.dof_offset(b) + k) - s.dof_lower(s.dof_offset(b) + k));
    c.root_pos.col(t) = Vec3(0.1 * t, 0, 0.9);
    c.set_rot(t, rt_random_rot(rng, 3.0));
  }
  const G1Clip g = retarget_to_g1(c);
  double excess = 0;
  EXPECT_EQ(g1_limit_violations(g, g1_description(), &excess), 0);
  EXPECT_EQ(excess, 0.0);
  EXPECT_GE(g1_lowest_point(g1_description(), g.poses(g1_description(), 0)), -1e-9);  // grounded: no penetration
}

TEST(G1Retarget, StandingHumanoidGivesStandingG1) {
  const G1Description& d = g1_description();
  const MotionClip c = rt_standing_clip(10);
  G1RetargetReport rep;
  const G1Clip g = retarget_to_g1(c, {}, &rep);
  ASSERT_EQ(g.num_frames(), 10);
  EXPECT_NEAR(rep.root_scale, 0.837951, 1e-6);      // 0.791864 / 0.945
  EXPECT_NEAR(rep.effector_scale, 0.753777, 1e-6);  // 1.3199 / 1.7510
  for (int t = 0; t < g.num_frames(); ++t) {
    const LinkPoses p = g.poses(d, t);
    for (const char* foot : {"left_ankle_roll_link", "right_ankle_roll_link"}) {
      const int f = d.link_index(foot);
      EXPECT_NEAR(g1_lowest_point(d, p, f), 0.0, 1e-3) << foot;          // on the ground
      EXPECT_GT((p.rot[static_cast<std::size_t>(f)] * Vec3::UnitZ()).z(), 0.995) << foot;  // flat
    }
    for (int knee : {3, 9}) {
      EXPECT_GE(g.q(knee, t), -0.0873);
      EXPECT_LT(g.q(knee, t), 0.25) << "knee " << knee << " nearly straight";
    }
    EXPECT_LT(std::abs(g.q(14, t)), 0.05) << "waist pitch: trunk upright";
    EXPECT_NEAR(g.root_pos(2, t), d.nominal_root_height, 0.02);
    // hands below the shoulders, beside the thighs
    EXPECT_LT(p.pos[static_cast<std::size_t>(d.link_index("left_wrist_yaw_link"))].z(), 0.75);
  }
  const G1QualityReport q = g1_retarget_quality(g, c);
  EXPECT_EQ(q.limit_violations, 0);
  EXPECT_LT(q.foot_skating, 1e-6);
  EXPECT_LT(q.penetration_max, 1e-9);
  EXPECT_LT(q.effector_error_by[kLeftFoot], 0.005);
  EXPECT_LT(q.effector_error_mean, 0.03);
  EXPECT_NEAR(q.contact_fraction, 1.0, 1e-12);
}

TEST(G1Retarget, SharedWalkClip) {
  const std::string dir = rt_motions_dir("cmu");
  if (dir.empty())
    GTEST_SKIP() << "shared motions/cmu not found (set MASKADAPT_DATA_DIR to the directory holding motions/)";
  const MotionClip c = import_motion(dir + "/02_01_walk.bvh");
  G1RetargetReport rep;
  const G1Clip g = retarget_to_g1(c, {}, &rep);
  ASSERT_EQ(g.num_frames(), c.num_frames());
  EXPECT_NO_THROW(g.validate());
  const G1QualityReport q = g1_retarget_quality(g, c);
  RecordProperty("skating_cm_s", std::to_string(100 * q.foot_skating));
  EXPECT_EQ(q.limit_violations, 0);
  EXPECT_EQ(q.limit_excess_max, 0.0);
  EXPECT_LT(q.penetration_max, 1e-9);
  // Bound: mean horizontal speed of a foot whose lowest point is within 1 cm of the floor
  // ≤ 35 cm/s (measured 28.5 cm/s; the humanoid source skates 26.9 cm/s by motion_quality's
  // 2.5 cm definition: the raw capture's swing toes pass close to the floor).
  EXPECT_LT(q.foot_skating, 0.35) << q.to_string();
  // Planted (level) feet barely slide: ≤ 5 cm/s (measured 3.0 cm/s).
  EXPECT_LT(q.flat_skating, 0.05) << q.to_string();
  EXPECT_GT(q.contact_fraction, 0.3) << "stance feet on the floor";
  EXPECT_LT(q.effector_error_mean, 0.04) << q.to_string();
  EXPECT_LT(q.effector_error_by[kLeftFoot], 0.03);
  // the robot walks as far as the scaled source (3.2 m × 0.838)
  const double travel = (g.root_pos.col(g.num_frames() - 1) - g.root_pos.col(0)).head<2>().norm();
  const double src_travel = (c.root_pos.col(c.num_frames() - 1) - c.root_pos.col(0)).head<2>().norm();
  EXPECT_NEAR(travel, rep.root_scale * src_travel, 1e-9);
}

TEST(G1Retarget, BadInputThrowsClearErrors) {
  auto expect_error = [](const MotionClip& c, const std::string& needle) {
    try {
      (void)retarget_to_g1(c);
      ADD_FAILURE() << "no error for: " << needle;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  MotionClip empty;
  empty.name = "empty";
  empty.resize(0, humanoid_skeleton().num_dofs());
  expect_error(empty, "has no frames");

  MotionClip nan = rt_standing_clip(5);
  nan.q(10, 3) = std::numeric_limits<double>::quiet_NaN();
  expect_error(nan, "frame 3 has a non-finite value in q");
  MotionClip nan_root = rt_standing_clip(5);
  nan_root.root_pos(2, 1) = std::numeric_limits<double>::infinity();
  expect_error(nan_root, "frame 1 has a non-finite value in root_pos");

  MotionClip other;
  other.name = "g1-shaped";
  other.resize(4, 29);  // e.g. G1 angles passed as a humanoid clip
  expect_error(other, "expected a clip on the reference humanoid skeleton (63 joint angles per frame), got 29");

  MotionClip bad_rot = rt_standing_clip(3);
  bad_rot.root_rot.col(2) *= 2.0;
  expect_error(bad_rot, "not unit length");
}

TEST(G1Retarget, ClipFileRoundTrip) {
  const MotionClip c = rt_standing_clip(4);
  G1Clip g = retarget_to_g1(c);
  g.name = "standing_g1";
  const auto path = (std::filesystem::temp_directory_path() / "maskadapt_test_g1clip.npz").string();
  save_g1_clip(path, g);
  const G1Clip back = load_g1_clip(path);
  std::filesystem::remove(path);
  EXPECT_EQ(back.name, g.name);
  EXPECT_EQ(back.fps, g.fps);
  EXPECT_EQ(back.q, g.q);
  EXPECT_EQ(back.root_pos, g.root_pos);
  EXPECT_EQ(back.root_rot, g.root_rot);
  npz::Archive a = g1_clip_to_archive(g);
  a["q"] = npz::matrix(MatrixXd::Zero(4, 28));
  EXPECT_THROW(g1_clip_from_archive(a, "x.npz"), Error);
}
