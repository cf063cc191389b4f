#include <gtest/gtest.h>

#include "maskadapt/nn/popart.hpp"

using namespace maskadapt;
using namespace maskadapt::nn;

namespace {
// Un-normalised outputs σ ⊙ net(x) + μ.
Eigen::MatrixXd unnormalised(const Mlp<double>& net, const PopArt<double>& p, const Eigen::MatrixXd& x) {
  const Eigen::MatrixXd n = net.forward(x);
  Eigen::MatrixXd out(n.rows(), n.cols());
  p.denormalize(n, out);
  return out;
}
}  // namespace

TEST(PopArt, PreservesOutputsAcrossStatisticsUpdates) {
  Rng rng(12);
  Mlp<double> net(MlpSpec{4, {8}, 2, Activation::Tanh}, rng);
  PopArt<double> popart(2, /*beta=*/0.3);
  Eigen::MatrixXd x(4, 10);
  for (Index i = 0; i < x.size(); ++i) x.data()[i] = rng.normal();
  for (int k = 0; k < 5; ++k) {
    Eigen::MatrixXd targets(2, 32);
    for (Index j = 0; j < 32; ++j) {
      targets(0, j) = 1000.0 + 300.0 * rng.normal();  // very different scales per objective
      targets(1, j) = -0.01 + 0.002 * rng.normal();
    }
    const Eigen::MatrixXd before = unnormalised(net, popart, x);
    const Eigen::VectorXd mu0 = popart.mean();
    popart.update(targets, net);
    EXPECT_GT((popart.mean() - mu0).cwiseAbs().maxCoeff(), 1e-4);  // statistics really changed
    const Eigen::MatrixXd after = unnormalised(net, popart, x);
    EXPECT_LT(((after - before).array().abs() / before.array().abs().max(1.0)).maxCoeff(), 1e-12) << "update " << k;
  }
}

TEST(PopArt, BetaOneTracksBatchMomentsExactly) {
  PopArt<double> p(1, /*beta=*/1.0);
  Eigen::MatrixXd y(1, 4);
  y << 1, 2, 3, 6;  // mean 3, population variance (4+1+0+9)/4 = 3.5
  Eigen::MatrixXd W = Eigen::MatrixXd::Ones(1, 2);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(1);
  p.update(y, W, b);
  EXPECT_NEAR(p.mean()[0], 3.0, 1e-14);
  EXPECT_NEAR(p.stddev()[0], std::sqrt(3.5), 1e-14);
  Eigen::MatrixXd n(1, 4), back(1, 4);
  p.normalize(y, n);
  EXPECT_NEAR(n.mean(), 0.0, 1e-14);
  p.denormalize(n, back);
  EXPECT_LT((back - y).cwiseAbs().maxCoeff(), 1e-14);
  // Rescaling from (μ=0, σ=1): W ← W/σ, b ← (0 − 3)/σ.
  EXPECT_NEAR(W(0, 0), 1.0 / std::sqrt(3.5), 1e-14);
  EXPECT_NEAR(b[0], -3.0 / std::sqrt(3.5), 1e-14);
}

TEST(PopArt, RejectsBadInput) {
  EXPECT_THROW(PopArt<float>(0), Error);
  EXPECT_THROW(PopArt<float>(2, 0.0), Error);
  PopArt<float> p(2);
  Mlp<float> relu_out(MlpSpec{2, {}, 2, Activation::ReLU, Activation::ReLU});
  EXPECT_THROW(p.update(Eigen::MatrixXf::Zero(2, 3), relu_out), Error);
  Mlp<float> net(MlpSpec{2, {}, 2});
  EXPECT_THROW(p.update(Eigen::MatrixXf::Zero(3, 3), net), Error);
}

// The update from a batch's moments (what a distributed trainer forms from all ranks' sums) is
// the update from the batch: two halves' Σy and Σy² over the whole count give the same statistics
// and the same rescaled last layer, to rounding; bad moments are refused naming the field.
TEST(PopArt, UpdateFromMomentsIsTheUpdateFromTheBatch) {
  Rng rng(5);
  Mlp<double> net_a(MlpSpec{3, {6}, 2, Activation::Tanh}, rng);
  Mlp<double> net_b = net_a;
  PopArt<double> a(2, 0.25), b(2, 0.25);
  Eigen::MatrixXd y(2, 40);
  for (Index j = 0; j < y.cols(); ++j) {
    y(0, j) = 50.0 + 10.0 * rng.normal();
    y(1, j) = -3.0 + 0.5 * rng.normal();
  }
  a.update(y, net_a);
  // two "ranks" of 20 samples each: sums added, divided by the total count
  const Eigen::VectorXd s1 = y.leftCols(20).rowwise().sum() + y.rightCols(20).rowwise().sum();
  const Eigen::VectorXd s2 = y.leftCols(20).array().square().rowwise().sum().matrix() + y.rightCols(20).array().square().rowwise().sum().matrix();
  b.update_from_moments(s1 / 40.0, s2 / 40.0, net_b);
  EXPECT_LT((a.mean() - b.mean()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((a.second_moment() - b.second_moment()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((net_a.params() - net_b.params()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_GT((a.mean() - Eigen::VectorXd::Zero(2)).cwiseAbs().maxCoeff(), 1.0);  // the statistics moved
  Eigen::VectorXd bad = s1 / 40.0;
  bad[1] = NAN;
  try {
    b.update_from_moments(bad, s2 / 40.0, net_b);
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("batch_mean"), std::string::npos) << e.what();
  }
  EXPECT_THROW(b.update_from_moments(Eigen::VectorXd::Zero(3), Eigen::VectorXd::Ones(3), net_b), Error);
}
