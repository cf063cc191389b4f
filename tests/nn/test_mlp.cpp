#include <gtest/gtest.h>
#include "../blas_kernel.hpp"

#include "fd.hpp"
#include "maskadapt/nn/mlp.hpp"

using namespace maskadapt;
using namespace maskadapt::nn;

namespace {
const Activation kMlpActivations[] = {Activation::Identity, Activation::ReLU, Activation::ELU, Activation::SiLU, Activation::Tanh};

Eigen::MatrixXd random_matrix(Rng& rng, Index r, Index c) {
  Eigen::MatrixXd m(r, c);
  for (Index i = 0; i < m.size(); ++i) m.data()[i] = rng.normal();
  return m;
}
}  // namespace

TEST(Mlp, LayoutIsFlatLayerByLayer) {
  Mlp<float> net(MlpSpec{3, {4}, 2});
  EXPECT_EQ(net.num_params(), 4 * 3 + 4 + 2 * 4 + 2);
  EXPECT_EQ(net.spec().num_params(), net.num_params());
  net.params().setLinSpaced(net.num_params(), 0.f, float(net.num_params() - 1));
  EXPECT_EQ(net.weight(0)(0, 0), 0.f);
  EXPECT_EQ(net.weight(0)(1, 0), 1.f);  // column-major
  EXPECT_EQ(net.weight(0)(0, 1), 4.f);
  EXPECT_EQ(net.bias(0)(0), 12.f);
  EXPECT_EQ(net.weight(1)(0, 0), 16.f);
  EXPECT_EQ(net.bias(1)(1), 25.f);
  EXPECT_EQ(net.params().data(), net.block().storage().data());
  EXPECT_EQ(net.grads().data(), net.block().storage().data() + net.num_params());
}

TEST(Mlp, KnownForwardValue) {
  Mlp<double> net(MlpSpec{2, {2}, 1, Activation::ReLU});
  net.weight(0) << 1, -1, 2, 0.5;
  net.bias(0) << 0.5, -10;
  net.weight(1) << 3, 7;
  net.bias(1) << 0.25;
  Eigen::MatrixXd x(2, 2);
  x << 1, -1, 2, 4;  // columns (1,2) and (-1,4)
  const Eigen::MatrixXd y = net.forward(x);
  // col 0: h = relu((1-2+0.5), (2+1-10)) = (0,0) -> y = .25; col 1: h = relu((-1-4+.5),(-2+2-10)) = 0 -> .25
  EXPECT_DOUBLE_EQ(y(0, 0), 0.25);
  x << 3, -1, 1, 4;  // col 0: h = relu(3-1+.5, 6+.5-10) = (2.5, 0) -> 7.75
  EXPECT_DOUBLE_EQ(net.forward(x)(0, 0), 7.75);
}

TEST(Mlp, PytorchDefaultInitBoundsAndDeterminism) {
  Rng a(11), b(11);
  Mlp<float> n1(MlpSpec{100, {50}, 8}, a), n2(MlpSpec{100, {50}, 8}, b);
  EXPECT_TRUE(n1.params() == n2.params());
  const float b0 = 1.f / std::sqrt(100.f), b1 = 1.f / std::sqrt(50.f);
  EXPECT_LE(n1.weight(0).cwiseAbs().maxCoeff(), b0);
  EXPECT_GT(n1.weight(0).cwiseAbs().maxCoeff(), 0.95f * b0);
  EXPECT_LE(n1.bias(0).cwiseAbs().maxCoeff(), b0);
  EXPECT_LE(n1.weight(1).cwiseAbs().maxCoeff(), b1);
  EXPECT_GT(n1.weight(1).cwiseAbs().maxCoeff(), 0.9f * b1);
  // Uniform(±b): variance b²/3.
  const double var = n1.weight(0).cast<double>().array().square().mean();
  EXPECT_NEAR(var, b0 * b0 / 3.0, 0.05 * b0 * b0 / 3.0);
}

