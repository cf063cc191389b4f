// Retargeting: the humanoid onto itself is the identity (via BVH in both axis conventions and via
// AMASS parameters); the shared CMU walk has plausible height, steps and little foot skating.
#include <maskadapt/motion/quality.hpp>
#include <maskadapt/humanoid/retarget.hpp>
#include <maskadapt/humanoid/synthetic.hpp>

#include <gtest/gtest.h>
#include <xtensor/xbuilder.hpp>

#include <filesystem>

#include "test_util.hpp"

using namespace maskadapt;

namespace {

/// A humanoid clip with non-trivial roots and joints (the synthetic walk, turned and lifted).
MotionClip test_clip() {
  MotionClip c = synthetic_walk();
  for (int t = 0; t < c.num_frames(); ++t) {
    c.set_rot(t, Quat(Eigen::AngleAxisd(0.7 + 0.02 * t, Vec3::UnitZ())) * c.rot(t));
    c.root_pos.col(t) += Vec3(1.0, -2.0, 0.0);
  }
  return c;
}

void expect_same_clip(const MotionClip& a, const MotionClip& b, double tol) {
  ASSERT_EQ(a.num_frames(), b.num_frames());
  EXPECT_LT((a.q - b.q).cwiseAbs().maxCoeff(), tol);
  EXPECT_LT((a.root_pos - b.root_pos).cwiseAbs().maxCoeff(), tol);
  for (int t = 0; t < a.num_frames(); ++t) EXPECT_LT(a.rot(t).angularDistance(b.rot(t)), tol) << t;
}

}  // namespace

TEST(Retarget, HumanoidBvhOntoItselfIsIdentity) {
  const MotionClip c = test_clip();
  RetargetOptions opt;
  opt.ground = false;
  opt.scale_root = false;
  for (bool y_up : {true, false}) {
    SCOPED_TRACE(y_up ? "Y-up export" : "Z-up export");
    const bvh::Motion m = bvh::parse(bvh::to_string(clip_to_bvh(c, humanoid_skeleton(), y_up), 12));
    RetargetReport rep;
    const MotionClip back = retarget_bvh(m, humanoid_joint_map(y_up ? 'y' : 'z'), opt, &rep);
    expect_same_clip(c, back, 1e-6);
    EXPECT_EQ(rep.clamped_fraction, 0.0);
    EXPECT_TRUE(rep.unmapped.empty());
    EXPECT_NEAR(rep.root_scale, 1.0, 1e-12);
  }
}

TEST(Retarget, AmassOfTheHumanoidIsIdentity) {
  // SMPL parameters generated from a humanoid clip: local rotations in SMPL axes, z-up world.
  const MotionClip c = test_clip();
  const Mat3 C = detail::y_up_to_z_up();
  const Quat Cq(C);
  npz::AmassMotion a;
  a.fps = c.fps;
  const auto T = static_cast<std::size_t>(c.num_frames());
  a.poses = xt::zeros<double>({T, std::size_t{66}});  // (frames × 3·joints)
  a.trans = Tensor<double, 2>::from_shape({T, 3});    // (frames × 3)
  auto set_row = [](Tensor<double, 2>& x, int t, int col, const Vec3& v) {
    for (int k = 0; k < 3; ++k) x(static_cast<std::size_t>(t), static_cast<std::size_t>(col + k)) = v(k);
  };
  for (int t = 0; t < c.num_frames(); ++t) {
    set_row(a.trans, t, 0, c.root_pos.col(t));
    set_row(a.poses, t, 0, quat_log(c.rot(t) * Cq));
    for (int b = 1; b < 22; ++b) {
      const Quat L = joint_rotation(c.q.col(t).segment<3>(humanoid_skeleton().dof_offset(b)));
      set_row(a.poses, t, 3 * b, quat_log(Cq.conjugate() * L * Cq));
    }
  }
  RetargetOptions opt;
  opt.ground = false;
  expect_same_clip(c, retarget_amass(a, 'z', opt), 1e-6);
}

TEST(Retarget, ResamplesToThirtyHertzWithSlerp) {
  // 120 Hz humanoid BVH → 30 Hz clip keeps every fourth frame exactly
  MotionClip c = test_clip();
  c.fps = 120.0;
  RetargetOptions opt;
  opt.ground = false;
  opt.scale_root = false;
  const MotionClip back = retarget_bvh(clip_to_bvh(c), humanoid_joint_map('y'), opt);
  ASSERT_EQ(back.num_frames(), (c.num_frames() - 1) / 4 + 1);
  for (int k = 0; k < back.num_frames(); ++k)
    EXPECT_LT((back.q.col(k) - c.q.col(4 * k)).cwiseAbs().maxCoeff(), 1e-6) << k;
}

TEST(Retarget, JointMapFromJson) {
  const auto j = nlohmann::json::parse(
      R"({"name": "mine", "unit_scale": 0.01, "up_axis": "z", "calibration_frame": -1,
          "joints": {"Pelvis": "Hips", "L_Hip": "LeftUpLeg"}, "tips": {"L_Toe": "LeftToe_End"}})");
  const JointMap m = joint_map_from_json(j);
  EXPECT_EQ(m.name, "mine");
  EXPECT_EQ(m.unit_scale, 0.01);
  EXPECT_EQ(m.up_axis, 'z');
  EXPECT_EQ(m.calibration_frame, -1);
  ASSERT_EQ(m.joints.size(), 2u);
  EXPECT_EQ(m.tips.at("L_Toe"), "LeftToe_End");
  EXPECT_THROW(joint_map_from_json(nlohmann::json::parse(R"({"joints": 3})")), Error);
  EXPECT_THROW(joint_map_from_json(nlohmann::json::parse(R"({"up_axis": "x", "joints": {}})")), Error);
  // a map naming a joint the file lacks is reported with the body it was for
  const bvh::Motion m2 = clip_to_bvh(test_clip());
  try {
    retarget_bvh(m2, m);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "L_Hip");  // JSON objects iterate in key order: L_Hip first
    EXPECT_NE(std::string(e.what()).find("'LeftUpLeg', which the file lacks"), std::string::npos) << e.what();
  }
}

