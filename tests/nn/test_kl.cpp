#include <gtest/gtest.h>

#include <cmath>

#include "fd.hpp"
#include "maskadapt/nn/kl.hpp"

using namespace maskadapt;
using namespace maskadapt::nn;

namespace {
Eigen::MatrixXd kl_random(Rng& rng, Index r, Index c, double s = 1.0) {
  Eigen::MatrixXd m(r, c);
  for (Index i = 0; i < m.size(); ++i) m.data()[i] = s * rng.normal();
  return m;
}
}  // namespace

TEST(Kl, KnownValue) {
  // KL(N(0,1) ‖ N(1,2²)) = log 2 + (1 + 1)/8 − ½.
  Eigen::MatrixXd mp(1, 1), lp(1, 1), mq(1, 1), lq(1, 1);
  mp << 0;
  lp << 0;
  mq << 1;
  lq << std::log(2.0);
  EXPECT_NEAR(kl_diag_gaussian<double>(mp, lp, mq, lq)[0], std::log(2.0) + 0.25 - 0.5, 1e-15);
  // Reverse direction: KL(N(1,4) ‖ N(0,1)) = −log 2 + (4 + 1)/2 − ½.
  EXPECT_NEAR(kl_diag_gaussian<double>(mq, lq, mp, lp)[0], -std::log(2.0) + 2.5 - 0.5, 1e-15);
}

TEST(Kl, ZeroForIdenticalDistributionsWithZeroGradient) {
  Rng rng(3);
  const Eigen::MatrixXd m = kl_random(rng, 5, 7), ls = kl_random(rng, 5, 7, 0.5);
  const RowVectorX<double> kl = kl_diag_gaussian<double>(m, ls, m, ls);
  EXPECT_EQ(kl.cwiseAbs().maxCoeff(), 0.0);
  Eigen::MatrixXd a, b, c, d;
  kl_diag_gaussian_mean<double>(m, ls, m, ls, {&a, &b, &c, &d});
  EXPECT_EQ(a.cwiseAbs().maxCoeff() + b.cwiseAbs().maxCoeff() + c.cwiseAbs().maxCoeff() + d.cwiseAbs().maxCoeff(), 0.0);
  // And strictly positive otherwise.
  const Eigen::MatrixXd m2 = m + kl_random(rng, 5, 7, 0.1);
  EXPECT_GT(kl_diag_gaussian<double>(m, ls, m2, ls).minCoeff(), 0.0);
}

TEST(Kl, GradientsWrtBothSidesMatchFiniteDifferences) {
  for (int seed = 0; seed < 8; ++seed) {
    Rng rng(50 + seed);
    const Index d = 1 + static_cast<Index>(rng.uniform_int(6)), B = 1 + static_cast<Index>(rng.uniform_int(5));
    for (int shapes = 0; shapes < 4; ++shapes) {
      const bool p_shared = shapes & 1, q_shared = shapes & 2;
      Eigen::MatrixXd mp = kl_random(rng, d, B), mq = kl_random(rng, d, B);
      Eigen::MatrixXd lp = kl_random(rng, d, p_shared ? 1 : B, 0.5), lq = kl_random(rng, d, q_shared ? 1 : B, 0.5);
      const RowVectorX<double> w = kl_random(rng, 1, B);
      auto loss = [&] { return kl_diag_gaussian<double>(mp, lp, mq, lq).dot(w); };
      Eigen::MatrixXd gmp, glp, gmq, glq;
      kl_diag_gaussian_backward<double>(mp, lp, mq, lq, w, {&gmp, &glp, &gmq, &glq});
      EXPECT_LT(test::rel_error(gmp, test::central_diff<Eigen::MatrixXd>(mp, loss)), 1e-6) << "mean_p";
      EXPECT_LT(test::rel_error(glp, test::central_diff<Eigen::MatrixXd>(lp, loss)), 1e-6) << "log_std_p";
      EXPECT_LT(test::rel_error(gmq, test::central_diff<Eigen::MatrixXd>(mq, loss)), 1e-6) << "mean_q";
      EXPECT_LT(test::rel_error(glq, test::central_diff<Eigen::MatrixXd>(lq, loss)), 1e-6) << "log_std_q";

      // The fused mean version: value = mean of per-sample KL, gradient = weight/B · backward(1).
      Eigen::MatrixXd fmp, flp, fmq, flq;
      const double v = kl_diag_gaussian_mean<double>(mp, lp, mq, lq, {&fmp, &flp, &fmq, &flq}, {false, 3.0});
      EXPECT_NEAR(v, kl_diag_gaussian<double>(mp, lp, mq, lq).mean(), 1e-14);
      auto mean_loss = [&] { return 3.0 * kl_diag_gaussian<double>(mp, lp, mq, lq).mean(); };
      EXPECT_LT(test::rel_error(fmq, test::central_diff<Eigen::MatrixXd>(mq, mean_loss)), 1e-6);
      EXPECT_LT(test::rel_error(flq, test::central_diff<Eigen::MatrixXd>(lq, mean_loss)), 1e-6);
      EXPECT_LT(test::rel_error(fmp, test::central_diff<Eigen::MatrixXd>(mp, mean_loss)), 1e-6);
      EXPECT_LT(test::rel_error(flp, test::central_diff<Eigen::MatrixXd>(lp, mean_loss)), 1e-6);
    }
  }
}

