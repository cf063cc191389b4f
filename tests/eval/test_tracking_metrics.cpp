#include <maskadapt/eval/tracking_metrics.hpp>

#include <gtest/gtest.h>

using namespace maskadapt;
using namespace maskadapt::eval;

namespace {
// Two designated bodies; body b is displaced from its target by `d[b]` along x.
std::pair<Matrix3X, Matrix3X> frame(double d0, double d1) {
  Matrix3X target(3, 2);
  target << 0.1, -0.3, 0.2, 0.4, 1.0, 1.2;
  Matrix3X actual = target;
  actual(0, 0) += d0;
  actual(0, 1) += d1;
  return {actual, target};
}
}  // namespace

TEST(TrackingMetrics, MeanPositionErrorKnownValue) {
  Matrix3X target = Matrix3X::Zero(3, 2), actual(3, 2);
  actual << 0.3, 0.0, 0.0, 0.4, 0.0, 0.0;  // deviations 0.3 and 0.4 m
  EXPECT_NEAR(mean_position_error(actual, target), 0.35, 1e-15);
  actual.col(1) << 0.0, 0.3, 0.4;  // 0.5 m
  EXPECT_NEAR(mean_position_error(actual, target), 0.4, 1e-15);
}

TEST(TrackingMetrics, EpisodeErrorAndSuccess) {
  TrackingEpisode ok, fails;
  for (double d : {0.1, 0.2, 0.3}) {
    auto [a, t] = frame(d, d);
    ok.add_frame(a, t);
  }
  EXPECT_NEAR(ok.mean_error(), 0.2, 1e-12);
  EXPECT_TRUE(ok.success());
  for (double d : {0.1, 0.6, 0.1}) {  // one frame deviates by 0.6 m > 0.5 m
    auto [a, t] = frame(d, d);
    fails.add_frame(a, t);
  }
  EXPECT_NEAR(fails.mean_error(), 0.8 / 3, 1e-12);
  EXPECT_NEAR(fails.max_mean_deviation(), 0.6, 1e-12);
  EXPECT_FALSE(fails.success());
}

TEST(TrackingMetrics, DeviationModesDiffer) {
  // Body deviations 0.2 and 0.7: the mean (0.45) is within 0.5 m, one body is not.
  TrackingEpisode mean_mode(0.5, DeviationMode::MeanOverBodies), any_mode(0.5, DeviationMode::AnyBody);
  auto [a, t] = frame(0.2, 0.7);
  mean_mode.add_frame(a, t);
  any_mode.add_frame(a, t);
  EXPECT_TRUE(mean_mode.success());
  EXPECT_FALSE(any_mode.success());
  EXPECT_NEAR(any_mode.max_body_deviation(), 0.7, 1e-12);
}

TEST(TrackingMetrics, SummaryCountsAndRates) {
  TrackingSummary s;
  EXPECT_EQ(s.success_rate(), 0.0);
  for (int e = 0; e < 4; ++e) {
    TrackingEpisode ep;
    const int frames = e + 1;  // 1, 2, 3, 4 frames
    for (int f = 0; f < frames; ++f) {
      auto [a, t] = frame(e == 3 ? 0.9 : 0.1 * (e + 1), 0.1 * (e + 1));  // episode 3 fails
      ep.add_frame(a, t);
    }
    s.add(ep);
  }
  EXPECT_EQ(s.episodes, 4);
  EXPECT_EQ(s.successes, 3);
  EXPECT_DOUBLE_EQ(s.success_rate(), 0.75);
  EXPECT_EQ(s.frames, 10);
  // Episode means: 0.1, 0.2, 0.3, (0.9 + 0.4)/2 = 0.65.
  EXPECT_NEAR(s.mean_error_per_episode(), (0.1 + 0.2 + 0.3 + 0.65) / 4, 1e-12);
  EXPECT_NEAR(s.mean_error_per_frame(), (0.1 * 1 + 0.2 * 2 + 0.3 * 3 + 0.65 * 4) / 10, 1e-12);
  TrackingSummary twice = s;
  twice += s;
  EXPECT_EQ(twice.episodes, 8);
  EXPECT_DOUBLE_EQ(twice.success_rate(), 0.75);
}

TEST(TrackingMetrics, RejectsBadInput) {
  EXPECT_THROW(mean_position_error(Matrix3X::Zero(3, 2), Matrix3X::Zero(3, 3)), Error);
  EXPECT_THROW(mean_position_error(Matrix3X::Zero(3, 0), Matrix3X::Zero(3, 0)), Error);
  Matrix3X bad = Matrix3X::Zero(3, 1);
  bad(2, 0) = std::nan("");
  EXPECT_THROW(mean_position_error(bad, Matrix3X::Zero(3, 1)), Error);
  EXPECT_THROW(TrackingEpisode(0.0), Error);
  TrackingEpisode empty;
  EXPECT_THROW((void)empty.success(), Error);
  TrackingSummary s;
  EXPECT_THROW(s.add(empty), Error);
}
