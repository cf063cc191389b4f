#include <maskadapt/eval/rollout_file.hpp>
#include <maskadapt/humanoid/description.hpp>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

using namespace maskadapt;
using namespace maskadapt::eval;

namespace {

std::string temp_path(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("maskadapt_eval_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

// A 10-frame rollout of the humanoid waving its arms, masks switching at frame 5, goals and texts.
Rollout sample_rollout() {
  const Skeleton& skel = humanoid_skeleton();
  Rollout r = make_rollout(humanoid_description());
  r.metadata.command = "maskadapt play ckpt.bin --mask legs";
  r.metadata.checkpoint = "ckpt.bin";
  r.metadata.seed = 42;
  r.metadata.extra["lambda_mi"] = "1.0";
  r.texts = {{0.0, "wave hands"}, {0.2, "raise arms"}};
  RolloutGoals goals;
  goals.bodies = {hb::LWrist, hb::RWrist};
  for (int f = 0; f < 10; ++f) {
    KinematicState s = humanoid_standing_pose();
    s.root_pos.x() = 0.05 * f;
    s.root_rot = Quat(Eigen::AngleAxisd(0.1 * f, Vec3::UnitZ()));
    s.q[Skeleton::dof_offset(hb::LShoulder)] = 0.3 * std::sin(f);
    s.q[Skeleton::dof_offset(hb::RKnee) + 1] = 0.5;
    const BodyStates bs = forward_kinematics(skel, s);
    std::vector<bool> contacts(static_cast<std::size_t>(skel.num_bodies()), false);
    contacts[hb::LAnkle] = f % 2 == 0;
    contacts[hb::RAnkle] = true;
    add_frame(r, bs, f < 5 ? PartMask::parse("legs") : PartMask::parse("arms"), contacts);
    Matrix3X t(3, 2);
    t.col(0) = bs.pos.col(hb::LWrist) + Vec3(0.1, 0, 0.2);
    t.col(1) = bs.pos.col(hb::RWrist) + Vec3(0.1, 0, 0.2);
    goals.targets.push_back(f == 9 ? Matrix3X(3, 0) : t);
  }
  r.goals = goals;
  return r;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(RolloutFile, DefaultGeomsAreCapsulesFromParentToChild) {
  const Skeleton& skel = humanoid_skeleton();
  const RolloutSkeleton s = rollout_skeleton(skel);
  // The pelvis has three children (both hips, the torso): three capsules to their joints.
  ASSERT_EQ(s.geoms[hb::Pelvis].size(), 3u);
  EXPECT_EQ(s.geoms[hb::Pelvis][0].type, RolloutGeom::Type::Capsule);
  EXPECT_TRUE(s.geoms[hb::Pelvis][0].to.isApprox(skel.offsets.col(hb::LHip)));
  // Leaves (head, wrists, toes) get a sphere.
  ASSERT_EQ(s.geoms[hb::Head].size(), 1u);
  EXPECT_EQ(s.geoms[hb::Head][0].type, RolloutGeom::Type::Sphere);
}

TEST(RolloutFile, HumanoidGeomsComeFromTheDescription) {
  const auto& d = humanoid_description();
  const RolloutSkeleton s = rollout_skeleton(d);
  for (int b = 0; b < s.num_bodies(); ++b) {
    ASSERT_EQ(s.geoms[b].size(), d.bodies[b].geoms.size()) << s.names[b];
    for (std::size_t k = 0; k < s.geoms[b].size(); ++k) {
      EXPECT_TRUE(s.geoms[b][k].from.isApprox(d.bodies[b].geoms[k].a) || d.bodies[b].geoms[k].a.isZero());
      EXPECT_DOUBLE_EQ(s.geoms[b][k].radius, d.bodies[b].geoms[k].radius);
    }
  }
  EXPECT_EQ(s.geoms[hb::Head][0].type, RolloutGeom::Type::Sphere);
  EXPECT_EQ(s.geoms[hb::LAnkle][0].type, RolloutGeom::Type::Box);
}

TEST(RolloutFile, WriteReadRoundTrip) {
  const Rollout r = sample_rollout();
  const std::string path = temp_path("roundtrip.json");
  write_rollout(r, path);
  const Rollout back = read_rollout(path);
  ASSERT_EQ(back.num_frames(), 10);
  EXPECT_EQ(back.fps, 30.0);
  EXPECT_EQ(back.skeleton.names, r.skeleton.names);
  EXPECT_EQ(back.skeleton.parents, r.skeleton.parents);
  EXPECT_EQ(back.skeleton.parts, r.skeleton.parts);
  EXPECT_TRUE(back.skeleton.offsets.isApprox(r.skeleton.offsets, 1e-4));
  for (int f = 0; f < 10; ++f) {
    EXPECT_LE((back.positions[f] - r.positions[f]).cwiseAbs().maxCoeff(), 0.5e-5 + 1e-12);
    for (int b = 0; b < r.skeleton.num_bodies(); ++b)
      EXPECT_LT(back.rotations[f][b].normalized().angularDistance(r.rotations[f][b]), 5e-6)  // 6 decimals
          << "frame " << f << " body " << b;
    EXPECT_EQ(back.masks[f], r.masks[f]);
    EXPECT_EQ(back.contacts[f], r.contacts[f]);
  }
  EXPECT_EQ(back.masks[0].bits, PartMask::parse("legs").bits);
  EXPECT_EQ(back.masks[9].bits, PartMask::parse("arms").bits);
  ASSERT_EQ(back.texts.size(), 2u);
  EXPECT_EQ(back.texts[1].text, "raise arms");
  EXPECT_DOUBLE_EQ(back.texts[1].t, 0.2);
  ASSERT_TRUE(back.goals.has_value());
  EXPECT_EQ(back.goals->bodies, (std::vector<int>{hb::LWrist, hb::RWrist}));
  EXPECT_EQ(back.goals->targets[9].cols(), 0);
  EXPECT_LE((back.goals->targets[3] - r.goals->targets[3]).cwiseAbs().maxCoeff(), 1e-5);
  EXPECT_EQ(back.metadata.command, r.metadata.command);
  EXPECT_EQ(back.metadata.seed, 42);
  EXPECT_EQ(back.metadata.extra.at("lambda_mi"), "1.0");
  EXPECT_EQ(back.skeleton.geoms[hb::LAnkle][0].type, RolloutGeom::Type::Box);
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
}

TEST(RolloutFile, JsonLayoutMatchesTheDocumentedSchema) {
  const auto j = to_json(sample_rollout());
  EXPECT_EQ(j["format"], "maskadapt-rollout");
  EXPECT_EQ(j["version"], 1);
  EXPECT_EQ(j["num_frames"], 10);
  EXPECT_EQ(j["frames"]["positions"][0].size(), 3u * 22);
  EXPECT_EQ(j["frames"]["rotations"][0].size(), 4u * 22);
  EXPECT_EQ(j["frames"]["masks"][0], 24);  // legs = bits 3 and 4
  EXPECT_EQ(j["frames"]["masks"][5], 6);   // arms = bits 1 and 2
  EXPECT_EQ(j["skeleton"]["bodies"][1]["part"], "left_leg");
  EXPECT_EQ(j["part_names"][4], "right_leg");
  // Root position of frame 2 (x = 0.1 m) and a unit quaternion with w ≥ 0, stored x, y, z, w.
  EXPECT_NEAR(j["frames"]["positions"][2][0].get<double>(), 0.1, 1e-12);
  const auto& q = j["frames"]["rotations"][2];
  EXPECT_NEAR(q[2].get<double>(), std::sin(0.1), 1e-6);  // z of a yaw rotation by 0.2 rad
  EXPECT_NEAR(q[3].get<double>(), std::cos(0.1), 1e-6);
}

TEST(RolloutFile, NonFinitePositionNamesFrameAndBody) {
  Rollout r = make_rollout(humanoid_skeleton());
  BodyStates bs = forward_kinematics(humanoid_skeleton(), humanoid_standing_pose());
  add_frame(r, bs, PartMask::none());
  bs.pos(2, hb::LElbow) = std::nan("");
  const std::string msg = error_of([&] { add_frame(r, bs, PartMask::none()); });
  EXPECT_NE(msg.find("frame 1"), std::string::npos) << msg;
  EXPECT_NE(msg.find("L_Elbow"), std::string::npos) << msg;
  EXPECT_EQ(r.num_frames(), 1);  // unchanged on error
  // The same check guards a rollout assembled by hand.
  r.positions[0](0, hb::Head) = std::numeric_limits<double>::infinity();
  const std::string msg2 = error_of([&] { to_json(r); });
  EXPECT_NE(msg2.find("frame 0"), std::string::npos) << msg2;
  EXPECT_NE(msg2.find("Head"), std::string::npos) << msg2;
}

TEST(RolloutFile, WrongSizesAreRejected) {
  Rollout r = make_rollout(humanoid_skeleton());
  const BodyStates bs = forward_kinematics(humanoid_skeleton(), humanoid_standing_pose());
  EXPECT_THROW(add_frame(r, bs, PartMask::none(), std::vector<int>(3, 0)), Error);  // 3 contact flags for 22 bodies
  Rollout r2 = sample_rollout();
  r2.goals->bodies.push_back(99);
  EXPECT_THROW(to_json(r2), Error);
  Rollout r3 = sample_rollout();
  r3.texts = {{1.0, "b"}, {0.5, "a"}};  // unsorted
  EXPECT_THROW(to_json(r3), Error);
}

TEST(RolloutFile, ReaderNamesTheFieldAtFault) {
  auto j = to_json(sample_rollout());
  auto bad_version = j;
  bad_version["version"] = 7;
  EXPECT_NE(error_of([&] { rollout_from_json(bad_version, "x.json"); }).find("version"), std::string::npos);
  auto short_frame = j;
  short_frame["frames"]["positions"][3].erase(0);
  const std::string m1 = error_of([&] { rollout_from_json(short_frame, "x.json"); });
  EXPECT_NE(m1.find("frames.positions[3]"), std::string::npos) << m1;
  EXPECT_NE(m1.find("x.json"), std::string::npos) << m1;
  auto bad_part = j;
  bad_part["skeleton"]["bodies"][2]["part"] = "tail";
  EXPECT_NE(error_of([&] { rollout_from_json(bad_part); }).find("skeleton.bodies[2].part"), std::string::npos);
  auto bad_mask = j;
  bad_mask["frames"]["masks"][1] = 64;
  EXPECT_NE(error_of([&] { rollout_from_json(bad_mask); }).find("frames.masks[1]"), std::string::npos);
  auto missing = j;
  missing.erase("fps");
  EXPECT_NE(error_of([&] { rollout_from_json(missing); }).find("fps"), std::string::npos);

  const std::string path = temp_path("malformed.json");
  std::ofstream(path) << "{\"format\": \"maskadapt-rollout\", ";
  const std::string m2 = error_of([&] { read_rollout(path); });
  EXPECT_NE(m2.find("malformed JSON"), std::string::npos) << m2;
  EXPECT_THROW(read_rollout(temp_path("does_not_exist.json")), Error);
}
