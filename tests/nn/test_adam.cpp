#include <gtest/gtest.h>
#include "../blas_kernel.hpp"

#include <cmath>
#include <cstring>
#include <limits>

#include "maskadapt/core/rng.hpp"
#include "maskadapt/core/thread_pool.hpp"
#include "maskadapt/nn/adam.hpp"
#include "maskadapt/nn/mlp.hpp"

using namespace maskadapt;
using namespace maskadapt::nn;

// torch.optim.Adam written out scalar by scalar from its documentation, in double.
struct RefAdam {
  double lr, b1, b2, eps, wd;
  bool decoupled;
  double m = 0, v = 0;
  int t = 0;
  double step(double theta, double g) {
    ++t;
    if (decoupled) theta *= 1 - lr * wd;
    else g += wd * theta;
    m = b1 * m + (1 - b1) * g;
    v = b2 * v + (1 - b2) * g * g;
    const double mhat = m / (1 - std::pow(b1, t)), vhat = v / (1 - std::pow(b2, t));
    return theta - lr * mhat / (std::sqrt(vhat) + eps);
  }
};

TEST(Adam, ConstantGradientMovesByLrTimesSign) {
  // With a constant gradient, m̂ = g and v̂ = g² exactly, so each step moves by lr·g/(|g| + eps).
  ParameterBlock<double> b(3);
  b.params() << 1.0, -2.0, 0.5;
  Adam<double> opt;
  const Eigen::Vector3d g(0.3, -4.0, 1e-3);
  for (int k = 1; k <= 5; ++k) {
    b.grads() = g;
    const Eigen::Vector3d before = b.params();
    ASSERT_TRUE(opt.step(b));
    for (int i = 0; i < 3; ++i)
      EXPECT_NEAR(before[i] - b.params()[i], 1e-3 * g[i] / (std::abs(g[i]) + 1e-8), 1e-15) << "step " << k;
  }
  EXPECT_EQ(opt.step_count(), 5);
}

TEST(Adam, MatchesTorchAlgorithmForVaryingGradients) {
  for (int variant = 0; variant < 3; ++variant) {
    AdamConfig cfg;
    cfg.lr = 0.01;
    cfg.beta1 = 0.8;
    cfg.beta2 = 0.95;
    cfg.eps = 1e-6;
    if (variant >= 1) cfg.weight_decay = 0.1;
    cfg.decoupled_weight_decay = variant == 2;
    Adam<double> opt(cfg);
    ParameterBlock<double> b(2);
    b.params() << 0.7, -1.3;
    RefAdam r0{cfg.lr, cfg.beta1, cfg.beta2, cfg.eps, cfg.weight_decay, cfg.decoupled_weight_decay};
    RefAdam r1 = r0;
    double t0 = 0.7, t1 = -1.3;
    const double grads[5][2] = {{0.5, -0.1}, {-0.2, 0.3}, {1.5, 0.0}, {0.01, -2.0}, {-0.7, 0.4}};
    for (const auto& g : grads) {
      b.grads() << g[0], g[1];
      ASSERT_TRUE(opt.step(b));
      t0 = r0.step(t0, g[0]);
      t1 = r1.step(t1, g[1]);
      EXPECT_NEAR(b.params()[0], t0, 1e-14) << "variant " << variant;
      EXPECT_NEAR(b.params()[1], t1, 1e-14) << "variant " << variant;
    }
  }
}

TEST(Adam, GlobalGradientClippingAcrossBlocks) {
  ParameterBlock<double> a(1), b(1);
  a.grads() << 3.0;
  b.grads() << 4.0;  // global norm 5
  AdamConfig cfg;
  cfg.max_grad_norm = 1.0;
  Adam<double> opt(cfg);
  const AdamStepResult r = opt.step({&a, &b});
  ASSERT_TRUE(r.applied);
  EXPECT_DOUBLE_EQ(r.grad_norm, 5.0);
  EXPECT_NEAR(r.clip_scale, 1.0 / (5.0 + 1e-6), 1e-15);
  EXPECT_NEAR(a.grads()[0], 3.0 / (5.0 + 1e-6), 1e-15);  // clipped in place (torch semantics)
  EXPECT_NEAR(b.grads()[0], 4.0 / (5.0 + 1e-6), 1e-15);
  // A small gradient is not scaled.
  a.grads() << 0.1;
  b.grads() << 0.0;
  const AdamStepResult r2 = opt.step({&a, &b});
  EXPECT_EQ(r2.clip_scale, 1.0);
  EXPECT_EQ(a.grads()[0], 0.1);
}

