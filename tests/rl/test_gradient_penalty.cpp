#include <maskadapt/rl/gradient_penalty.hpp>

#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include <maskadapt/core/thread_pool.hpp>
#include <maskadapt/nn/chunks.hpp>

using namespace maskadapt;
using namespace maskadapt::rl;

namespace {
// P(θ) recomputed from scratch: ∂d/∂x by central differences would be too noisy to
// differentiate again, so the input gradient uses an ordinary backward pass (dx) — an
// independent code path from the double-backprop under test.
double penalty(const nn::Mlp<double>& net, const MatrixXd& x, Index rows, double weight) {
  nn::TrainCache<double> c;
  net.forward_train(x, c);
  MatrixXd dx;
  VectorXd sink = VectorXd::Zero(net.num_params());
  net.backward(c, MatrixXd::Ones(1, x.cols()), sink, &dx);
  return weight * dx.topRows(rows).squaredNorm() / static_cast<double>(x.cols());
}

// Largest relative difference between grad[k] and the central difference of P in parameter k,
// over the parameters `which`.
double max_fd_error(const nn::Mlp<double>& net, const MatrixXd& x, Index rows, double weight, const VectorXd& grad,
                    const std::vector<Index>& which) {
  double max_err = 0;
  const double h = 1e-6;
  for (Index k : which) {
    nn::Mlp<double> p = net;
    p.params()[k] += h;
    const double lp = penalty(p, x, rows, weight);
    p.params()[k] -= 2 * h;
    const double fd = (lp - penalty(p, x, rows, weight)) / (2 * h);
    max_err = std::max(max_err, std::abs(fd - grad[k]) / std::max(1.0, std::abs(fd)));
  }
  return max_err;
}
}  // namespace

// ∂P/∂θ from double backprop equals the central finite difference of P for every parameter,
// for every smooth activation (ReLU: f'' = 0 almost everywhere, also checked), several depths.
TEST(GradientPenalty, ParameterGradientMatchesFiniteDifferences) {
  using nn::Activation;
  for (Activation a : {Activation::Tanh, Activation::SiLU, Activation::ELU, Activation::ReLU}) {
    for (std::vector<Index> hidden : {std::vector<Index>{6}, std::vector<Index>{5, 4}, std::vector<Index>{4, 3, 5}}) {
      Rng rng(17);
      nn::Mlp<double> net(nn::MlpSpec{7, hidden, 1, a}, rng);
      const MatrixXd x = MatrixXd::NullaryExpr(7, 5, [&] { return rng.normal(); });
      const Index rows = 5;  // the last two inputs are "conditioning", not penalised
      const double weight = 5.0;
      nn::TrainCache<double> cache;
      net.forward_train(x, cache);
      VectorXd grad = VectorXd::Zero(net.num_params());
      GradientPenaltyWorkspace<double> ws;
      const double P = gradient_penalty(net, cache, rows, weight, grad, ws);
      EXPECT_NEAR(P, penalty(net, x, rows, weight), 1e-12 * std::max(1.0, P));
      EXPECT_GT(P, 0.0);
      std::vector<Index> all(static_cast<std::size_t>(net.num_params()));
      for (Index k = 0; k < net.num_params(); ++k) all[static_cast<std::size_t>(k)] = k;
      EXPECT_LT(max_fd_error(net, x, rows, weight, grad, all), 1e-6) << nn::to_string(a) << " depth " << hidden.size();
    }
  }
}

// A pass over real and fake samples together (real first) penalises only its first `columns`
// samples: the same P and ∂P/∂θ as a pass over the real samples alone.
TEST(GradientPenalty, LeadingColumnsOfAJointPassEqualTheirOwnPass) {
  using nn::Activation;
  for (Activation a : {Activation::ReLU, Activation::Tanh}) {
    Rng rng(5);
    nn::Mlp<double> net(nn::MlpSpec{6, {5, 4}, 1, a}, rng);
    const MatrixXd real = MatrixXd::NullaryExpr(6, 4, [&] { return rng.normal(); });
    const MatrixXd fake = MatrixXd::NullaryExpr(6, 3, [&] { return rng.normal(); });
    MatrixXd both(6, 7);
    both << real, fake;
    nn::TrainCache<double> c_real, c_both;
    net.forward_train(real, c_real);
    net.forward_train(both, c_both);
    GradientPenaltyWorkspace<double> ws;
    VectorXd g_real = VectorXd::Zero(net.num_params()), g_both = VectorXd::Zero(net.num_params());
    const double p_real = gradient_penalty(net, c_real, 5, 3.0, g_real, ws);
    const double p_both = gradient_penalty(net, c_both, 5, 3.0, g_both, ws, nullptr, 4);
    EXPECT_NEAR(p_both, p_real, 1e-12) << nn::to_string(a);
    EXPECT_LT((g_both - g_real).cwiseAbs().maxCoeff(), 1e-12) << nn::to_string(a);
    EXPECT_GT(g_real.cwiseAbs().maxCoeff(), 1e-3);
    EXPECT_THROW(gradient_penalty(net, c_both, 5, 3.0, g_both, ws, nullptr, 8), Error);
  }
}

