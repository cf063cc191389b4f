#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/humanoid/mjcf.hpp>

#include "../build_paths.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>

using namespace maskadapt;

TEST(HumanoidDescription, SmplOrderNamesAndTopology) {
  const Skeleton& s = humanoid_skeleton();
  ASSERT_EQ(s.num_bodies(), 22);
  EXPECT_EQ(s.num_dofs(), 63);
  // SMPL kinematic tree parents for joints 0..21.
  const std::vector<int> smpl_parents = {-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19};
  EXPECT_EQ(s.parents, smpl_parents);
  EXPECT_EQ(s.names[hb::LKnee], "L_Knee");
  EXPECT_EQ(s.names[hb::Head], "Head");
  EXPECT_EQ(s.names[hb::RWrist], "R_Wrist");
  EXPECT_NO_THROW(s.validate());
}

TEST(HumanoidDescription, LeftRightMirrorSymmetric) {
  const Skeleton& s = humanoid_skeleton();
  for (int i = 0; i < s.num_bodies(); ++i) {
    if (s.names[i].rfind("L_", 0) != 0) continue;
    const int j = s.index_of("R_" + s.names[i].substr(2));
    const Vec3 mirrored(s.offsets(0, i), -s.offsets(1, i), s.offsets(2, i));
    EXPECT_LT((mirrored - s.offsets.col(j)).norm(), 1e-12) << s.names[i];
    // Mirroring flips x- and z-hinges: lower_L(x) = −upper_R(x); y-hinges are equal.
    EXPECT_DOUBLE_EQ(s.dof_lower(s.dof_offset(i) + 0), -s.dof_upper(s.dof_offset(j) + 0)) << s.names[i];
    EXPECT_DOUBLE_EQ(s.dof_lower(s.dof_offset(i) + 1), s.dof_lower(s.dof_offset(j) + 1)) << s.names[i];
    EXPECT_DOUBLE_EQ(s.dof_lower(s.dof_offset(i) + 2), -s.dof_upper(s.dof_offset(j) + 2)) << s.names[i];
    EXPECT_DOUBLE_EQ(humanoid_description().bodies[i].mass(), humanoid_description().bodies[j].mass());
  }
}

TEST(HumanoidDescription, PlausibleAdult) {
  const HumanoidDescription& d = humanoid_description();
  EXPECT_GE(d.total_mass(), 60.0);
  EXPECT_LE(d.total_mass(), 75.0);
  const BodyStates b = forward_kinematics(d.skeleton, humanoid_standing_pose());
  // Head top (sphere) 1.6–1.85 m; arm span (wrist to wrist) 1.3–1.6 m; leg length 0.8–1.0 m.
  const Geom& head = d.bodies[hb::Head].geoms[0];
  const double head_top = b.pos(2, hb::Head) + head.a.z() + head.radius;
  EXPECT_GT(head_top, 1.6);
  EXPECT_LT(head_top, 1.85);
  const double span = b.pos(1, hb::LWrist) - b.pos(1, hb::RWrist);
  EXPECT_GT(span, 1.3);
  EXPECT_LT(span, 1.6);
  EXPECT_NEAR(b.pos(2, hb::LHip) - b.pos(2, hb::LAnkle), 0.77, 0.05);
}

TEST(HumanoidDescription, SolesTouchTheFloorAtTheStandingPose) {
  const HumanoidDescription& d = humanoid_description();
  const BodyStates b = forward_kinematics(d.skeleton, humanoid_standing_pose());
  for (int foot : {hb::LAnkle, hb::RAnkle, hb::LToe, hb::RToe}) {
    const Geom& g = d.bodies[foot].geoms[0];
    ASSERT_EQ(g.type, Geom::Type::Box);
    EXPECT_NEAR(b.pos(2, foot) + g.a.z() - g.b.z(), 0.0, 1e-9) << d.skeleton.names[foot];
  }
}

TEST(HumanoidDescription, PartsOfBodiesAndActions) {
  const Skeleton& s = humanoid_skeleton();
  std::multiset<BodyPart> counts(s.parts.begin(), s.parts.end());
  EXPECT_EQ(counts.count(BodyPart::Trunk), 6u);  // pelvis, 3 spine, neck, head
  for (BodyPart p : {BodyPart::LeftArm, BodyPart::RightArm, BodyPart::LeftLeg, BodyPart::RightLeg})
    EXPECT_EQ(counts.count(p), 4u) << part_name(p);
  EXPECT_EQ(s.parts[hb::LThorax], BodyPart::LeftArm);
  EXPECT_EQ(s.parts[hb::RToe], BodyPart::RightLeg);
  const auto ap = action_parts(s);
  ASSERT_EQ(ap.size(), 63u);
  EXPECT_EQ(ap[3 * (hb::LKnee - 1) + 1], BodyPart::LeftLeg);
  EXPECT_EQ(ap[3 * (hb::RElbow - 1) + 2], BodyPart::RightArm);
  EXPECT_EQ(ap[3 * (hb::Neck - 1)], BodyPart::Trunk);
}

