// The G1's motion through the character-generic motion layer (issue 18, parts 2 and 5): a
// MotionLibrary on the robot's single-axis skeleton (frames exact, hinge angles lerped, AMP windows
// of the robot's observation), joint angles recovered from body orientations, part-wise blends,
// the trainers' motion sources with env.character = "g1". No MuJoCo needed.
#include <maskadapt/g1/clip.hpp>
#include <maskadapt/g1/retarget.hpp>
#include <maskadapt/g1/skeleton.hpp>
#include <maskadapt/humanoid/synthetic.hpp>
#include <maskadapt/mask/apply.hpp>
#include <maskadapt/motion/blend.hpp>
#include <maskadapt/motion/library.hpp>
#include <maskadapt/train/config.hpp>
#include <maskadapt/train/motion_sources.hpp>
#include <maskadapt/train/play.hpp>

#include <gtest/gtest.h>

#include <random>

using namespace maskadapt;

namespace {

const Skeleton& G() { return g1::g1_skeleton(); }

/// The built-in synthetic walk retargeted onto the robot, as a clip on its skeleton.
const MotionClip& g1_walk() {
  static const MotionClip c = [] {
    MotionClip m = g1::to_motion_clip(g1::retarget_to_g1(synthetic_walk()));
    m.name = "g1_walk";
    return m;
  }();
  return c;
}

}  // namespace

TEST(G1Motion, LibraryGivesFramesExactlyAndLerpsEachHingeBetweenThem) {
  MotionLibrary lib(G());
  lib.add(g1_walk());
  const MotionClip& c = lib.clip(0);
  ASSERT_EQ(c.num_dofs(), 29);
  for (int t : {0, 7, c.num_frames() - 3}) {  // (a looping clip's last frame time is its first)
    const KinematicState at = lib.state(0, t / c.fps);
    EXPECT_EQ((at.q - c.q.col(t)).cwiseAbs().maxCoeff(), 0.0) << "frame " << t;
    EXPECT_LT((at.root_pos - c.root_pos.col(t)).norm(), 1e-12);
    // between frames t and t+1 at weight 0.3: each hinge angle is the lerp
    const KinematicState mid = lib.state(0, (t + 0.3) / c.fps);
    const VectorXd lerp = 0.7 * c.q.col(t) + 0.3 * c.q.col(t + 1);
    EXPECT_LT((mid.q - lerp).cwiseAbs().maxCoeff(), 1e-12) << "frame " << t;
    // joint rates: the central difference over one frame each side
    if (t > 0) {
      const VectorXd qd = (c.q.col(t + 1) - c.q.col(t - 1)) * (c.fps / 2.0);
      EXPECT_LT((at.qd - qd).cwiseAbs().maxCoeff(), 1e-9) << "frame " << t;
    }
  }
}

TEST(G1Motion, AmpWindowsHaveTheRobotsObservation) {
  MotionLibrary lib(G());
  lib.add(g1_walk());
  // s = (root height, 3 per non-root body, 12 per body): 1 + 3·29 + 12·30 for the 30 links
  EXPECT_EQ(observation_dim(G()), 1 + 3 * 29 + 12 * 30);
  EXPECT_EQ(lib.amp_window_dim(), kAmpWindowFrames * observation_dim(G()));
  Rng rng(3);
  const MatrixXf w = lib.sample_amp_windows(rng, 8);
  EXPECT_TRUE(w.allFinite());
  // the last frame of a window is the observation of the body states at its end time
  const double t_end = 1.0;
  VectorXf one(lib.amp_window_dim());
  lib.amp_window(0, t_end, one);
  const VectorXf last = compute_observation(G(), lib.body_states(0, t_end));
  EXPECT_LT((one.tail(observation_dim(G())) - last).cwiseAbs().maxCoeff(), 1e-5);
}

TEST(G1Motion, JointAnglesFromBodyStatesInvertForwardKinematics) {
  std::mt19937_64 gen(7);
  for (int trial = 0; trial < 20; ++trial) {
    KinematicState s = KinematicState::zero(G());
    s.root_pos = Vec3(0.3, -0.2, 0.8);
    s.root_rot = Quat(Eigen::AngleAxisd(0.4 * trial, Vec3(0.2, 0.3, 1.0).normalized()));
    for (int k = 0; k < G().num_dofs(); ++k)
      s.q[k] = std::uniform_real_distribution<double>(G().dof_lower(k), G().dof_upper(k))(gen);
    const BodyStates b = forward_kinematics(G(), s);
    const VectorXd q = train::joint_angles_from_body_states(G(), b, VectorXd());
    EXPECT_LT((q - s.q).cwiseAbs().maxCoeff(), 1e-12) << "trial " << trial;
  }
}