TEST(Kl, StopGradientReallyStops) {
  Rng rng(9);
  const Eigen::MatrixXd mp = kl_random(rng, 4, 3), mq = kl_random(rng, 4, 3), lp = kl_random(rng, 4, 1, 0.4), lq = kl_random(rng, 4, 1, 0.4);
  Eigen::MatrixXd gmp = Eigen::MatrixXd::Constant(4, 3, 7.0), glp = Eigen::MatrixXd::Constant(4, 1, 7.0);
  Eigen::MatrixXd gmq, glq, ref_mq, ref_lq;
  kl_diag_gaussian_mean<double>(mp, lp, mq, lq, {&gmp, &glp, &gmq, &glq}, {true, 1.0});
  EXPECT_TRUE(gmp == Eigen::MatrixXd::Constant(4, 3, 7.0));  // untouched
  EXPECT_TRUE(glp == Eigen::MatrixXd::Constant(4, 1, 7.0));
  kl_diag_gaussian_mean<double>(mp, lp, mq, lq, {nullptr, nullptr, &ref_mq, &ref_lq});
  EXPECT_TRUE(gmq == ref_mq);  // q's gradient is the same as without stop-gradient
  EXPECT_TRUE(glq == ref_lq);
  EXPECT_GT(gmq.cwiseAbs().maxCoeff(), 0.0);
  const RowVectorX<double> ones = RowVectorX<double>::Ones(3);
  kl_diag_gaussian_backward<double>(mp, lp, mq, lq, ones, {&gmp, &glp, nullptr, nullptr}, true);
  EXPECT_TRUE(gmp == Eigen::MatrixXd::Constant(4, 3, 7.0));
}

TEST(Kl, MatchesMonteCarloEstimate) {
  // KL(p‖q) = E_{x~p}[log p(x) − log q(x)].
  Rng rng(21);
  const Index d = 3, N = 200000;
  Eigen::MatrixXd mp1(d, 1), mq1(d, 1), lp(d, 1), lq(d, 1);
  mp1 << 0.2, -0.5, 1.0;
  mq1 << 0.0, 0.3, 0.7;
  lp << -0.3, 0.1, 0.0;
  lq << 0.2, -0.2, 0.4;
  const double exact = kl_diag_gaussian<double>(mp1, lp, mq1, lq)[0];
  const Eigen::MatrixXd mp = mp1.replicate(1, N), mq = mq1.replicate(1, N);
  Eigen::MatrixXd x(d, N);
  gaussian_sample<double>(mp, lp, rng, x);
  RowVectorX<double> logp(N), logq(N);
  gaussian_log_prob<double>(mp, lp, x, logp);
  gaussian_log_prob<double>(mq, lq, x, logq);
  const RowVectorX<double> diff = logp - logq;
  const double mc = diff.mean();
  const double se = std::sqrt((diff.array() - mc).square().mean() / N);
  EXPECT_NEAR(mc, exact, 4 * se) << "exact " << exact << " mc " << mc << " se " << se;
  EXPECT_GT(exact, 0.1);
}

TEST(Kl, ShapeErrors) {
  Eigen::MatrixXd a(3, 4), b(3, 5), l(3, 1);
  EXPECT_THROW(kl_diag_gaussian<double>(a, l, b, l), Error);
  Eigen::MatrixXd l2(3, 2);
  EXPECT_THROW(kl_diag_gaussian<double>(a, l2, a, l), Error);
}
