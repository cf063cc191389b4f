// Proves the inference path allocates nothing once the workspace has seen the batch size.
// Built as its own executable: Eigen's runtime malloc check must be enabled before any Eigen
// header in every translation unit of the binary, and its assertion must work in Release builds.
#define EIGEN_RUNTIME_NO_MALLOC
#include <stdexcept>
#define eigen_assert(x) \
  do { if (!(x)) throw std::runtime_error("Eigen assertion failed: " #x); } while (false)

#include <atomic>
#include <cstdlib>
#include <new>

#include <gtest/gtest.h>

#include "maskadapt/nn/mlp.hpp"

// Counts every operator-new allocation (std::string, std::vector, …); Eigen's own allocations go
// through malloc and are caught by EIGEN_RUNTIME_NO_MALLOC.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
static std::atomic<long> g_news{0};
void* operator new(std::size_t n) {
  ++g_news;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

using namespace maskadapt;
using namespace maskadapt::nn;

TEST(MlpNoAlloc, CheckIsLive) {
  Eigen::internal::set_is_malloc_allowed(false);
  EXPECT_THROW({ Eigen::MatrixXf m(8, 8); (void)m; }, std::runtime_error);  // the check really fires
  Eigen::internal::set_is_malloc_allowed(true);
}

TEST(MlpNoAlloc, ForwardAllocatesNothingAfterWarmup) {
  Rng rng(1);
  for (Activation a : {Activation::ReLU, Activation::ELU, Activation::SiLU, Activation::Tanh}) {
    Mlp<float> net(MlpSpec{12, {32, 24}, 5, a}, rng);
    Eigen::MatrixXf x = Eigen::MatrixXf::Random(12, 16), y(5, 16), y_small(5, 3);
    InferenceWorkspace<float> ws;
    net.forward(x, y, ws);  // warm-up: workspace grows here
    const Eigen::MatrixXf expected = y;
    const long news_before = g_news.load();
    Eigen::internal::set_is_malloc_allowed(false);
    try {
      for (int k = 0; k < 3; ++k) net.forward(x, y, ws);
      net.forward(x.leftCols(3), y_small, ws);  // smaller batches reuse the workspace
    } catch (...) {
      Eigen::internal::set_is_malloc_allowed(true);
      ADD_FAILURE() << "forward allocated for activation " << to_string(a);
      continue;
    }
    Eigen::internal::set_is_malloc_allowed(true);
    EXPECT_EQ(g_news.load(), news_before) << "operator new called during forward";
    EXPECT_TRUE(y == expected);
    EXPECT_LT((y_small - expected.leftCols(3)).cwiseAbs().maxCoeff(), 1e-6f);
  }
}

TEST(MlpNoAlloc, TrainingPassReusesCache) {
  Rng rng(2);
  Mlp<float> net(MlpSpec{6, {10}, 4, Activation::Tanh}, rng);
  const Eigen::MatrixXf x = Eigen::MatrixXf::Random(6, 8), dy = Eigen::MatrixXf::Random(4, 8);
  TrainCache<float> cache;
  net.forward_train(x, cache);
  net.backward(cache, dy, net.grads());
  Eigen::internal::set_is_malloc_allowed(false);
  bool ok = true;
  try {
    net.forward_train(x, cache);
    net.backward(cache, dy, net.grads());
  } catch (...) {
    ok = false;
  }
  Eigen::internal::set_is_malloc_allowed(true);
  EXPECT_TRUE(ok) << "forward_train/backward allocated with a warm cache";
}

// With a pool the chunked products run on two threads; still no allocation (the pool's job is a
// std::function holding one reference, inside its small-object buffer). Eigen's own GEMM
// allocates blocking buffers for products this size, so this holds with the BLAS backend only.
TEST(MlpNoAlloc, ForwardOnAPoolAllocatesNothingAfterWarmup) {
#if !defined(MASKADAPT_HAS_BLAS)
  GTEST_SKIP() << "built without EIGEN_USE_BLAS: Eigen's GEMM allocates its blocking buffers";
#endif
  Rng rng(3);
  Mlp<float> net(MlpSpec{64, {512, 512}, 16}, rng);
  ASSERT_GE(512.0 * 512.0 * 256.0, kMinChunkedMacs);  // the middle layer really is split
  Eigen::MatrixXf x = Eigen::MatrixXf::Random(64, 256), y(16, 256);
  ThreadPool pool(2);
  InferenceWorkspace<float> ws;
  ws.pool = &pool;
  net.forward(x, y, ws);
  const Eigen::MatrixXf expected = y;
  const long news_before = g_news.load();
  Eigen::internal::set_is_malloc_allowed(false);
  bool threw = false;
  try {
    for (int k = 0; k < 3; ++k) net.forward(x, y, ws);
  } catch (...) {
    threw = true;
  }
  Eigen::internal::set_is_malloc_allowed(true);
  EXPECT_FALSE(threw) << "forward on a pool allocated through Eigen";
  EXPECT_EQ(g_news.load(), news_before) << "operator new called during forward on a pool";
  EXPECT_TRUE(y == expected);
}