TEST(Retarget, CmuWalkIsPlausible) {
  MASKADAPT_REQUIRE_CMU(dir);
  for (const char* f : {"02_01_walk.bvh", "07_01_walk.bvh"}) {
    SCOPED_TRACE(f);
    RetargetReport rep;
    const MotionClip c = import_motion(dir + "/" + f, {}, &rep);
    EXPECT_EQ(c.fps, 30.0);
    EXPECT_NEAR(rep.source_fps, 120.0, 0.01);  // Frame Time .0083333
    // frame 0 (T-pose) dropped: (source frames − 2) / 4 + 1 frames at 30 Hz
    EXPECT_EQ(c.num_frames(), (rep.source_frames - 2) / 4 + 1);
    const QualityReport q = motion_quality(c, humanoid_description());
    EXPECT_GT(q.root_height_mean, 0.85);
    EXPECT_LT(q.root_height_mean, 1.0);
    const double speed = q.travel / q.duration;  // CMU walks: one pass across the room
    EXPECT_GT(speed, 0.8);
    EXPECT_LT(speed, 1.8);
    // step length: the largest horizontal distance between the ankles
    double step = 0;
    for (int t = 0; t < c.num_frames(); ++t) {
      const BodyStates b = forward_kinematics(humanoid_skeleton(), c.frame(t));
      step = std::max(step, (b.pos.col(hb::LAnkle) - b.pos.col(hb::RAnkle)).head<2>().norm());
    }
    EXPECT_GT(step, 0.45);
    EXPECT_LT(step, 0.95);
    EXPECT_LT(q.foot_skating, 0.35);  // m/s, mean horizontal speed of feet in contact (raw CMU data)
    EXPECT_LT(q.penetration_max, 0.005);  // grounded at the 2 % quantile: at most a few mm below
    EXPECT_EQ(q.limit_violation_fraction, 0.0);
  }
}

TEST(Retarget, EverySharedClipImports) {
  MASKADAPT_REQUIRE_CMU(dir);
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().extension() != ".bvh") continue;
    SCOPED_TRACE(e.path().filename().string());
    RetargetReport rep;
    const MotionClip c = import_motion(e.path().string(), {}, &rep);
    c.validate(humanoid_skeleton());
    const double h = c.root_pos.row(2).mean();
    EXPECT_GT(h, 0.6);
    EXPECT_LT(h, 1.2);
    // 30 Hz frames cover the source (frame 0 dropped) up to its last whole 1/30 s
    const double source_duration = (rep.source_frames - 2) / rep.source_fps;
    EXPECT_LE(c.duration(), source_duration + 1e-3 / 30);
    EXPECT_GT(c.duration(), source_duration - 1.0 / 30);
  }
}

TEST(Quality, SyntheticClipsAreClean) {
  for (const char* n : {"walk", "arms", "kick", "jump"}) {
    SCOPED_TRACE(n);
    const MotionClip c = synthetic_clip(n);
    const QualityReport q = motion_quality(c, humanoid_description());
    EXPECT_LT(q.foot_skating, 0.12);
    EXPECT_LT(q.penetration_max, 1e-9);
    EXPECT_EQ(q.limit_violation_fraction, 0.0);
    EXPECT_EQ(q.self_collision_fraction, 0.0);
    EXPECT_GT(q.contact_fraction, 0.3);
  }
}

TEST(Quality, DetectsPenetrationViolationsAndSelfCollision) {
  MotionClip c = synthetic_arm_circles();
  c.root_pos.row(2).array() -= 0.05;  // sink 5 cm
  c.q(humanoid_skeleton().dof_offset(hb::LKnee) + 1, 0) = 3.0;  // beyond the knee limit (2.7)
  // frame 1: left arm folded through the chest
  c.q.col(1).segment<3>(humanoid_skeleton().dof_offset(hb::LShoulder)) = Vec3(0, 0, -2.5);
  c.q.col(1).segment<3>(humanoid_skeleton().dof_offset(hb::LElbow)) = Vec3(0, 0, -2.8);
  const QualityReport q = motion_quality(c, humanoid_description());
  EXPECT_NEAR(q.penetration_max, 0.05, 1e-6);
  EXPECT_NEAR(q.limit_violation_max, 0.3, 1e-9);
  EXPECT_GT(q.self_collision_fraction, 0.0);
  EXPECT_LE(q.self_collision_fraction, 2.0 / c.num_frames());
}

TEST(Geometry, SegmentDistanceClosedForms) {
  using geometry::segment_distance;
  EXPECT_NEAR(segment_distance({0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, 1, 1}), 1.0, 1e-12);  // skew
  EXPECT_NEAR(segment_distance({0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}), 1.0, 1e-12);      // collinear gap
  EXPECT_NEAR(segment_distance({0, 0, 0}, {1, 0, 0}, {0, 2, 0}, {1, 2, 0}), 2.0, 1e-12);      // parallel
  EXPECT_NEAR(segment_distance({0, 0, 0}, {0, 0, 0}, {-1, 1, 0}, {1, 1, 0}), 1.0, 1e-12);     // point
  EXPECT_NEAR(segment_distance({0, -1, 0}, {0, 1, 0}, {-1, 0, 0}, {1, 0, 0}), 0.0, 1e-12);    // crossing
}
