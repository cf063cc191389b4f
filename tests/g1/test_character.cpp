// The G1-like robot through the simulator concept (issue 18, parts 1 and 5): MujocoHumanoidSim
// runs any MujocoCharacter — the robot stands in its nominal pose under PD without a fall, a reset
// to a retargeted frame places every link where forward kinematics puts it, save/load of an env
// is bit-exact — and a character whose MJCF disagrees with its skeleton is refused by name; the
// shipped G1 walkers load and walk.
#include <maskadapt/g1/retarget.hpp>
#include <maskadapt/humanoid/synthetic.hpp>
#include <maskadapt/motion/library.hpp>
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>
#include <maskadapt/sim/termination.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/motion_sources.hpp>
#include <maskadapt/train/play.hpp>
#include <maskadapt/train/policy_export.hpp>

#include "../build_paths.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <string>

using namespace maskadapt;

namespace {

const MujocoCharacter& robot() { return mujoco_character("g1"); }

std::string error_of(auto&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

}  // namespace

TEST(G1Character, SimulatorRunsTheRobotAndItStandsUnderPd) {
  MujocoHumanoidSim sim(2, 1, robot());
  EXPECT_EQ(sim.skeleton().num_dofs(), 29);
  EXPECT_EQ(sim.skeleton().num_bodies(), 30);
  EXPECT_DOUBLE_EQ(sim.control_dt(), 8.0 / 240.0);
  // the first state is the nominal standing pose, as forward kinematics places it
  const BodyStates fk = forward_kinematics(robot().skeleton, robot().standing);
  EXPECT_LT((sim.body_states(0).pos - fk.pos).cwiseAbs().maxCoeff(), 1e-9);
  // 5 s holding the nominal pose: no fall by the robot's own criteria, the pelvis stays put
  const FallCriteria fall = robot().fall_criteria(0.3);
  const MatrixXd hold = robot().standing.q.replicate(1, 2);
  const double z0 = sim.body_states(0).pos(2, 0);
  for (int step = 0; step < 150; ++step) {
    sim.step(hold);
    ASSERT_FALSE(has_fallen(fall, sim.body_states(0), sim.contacts(0))) << "step " << step;
  }
  EXPECT_LT(std::abs(sim.body_states(0).pos(2, 0) - z0), 0.03) << "pelvis height drift (m)";
  EXPECT_EQ(sim.step_stats().physics_resets, 0);
  // the soles are on the floor, nothing else is
  const int left = robot().skeleton.index_of("left_ankle_roll_link"), right = robot().skeleton.index_of("right_ankle_roll_link");
  EXPECT_TRUE(sim.contacts(0)[static_cast<std::size_t>(left)] && sim.contacts(0)[static_cast<std::size_t>(right)]);
}

TEST(G1Character, ResetToARetargetedFramePlacesEveryLink) {
  MotionLibrary lib(robot().skeleton);
  lib.add(g1::to_motion_clip(g1::retarget_to_g1(synthetic_walk())));
  MujocoHumanoidSim sim(1, 1, robot());
  for (double t : {0.2, 0.55, 0.9}) {
    const KinematicState s = lib.state(0, t);
    sim.reset(0, s);
    const BodyStates want = forward_kinematics(robot().skeleton, s);
    const BodyStates& got = sim.body_states(0);
    EXPECT_LT((got.pos - want.pos).cwiseAbs().maxCoeff(), 1e-9) << "t " << t;
    for (int i = 0; i < got.num_bodies(); ++i)
      EXPECT_GT(std::abs(got.rot[static_cast<std::size_t>(i)].dot(want.rot[static_cast<std::size_t>(i)])), 1 - 1e-12)
          << robot().skeleton.names[static_cast<std::size_t>(i)];
    EXPECT_LT((got.lin_vel - want.lin_vel).cwiseAbs().maxCoeff(), 1e-8) << "t " << t;
    EXPECT_LT((got.ang_vel - want.ang_vel).cwiseAbs().maxCoeff(), 1e-8) << "t " << t;
    EXPECT_LT((sim.joint_angles(0) - s.q).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(G1Character, SavedStateContinuesBitExactly) {
  MujocoHumanoidSim a(1, 1, robot()), b(1, 1, robot());
  Rng rng(5);
  auto targets = [&] {
    MatrixXd u(29, 1);
    for (int k = 0; k < 29; ++k) u(k, 0) = robot().standing.q[k] + 0.2 * (rng.uniform() - 0.5);
    return u;
  };
  for (int s = 0; s < 10; ++s) a.step(targets());
  b.load_state(0, a.save_state(0));
  for (int s = 0; s < 10; ++s) {
    const MatrixXd u = targets();
    a.step(u);
    b.step(u);
  }
  EXPECT_EQ(a.save_state(0), b.save_state(0));
}

TEST(G1Character, AModelThatDisagreesWithTheSkeletonIsRefusedByName) {
  MujocoCharacter c = robot();
  c.joint_names[3] = "left_knee_typo";
  EXPECT_NE(error_of([&] { MujocoHumanoidSim sim(1, 1, c); }).find("left_knee_typo"), std::string::npos);
  c = robot();
  std::swap(c.joint_names[0], c.joint_names[1]);  // a hinge on another body than its DoF's
  EXPECT_NE(error_of([&] { MujocoHumanoidSim sim(1, 1, c); }).find("is not on body"), std::string::npos);
  c = robot();
  c.physics_dt *= 2;
  EXPECT_NE(error_of([&] { MujocoHumanoidSim sim(1, 1, c); }).find("physics_dt"), std::string::npos);
  EXPECT_NE(error_of([] { (void)mujoco_character("robot", "--character"); }).find("--character"), std::string::npos);
}

TEST(G1Character, TheHumanoidCharacterIsTheDescriptionsModel) {
  // the humanoid through its character and through its description: the same simulator
  MujocoHumanoidSim by_desc(1), by_character(1, 1, mujoco_character("humanoid"));
  EXPECT_EQ(by_character.character().mjcf, humanoid_mjcf(humanoid_description()));
  MatrixXd u = MatrixXd::Constant(63, 1, 0.1);
  for (int s = 0; s < 5; ++s) {
    by_desc.step(u);
    by_character.step(u);
  }
  EXPECT_EQ(by_desc.save_state(0), by_character.save_state(0));
}

// The robot's shipped walkers (models/README.md): policy-only exports on the robot's dims that say
// how they were trained, and that walk 10 s on the simulated robot from a real walk's frames.
TEST(ShippedG1Models, WalkTenSecondsOnTheRobot) {
  const std::string data = motion_data_dir(maskadapt::build_paths::default_data_dir());
  const std::string walk = data + "/motions/bandai/locomotion/dataset-1_walk_normal_001.bvh";
  struct Model {
    const char* file;
    long long iteration;
    bool masked;
    const char* mask;  ///< the mask it walks with
  };
  for (const Model m : {Model{"g1_amp_walk_bandai.bin", 5969, false, "none"},
                        Model{"g1_mask_mi_walk_bandai.bin", 7470, true, "left_leg,right_leg"}}) {
    const std::string path = maskadapt::build_paths::source_dir() + "/models/" + m.file;
    const Checkpoint c = load_checkpoint(path);
    ASSERT_TRUE(train::is_policy_export(c)) << path;
    EXPECT_EQ(train::checkpoint_character(c), "g1") << path;
    const Skeleton& skel = robot().skeleton;
    const Index d = observation_dim(skel);
    const train::LoadedBasePolicy base = train::load_base_policy(c, {d, d + kNumParts, 29, d * kAmpWindowFrames}, path);
    EXPECT_EQ(c.get_int("trainer/iteration"), m.iteration) << path;
    EXPECT_EQ(base.config.env.motions, std::vector<std::string>{"bandai-walk"}) << path;
    EXPECT_EQ(base.config.mask.prob > 0, m.masked) << path;
    EXPECT_NE(train::export_provenance(c).note.find("--character g1"), std::string::npos) << path;
    if (!std::filesystem::exists(walk)) {
      std::cout << "ShippedG1Models: the rollout needs the shared Bandai walks (MASKADAPT_DATA_DIR); skipped\n";
      continue;
    }
    auto lib = train::load_motion_library({walk}, data, robot());
    MujocoHumanoidSim sim(1, 1, robot());
    train::PlayOptions opt;
    opt.seconds = 10;
    opt.deterministic = true;
    opt.masks = MaskSampler::fixed(PartMask::parse(m.mask));
    const train::PlayResult r = train::play_base_policy(sim, base.policy, train::library_reset_sampler(lib), opt,
                                                        eval::make_rollout(robot()), robot().fall_criteria(0.3), 0.3);
    const Vec3 moved = r.root.col(r.root.cols() - 1) - r.root.col(0);
    EXPECT_TRUE(r.fall_times.empty()) << path << ", mask " << m.mask << ": fell at " << r.fall_times.front() << " s";
    EXPECT_GT(std::hypot(moved.x(), moved.y()), 3.0) << path << ": metres walked in 10 s, mask " << m.mask;
  }
}
