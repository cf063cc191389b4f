#include <gtest/gtest.h>

#include <limits>

#include "maskadapt/core/rng.hpp"
#include "maskadapt/nn/normalizer.hpp"

using namespace maskadapt;
using namespace maskadapt::nn;

namespace {
Eigen::MatrixXf data(Rng& rng, Index d, Index n) {
  Eigen::MatrixXf m(d, n);
  for (Index j = 0; j < n; ++j)
    for (Index i = 0; i < d; ++i) m(i, j) = static_cast<float>(100.0 * i + (i + 1) * rng.normal());
  return m;
}
}  // namespace

TEST(Normalizer, IncrementalAndMergedEqualOnePass) {
  Rng rng(4);
  const Eigen::MatrixXf all = data(rng, 3, 1000);
  const Eigen::MatrixXd ad = all.cast<double>();
  const Eigen::VectorXd mean = ad.rowwise().mean();
  const Eigen::VectorXd var = (ad.colwise() - mean).array().square().rowwise().mean();

  RunningNormalizer<float> inc(3), w1(3), w2(3), w3(3);
  for (Index c = 0; c < 1000; c += 100) inc.update(all.middleCols(c, 100));
  w1.update(all.leftCols(137));
  w2.update(all.middleCols(137, 500));
  w3.update(all.rightCols(363));
  w1.merge(w2);
  w1.merge(w3);
  for (const auto* n : {&inc, &w1}) {
    EXPECT_EQ(n->count(), 1000);
    EXPECT_LT((n->mean() - mean).cwiseAbs().maxCoeff(), 1e-11);
    EXPECT_LT(((n->variance() - var).array() / var.array()).abs().maxCoeff(), 1e-11);
  }
  RunningNormalizer<float> empty(3);
  w1.merge(empty);
  EXPECT_EQ(w1.count(), 1000);
}

TEST(Normalizer, NormalizeClipsAndDenormalizeInverts) {
  Rng rng(5);
  RunningNormalizer<float> n(3, /*clip=*/2.0);
  const Eigen::MatrixXf x = data(rng, 3, 500);
  n.update(x);
  Eigen::MatrixXf z = n.normalize(x);
  EXPECT_LE(z.cwiseAbs().maxCoeff(), 2.0f);
  // Unclipped entries invert exactly (to float precision).
  Eigen::MatrixXf back(3, 500);
  n.denormalize(z, back);
  int checked = 0;
  for (Index i = 0; i < z.size(); ++i)
    if (std::abs(z.data()[i]) < 1.99f) {
      EXPECT_NEAR(back.data()[i], x.data()[i], 1e-3f * std::max(1.0f, std::abs(x.data()[i])));
      ++checked;
    }
  EXPECT_GT(checked, 1000);
  // Normalised data has ~zero mean, ~unit variance where clipping is rare.
  RunningNormalizer<float> wide(3, /*clip=*/0.0);
  wide.update(x);
  const Eigen::MatrixXf zw = wide.normalize(x);
  EXPECT_LT(zw.cast<double>().rowwise().mean().cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_NEAR(zw.cast<double>().array().square().rowwise().mean().maxCoeff(), 1.0, 1e-4);
}

TEST(Normalizer, IdentityBeforeDataAndRejectsBadInput) {
  RunningNormalizer<double> n(2);
  Eigen::MatrixXd x(2, 1);
  x << 0.5, -1.5;
  EXPECT_LT((n.normalize(x) - x).cwiseAbs().maxCoeff(), 1e-8);
  Eigen::MatrixXd bad(2, 2);
  bad << 1, std::numeric_limits<double>::quiet_NaN(), 2, 3;
  EXPECT_THROW(n.update(bad), Error);
  EXPECT_EQ(n.count(), 0);
  EXPECT_THROW(n.update(Eigen::MatrixXd::Zero(3, 2)), Error);
  EXPECT_THROW(n.merge(RunningNormalizer<double>(3)), Error);
}
