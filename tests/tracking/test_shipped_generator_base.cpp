// Issue 42: the shipped generator (models/text_generator.bin) from the histories partial tracking
// actually gives it — walks of the shipped base (models/mask_mi_walk_bandai.bin) simulated by
// MuJoCo (train/base_walks.hpp; the source "base rollouts" of `eval-generator --per-source`: seeds 1
// and 2, 4 s, histories ending at 2 s and 3 s). Floors in shipped_generator_floors.hpp.
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>
#include <maskadapt/tracking/arm_eval.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/base_walks.hpp>
#include <maskadapt/train/config.hpp>
#include <maskadapt/train/motion_sources.hpp>

#include "../build_paths.hpp"
#include "shipped_generator_floors.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

using namespace maskadapt;
using namespace maskadapt::tracking;

namespace {

std::string data_dir() {
  const char* env = std::getenv("MASKADAPT_DATA_DIR");
  return env && *env ? std::string(env) : maskadapt::build_paths::default_data_dir();
}

/// Rollouts of the shipped base, as eval-generator --per-source draws them.
std::vector<MotionClip> shipped_base_walks(const std::vector<std::uint64_t>& seeds, double seconds) {
  const std::string path = maskadapt::build_paths::source_dir() + "/models/mask_mi_walk_bandai.bin";
  const Checkpoint ck = load_checkpoint(path);
  const MujocoCharacter& character = mujoco_character(train::checkpoint_character(ck, path), path);
  MujocoHumanoidSim sim(1, 1, character);
  const train::PolicyDims dims{observation_dim(sim.skeleton()), observation_dim(sim.skeleton()) + kNumParts,
                               sim.skeleton().num_dofs(), observation_dim(sim.skeleton()) * kAmpWindowFrames};
  const train::LoadedBasePolicy loaded = train::load_base_policy(ck, dims, path);
  auto lib = train::load_motion_library(loaded.config.env.motions, data_dir(), character);
  return train::base_policy_walks(sim, loaded.policy, train::library_reset_sampler(lib),
                                  character.fall_criteria(loaded.config.env.termination_height),
                                  loaded.config.env.termination_height, seeds, seconds);
}

}  // namespace

TEST(BaseWalks, AreThirtyHertzWalksOfTheSimulatedBase) {
  if (!std::filesystem::is_directory(data_dir() + "/motions/bandai/locomotion"))
    GTEST_SKIP() << "no Bandai walks under " << data_dir() << "/motions: the base's reset states need them";
  const auto walks = shipped_base_walks({1, 2}, 2.0);
  ASSERT_EQ(walks.size(), 2u);
  for (const auto& w : walks) {
    EXPECT_EQ(w.fps, 30.0);
    EXPECT_EQ(w.num_frames(), 61);  // frame 0 and one per control step of 1/30 s
    EXPECT_EQ(w.labels, (std::vector<std::string>{"walk forward", "walk"}));
    const double moved = (w.root_pos.col(60) - w.root_pos.col(0)).head<2>().norm();
    EXPECT_GT(moved, 0.5) << w.name;  // it walks (the base's walking speed is about 1 m/s)
  }
  EXPECT_NE(walks[0].q, walks[1].q);  // two seeds, two starts
  EXPECT_EQ(shipped_base_walks({1}, 2.0)[0].q, walks[0].q);  // one seed, one rollout
}

TEST(ShippedGenerator, FollowsItsArmsPromptsFromTheSimulatedBase) {
  const std::string dir = data_dir();
  if (!std::filesystem::is_directory(dir + "/motions/bandai/gestures"))
    GTEST_SKIP() << "no arm clips under " << dir << "/motions (set MASKADAPT_DATA_DIR): the probe needs them";
  const Skeleton& skel = humanoid_skeleton();
  BuiltinGenerator g = BuiltinGenerator::load(maskadapt::build_paths::source_dir() + "/models/text_generator.bin", skel);
  Rng rng(12345);
  const GeneratorEvalSet ev = make_generator_eval_set(dir, skel, rng);
  std::vector<LabelledTrajectory> l;
  for (const auto& w : shipped_base_walks({1, 2}, 4.0)) l.push_back(labelled_from_clip(w, skel));
  const WalkingHistorySource src = walking_history_source("base rollouts", skel, l, {60, 90}, g.history_frames());
  PromptEvalOptions o;
  o.samples = 10;
  std::vector<std::vector<ArmWindowStats>> stats;
  const ArmFollowingReport r = evaluate_prompts(g, ev.prompts, src.histories, ev.classifier, o, &stats);
  test::expect_source_floor(summarise_source(src, r, stats), test::kBaseSourceFloor, test::report_table(r));
}
