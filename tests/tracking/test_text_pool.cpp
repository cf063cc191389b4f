#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/tracking/text_pool.hpp>

#include "../build_paths.hpp"

#include <gtest/gtest.h>

#include <cstdlib>

using namespace maskadapt;
using namespace maskadapt::tracking;

TEST(TextPool, LabelsFromClipNames) {
  EXPECT_EQ(text_from_clip_name("02_10_wash_self"), "wash self");
  EXPECT_EQ(text_from_clip_name("135_04_front_kick"), "front kick");
  EXPECT_EQ(text_from_clip_name("walk"), "walk");
}

TEST(TextPool, ArmsRelatedFilter) {
  EXPECT_TRUE(is_arms_related("raise arms"));
  EXPECT_TRUE(is_arms_related("Wave hands"));
  EXPECT_TRUE(is_arms_related("punch"));
  EXPECT_FALSE(is_arms_related("leg raise"));
  EXPECT_FALSE(is_arms_related("walk forward"));
  EXPECT_FALSE(is_arms_related("front kick"));
}

TEST(TextPool, PoolFromLabelledClips) {
  std::vector<LabelledTrajectory> clips(3);
  clips[0].texts = {"walk forward"};
  clips[1].texts = {"rotate arms", "swing arms"};
  clips[2].texts = {"punch", "rotate arms"};
  const auto pool = arms_text_pool(clips);
  EXPECT_EQ(pool, (std::vector<std::string>{"punch", "rotate arms", "swing arms"}));
  Rng rng(2);
  for (int i = 0; i < 20; ++i) EXPECT_TRUE(std::find(pool.begin(), pool.end(), sample_text(pool, rng)) != pool.end());
  EXPECT_THROW(arms_text_pool({clips[0]}), Error);
}

TEST(TextPool, SharedCmuClipsGiveAnArmsPool) {
  const char* env = std::getenv("MASKADAPT_DATA_DIR");
  const std::string dir = (env ? std::string(env) : maskadapt::build_paths::default_data_dir()) + "/motions/cmu";
  if (!std::filesystem::is_directory(dir)) GTEST_SKIP() << "no CMU clips under " << dir;
  std::vector<std::string> skipped;
  const auto clips = load_labelled_clips(dir, humanoid_skeleton(), &skipped);
  EXPECT_EQ(clips.size(), 15u) << (skipped.empty() ? "" : skipped[0]);
  const auto pool = arms_text_pool(clips);
  EXPECT_TRUE(std::find(pool.begin(), pool.end(), "wash self") != pool.end());
  EXPECT_TRUE(std::find(pool.begin(), pool.end(), "punch") != pool.end());
  EXPECT_TRUE(std::find(pool.begin(), pool.end(), "walk") == pool.end());
}
