#include <maskadapt/train/progress.hpp>
#include <maskadapt/tasks/imitation.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>

using namespace maskadapt;
using namespace maskadapt::train;

TEST(TrainProgress, DurationFormatting) {
  EXPECT_EQ(format_duration(12.4), "12s");
  EXPECT_EQ(format_duration(185), "3m05s");
  EXPECT_EQ(format_duration(3720), "1h02m");
  EXPECT_EQ(format_duration(NAN), "--");
}

TEST(TrainProgress, ProgressLineShowsTheKeyNumbers) {
  IterationStats s;
  s.iteration = 120;
  s.samples_per_s = 3140;
  s.episode_length = 6.21;
  s.disc_reward = 0.412;
  s.mi_kl = 0.0312;
  s.time_sim = 4;
  s.time_inference = 2;
  s.time_update = 4;
  s.time_disc = 1.5;  // part of the update
  s.eta_s = 1270;
  const auto line = format_progress(s, 500);
  EXPECT_NE(line.find("120/500"), std::string::npos) << line;
  EXPECT_NE(line.find("3140 sps"), std::string::npos) << line;
  EXPECT_NE(line.find("6.21 s"), std::string::npos) << line;
  EXPECT_NE(line.find("r_D 0.412"), std::string::npos) << line;
  EXPECT_NE(line.find("KL_MI 0.0312"), std::string::npos) << line;
  EXPECT_NE(line.find("sim 40%"), std::string::npos) << line;
  EXPECT_NE(line.find("upd 40% (disc 15%)"), std::string::npos) << line;
  EXPECT_NE(line.find("ETA 21m10s"), std::string::npos) << line;
}

TEST(TrainProgress, JsonlLogWritesOneParsableObjectPerLine) {
  const auto path = (std::filesystem::temp_directory_path() / "maskadapt_log_test.jsonl").string();
  {
    JsonlLog log(path);
    IterationStats s;
    for (int i = 1; i <= 3; ++i) {
      s.iteration = i;
      s.episode_length = i == 2 ? NAN : 1.5 * i;
      log.write(to_json(s));
    }
  }
  {
    JsonlLog log(path, /*append=*/true);
    IterationStats s;
    s.iteration = 4;
    log.write(to_json(s));
  }
  std::ifstream in(path);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    const auto j = nlohmann::json::parse(line);
    ++n;
    EXPECT_EQ(j.at("iteration").get<int>(), n);
    for (const char* key : {"samples", "samples_per_s", "episode_length", "disc_reward", "disc_real", "disc_fake",
                            "mi_kl", "policy_loss", "value_loss", "entropy", "approx_kl", "clip_frac", "grad_norm",
                            "time_sim", "time_inference", "time_update", "time_disc", "time_ppo", "time_disc_reward",
                            "time_disc_real_windows", "skipped_updates"})
      EXPECT_TRUE(j.contains(key)) << key;
    if (n == 2) {
      EXPECT_TRUE(j.at("episode_length").is_null());  // NaN → null, still valid JSON
    }
  }
  EXPECT_EQ(n, 4);
  std::filesystem::remove(path);
}

// A resumed run first cuts its log back to the checkpoint's iteration: the lines of iterations a
// killed run logged after its last checkpoint (which the resumed run repeats) and an unfinished
// last line are dropped; lines without an iteration stay; a missing log is left missing.
TEST(TrainProgress, ResumedLogDropsTheIterationsItWillRepeat) {
  const auto path = (std::filesystem::temp_directory_path() / "maskadapt_log_resume_test.jsonl").string();
  {
    std::ofstream out(path, std::ios::trunc);
    out << R"({"note":"header"})" << '\n';
    for (int i = 1; i <= 7; ++i) out << R"({"iteration":)" << i << "}\n";
    out << R"({"iteration":8,"samp)";  // killed in mid-write
  }
  drop_log_lines_after(path, 5);
  {
    JsonlLog log(path, /*append=*/true);
    log.write(nlohmann::json{{"iteration", 6}});
  }
  std::ifstream in(path);
  std::string line;
  std::vector<long long> its;
  int without = 0;
  while (std::getline(in, line)) {
    const auto j = nlohmann::json::parse(line);
    if (j.contains("iteration")) its.push_back(j["iteration"].get<long long>());
    else ++without;
  }
  EXPECT_EQ(its, (std::vector<long long>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(without, 1);
  std::filesystem::remove(path);
  EXPECT_NO_THROW(drop_log_lines_after(path, 5));
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(TrainProgress, FinishIterationStatsDerivesTheEpisodeColumns) {
  const tasks::EpisodeStats es{
      .episodes = 4, .falls = 1, .total_seconds = 10.0, .steps = 200, .masked_steps = 150, .sim_resets = 2};
  IterationStats st;
  finish_iteration_stats(st, 7, 7168, 1024, 0.5, es);
  EXPECT_EQ(st.iteration, 7);
  EXPECT_EQ(st.samples, 7168);
  EXPECT_DOUBLE_EQ(st.samples_per_s, 2048.0);
  EXPECT_DOUBLE_EQ(st.time_total, 0.5);
  EXPECT_DOUBLE_EQ(st.episode_length, 2.5);
  EXPECT_DOUBLE_EQ(st.episodes, 4.0);
  EXPECT_DOUBLE_EQ(st.fall_rate, 0.25);
  EXPECT_DOUBLE_EQ(st.mask_fraction, 0.75);
  EXPECT_EQ(st.sim_resets, 2);
  finish_iteration_stats(st, 8, 8192, 1024, 0.5, tasks::EpisodeStats{});  // nothing ended
  EXPECT_TRUE(std::isnan(st.episode_length));
  EXPECT_TRUE(std::isnan(st.fall_rate));
  EXPECT_DOUBLE_EQ(st.mask_fraction, 0.0);
}
