#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "fd.hpp"
#include "maskadapt/nn/gaussian.hpp"

using namespace maskadapt;
using namespace maskadapt::nn;

namespace {
Eigen::MatrixXd rnd(Rng& rng, Index r, Index c, double s = 1.0) {
  Eigen::MatrixXd m(r, c);
  for (Index i = 0; i < m.size(); ++i) m.data()[i] = s * rng.normal();
  return m;
}
}  // namespace

TEST(Gaussian, LogProbKnownValue) {
  // 1-D N(1, 2²) at x = 2: −½(1/2)² − log 2 − ½ log 2π.
  Eigen::MatrixXd mean(1, 1), ls(1, 1), x(1, 1);
  mean << 1;
  ls << std::log(2.0);
  x << 2;
  RowVectorX<double> lp(1);
  gaussian_log_prob<double>(mean, ls, x, lp);
  EXPECT_NEAR(lp[0], -0.125 - std::log(2.0) - 0.5 * std::log(2 * std::numbers::pi), 1e-15);
  const RowVectorX<double> h = gaussian_entropy<double>(ls);
  EXPECT_NEAR(h[0], 0.5 * std::log(2 * std::numbers::pi * std::exp(1.0) * 4.0), 1e-14);
}

TEST(Gaussian, LogProbAndEntropyGradientsMatchFiniteDifferences) {
  for (int seed = 0; seed < 6; ++seed) {
    Rng rng(seed);
    const Index d = 1 + static_cast<Index>(rng.uniform_int(5)), B = 1 + static_cast<Index>(rng.uniform_int(5));
    for (bool shared : {true, false}) {
      Eigen::MatrixXd mean = rnd(rng, d, B), x = rnd(rng, d, B, 1.5), ls = rnd(rng, d, shared ? 1 : B, 0.5);
      const RowVectorX<double> w = rnd(rng, 1, B);  // L = Σ_j w_j log p_j
      auto loss = [&] {
        RowVectorX<double> lp(B);
        gaussian_log_prob<double>(mean, ls, x, lp);
        return lp.dot(w);
      };
      Eigen::MatrixXd dmean, dls;
      gaussian_log_prob_backward<double>(mean, ls, x, w, &dmean, &dls);
      EXPECT_LT(test::rel_error(dmean, test::central_diff<Eigen::MatrixXd>(mean, loss)), 1e-6);
      EXPECT_LT(test::rel_error(dls, test::central_diff<Eigen::MatrixXd>(ls, loss)), 1e-6);

      const RowVectorX<double> wh = rnd(rng, 1, ls.cols());
      auto hloss = [&] { return gaussian_entropy<double>(ls).dot(wh); };
      Eigen::MatrixXd dh;
      gaussian_entropy_backward<double>(ls, wh, dh);
      EXPECT_LT(test::rel_error(dh, test::central_diff<Eigen::MatrixXd>(ls, hloss)), 1e-6);
    }
  }
}

TEST(Gaussian, BackwardAccumulates) {
  Rng rng(1);
  const Eigen::MatrixXd mean = rnd(rng, 3, 4), x = rnd(rng, 3, 4), ls = rnd(rng, 3, 1, 0.3);
  const RowVectorX<double> w = RowVectorX<double>::Ones(4);
  Eigen::MatrixXd dm1, dl1, dm2 = Eigen::MatrixXd::Constant(3, 4, 2.0), dl2 = Eigen::MatrixXd::Constant(3, 1, -1.0);
  gaussian_log_prob_backward<double>(mean, ls, x, w, &dm1, &dl1);
  gaussian_log_prob_backward<double>(mean, ls, x, w, &dm2, &dl2);
  EXPECT_LT((dm2 - dm1 - Eigen::MatrixXd::Constant(3, 4, 2.0)).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_LT((dl2 - dl1 - Eigen::MatrixXd::Constant(3, 1, -1.0)).cwiseAbs().maxCoeff(), 1e-14);
  Eigen::MatrixXd wrong(2, 2);
  EXPECT_THROW(gaussian_log_prob_backward<double>(mean, ls, x, w, &wrong, nullptr), Error);
}

TEST(Gaussian, SamplingIsDeterministicAndHasTheRightMoments) {
  const Index d = 2, B = 100000;
  Eigen::MatrixXd mean(d, B);
  mean.row(0).setConstant(0.5);
  mean.row(1).setConstant(-2.0);
  Eigen::MatrixXd ls(d, 1);
  ls << std::log(0.3), std::log(2.0);
  Eigen::MatrixXd a(d, B), b(d, B);
  Rng r1(77), r2(77);
  gaussian_sample<double>(mean, ls, r1, a);
  gaussian_sample<double>(mean, ls, r2, b);
  EXPECT_TRUE(a == b);
  const Eigen::VectorXd m = a.rowwise().mean();
  const Eigen::VectorXd sd = ((a.colwise() - m).array().square().rowwise().mean()).sqrt();
  EXPECT_NEAR(m[0], 0.5, 4 * 0.3 / std::sqrt(double(B)));
  EXPECT_NEAR(m[1], -2.0, 4 * 2.0 / std::sqrt(double(B)));
  EXPECT_NEAR(sd[0], 0.3, 0.01 * 0.3);
  EXPECT_NEAR(sd[1], 2.0, 0.01 * 2.0);
  // Entropy = −E[log p]: Monte-Carlo check.
  RowVectorX<double> lp(B);
  gaussian_log_prob<double>(mean, ls, a, lp);
  EXPECT_NEAR(-lp.mean(), gaussian_entropy<double>(ls)[0], 0.01);
}

TEST(Gaussian, ShapeErrors) {
  Eigen::MatrixXd mean(3, 4), x(3, 4), ls_bad(3, 2), x_bad(2, 4);
  RowVectorX<double> lp(4);
  EXPECT_THROW(gaussian_log_prob<double>(mean, ls_bad, x, lp), Error);
  EXPECT_THROW(gaussian_log_prob<double>(mean, Eigen::MatrixXd::Zero(3, 1), x_bad, lp), Error);
}
