// The G1-like robot's description: tree, parts, published figures, symmetry, standing pose, and
// the generated MJCF (deterministic, committed copy up to date). No MuJoCo needed.
#include <maskadapt/g1/mjcf.hpp>

#include "../build_paths.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

using namespace maskadapt;
using namespace maskadapt::g1;

namespace {
const G1Description& D() { return g1_description(); }
}  // namespace

TEST(G1Description, TreeJointsAndParts) {
  const G1Description& d = D();
  ASSERT_EQ(d.num_bodies(), kNumBodies);
  ASSERT_EQ(d.num_joints(), 29);  // the 29-DoF variant
  EXPECT_NO_THROW(d.validate());
  // Unitree's motor order.
  const char* joints[kNumJoints] = {
      "left_hip_pitch_joint", "left_hip_roll_joint", "left_hip_yaw_joint", "left_knee_joint",
      "left_ankle_pitch_joint", "left_ankle_roll_joint", "right_hip_pitch_joint", "right_hip_roll_joint",
      "right_hip_yaw_joint", "right_knee_joint", "right_ankle_pitch_joint", "right_ankle_roll_joint",
      "waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint", "left_shoulder_pitch_joint",
      "left_shoulder_roll_joint", "left_shoulder_yaw_joint", "left_elbow_joint", "left_wrist_roll_joint",
      "left_wrist_pitch_joint", "left_wrist_yaw_joint", "right_shoulder_pitch_joint", "right_shoulder_roll_joint",
      "right_shoulder_yaw_joint", "right_elbow_joint", "right_wrist_roll_joint", "right_wrist_pitch_joint",
      "right_wrist_yaw_joint"};
  for (int j = 0; j < kNumJoints; ++j) EXPECT_EQ(d.links[j + 1].joint, joints[j]);
  EXPECT_EQ(d.links[d.link_index("torso_link")].parent, d.link_index("waist_roll_link"));
  EXPECT_EQ(d.links[d.link_index("left_shoulder_pitch_link")].parent, d.link_index("torso_link"));
  EXPECT_EQ(d.links[d.link_index("right_hip_pitch_link")].parent, 0);
  EXPECT_THROW(d.link_index("tail_link"), Error);
  int per_part[kNumParts] = {};
  for (const auto& l : d.links) ++per_part[static_cast<int>(l.part)];
  EXPECT_EQ(per_part[static_cast<int>(BodyPart::Trunk)], 4);  // pelvis, waist yaw/roll, torso
  EXPECT_EQ(per_part[static_cast<int>(BodyPart::LeftLeg)], 6);
  EXPECT_EQ(per_part[static_cast<int>(BodyPart::RightLeg)], 6);
  EXPECT_EQ(per_part[static_cast<int>(BodyPart::LeftArm)], 7);
  EXPECT_EQ(per_part[static_cast<int>(BodyPart::RightArm)], 7);
}

TEST(G1Description, TiltedAxesFromTheUrdfFrames) {
  // The hip roll/yaw axes are tilted by 0.1749 rad about y, the shoulder pitch axes by 0.27931
  // rad about x; everything else is a coordinate axis.
  const G1Description& d = D();
  const Vec3 roll = d.links[d.link_index("left_hip_roll_link")].axis;
  EXPECT_NEAR(roll.x(), std::cos(0.1749), 1e-9);
  EXPECT_NEAR(roll.z(), std::sin(0.1749), 1e-9);
  const Vec3 yaw = d.links[d.link_index("right_hip_yaw_link")].axis;
  EXPECT_NEAR(yaw.x(), -std::sin(0.1749), 1e-9);
  EXPECT_NEAR(yaw.z(), std::cos(0.1749), 1e-9);
  const Vec3 lsp = d.links[d.link_index("left_shoulder_pitch_link")].axis;
  const Vec3 rsp = d.links[d.link_index("right_shoulder_pitch_link")].axis;
  EXPECT_NEAR(lsp.y(), std::cos(0.27931), 1e-9);
  EXPECT_NEAR(lsp.z(), std::sin(0.27931), 1e-9);
  EXPECT_NEAR(rsp.z(), -std::sin(0.27931), 1e-9);
  EXPECT_EQ(d.links[d.link_index("left_knee_link")].axis, Vec3::UnitY());
  EXPECT_EQ(d.links[d.link_index("left_shoulder_roll_link")].axis, Vec3::UnitX());
  // The knee sits almost straight below the hip (URDF offsets through the tilted frames).
  const Vec3 knee = forward_kinematics(d, Vec3::Zero(), Quat::Identity(), VectorXd::Zero(kNumJoints)).pos[4];
  EXPECT_NEAR(knee.x(), 0.0, 1e-3);
}

