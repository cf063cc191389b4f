// The H_norm threshold probes (eval/threshold_probes.hpp) on reference frames with known
// distances: two clips of 10 frames on a line, 1 apart within a clip and 100 apart between clips.
#include <maskadapt/eval/threshold_probes.hpp>

#include <gtest/gtest.h>

#include <cmath>

using namespace maskadapt;
using maskadapt::eval::probe_thresholds;

namespace {

MatrixXf two_line_clips() {
  MatrixXf r = MatrixXf::Zero(1, 20);  // (1 × 20): clip A at x = 0..9, clip B at x = 100..109
  for (Index i = 0; i < 10; ++i) {
    r(0, i) = static_cast<float>(i);
    r(0, 10 + i) = static_cast<float>(100 + i);
  }
  return r;
}

}  // namespace

// Threshold 0.5: every frame visits only itself. A frozen pose visits one frame (0), one clip
// visits its 10 frames evenly (log 10 / log 20), a long replay covers all 20 almost evenly.
TEST(ThresholdProbes, ASmallThresholdSeparatesReplayFromCollapseByClosedForm) {
  eval::ThresholdProbeOptions opt;
  opt.windows = 64;
  opt.window_frames = 10;
  opt.counting = eval::VisitCounting::all_within;
  const auto p = probe_thresholds(two_line_clips(), {10, 10}, {0.5}, opt);
  ASSERT_EQ(p.size(), 1u);
  EXPECT_DOUBLE_EQ(p[0].frozen, 0.0);
  EXPECT_DOUBLE_EQ(p[0].frozen_max, 0.0);
  EXPECT_NEAR(p[0].one_clip, std::log(10.0) / std::log(20.0), 1e-12);
  EXPECT_NEAR(p[0].one_clip_max, std::log(10.0) / std::log(20.0), 1e-12);
  EXPECT_GT(p[0].replay, 0.95);
  EXPECT_DOUBLE_EQ(p[0].replay_matched, 1.0);
}

// Threshold 1.5: a frozen frame visits itself and its neighbours in its clip (3 frames, 2 at a
// clip's ends). Threshold 1000: every frame visits every frame, so even a frozen pose scores 1 —
// the failure that the probes exist to catch.
TEST(ThresholdProbes, NeighboursCountUpToTheThresholdAndAHugeThresholdScoresEverythingOne) {
  eval::ThresholdProbeOptions opt;
  opt.probes = 16;
  opt.counting = eval::VisitCounting::all_within;
  const auto p = probe_thresholds(two_line_clips(), {10, 10}, {1.5, 1000.0}, opt);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_LE(p[0].frozen_max, std::log(3.0) / std::log(20.0) + 1e-12);
  EXPECT_GE(p[0].frozen, std::log(2.0) / std::log(20.0) - 1e-12);
  EXPECT_NEAR(p[1].frozen, 1.0, 1e-12);
  EXPECT_NEAR(p[1].one_clip, 1.0, 1e-12);
  EXPECT_NEAR(p[1].replay, 1.0, 1e-12);
}

// Nearest counting (the default): the frozen pose visits one frame and one clip its own frames at
// every threshold, so the probes keep their order however large the threshold.
TEST(ThresholdProbes, NearestCountingSeparatesTheProbesAtEveryThreshold) {
  eval::ThresholdProbeOptions opt;
  opt.windows = 64;
  opt.window_frames = 10;
  const auto p = probe_thresholds(two_line_clips(), {10, 10}, {0.5, 1.5, 1000.0}, opt);
  for (const auto& q : p) {
    EXPECT_DOUBLE_EQ(q.frozen_max, 0.0) << q.threshold;
    EXPECT_NEAR(q.one_clip, std::log(10.0) / std::log(20.0), 1e-12) << q.threshold;
    EXPECT_GT(q.replay, 0.95) << q.threshold;
  }
}

TEST(ThresholdProbes, InconsistentClipLengthsAndBadThresholdsAreErrors) {
  const MatrixXf r = two_line_clips();
  EXPECT_THROW(probe_thresholds(r, {10, 9}, {0.5}), Error);
  EXPECT_THROW(probe_thresholds(r, {10, 0, 10}, {0.5}), Error);
  EXPECT_THROW(probe_thresholds(r, {}, {0.5}), Error);
  EXPECT_THROW(probe_thresholds(r, {10, 10}, {std::nan("")}), Error);
  EXPECT_THROW(probe_thresholds(r, {10, 10}, {-1.0}), Error);
}
