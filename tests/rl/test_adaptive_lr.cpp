// The adaptive-KL learning-rate rule (rl/adaptive_lr.hpp) on hand-computed cases.
#include <maskadapt/rl/adaptive_lr.hpp>

#include <gtest/gtest.h>

#include <cmath>

using namespace maskadapt;
using maskadapt::rl::adapt_learning_rate;
using maskadapt::rl::AdaptiveKlSchedule;

TEST(AdaptiveLr, StepsFollowTheKlAgainstItsTarget) {
  const AdaptiveKlSchedule s;  // target 0.01, factor 1.5, [1e-6, 1e-2]
  EXPECT_DOUBLE_EQ(adapt_learning_rate(1e-4, 0.03, s), 1e-4 / 1.5);   // > 2·target: smaller
  EXPECT_DOUBLE_EQ(adapt_learning_rate(1e-4, 0.001, s), 1e-4 * 1.5);  // < target/2: larger
  EXPECT_DOUBLE_EQ(adapt_learning_rate(1e-4, 0.01, s), 1e-4);         // in the band: unchanged
  EXPECT_DOUBLE_EQ(adapt_learning_rate(1e-4, 0.02, s), 1e-4);         // band edges are inclusive
  EXPECT_DOUBLE_EQ(adapt_learning_rate(1e-4, 0.005, s), 1e-4);
  EXPECT_DOUBLE_EQ(adapt_learning_rate(1e-4, NAN, s), 1e-4 / 1.5);    // a blown-up step: smaller
  EXPECT_DOUBLE_EQ(adapt_learning_rate(1e-2, 0.0, s), 1e-2);          // clamped at max_lr
  EXPECT_DOUBLE_EQ(adapt_learning_rate(1.2e-6, 1.0, s), 1e-6);        // clamped at min_lr
}

// Fed a KL that scales with lr² (a step's KL grows as the square of its size), the rule settles
// at the rate whose KL is inside [target/2, 2·target] and stays there.
TEST(AdaptiveLr, SettlesWhereTheKlMeetsTheTarget) {
  const AdaptiveKlSchedule s;
  const double kl_per_lr2 = 1e6;  // KL = 1e6·lr²: target 0.01 ⇔ lr = 1e-4
  double lr = 1e-6;
  for (int k = 0; k < 40; ++k) lr = adapt_learning_rate(lr, kl_per_lr2 * lr * lr, s);
  const double kl = kl_per_lr2 * lr * lr;
  EXPECT_GE(kl, 0.5 * s.desired_kl);
  EXPECT_LE(kl, 2.0 * s.desired_kl);
  EXPECT_DOUBLE_EQ(adapt_learning_rate(lr, kl, s), lr);
}

TEST(AdaptiveLr, BadSchedulesNameTheirField) {
  AdaptiveKlSchedule s;
  s.factor = 1.0;
  try {
    s.validate("ppo.adaptive_lr");
    FAIL() << "factor 1 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ppo.adaptive_lr.factor"), std::string::npos) << e.what();
  }
  s = AdaptiveKlSchedule{};
  s.min_lr = 1e-2;
  s.max_lr = 1e-3;
  EXPECT_THROW(s.validate(), Error);
  s = AdaptiveKlSchedule{};
  s.desired_kl = NAN;
  EXPECT_THROW(s.validate(), Error);
}
