#include <maskadapt/core/rng.hpp>
#include <maskadapt/eval/dtw.hpp>

#include <gtest/gtest.h>

using namespace maskadapt;
using maskadapt::eval::dtw;

namespace {
MatrixXd random_seq(Rng& rng, Index d, Index n) {
  MatrixXd m(d, n);
  for (Index k = 0; k < m.size(); ++k) m.data()[k] = rng.normal();
  return m;
}
MatrixXd row(std::initializer_list<double> xs) {
  MatrixXd m(1, static_cast<Index>(xs.size()));
  Index i = 0;
  for (double x : xs) m(0, i++) = x;
  return m;
}
}  // namespace

TEST(Dtw, IdenticalSequencesCostNothing) {
  Rng rng(1);
  const MatrixXd a = random_seq(rng, 5, 40);
  const auto r = dtw(a, a);
  EXPECT_DOUBLE_EQ(r.total_cost, 0.0);
  ASSERT_EQ(r.path.size(), 40u);
  for (std::size_t k = 0; k < r.path.size(); ++k) EXPECT_EQ(r.path[k], std::make_pair(Index(k), Index(k)));
}

TEST(Dtw, TimeStretchedCopyCostsNothing) {
  Rng rng(2);
  const MatrixXd a = random_seq(rng, 3, 25);
  MatrixXd b(3, 50);  // every frame shown twice: half speed
  for (Index i = 0; i < 25; ++i) b.col(2 * i) = b.col(2 * i + 1) = a.col(i);
  const auto r = dtw(a, b);
  EXPECT_DOUBLE_EQ(r.total_cost, 0.0);
  EXPECT_EQ(r.path.size(), 50u);
  for (auto [i, j] : r.path) EXPECT_EQ(i, j / 2);
}

TEST(Dtw, HandComputedSmallCase) {
  // a = (0, 1, 3), b = (0, 3): costs |a_i − b_j| = [[0, 3], [1, 2], [3, 0]].
  // D = [[0, 3], [1, 3], [4, 1]] → total 1 along (0,0), (1,0), (2,1).
  const auto r = dtw(row({0, 1, 3}), row({0, 3}));
  EXPECT_DOUBLE_EQ(r.total_cost, 1.0);
  EXPECT_DOUBLE_EQ(r.mean_cost, 1.0 / 3.0);
  const std::vector<std::pair<Index, Index>> expected = {{0, 0}, {1, 0}, {2, 1}};
  EXPECT_EQ(r.path, expected);
}

TEST(Dtw, EuclideanCostInSeveralDimensions) {
  MatrixXd a(2, 1), b(2, 1);
  a << 0, 0;
  b << 3, 4;
  EXPECT_DOUBLE_EQ(dtw(a, b).total_cost, 5.0);
}

TEST(Dtw, ZeroBandOnEqualLengthsIsTheDiagonal) {
  Rng rng(3);
  const MatrixXd a = random_seq(rng, 4, 30), b = random_seq(rng, 4, 30);
  double diagonal = 0.0;
  for (Index i = 0; i < 30; ++i) diagonal += (a.col(i) - b.col(i)).norm();
  const auto banded = dtw(a, b, 0);
  EXPECT_NEAR(banded.total_cost, diagonal, 1e-9);
  const auto wider = dtw(a, b, 3), full = dtw(a, b);
  EXPECT_LE(wider.total_cost, banded.total_cost + 1e-12);
  EXPECT_LE(full.total_cost, wider.total_cost + 1e-12);
  EXPECT_LT(full.total_cost, diagonal);  // random sequences: warping helps
}

TEST(Dtw, SymmetricAndPathIsValid) {
  Rng rng(4);
  const MatrixXd a = random_seq(rng, 3, 17), b = random_seq(rng, 3, 29);
  const auto ab = dtw(a, b), ba = dtw(b, a);
  EXPECT_NEAR(ab.total_cost, ba.total_cost, 1e-9);
  double sum = 0.0;
  ASSERT_EQ(ab.path.front(), std::make_pair(Index(0), Index(0)));
  ASSERT_EQ(ab.path.back(), std::make_pair(Index(16), Index(28)));
  for (std::size_t k = 0; k < ab.path.size(); ++k) {
    const auto [i, j] = ab.path[k];
    sum += (a.col(i) - b.col(j)).norm();
    if (k > 0) {
      const auto [pi, pj] = ab.path[k - 1];
      EXPECT_TRUE((i - pi == 1 || i - pi == 0) && (j - pj == 1 || j - pj == 0) && (i + j > pi + pj));
    }
  }
  EXPECT_NEAR(sum, ab.total_cost, 1e-9);  // the path really has the reported cost
}

TEST(Dtw, BandSmallerThanLengthDifferenceStillReachesTheEnd) {
  Rng rng(5);
  const MatrixXd a = random_seq(rng, 2, 10), b = random_seq(rng, 2, 16);
  const auto r = dtw(a, b, 1);  // widened to |n − m| = 6
  EXPECT_TRUE(std::isfinite(r.total_cost));
  EXPECT_EQ(r.path.back(), std::make_pair(Index(9), Index(15)));
}

TEST(Dtw, RejectsBadInput) {
  EXPECT_THROW(dtw(MatrixXd(2, 0), MatrixXd::Zero(2, 3)), Error);
  EXPECT_THROW(dtw(MatrixXd::Zero(2, 3), MatrixXd::Zero(3, 3)), Error);
  MatrixXd bad = MatrixXd::Zero(2, 3);
  bad(0, 2) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(dtw(bad, MatrixXd::Zero(2, 3)), Error);
}
