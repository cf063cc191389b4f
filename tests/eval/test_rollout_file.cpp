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
    s.q[humanoid_skeleton().dof_offset(hb::LShoulder)] = 0.3 * std::sin(f);
    s.q[humanoid_skeleton().dof_offset(hb::RKnee) + 1] = 0.5;
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

// ---- scene goals (goal tasks: location targets, heading arrows, the strike box) -----------------

namespace {

// sample_rollout() plus a scene: a strike box tipping over about x, a location target that moves
// once (none on frame 9), and a heading arrow from the root (none on frames 0 and 1).
Rollout scene_rollout() {
  Rollout r = sample_rollout();
  RolloutScene sc;
  RolloutObject box{"strike_box", Vec3(0.2, 0.2, 0.6), {}, {}};
  for (int f = 0; f < r.num_frames(); ++f) {
    box.positions.push_back(Vec3(2.0, 0.5, 0.6 - 0.03 * f));
    box.rotations.push_back(Quat(Eigen::AngleAxisd(0.15 * f, Vec3::UnitX())));
    sc.targets.push_back(f == 9 ? std::vector<RolloutTarget>{} : std::vector<RolloutTarget>{{Vec3(f < 5 ? 3.0 : -1.0, 1.25, 0.0), 0.5}});
    const Vec3 root = r.positions[static_cast<std::size_t>(f)].col(0);
    if (f < 2) sc.arrows.emplace_back();
    else sc.arrows.push_back({heading_arrow(root, Vec3(std::cos(0.3 * f), std::sin(0.3 * f), 0.2), 1.25)});
  }
  sc.objects.push_back(box);
  r.scene = sc;
  return r;
}

// The field named by the Error `f` throws (or "(no error)").
std::string field_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.context().field;
  }
  return "(no error)";
}

}  // namespace

TEST(RolloutFile, HeadingArrowStartsOnTheFloorBelowTheRoot) {
  const RolloutArrow a = heading_arrow(Vec3(1.0, 2.0, 0.9), Vec3(3.0, 4.0, 1.0), 1.5);
  EXPECT_TRUE(a.origin.isApprox(Vec3(1.0, 2.0, 0.0)));
  EXPECT_TRUE(a.direction.isApprox(Vec3(0.6, 0.8, 0.0)));
  EXPECT_EQ(a.speed, 1.5);
  EXPECT_EQ(field_of([] { heading_arrow(Vec3::Zero(), Vec3::UnitZ(), 1.0); }), "scene.arrows.direction");
}

TEST(RolloutFile, SceneRoundTrip) {
  const Rollout r = scene_rollout();
  const std::string path = temp_path("scene.json");
  write_rollout(r, path);
  const Rollout back = read_rollout(path);
  ASSERT_TRUE(back.scene.has_value());
  const auto &a = *r.scene, &b = *back.scene;
  ASSERT_EQ(b.objects.size(), 1u);
  EXPECT_EQ(b.objects[0].name, "strike_box");
  EXPECT_TRUE(b.objects[0].half_size.isApprox(Vec3(0.2, 0.2, 0.6)));
  ASSERT_EQ(b.objects[0].positions.size(), 10u);
  ASSERT_EQ(b.objects[0].rotations.size(), 10u);
  ASSERT_EQ(b.targets.size(), 10u);
  ASSERT_EQ(b.arrows.size(), 10u);
  for (std::size_t f = 0; f < 10; ++f) {
    EXPECT_LE((b.objects[0].positions[f] - a.objects[0].positions[f]).cwiseAbs().maxCoeff(), 0.5e-5 + 1e-12);
    EXPECT_LT(b.objects[0].rotations[f].angularDistance(a.objects[0].rotations[f]), 5e-6) << "frame " << f;
    ASSERT_EQ(b.targets[f].size(), a.targets[f].size()) << "frame " << f;
    for (std::size_t k = 0; k < a.targets[f].size(); ++k) {
      EXPECT_TRUE(b.targets[f][k].position.isApprox(a.targets[f][k].position, 1e-6));
      EXPECT_EQ(b.targets[f][k].radius, 0.5);
    }
    ASSERT_EQ(b.arrows[f].size(), a.arrows[f].size()) << "frame " << f;
    for (std::size_t k = 0; k < a.arrows[f].size(); ++k) {
      EXPECT_LE((b.arrows[f][k].origin - a.arrows[f][k].origin).cwiseAbs().maxCoeff(), 0.5e-5 + 1e-12);
      EXPECT_LE((b.arrows[f][k].direction - a.arrows[f][k].direction).cwiseAbs().maxCoeff(), 0.5e-6 + 1e-12);
      EXPECT_EQ(b.arrows[f][k].speed, 1.25);
    }
  }
  EXPECT_TRUE(b.targets[9].empty());
  EXPECT_TRUE(b.arrows[0].empty());
  // The rest of the rollout is unaffected by the scene.
  EXPECT_EQ(back.num_frames(), 10);
  EXPECT_EQ(back.goals->bodies, r.goals->bodies);
  // Writing what was read gives the same targets and arrows (the rounding is idempotent).
  EXPECT_EQ(to_json(back)["scene"]["targets"], to_json(r)["scene"]["targets"]);
  EXPECT_EQ(to_json(back)["scene"]["arrows"], to_json(r)["scene"]["arrows"]);
}