TEST(Adam, NonFiniteGradientLeavesEverythingUntouched) {
  for (double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    ParameterBlock<double> b(3);
    b.params() << 1, 2, 3;
    Adam<double> opt;
    b.grads() << 0.1, 0.2, 0.3;
    ASSERT_TRUE(opt.step(b));
    const Eigen::VectorXd before = b.storage();
    b.grads() << 0.1, bad, 0.3;
    const Eigen::VectorXd with_bad_grad = b.storage();
    const AdamStepResult r = opt.step(b);
    EXPECT_FALSE(r.applied);
    EXPECT_FALSE(static_cast<bool>(r));
    EXPECT_FALSE(std::isfinite(r.grad_norm));
    EXPECT_EQ(opt.step_count(), 1);
    EXPECT_TRUE(b.params() == before.head(3));
    EXPECT_TRUE(b.adam_m() == before.segment(6, 3));
    EXPECT_TRUE(b.adam_v() == before.segment(9, 3));
    EXPECT_EQ(0, std::memcmp(b.grads().data(), with_bad_grad.data() + 3, 3 * sizeof(double)));  // grads not clipped/scaled
  }
}

TEST(Adam, RejectsBadConfig) {
  AdamConfig c;
  c.beta1 = 1.0;
  EXPECT_THROW(Adam<float>{c}, Error);
  c = {};
  c.lr = -1;
  EXPECT_THROW(Adam<float>{c}, Error);
}

namespace {
// Fits y = sin(2x) on [-1.5, 1.5] with a [32, 32] tanh MLP; returns the final MSE.
// The batch is split into 4 fixed shards whose gradients are computed in parallel and summed in
// shard order, so results cannot depend on the thread count.
Eigen::VectorXf train_regression(std::size_t threads, int steps, float* final_loss) {
  Rng rng(2024);
  Mlp<float> net(MlpSpec{1, {32, 32}, 1, Activation::Tanh}, rng);
  const Index B = 64, shards = 4;
  Eigen::MatrixXf x(1, B), y(1, B);
  for (Index j = 0; j < B; ++j) {
    x(0, j) = static_cast<float>(rng.uniform(-1.5, 1.5));
    y(0, j) = std::sin(2 * x(0, j));
  }
  AdamConfig cfg;
  cfg.lr = 3e-3;
  Adam<float> opt(cfg);
  ThreadPool pool(threads);
  std::vector<TrainCache<float>> caches(shards);
  std::vector<Eigen::VectorXf> shard_grads(shards, Eigen::VectorXf::Zero(net.num_params()));
  std::vector<float> shard_loss(shards);
  float loss = 0;
  for (int s = 0; s < steps; ++s) {
    pool.parallel_for(0, shards, [&](std::size_t k) {
      const Index n = B / shards, c0 = static_cast<Index>(k) * n;
      const Eigen::MatrixXf& pred = net.forward_train(x.middleCols(c0, n), caches[k]);
      const Eigen::MatrixXf diff = pred - y.middleCols(c0, n);
      shard_loss[k] = diff.squaredNorm() / B;
      shard_grads[k].setZero();
      net.backward(caches[k], diff * (2.0f / B), shard_grads[k]);
    });
    net.zero_grad();
    loss = 0;
    for (Index k = 0; k < shards; ++k) {
      net.grads() += shard_grads[k];
      loss += shard_loss[k];
    }
    EXPECT_TRUE(opt.step(net.block()));
  }
  *final_loss = loss;
  return net.params();
}
}  // namespace

TEST(Adam, RegressionReachesTargetLossAndIsBitIdenticalForAnyThreadCount) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  float l1 = 0, l2 = 0, l3 = 0;
  const Eigen::VectorXf p1 = train_regression(1, 1500, &l1);
  const Eigen::VectorXf p2 = train_regression(2, 1500, &l2);
  const Eigen::VectorXf p3 = train_regression(3, 1500, &l3);
  EXPECT_LT(l1, 2e-3) << "sin regression did not reach the target MSE";  // initial MSE ≈ 0.5
  EXPECT_EQ(0, std::memcmp(p1.data(), p2.data(), sizeof(float) * p1.size()));
  EXPECT_EQ(0, std::memcmp(p1.data(), p3.data(), sizeof(float) * p1.size()));
  EXPECT_EQ(l1, l2);
}