// At the discriminator's sizes the products run in the Mlp's chunks on a pool (nn/chunks.hpp):
// still the finite-difference gradient (sampled parameters of every layer), and the same bits
// for no pool and pools of 1, 2 and 3 threads.
TEST(GradientPenalty, ChunkedOnAPoolMatchesFiniteDifferencesAndAnyPoolGivesTheSameBits) {
  using nn::Activation;
  for (Activation a : {Activation::ReLU, Activation::Tanh}) {
    Rng rng(23);
    nn::Mlp<double> net(nn::MlpSpec{300, {256, 128}, 1, a}, rng);
    ASSERT_TRUE(nn::worth_chunking(256, 300, 192) && nn::worth_chunking(128, 256, 192));  // both layers split
    const MatrixXd x = MatrixXd::NullaryExpr(300, 192, [&] { return rng.normal(); });
    const Index rows = 290;
    const double weight = 5.0;
    auto run = [&](ThreadPool* pool, VectorXd& grad) {
      nn::TrainCache<double> cache;
      cache.pool = pool;
      net.forward_train(x, cache);
      grad = VectorXd::Zero(net.num_params());
      GradientPenaltyWorkspace<double> ws;
      return gradient_penalty(net, cache, rows, weight, grad, ws, nullptr, 160);  // leading columns too
    };
    VectorXd grad;
    const double P = run(nullptr, grad);
    const MatrixXd x_real = x.leftCols(160);
    EXPECT_NEAR(P, penalty(net, x_real, rows, weight), 1e-12 * std::max(1.0, P)) << nn::to_string(a);
    for (std::size_t threads : {1, 2, 3}) {
      ThreadPool pool(threads);
      VectorXd g_pool;
      const double P_pool = run(&pool, g_pool);
      EXPECT_EQ(0, std::memcmp(&P, &P_pool, sizeof(double))) << threads << " threads";
      EXPECT_EQ(0, std::memcmp(grad.data(), g_pool.data(), sizeof(double) * static_cast<std::size_t>(grad.size())))
          << nn::to_string(a) << ", " << threads << " threads";
    }
    std::vector<Index> sampled(40);
    for (Index& k : sampled) k = static_cast<Index>(rng.uniform_int(static_cast<std::uint64_t>(net.num_params())));
    EXPECT_LT(max_fd_error(net, x_real, rows, weight, grad, sampled), 1e-6) << nn::to_string(a);
    EXPECT_GT(grad.cwiseAbs().maxCoeff(), 1e-6);
  }
}

TEST(GradientPenalty, LinearNetworkClosedForm) {
  // d = wᵀx + b: ∂d/∂x = w, P = weight·‖w_S‖², ∂P/∂w_S = 2·weight·w_S, ∂P/∂b = 0.
  Rng rng(3);
  nn::Mlp<double> net(nn::MlpSpec{4, {}, 1}, rng);
  const MatrixXd x = MatrixXd::Random(4, 3);
  nn::TrainCache<double> cache;
  net.forward_train(x, cache);
  VectorXd grad = VectorXd::Zero(net.num_params());
  GradientPenaltyWorkspace<double> ws;
  const double P = gradient_penalty(net, cache, 3, 2.0, grad, ws);
  const VectorXd wv = net.weight(0).transpose();
  EXPECT_NEAR(P, 2.0 * wv.head(3).squaredNorm(), 1e-14);
  for (Index i = 0; i < 3; ++i) EXPECT_NEAR(grad[i], 4.0 * wv[i], 1e-14);
  EXPECT_EQ(grad[3], 0.0);
  EXPECT_EQ(grad[4], 0.0);
}

TEST(GradientPenalty, RejectsVectorOutput) {
  Rng rng(3);
  nn::Mlp<double> net(nn::MlpSpec{4, {3}, 2}, rng);
  nn::TrainCache<double> cache;
  net.forward_train(MatrixXd::Zero(4, 2), cache);
  VectorXd grad = VectorXd::Zero(net.num_params());
  GradientPenaltyWorkspace<double> ws;
  EXPECT_THROW(gradient_penalty(net, cache, 4, 1.0, grad, ws), Error);
}
