// The training snapshots committed under models/training/ (models/README.md): compacted base-
// training checkpoints (`maskadapt checkpoint compact`) that a later session continues with
// `train-base --resume`. Each must load with its checksum verified, have no replay buffer, and
// resume with today's code on its character in MuJoCo (the humanoid, or the G1-like robot for a
// run with env.character "g1"): one iteration runs, moves the policy and refills the replay
// buffer. Needs the motions the run trained on (skips without them).
#include "../build_paths.hpp"
#include "../motion/test_util.hpp"

#include <maskadapt/sim/mujoco/humanoid_sim.hpp>
#include <maskadapt/train/base_trainer.hpp>
#include <maskadapt/train/motion_sources.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

using namespace maskadapt;
using namespace maskadapt::train;

namespace {

std::vector<std::string> committed_snapshots() {
  std::vector<std::string> out;
  const std::filesystem::path dir = maskadapt::build_paths::source_dir() + "/models/training";
  if (std::filesystem::is_directory(dir))
    for (const auto& e : std::filesystem::directory_iterator(dir))
      if (e.path().extension() == ".ckpt") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

TEST(TrainingSnapshots, EachCommittedSnapshotResumesOnItsCharacter) {
  const auto snapshots = committed_snapshots();
  if (snapshots.empty()) GTEST_SKIP() << "no models/training/*.ckpt";
  MASKADAPT_REQUIRE_MOTIONS(bandai, "bandai");
  (void)bandai;
  for (const auto& path : snapshots) {
    SCOPED_TRACE(path);
    const Checkpoint c = load_checkpoint(path);
    EXPECT_FALSE(c.contains("replay/storage")) << "commit the compacted form (maskadapt checkpoint compact)";
    EXPECT_NE(c.get_string("provenance/history").find("train-base"), std::string::npos);
    BaseTrainConfig cfg = config_from_string(c.get_string("config"), path + " (config)");
    cfg.run.threads = 1;
    const MujocoCharacter& character = mujoco_character(cfg.env.character, path + " (env.character)");
    auto lib = load_motion_library(cfg.env.motions, test::data_base_dir(), character);
    ThreadPool pool(1);
    MujocoHumanoidSim sim(static_cast<std::size_t>(cfg.env.num_envs), pool, character);
    BaseTrainer<MujocoHumanoidSim> trainer(sim, library_reset_sampler(lib), library_window_sampler(lib, &pool), cfg, &pool,
                                           character.fall_criteria(cfg.env.termination_height));
    trainer.load(c);
    const long long it = trainer.iteration();
    const VectorXf before = c.get_vector<float>("actor/params");
    const IterationStats st = trainer.iterate();
    EXPECT_EQ(trainer.iteration(), it + 1);
    EXPECT_EQ(st.skipped_updates, 0);
    Checkpoint after;
    trainer.save(after);
    EXPECT_GT((after.get_vector<float>("actor/params") - before).cwiseAbs().maxCoeff(), 0.0f);
    EXPECT_EQ(after.get_int("replay/size"), trainer.samples() - c.get_int("trainer/samples"));
  }
}