// The step on blocks large enough to be split over the pool (≥ kMinSplitElements parameters,
// odd sizes so the last segment is short), with clipping and both weight decays: the same bits
// with no pool and with pools of 1, 2 and 3 threads; and the element-wise result matches the
// scalar torch formula of RefAdam. A NaN in the very last segment leaves every block untouched.
TEST(Adam, SplitOverThePoolBitIdenticalAndEqualToTheScalarFormula) {
  const Index na = 70001, nb = 3001;
  ASSERT_GE(static_cast<double>(na + nb), kMinSplitElements);
  auto fill = [](ParameterBlock<float>& b, Rng& rng, bool params) {  // N(0, 1) θ, N(0, 0.5²) g
    for (Index i = 0; i < b.size(); ++i) {
      if (params) b.params()[i] = static_cast<float>(rng.normal());
      b.grads()[i] = static_cast<float>(0.5 * rng.normal());
    }
  };
  for (const bool decoupled : {false, true}) {
    AdamConfig cfg;
    cfg.lr = 1e-2;
    cfg.weight_decay = 0.01;
    cfg.decoupled_weight_decay = decoupled;
    cfg.max_grad_norm = 50.0;  // ‖g‖ ≈ √(73002)·0.5 ≈ 135: clipped
    struct Run {
      ParameterBlock<float> a, b;
      AdamStepResult r;
    };
    auto run = [&](std::size_t threads) {
      Run out{ParameterBlock<float>(na), ParameterBlock<float>(nb), {}};
      Rng rng(77);
      Adam<float> opt(cfg);
      ThreadPool pool(threads == 0 ? 1 : threads);
      ScopedPool scope(threads == 0 ? nullptr : &pool);
      for (int step = 0; step < 3; ++step) {
        fill(out.a, rng, step == 0);
        fill(out.b, rng, step == 0);
        out.r = opt.step({&out.a, &out.b});
      }
      return out;
    };
    const Run ref = run(0);
    EXPECT_TRUE(ref.r.applied);
    EXPECT_LT(ref.r.clip_scale, 1.0);
    for (const std::size_t threads : {1, 2, 3}) {
      const Run got = run(threads);
      EXPECT_EQ(got.r.grad_norm, ref.r.grad_norm) << threads << " threads";
      EXPECT_EQ(got.r.clip_scale, ref.r.clip_scale);
      for (const auto& [x, y] : {std::pair{&got.a, &ref.a}, std::pair{&got.b, &ref.b}}) {
        EXPECT_EQ(0, std::memcmp(x->params().data(), y->params().data(), sizeof(float) * x->size()));
        EXPECT_EQ(0, std::memcmp(x->adam_m().data(), y->adam_m().data(), sizeof(float) * x->size()));
        EXPECT_EQ(0, std::memcmp(x->adam_v().data(), y->adam_v().data(), sizeof(float) * x->size()));
        EXPECT_EQ(0, std::memcmp(x->grads().data(), y->grads().data(), sizeof(float) * x->size()));
      }
    }
    // One step from fresh moments against the scalar formula (gradients clipped by clip_scale).
    ParameterBlock<float> a(na), b(nb);
    Rng rng(78);
    fill(a, rng, true);
    fill(b, rng, true);
    const Eigen::VectorXf a0 = a.params(), ga = a.grads();
    double sq = 0;
    for (const auto* blk : {&a, &b})
      for (Index i = 0; i < blk->size(); ++i) sq += double(blk->grads()[i]) * double(blk->grads()[i]);
    Adam<float> opt(cfg);
    ThreadPool pool(2);
    ScopedPool scope(&pool);
    const AdamStepResult r = opt.step({&a, &b});
    EXPECT_NEAR(r.grad_norm, std::sqrt(sq), 1e-9 * std::sqrt(sq));
    for (Index i = 0; i < na; i += 997) {
      RefAdam ref_adam{cfg.lr, cfg.beta1, cfg.beta2, cfg.eps, cfg.weight_decay, decoupled};
      const double want = ref_adam.step(a0[i], double(ga[i]) * r.clip_scale);
      EXPECT_NEAR(a.params()[i], want, 1e-5 * std::max(1.0, std::abs(want))) << "element " << i;
    }
    // NaN in the last segment of the second block: nothing changes, in any block.
    const Eigen::VectorXf pa = a.params(), pb = b.params(), ma = a.adam_m();
    b.grads()[nb - 1] = std::numeric_limits<float>::quiet_NaN();
    const AdamStepResult bad = opt.step({&a, &b});
    EXPECT_FALSE(bad.applied);
    EXPECT_EQ(opt.step_count(), 1);
    EXPECT_EQ(0, std::memcmp(pa.data(), a.params().data(), sizeof(float) * na));
    EXPECT_EQ(0, std::memcmp(pb.data(), b.params().data(), sizeof(float) * nb));
    EXPECT_EQ(0, std::memcmp(ma.data(), a.adam_m().data(), sizeof(float) * na));
  }
}