TEST(Mlp, InferenceEqualsTrainingForward) {
  Rng rng(5);
  for (Activation a : kMlpActivations) {
    Mlp<float> net(MlpSpec{7, {9, 6}, 3, a, Activation::Tanh}, rng);
    const Eigen::MatrixXf x = random_matrix(rng, 7, 13).cast<float>();
    InferenceWorkspace<float> ws;
    Eigen::MatrixXf y(3, 13);
    net.forward(x, y, ws);
    TrainCache<float> cache;
    const Eigen::MatrixXf& yt = net.forward_train(x, cache);
    EXPECT_LT((y - yt).cwiseAbs().maxCoeff(), 1e-6f) << to_string(a);
    // Smaller batch through the same (larger) workspace, and a column block as input.
    Eigen::MatrixXf y2(3, 4);
    net.forward(x.middleCols(2, 4), y2, ws);
    EXPECT_LT((y2 - yt.middleCols(2, 4)).cwiseAbs().maxCoeff(), 1e-6f);
  }
}

// Every backward pass vs central finite differences in double, over random shapes, seeds and every
// activation (hidden and output).
TEST(Mlp, BackwardMatchesFiniteDifferences) {
  for (int seed = 0; seed < 4; ++seed) {
    Rng rng(100 + seed);
    for (Activation hidden_act : kMlpActivations) {
      for (Activation out_act : kMlpActivations) {
        MlpSpec spec;
        spec.inputs = 1 + static_cast<Index>(rng.uniform_int(5));
        const int layers = static_cast<int>(rng.uniform_int(3));  // 0..2 hidden layers
        for (int l = 0; l < layers; ++l) spec.hidden.push_back(1 + static_cast<Index>(rng.uniform_int(6)));
        spec.outputs = 1 + static_cast<Index>(rng.uniform_int(4));
        spec.activation = hidden_act;
        spec.output_activation = out_act;
        const Index B = 1 + static_cast<Index>(rng.uniform_int(4));
        Mlp<double> net(spec, rng);
        Eigen::MatrixXd x = random_matrix(rng, spec.inputs, B);
        const Eigen::MatrixXd R = random_matrix(rng, spec.outputs, B);  // L = Σ R ⊙ y
        auto loss = [&] { return (net.forward(x).array() * R.array()).sum(); };

        TrainCache<double> cache;
        net.forward_train(x, cache);
        net.zero_grad();
        Eigen::VectorXd g0 = Eigen::VectorXd::Random(net.num_params());
        net.grads() = g0;  // backward must ADD
        Eigen::MatrixXd dx;
        net.backward(cache, R, net.grads(), &dx);
        const Eigen::VectorXd analytic = net.grads() - g0;

        Eigen::VectorXd p = net.params();
        const Eigen::VectorXd numeric = test::central_diff<Eigen::VectorXd>(p, [&] {
          net.params() = p;
          return loss();
        });
        net.params() = p;
        const Eigen::MatrixXd numeric_dx = test::central_diff<Eigen::MatrixXd>(x, loss);
        EXPECT_LT(test::rel_error(analytic, numeric), 1e-6)
            << "params, hidden=" << to_string(hidden_act) << " out=" << to_string(out_act) << " seed=" << seed;
        EXPECT_LT(test::rel_error(dx, numeric_dx), 1e-6)
            << "input, hidden=" << to_string(hidden_act) << " out=" << to_string(out_act) << " seed=" << seed;
      }
    }
  }
}

