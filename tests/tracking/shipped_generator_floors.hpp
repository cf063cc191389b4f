#pragma once
// Issue 42: what the shipped generator (models/text_generator.bin) must keep doing from every
// walking-history source, checked by test_shipped_generator.cpp (the shared data's walks and the
// synthetic walk) and test_shipped_generator_base.cpp (rollouts of the shipped base under MuJoCo).
// Each floor lies just below the figure measured with `maskadapt eval-generator --per-source`
// (10 samples per prompt, seeds 1-10; docs/generator.md "Any walking history").
#include <maskadapt/tracking/arm_eval.hpp>

#include <gtest/gtest.h>

#include <string>

namespace maskadapt::tracking::test {

struct SourceFloor {
  const char* source;
  double accuracy;         ///< probe accuracy over the 13 prompts
  double arms_high_share;  ///< share of "arms high" samples with a wrist ≥ 0.6 m above the pelvis
  double wave[3];          ///< shares of "wave right / left / both hands" samples with that wrist (both) above the head
  double speed_lo, speed_hi;  ///< generated walking speed over the history's, mean over all samples
};

// Measured 2026-12-07 (models/text_generator.bin of issue 42; 10 samples per prompt, seeds 1-10):
// accuracy 0.846 / 0.862 / 0.962 / 0.862 / 0.900 / 0.777 (base rollouts 0.923); "arms high" ≥ 0.6 m
// in every sample; every wave above the head in every sample except "wave both hands" from the
// synthetic walk (0 of 10: its right wrist stays below the head — issue 42's bar is missed there);
// speed ratios 0.859 / 0.985 / 0.873 / 0.888 / 1.038 / 0.786 (base 1.097); pelvis ratios within 0.02
// of 1. In the order of walking_history_sources:
inline constexpr SourceFloor kDataSourceFloors[] = {
    {"bandai", 0.82, 0.9, {0.9, 0.9, 0.9}, 0.84, 1.10},
    {"cmu 02_01", 0.84, 0.9, {0.9, 0.9, 0.9}, 0.95, 1.05},
    {"cmu 07_01", 0.94, 0.9, {0.9, 0.9, 0.9}, 0.85, 1.10},
    {"styles walk", 0.84, 0.9, {0.9, 0.9, 0.9}, 0.86, 1.10},
    {"styles female-walk", 0.88, 0.9, {0.9, 0.9, 0.9}, 0.95, 1.06},
    {"synthetic walk", 0.75, 0.9, {0.9, 0.9, 0.0}, 0.76, 1.10}};
inline constexpr SourceFloor kBaseSourceFloor = {"base rollouts", 0.90, 0.9, {0.9, 0.9, 0.9}, 0.95, 1.12};

/// The generated pelvis height over the history's (mean over all samples): measured within 0.02 of 1.
inline constexpr double kPelvisTolerance = 0.03;

inline void expect_source_floor(const SourceSummary& s, const SourceFloor& f, const std::string& table) {
  EXPECT_GE(s.accuracy, f.accuracy) << s.source << "\n" << table;
  EXPECT_GE(s.arms_high_share, f.arms_high_share) << s.source << "\n" << table;
  for (int k = 0; k < 3; ++k) EXPECT_GE(s.wave_share[k], f.wave[k]) << s.source << " wave " << k << "\n" << table;
  EXPECT_NEAR(s.pelvis_ratio, 1.0, kPelvisTolerance) << s.source;
  EXPECT_GE(s.speed_ratio, f.speed_lo) << s.source;
  EXPECT_LE(s.speed_ratio, f.speed_hi) << s.source;
}

inline std::string report_table(const ArmFollowingReport& r) {
  std::string t;
  for (std::size_t i = 0; i < r.classes.size(); ++i) t += r.classes[i] + ": " + std::to_string(r.accuracy[i]) + "\n";
  return t;
}

}  // namespace maskadapt::tracking::test