TEST(G1Description, LeftAndRightMirror) {
  const G1Description& d = D();
  for (int i = 1; i < d.num_bodies(); ++i) {
    const std::string& n = d.links[i].name;
    if (n.rfind("left_", 0) != 0) continue;
    const Link& l = d.links[i];
    const Link& r = d.links[d.link_index("right_" + n.substr(5))];
    EXPECT_NEAR(l.offset.x(), r.offset.x(), 1e-9) << n;
    EXPECT_NEAR(l.offset.y(), -r.offset.y(), 1e-9) << n;
    EXPECT_NEAR(l.offset.z(), r.offset.z(), 1e-9) << n;
    EXPECT_EQ(l.mass(), r.mass()) << n;
    EXPECT_EQ(l.kp, r.kp) << n;
    EXPECT_EQ(l.effort, r.effort) << n;
    // Mirroring y flips the sense of rotations about x and z: roll/yaw ranges mirror.
    const bool flips = std::abs(l.axis.y()) < 0.5;
    EXPECT_EQ(l.lower, flips ? -r.upper : r.lower) << n;
  }
}

TEST(G1Description, PublishedMassAndHeight) {
  const G1Description& d = D();
  std::cout << "total mass " << d.total_mass() << " kg, zero-pose pelvis height " << d.root_height
            << " m, nominal pelvis height " << d.nominal_root_height << " m\n";
  EXPECT_NEAR(d.total_mass(), 35.0, 1.0);  // Unitree: "about 35 kg"
  const auto p0 = forward_kinematics(d, Vec3(0, 0, d.root_height), Quat::Identity(), VectorXd::Zero(kNumJoints));
  EXPECT_NEAR(head_top_height(d, p0), 1.32, 0.005);  // Unitree: standing height 1320 mm
  EXPECT_NEAR(p0.pos[d.link_index("left_ankle_roll_link")].z(), 0.035, 1e-6);  // sole 0.035 m below
  EXPECT_NEAR(d.root_height, 0.793, 0.005);  // the pelvis height of public G1 models' standing keyframe
  // Nominal pose: knees bent, feet flat, trunk upright, soles on the floor.
  const auto pn = forward_kinematics(d, Vec3(0, 0, d.nominal_root_height), Quat::Identity(), d.nominal_q);
  EXPECT_LT(d.nominal_root_height, d.root_height - 0.005);  // knees bent 0.3 rad: 7.7 mm lower
  EXPECT_GT(d.nominal_q[d.link_index("left_knee_link") - 1], 0.1);
  for (const char* foot : {"left_ankle_roll_link", "right_ankle_roll_link"}) {
    EXPECT_NEAR(pn.pos[d.link_index(foot)].z(), 0.035, 1e-6);
    EXPECT_LT(pn.rot[d.link_index(foot)].angularDistance(Quat::Identity()), 1e-12);
  }
  EXPECT_LT(pn.rot[d.head_link].angularDistance(Quat::Identity()), 1e-12);
}

TEST(G1Description, ValidateRejectsBrokenDescriptions) {
  G1Description d = D();
  d.links[3].axis = Vec3(1, 1, 0);
  EXPECT_THROW(d.validate(), Error);
  d = D();
  d.nominal_q[3] = 3.0;  // knee beyond its range
  EXPECT_THROW(d.validate(), Error);
  d = D();
  d.links[5].parent = 7;
  EXPECT_THROW(d.validate(), Error);
  d = D();
  d.links[9].geoms.clear();
  EXPECT_THROW(g1_mjcf(d), Error);
}

TEST(G1Mjcf, DeterministicAndComplete) {
  const std::string a = g1_mjcf(D()), b = g1_mjcf(D());
  EXPECT_EQ(a, b);
  auto count = [&](const std::string& needle) {
    std::size_t n = 0;
    for (std::size_t p = a.find(needle); p != std::string::npos; p = a.find(needle, p + 1)) ++n;
    return n;
  };
  EXPECT_EQ(count("type=\"hinge\""), 29u);
  EXPECT_EQ(count("<general "), 29u);
  EXPECT_EQ(count("type=\"free\""), 1u);
  EXPECT_EQ(count("<body "), 30u);
  EXPECT_NE(a.find("axis=\"0.98474"), std::string::npos);  // the tilted hip roll axis
}

TEST(G1Mjcf, CommittedAssetIsUpToDate) {
  const std::string path = maskadapt::build_paths::source_dir() + "/assets/g1.xml";
  std::ifstream in(path, std::ios::binary);
  ASSERT_TRUE(in) << "missing " << path << " (regenerate: maskadapt_g1_mjcf " << path << ")";
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_EQ(ss.str(), g1_mjcf(D())) << "assets/g1.xml is stale: regenerate with the maskadapt_g1_mjcf target";
}