TEST(RolloutFile, SceneJsonLayout) {
  const auto j = to_json(scene_rollout());
  const auto& s = j["scene"];
  EXPECT_EQ(s["objects"][0]["name"], "strike_box");
  EXPECT_EQ(s["objects"][0]["type"], "box");
  EXPECT_EQ(s["objects"][0]["half_size"], nlohmann::json::array({0.2, 0.2, 0.6}));
  EXPECT_EQ(s["objects"][0]["positions"][3], nlohmann::json::array({2.0, 0.5, 0.51}));
  EXPECT_EQ(s["objects"][0]["rotations"][0], nlohmann::json::array({0.0, 0.0, 0.0, 1.0}));  // x, y, z, w
  EXPECT_EQ(s["targets"][0][0]["position"], nlohmann::json::array({3.0, 1.25, 0.0}));
  EXPECT_EQ(s["targets"][0][0]["radius"], 0.5);
  EXPECT_EQ(s["targets"][9], nlohmann::json::array());
  EXPECT_EQ(s["arrows"][1], nlohmann::json::array());
  EXPECT_EQ(s["arrows"][2][0]["origin"][2], 0.0);
  EXPECT_EQ(s["arrows"][2][0]["direction"].size(), 3u);
  EXPECT_EQ(s["arrows"][2][0]["speed"], 1.25);
  // Absent kinds are null; a rollout without a scene writes "scene": null.
  Rollout r = scene_rollout();
  r.scene->targets.clear();
  r.scene->arrows.clear();
  const auto j2 = to_json(r);
  EXPECT_TRUE(j2["scene"]["targets"].is_null());
  EXPECT_TRUE(j2["scene"]["arrows"].is_null());
  EXPECT_TRUE(to_json(sample_rollout())["scene"].is_null());
}

TEST(RolloutFile, FileWithoutSceneLoadsAsBefore) {
  // A document as written before scenes existed: no "scene" key at all.
  auto j = to_json(sample_rollout());
  j.erase("scene");
  const std::string path = temp_path("no_scene.json");
  std::ofstream(path) << j.dump();
  const Rollout back = read_rollout(path);
  EXPECT_FALSE(back.scene.has_value());
  EXPECT_EQ(back.num_frames(), 10);
  EXPECT_EQ(back.goals->bodies, (std::vector<int>{hb::LWrist, hb::RWrist}));
  EXPECT_EQ(back.positions[3], rollout_from_json(to_json(sample_rollout())).positions[3]);
  // Nothing else depends on the key: it loads exactly as the same document with "scene": null
  // (compared as documents; EXPECT_TRUE keeps a failure from printing both).
  auto with_null = j;
  with_null["scene"] = nullptr;
  EXPECT_TRUE(to_json(back) == to_json(rollout_from_json(with_null)));
  EXPECT_TRUE(to_json(back)["frames"]["positions"] == j["frames"]["positions"]);
  EXPECT_TRUE(to_json(back)["goals"] == j["goals"]);
  // "scene": null and a scene with every kind absent load too.
  j["scene"] = nullptr;
  EXPECT_FALSE(rollout_from_json(j).scene.has_value());
  j["scene"] = nlohmann::json::object();
  const Rollout empty = rollout_from_json(j);
  ASSERT_TRUE(empty.scene.has_value());
  EXPECT_TRUE(empty.scene->objects.empty() && empty.scene->targets.empty() && empty.scene->arrows.empty());
}