TEST(G1Motion, BlendTakesTheMaskedLinksFromTheSecondClip) {
  MotionClip arms = g1::to_motion_clip(g1::retarget_to_g1(synthetic_arm_circles()));
  const MotionClip& walk = g1_walk();
  const MotionClip out = blend_parts(walk, arms, PartMask::parse("arms"), G());
  ASSERT_EQ(out.num_frames(), walk.num_frames());
  for (int b = 1; b < G().num_bodies(); ++b) {
    const int k = G().dof_offset(b);
    const bool arm = PartMask::parse("arms").has(G().parts[b]);
    for (int t : {0, 5, 20}) {
      const int ta = t % (arms.num_frames() - 1);  // (arms loops when it is shorter than walk)
      EXPECT_EQ(out.q(k, t), arm ? arms.q(k, ta) : walk.q(k, t)) << G().names[b] << " frame " << t;
    }
  }
}

TEST(G1Motion, MotionSourcesRetargetOntoTheRobotAndKeepTheLabels) {
  const auto lib = train::load_motion_library({"walk"}, "", mujoco_character("g1"));
  const auto hum = train::load_motion_library({"walk"}, "", mujoco_character("humanoid"));
  ASSERT_EQ(lib->num_clips(), hum->num_clips());
  EXPECT_EQ(lib->skeleton().num_dofs(), 29);
  EXPECT_EQ(lib->clip(0).labels, hum->clip(0).labels);
  EXPECT_NEAR(lib->clip(0).duration(), hum->clip(0).duration(), 1e-12);
  // a G1 clip file is taken as it is
  const std::string file = (std::filesystem::temp_directory_path() / "maskadapt_test_g1_walk.npz").string();
  g1::save_g1_clip(file, g1::retarget_to_g1(synthetic_walk()));
  EXPECT_TRUE(g1::is_g1_clip_file(file));
  const auto from_file = train::load_motion_library({file}, "", mujoco_character("g1"));
  EXPECT_EQ(from_file->clip(0).q, lib->clip(0).q);
  std::filesystem::remove(file);
}

TEST(G1Motion, ConfigKeepsTheCharacterAndRefusesUnknownOnes) {
  train::BaseTrainConfig c = train::cpu_preset();
  EXPECT_EQ(c.env.character, "humanoid");
  c.env.character = "g1";
  const train::BaseTrainConfig back = train::config_from_string(train::to_json(c).dump());
  EXPECT_EQ(back.env.character, "g1");
  // a config written before the field existed reads as the humanoid
  nlohmann::json j = train::to_json(c);
  j["env"].erase("character");
  EXPECT_EQ(train::config_from_string(j.dump()).env.character, "humanoid");
  c.env.character = "robot";
  try {
    c.validate("run.json");
    FAIL() << "an unknown character was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("env.character"), std::string::npos) << e.what();
  }
}

TEST(G1Motion, PartsGroupTheRobotsLinksObservationAndActions) {
  // Unitree's motor order: legs 0–11, waist 12–14, left arm 15–21, right arm 22–28
  const auto dof = action_parts(G());
  for (int k = 0; k < 29; ++k) {
    const BodyPart want = k < 6 ? BodyPart::LeftLeg : k < 12 ? BodyPart::RightLeg : k < 15 ? BodyPart::Trunk
                          : k < 22                            ? BodyPart::LeftArm
                                                              : BodyPart::RightArm;
    EXPECT_EQ(dof[static_cast<std::size_t>(k)], want) << "DoF " << k;
  }
  // every observation element belongs to the part of the link it describes; masking the arms
  // hides exactly the arm links' 3 + 12 elements each (7 links per arm)
  const auto obs = observation_parts(G());
  ASSERT_EQ(obs.size(), static_cast<std::size_t>(observation_dim(G())));
  const PartElements pe(obs);
  const VectorXf keep = keep_vector(pe, PartMask::parse("arms"));
  EXPECT_EQ(keep.size() - keep.sum(), 2 * 7 * 15);
  EXPECT_EQ(PartElements(dof).of_part[static_cast<std::size_t>(BodyPart::LeftArm)].size(), 7u);
}
