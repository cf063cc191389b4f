#include <maskadapt/rl/amp_loss.hpp>
#include <maskadapt/rl/ppo_loss.hpp>

#include <gtest/gtest.h>

#include <cmath>

using namespace maskadapt;
using namespace maskadapt::rl;
using RowVectorXd = maskadapt::RowVectorX<double>;

TEST(PpoLoss, SurrogateKnownValuesAndGradient) {
  RowVectorXd lp_old(4), lp_new(4), adv(4), g;
  lp_old << 0, 0, 0, 0;
  // ρ = 1.1 (inside), 1.5 with A>0 (clipped: constant), 1.5 with A<0 (unclipped min), 0.5 with A<0 (clipped)
  lp_new << std::log(1.1), std::log(1.5), std::log(1.5), std::log(0.5);
  adv << 2, 1, -1, -3;
  const auto r = clipped_surrogate<double>(lp_new, lp_old, adv, 0.2, g);
  const double expected = -(1.1 * 2 + 1.2 * 1 + 1.5 * -1 + 0.8 * -3) / 4;
  EXPECT_NEAR(r.loss, expected, 1e-12);
  EXPECT_NEAR(g(0), -1.1 * 2 / 4, 1e-12);
  EXPECT_EQ(g(1), 0.0);
  EXPECT_NEAR(g(2), -1.5 * -1 / 4, 1e-12);
  EXPECT_EQ(g(3), 0.0);
  EXPECT_DOUBLE_EQ(r.clip_frac, 0.75);
  EXPECT_GT(r.approx_kl, 0.0);
  // Finite differences of the loss w.r.t. each new log-prob (away from the kinks).
  for (Index i = 0; i < 4; ++i) {
    RowVectorXd p = lp_new, m = lp_new, tmp;
    p(i) += 1e-6;
    m(i) -= 1e-6;
    const double fd = (clipped_surrogate<double>(p, lp_old, adv, 0.2, tmp).loss -
                       clipped_surrogate<double>(m, lp_old, adv, 0.2, tmp).loss) / 2e-6;
    EXPECT_NEAR(g(i), fd, 1e-8) << i;
  }
  // Identical policies: no KL, nothing clipped, loss = −mean A.
  const auto same = clipped_surrogate<double>(lp_old, lp_old, adv, 0.2, g);
  EXPECT_DOUBLE_EQ(same.approx_kl, 0.0);
  EXPECT_DOUBLE_EQ(same.clip_frac, 0.0);
  EXPECT_DOUBLE_EQ(same.loss, -adv.mean());
}

TEST(PpoLoss, ValueLossClippedAndUnclippedGradients) {
  MatrixXd v(2, 3), vo(2, 3), ret(2, 3), g;
  v << 0.1, 1.0, -0.5, 2.0, 0.0, 0.3;
  vo << 0.0, 0.0, 0.0, 0.0, 0.0, 0.0;
  ret << 1.0, -1.0, 0.2, 0.5, 0.05, -2.0;
  EXPECT_NEAR(value_loss<double>(v, vo, ret, 0.0, g), (v - ret).array().square().mean(), 1e-12);
  for (double clip : {0.0, 0.2}) {
    value_loss<double>(v, vo, ret, clip, g);
    for (Index i = 0; i < v.size(); ++i) {
      MatrixXd p = v, m = v, t;
      p.data()[i] += 1e-6;
      m.data()[i] -= 1e-6;
      const double fd = (value_loss<double>(p, vo, ret, clip, t) - value_loss<double>(m, vo, ret, clip, t)) / 2e-6;
      EXPECT_NEAR(g.data()[i], fd, 1e-7) << "clip " << clip << " entry " << i;
    }
  }
}

TEST(PpoLoss, NormalizeRows) {
  MatrixXd a(2, 4);
  a << 1, 2, 3, 4, 5, 5, 5, 5;
  normalize_rows(a);
  EXPECT_NEAR(a.row(0).mean(), 0.0, 1e-12);
  EXPECT_NEAR(a.row(0).squaredNorm() / 4, 1.0, 1e-6);
  EXPECT_EQ(a.row(1), RowVectorXd::Zero(4));
}

TEST(AmpLoss, ObjectivesMatchFiniteDifferencesAndKnownValues) {
  RowVectorXd real(3), fake(2), gr, gf;
  real << 0.5, -1.0, 3.0;
  fake << -2.0, 0.7;
  for (auto kind : {DiscriminatorLoss::BCE, DiscriminatorLoss::LSGAN}) {
    const auto o = amp_objective<double>(kind, real, fake, gr, gf);
    for (int side = 0; side < 2; ++side) {
      RowVectorXd& x = side == 0 ? real : fake;
      const RowVectorXd& g = side == 0 ? gr : gf;
      for (Index i = 0; i < x.cols(); ++i) {
        RowVectorXd t1, t2;
        const double keep = x(i);
        x(i) = keep + 1e-6;
        const double lp = amp_objective<double>(kind, real, fake, t1, t2).loss;
        x(i) = keep - 1e-6;
        const double lm = amp_objective<double>(kind, real, fake, t1, t2).loss;
        x(i) = keep;
        EXPECT_NEAR(g(i), (lp - lm) / 2e-6, 1e-8);
      }
    }
    EXPECT_DOUBLE_EQ(o.accuracy, 3.0 / 5.0);  // real −1.0 and fake 0.7 misclassified
  }
  // BCE at d = 0 everywhere: L = log 2.
  RowVectorXd z = RowVectorXd::Zero(2);
  EXPECT_NEAR(amp_objective<double>(DiscriminatorLoss::BCE, z, z, gr, gf).loss, std::log(2.0), 1e-12);
  // LSGAN perfect discriminator: zero loss.
  EXPECT_DOUBLE_EQ(amp_objective<double>(DiscriminatorLoss::LSGAN, RowVectorXd::Ones(2), -RowVectorXd::Ones(2), gr, gf).loss, 0.0);
}

TEST(AmpLoss, Rewards) {
  RowVectorXd d(3);
  d << 0.0, 100.0, -3.0;
  const RowVectorXd r = amp_reward<double>(DiscriminatorLoss::BCE, d);
  EXPECT_NEAR(r(0), std::log(2.0), 1e-12);
  EXPECT_NEAR(r(1), -std::log(1e-4), 1e-9);  // clamped: 1 − D never below 1e−4
  EXPECT_NEAR(r(2), -std::log(1.0 - 1.0 / (1.0 + std::exp(3.0))), 1e-12);
  const RowVectorXd l = amp_reward<double>(DiscriminatorLoss::LSGAN, d);
  EXPECT_DOUBLE_EQ(l(0), 0.75);
  EXPECT_DOUBLE_EQ(l(1), 0.0);
  EXPECT_DOUBLE_EQ(l(2), 0.0);
  EXPECT_TRUE(r.allFinite());
}