TEST(RolloutFile, SceneValidationNamesFieldAndFrame) {
  // In-memory rollouts (checked before writing): field and frame of the first problem.
  struct Case {
    std::string field;
    int frame;  // the frame the message must name, or -1
    std::function<void(RolloutScene&)> breakIt;
  };
  const std::vector<Case> cases = {
      {"scene.targets", -1, [](RolloutScene& s) { s.targets.pop_back(); }},
      {"scene.targets[3][0].radius", 3, [](RolloutScene& s) { s.targets[3][0].radius = -0.5; }},
      {"scene.targets[2][0].position", 2, [](RolloutScene& s) { s.targets[2][0].position.y() = std::nan(""); }},
      {"scene.arrows", -1, [](RolloutScene& s) { s.arrows.emplace_back(); }},
      {"scene.arrows[4][0].direction", 4, [](RolloutScene& s) { s.arrows[4][0].direction *= 2.0; }},
      {"scene.arrows[5][0].direction", 5, [](RolloutScene& s) { s.arrows[5][0].direction = Vec3(0.6, 0.0, 0.8); }},
      {"scene.arrows[6][0].speed", 6, [](RolloutScene& s) { s.arrows[6][0].speed = -1.0; }},
      {"scene.arrows[7][0].origin", 7, [](RolloutScene& s) { s.arrows[7][0].origin.x() = std::numeric_limits<double>::infinity(); }},
      {"scene.objects[0].half_size", -1, [](RolloutScene& s) { s.objects[0].half_size.z() = -0.6; }},
      {"scene.objects[0].half_size", -1, [](RolloutScene& s) { s.objects[0].half_size.x() = 0.0; }},
      {"scene.objects[0].positions", -1, [](RolloutScene& s) { s.objects[0].positions.pop_back(); }},
      {"scene.objects[0].rotations", -1, [](RolloutScene& s) { s.objects[0].rotations.emplace_back(Quat::Identity()); }},
      {"scene.objects[0].positions[2]", 2, [](RolloutScene& s) { s.objects[0].positions[2].z() = std::nan(""); }},
      {"scene.objects[0].rotations[4]", 4, [](RolloutScene& s) { s.objects[0].rotations[4].coeffs() *= 1.2; }},
  };
  for (const auto& c : cases) {
    Rollout r = scene_rollout();
    c.breakIt(*r.scene);
    std::string msg;
    try {
      to_json(r);
    } catch (const Error& e) {
      EXPECT_EQ(e.context().field, c.field) << e.what();
      msg = e.what();
    }
    ASSERT_FALSE(msg.empty()) << c.field << ": no error";
    if (c.frame >= 0) {
      EXPECT_NE(msg.find("frame " + std::to_string(c.frame) + ":"), std::string::npos) << msg;
    }
  }
  Rollout r = scene_rollout();
  r.scene->objects[0].rotations[4].coeffs() *= 1.2;
  const std::string msg = error_of([&] { to_json(r); });
  EXPECT_NE(msg.find("frame 4"), std::string::npos) << msg;
  EXPECT_NE(msg.find("strike_box"), std::string::npos) << msg;
}

TEST(RolloutFile, SceneReaderNamesTheFieldAtFault) {
  const auto j = to_json(scene_rollout());
  using nlohmann::json;
  const std::vector<std::pair<std::string, std::function<void(json&)>>> cases = {
      {"scene", [](json& d) { d["scene"] = 3; }},
      {"scene.targets", [](json& d) { d["scene"]["targets"].erase(0); }},
      {"scene.targets[3][0].radius", [](json& d) { d["scene"]["targets"][3][0]["radius"] = -1.0; }},
      {"scene.targets[3][0].radius", [](json& d) { d["scene"]["targets"][3][0].erase("radius"); }},
      {"scene.targets[2][0].position[1]", [](json& d) { d["scene"]["targets"][2][0]["position"][1] = nullptr; }},  // NaN is written as null
      {"scene.arrows", [](json& d) { d["scene"]["arrows"].push_back(json::array()); }},
      {"scene.arrows[4][0].direction", [](json& d) { d["scene"]["arrows"][4][0]["direction"] = {1.0, 1.0, 0.0}; }},
      {"scene.arrows[4][0].speed", [](json& d) { d["scene"]["arrows"][4][0]["speed"] = -2.0; }},
      {"scene.objects[0].type", [](json& d) { d["scene"]["objects"][0]["type"] = "sphere"; }},
      {"scene.objects[0].name", [](json& d) { d["scene"]["objects"][0].erase("name"); }},
      {"scene.objects[0].half_size", [](json& d) { d["scene"]["objects"][0]["half_size"][0] = -0.2; }},
      {"scene.objects[0].positions", [](json& d) { d["scene"]["objects"][0]["positions"].erase(0); }},
      {"scene.objects[0].rotations[5]", [](json& d) { d["scene"]["objects"][0]["rotations"][5] = {0.0, 0.0, 0.0, 2.0}; }},
      {"scene.objects[0].rotations[5]", [](json& d) { d["scene"]["objects"][0]["rotations"][5].erase(0); }},
  };
  for (const auto& [field, breakIt] : cases) {
    json d = j;
    breakIt(d);
    std::string msg;
    try {
      rollout_from_json(d, "x.json");
    } catch (const Error& e) {
      EXPECT_EQ(e.context().field, field) << e.what();
      msg = e.what();
    }
    ASSERT_FALSE(msg.empty()) << field << ": no error";
    EXPECT_NE(msg.find("x.json"), std::string::npos) << msg;
  }
}