TEST(Mlp, CacheExposesPreActivations) {
  Rng rng(9);
  Mlp<double> net(MlpSpec{3, {4}, 2, Activation::Tanh}, rng);
  const Eigen::MatrixXd x = random_matrix(rng, 3, 5);
  TrainCache<double> c;
  net.forward_train(x, c);
  const Eigen::MatrixXd z0 = (net.weight(0) * x).colwise() + net.bias(0);
  EXPECT_LT((c.pre[0] - z0).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_LT((c.post[0] - z0.array().tanh().matrix()).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_EQ(&c.layer_input(1), &c.post[0]);
  EXPECT_EQ(&c.output(), &c.post[1]);
}

TEST(Mlp, BadShapesThrow) {
  Mlp<float> net(MlpSpec{3, {4}, 2});
  InferenceWorkspace<float> ws;
  Eigen::MatrixXf y(2, 5);
  EXPECT_THROW(net.forward(Eigen::MatrixXf::Zero(4, 5), y, ws), Error);
  EXPECT_THROW(net.forward(Eigen::MatrixXf::Zero(3, 6), y, ws), Error);
  TrainCache<float> c;
  net.forward_train(Eigen::MatrixXf::Zero(3, 5), c);
  EXPECT_THROW(net.backward(c, Eigen::MatrixXf::Zero(2, 4), net.grads()), Error);
  Eigen::VectorXf small(3);
  EXPECT_THROW(net.backward(c, Eigen::MatrixXf::Zero(2, 5), small), Error);
  EXPECT_THROW(Mlp<float>(MlpSpec{0, {4}, 2}), Error);
  EXPECT_THROW(Mlp<float>(MlpSpec{3, {0}, 2}), Error);
  Mlp<float> empty;
  EXPECT_THROW(empty.forward(Eigen::MatrixXf::Zero(3, 1)), Error);
}

// The chunked, pool-parallel products (nn/chunks.hpp) against the layer formulas written out
// directly, in double, on shapes that exercise every split: columns (batch ≥ out), rows
// (out > batch), gW by rows (out ≥ in) and by columns (out < in), products too small to split, and
// the batch-1 GEMV.
TEST(Mlp, ChunkedProductsMatchDirectLayerFormulas) {
  Rng rng(42);
  const std::pair<MlpSpec, Index> cases[] = {
      {MlpSpec{150, {300, 140}, 70, Activation::ELU, Activation::Tanh}, 260},  // every split kind
      {MlpSpec{400, {1200, 300}, 70, Activation::ELU, Activation::Tanh}, 24},  // small batch: rows
      {MlpSpec{150, {300, 140}, 70, Activation::ELU, Activation::Tanh}, 3},    // below kMinChunkedMacs
      {MlpSpec{150, {300, 140}, 70, Activation::ELU, Activation::Tanh}, 1},    // inference: gemv_colmajor
  };
  for (const auto& [spec, batch] : cases) {
    ASSERT_EQ(double(spec.hidden[0]) * double(spec.inputs) * double(batch) >= kMinChunkedMacs, batch > 3);
    Mlp<double> net(spec, rng);
    const Eigen::MatrixXd x = random_matrix(rng, spec.inputs, batch);
    const Eigen::MatrixXd dy = random_matrix(rng, spec.outputs, batch);
    auto f = [](Activation a) { return [a](double z) { return activation_value(a, z); }; };
    auto df = [](Activation a) { return [a](double z) { return activation_derivative(a, z); }; };

    // Direct formulas.
    std::vector<Eigen::MatrixXd> in(3), pre(3);
    Eigen::MatrixXd a = x;
    for (Index l = 0; l < 3; ++l) {
      in[l] = a;
      pre[l] = (net.weight(l) * a).colwise() + Eigen::VectorXd(net.bias(l));
      a = pre[l].unaryExpr(f(spec.layer_activation(l)));
    }
    Eigen::VectorXd g_ref = Eigen::VectorXd::Zero(net.num_params());
    Eigen::MatrixXd d = dy.cwiseProduct(pre[2].unaryExpr(df(spec.output_activation))), dx_ref;
    for (Index l = 2; l >= 0; --l) {
      Eigen::Map<Eigen::MatrixXd>(g_ref.data() + net.weight_offset(l), spec.layer_outputs(l), spec.layer_inputs(l)) =
          d * in[l].transpose();
      g_ref.segment(net.bias_offset(l), spec.layer_outputs(l)) = d.rowwise().sum();
      const Eigen::MatrixXd da = net.weight(l).transpose() * d;
      if (l > 0) d = da.cwiseProduct(pre[l - 1].unaryExpr(df(spec.activation)));
      else dx_ref = da;
    }

    for (std::size_t threads : {0u, 1u, 2u, 3u}) {
      ThreadPool pool(threads == 0 ? 1 : threads);
      ThreadPool* p = threads == 0 ? nullptr : &pool;
      InferenceWorkspace<double> ws;
      ws.pool = p;
      Eigen::MatrixXd y(spec.outputs, batch);
      net.forward(x, y, ws);
      EXPECT_LT((y - a).cwiseAbs().maxCoeff(), 1e-12) << "batch " << batch << ", " << threads << " threads";
      TrainCache<double> cache;
      cache.pool = p;
      net.forward_train(x, cache);
      EXPECT_LT((cache.output() - a).cwiseAbs().maxCoeff(), 1e-12);
      net.zero_grad();
      Eigen::MatrixXd dx;
      net.backward(cache, dy, net.grads(), &dx);
      EXPECT_LT((net.grads() - g_ref).cwiseAbs().maxCoeff(), 1e-10) << "batch " << batch << ", " << threads;
      EXPECT_LT((dx - dx_ref).cwiseAbs().maxCoeff(), 1e-10) << "batch " << batch << ", " << threads;
    }
  }
}

// Same seed and data → bit-identical outputs and gradients with no pool and pools of 1, 2, 3
// threads (the chunk partition depends on shapes only).
TEST(Mlp, PoolSizeDoesNotChangeAnyBit) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  Rng init(9);
  const MlpSpec spec{330, {256, 200}, 63};
  Mlp<float> net(spec, init);
  Rng rng(10);
  const Eigen::MatrixXf x = random_matrix(rng, spec.inputs, 515).cast<float>();
  const Eigen::MatrixXf dy = random_matrix(rng, spec.outputs, 515).cast<float>();
  auto run = [&](ThreadPool* p, Eigen::MatrixXf& y, Eigen::VectorXf& g, Eigen::MatrixXf& dx) {
    InferenceWorkspace<float> ws;
    ws.pool = p;
    y.resize(spec.outputs, x.cols());
    net.forward(x, y, ws);
    TrainCache<float> cache;
    cache.pool = p;
    net.forward_train(x, cache);
    net.zero_grad();
    net.backward(cache, dy, net.grads(), &dx);
    g = net.grads();
  };
  Eigen::MatrixXf y0, dx0;
  Eigen::VectorXf g0;
  run(nullptr, y0, g0, dx0);
  for (std::size_t threads : {1u, 2u, 3u}) {
    ThreadPool pool(threads);
    Eigen::MatrixXf y, dx;
    Eigen::VectorXf g;
    run(&pool, y, g, dx);
    EXPECT_TRUE(y == y0) << threads << " threads";
    EXPECT_TRUE(g == g0) << threads << " threads";
    EXPECT_TRUE(dx == dx0) << threads << " threads";
  }
}

TEST(Gemv, MatchesEigenOnEveryTailLength) {
  Rng rng(77);
  for (Index m : {Index(1), Index(7), Index(63), Index(130)}) {
    for (Index n : {Index(1), Index(8), Index(13), Index(330)}) {
      const Eigen::MatrixXd big = random_matrix(rng, m + 5, n);  // leading dimension m + 5
      const Eigen::VectorXd x = random_matrix(rng, n, 1);
      Eigen::VectorXd y(m);
      gemv_colmajor<double>(m, n, big.data(), big.outerStride(), x.data(), y.data());
      const Eigen::VectorXd ref = big.topRows(m) * x;
      EXPECT_LT((y - ref).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + ref.cwiseAbs().maxCoeff())) << m << "x" << n;
    }
  }
}

// Batch 1 with a pool: the GEMV's rows are split over the threads; every output is the same sum.
TEST(Mlp, Batch1OnAPoolIsBitIdentical) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  Rng init(12);
  const MlpSpec spec{330, {1024, 300}, 63};
  ASSERT_GE(1024.0 * 330.0 * sizeof(float), kMinSplitGemvBytes);  // the first layer really is split
  Mlp<float> net(spec, init);
  Rng rng(13);
  const Eigen::MatrixXf x = random_matrix(rng, spec.inputs, 1).cast<float>();
  InferenceWorkspace<float> ws;
  Eigen::MatrixXf y0(spec.outputs, 1), y(spec.outputs, 1);
  net.forward(x, y0, ws);
  for (std::size_t threads : {2u, 3u}) {
    ThreadPool pool(threads);
    ws.pool = &pool;
    net.forward(x, y, ws);
    EXPECT_TRUE(y == y0) << threads << " threads";
  }
  TrainCache<float> cache;
  EXPECT_LT((y0 - net.forward_train(x, cache)).cwiseAbs().maxCoeff(), 1e-5f);  // GEMV vs GEMM path
}
