#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <string>

#include "maskadapt/core/rng.hpp"
#include "maskadapt/core/thread_pool.hpp"
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

// A batch large enough to be split over the pool (rows for update, columns for normalize):
// statistics equal the two-pass closed form, and statistics and outputs have the same bits with
// no pool and with pools of 1, 2 and 3 threads. A NaN in the last entry is named by row and
// column, and leaves the statistics untouched.
TEST(Normalizer, SplitOverThePoolBitIdenticalAndEqualToTwoPass) {
  Rng rng(6);
  const Index d = 300, n = 700;
  ASSERT_GE(double(d) * double(n), kMinSplitElements);
  const Eigen::MatrixXf x = data(rng, d, n), later = data(rng, d, n / 2);
  const Eigen::MatrixXd xd = x.cast<double>();
  const Eigen::VectorXd mean = xd.rowwise().mean();
  const Eigen::VectorXd var = (xd.colwise() - mean).array().square().rowwise().mean();
  struct Out {
    RunningNormalizer<float> norm;
    Eigen::MatrixXf z;
  };
  auto run = [&](std::size_t threads) {
    ThreadPool pool(threads == 0 ? 1 : threads);
    ScopedPool scope(threads == 0 ? nullptr : &pool);
    Out o{RunningNormalizer<float>(d), Eigen::MatrixXf(d, n)};
    o.norm.update(x);
    o.norm.update(later);
    o.norm.normalize(x, o.z);
    return o;
  };
  const Out ref = run(0);
  RunningNormalizer<float> once(d);
  once.update(x);
  EXPECT_LT((once.mean() - mean).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT(((once.variance() - var).array() / var.array()).abs().maxCoeff(), 1e-11);
  for (const std::size_t threads : {1, 2, 3}) {
    const Out got = run(threads);
    EXPECT_EQ(0, std::memcmp(got.norm.mean().data(), ref.norm.mean().data(), sizeof(double) * d)) << threads;
    EXPECT_EQ(0, std::memcmp(got.norm.m2().data(), ref.norm.m2().data(), sizeof(double) * d)) << threads;
    EXPECT_EQ(0, std::memcmp(got.z.data(), ref.z.data(), sizeof(float) * d * n)) << threads;
  }
  ThreadPool pool(2);
  ScopedPool scope(&pool);
  RunningNormalizer<float> norm(d);
  norm.update(x);
  Eigen::MatrixXf bad = later;
  bad(d - 1, n / 2 - 1) = std::numeric_limits<float>::infinity();
  try {
    norm.update(bad);
    ADD_FAILURE() << "an inf in the batch was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("row 299, col 349"), std::string::npos) << e.what();
  }
  EXPECT_EQ(norm.count(), n);
  EXPECT_EQ(0, std::memcmp(norm.mean().data(), once.mean().data(), sizeof(double) * d));
  EXPECT_EQ(0, std::memcmp(norm.m2().data(), once.m2().data(), sizeof(double) * d));
}