TEST(HumanoidDescription, GainsFollowTheStabilityNotes) {
  const HumanoidDescription& d = humanoid_description();
  EXPECT_EQ(d.bodies[hb::LAnkle].kp, 800);
  EXPECT_EQ(d.bodies[hb::RKnee].kp, 500);
  EXPECT_EQ(d.bodies[hb::LShoulder].kp, 300);
  EXPECT_EQ(d.bodies[hb::RElbow].kp, 200);
  EXPECT_EQ(d.bodies[hb::LWrist].kp, 100);
  for (int i = 1; i < 22; ++i) EXPECT_DOUBLE_EQ(d.bodies[i].kd, d.bodies[i].kp / 10);
  EXPECT_DOUBLE_EQ(d.control_dt(), 1.0 / 30.0);
  // 1/60 s physics × 2 substeps (issue 13) needs armature 0.08 legs/spine, 0.04 elsewhere.
  EXPECT_EQ(d.physics_dt, 1.0 / 60.0);
  EXPECT_EQ(d.substeps, 2);
  EXPECT_EQ(d.bodies[hb::LAnkle].armature, 0.08);
  EXPECT_EQ(d.bodies[hb::Chest].armature, 0.08);
  EXPECT_EQ(d.bodies[hb::RWrist].armature, 0.04);
  EXPECT_EQ(d.bodies[hb::Pelvis].armature, 0.0);
  EXPECT_EQ(d.dof_kp().size(), 63);
  EXPECT_EQ(d.dof_kp()[3 * (hb::LAnkle - 1) + 2], 800);
}

TEST(HumanoidDescription, LegacySettingsAreThoseBeforeIssue13) {
  const HumanoidDescription d = legacy_humanoid_description_120hz();
  EXPECT_EQ(d.physics_dt, 1.0 / 120.0);
  EXPECT_EQ(d.substeps, 4);
  EXPECT_DOUBLE_EQ(d.control_dt(), 1.0 / 30.0);
  EXPECT_EQ(d.bodies[hb::LHip].armature, 0.02);
  EXPECT_EQ(d.bodies[hb::LElbow].armature, 0.01);
  EXPECT_EQ(d.bodies[hb::LHip].kp, humanoid_description().bodies[hb::LHip].kp);
  EXPECT_EQ(humanoid_mjcf(d).find("armature=\"0.08\""), std::string::npos);
}

TEST(HumanoidMjcf, WritesThePhysicsOptions) {
  HumanoidDescription d = humanoid_description();
  const std::string a = humanoid_mjcf(d);
  EXPECT_NE(a.find("<option timestep=\"0.016666666666666666\" integrator=\"Euler\" solver=\"Newton\" iterations=\"100\" "
                   "tolerance=\"1e-08\" cone=\"pyramidal\" jacobian=\"auto\"/>"),
            std::string::npos)
      << a.substr(0, 600);
  d.physics.solver = PhysicsOptions::Solver::CG;
  d.physics.cone = PhysicsOptions::Cone::Elliptic;
  d.physics.jacobian = PhysicsOptions::Jacobian::Dense;
  d.physics.integrator = PhysicsOptions::Integrator::Implicit;
  d.physics.contact_timeconst = 0.04;
  const std::string b = humanoid_mjcf(d);
  for (const char* s : {"solver=\"CG\"", "cone=\"elliptic\"", "jacobian=\"dense\"", "integrator=\"implicit\"", "solref=\"0.04 1\""})
    EXPECT_NE(b.find(s), std::string::npos) << s;
  d.physics.iterations = 0;
  EXPECT_THROW(humanoid_mjcf(d), Error);
}

TEST(HumanoidMjcf, DeterministicAndComplete) {
  const std::string a = humanoid_mjcf(humanoid_description()), b = humanoid_mjcf(humanoid_description());
  EXPECT_EQ(a, b);
  auto count = [&](const std::string& needle) {
    std::size_t n = 0;
    for (std::size_t p = a.find(needle); p != std::string::npos; p = a.find(needle, p + 1)) ++n;
    return n;
  };
  EXPECT_EQ(count("<body "), 22u);
  EXPECT_EQ(count("type=\"hinge\""), 63u);
  EXPECT_EQ(count("<general "), 63u);
  EXPECT_EQ(count(" limited=\"true\""), 63u);
  EXPECT_EQ(count("ctrllimited=\"true\""), 63u);
  EXPECT_EQ(count("biasprm=\"0 -800 0\""), 6u);  // two ankles × 3 hinges, kp only
  EXPECT_NE(a.find("integrator=\"Euler\""), std::string::npos);
}

TEST(HumanoidMjcf, NumbersRoundTripExactly) {
  for (double x : {0.1, -0.386, 1.0 / 120.0, 0.94500000000000006, 1e-300, 123456.789})
    EXPECT_EQ(std::strtod(detail::mjcf_num(x).c_str(), nullptr), x);
  EXPECT_EQ(detail::mjcf_num(0.5), "0.5");
}

TEST(HumanoidMjcf, CommittedAssetIsUpToDate) {
  const std::string path = maskadapt::build_paths::source_dir() + "/assets/humanoid.xml";
  std::ifstream in(path, std::ios::binary);
  ASSERT_TRUE(in) << "missing " << path << " (regenerate: maskadapt_humanoid_mjcf " << path << ")";
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_EQ(ss.str(), humanoid_mjcf(humanoid_description()))
      << "assets/humanoid.xml is stale: regenerate with the maskadapt_humanoid_mjcf target";
}
