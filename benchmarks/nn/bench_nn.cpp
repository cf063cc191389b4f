// Neural-network kernel benchmarks (docs/benchmarks.md, section nn).
// Every figure is meant to be read as a ratio against a peer in the same run: the FMA peak, the
// memory-streaming floor, and (with -DMASKADAPT_WITH_TORCH=ON) LibTorch doing the same work.
//   ./maskadapt_bench_nn --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "../bench_main.hpp"

#include <immintrin.h>
#include <malloc.h>

#include <vector>

#include "maskadapt/core/blas_threads.hpp"
#include "maskadapt/core/thread_pool.hpp"
#include "maskadapt/nn/kl.hpp"
#include "maskadapt/nn/mlp.hpp"

#ifdef MASKADAPT_WITH_TORCH
#include <torch/torch.h>
#endif

using namespace maskadapt;
using namespace maskadapt::nn;

namespace {

MlpSpec big_spec() { return MlpSpec{330, {1024, 1024, 512}, 63}; }
MlpSpec small_spec() { return MlpSpec{330, {256, 256}, 63}; }

/// Multiply-adds per sample of a forward pass.
double macs_per_sample(const MlpSpec& s) {
  double m = 0;
  for (Index l = 0; l < s.num_layers(); ++l) m += double(s.layer_inputs(l)) * double(s.layer_outputs(l));
  return m;
}

Eigen::MatrixXf random_input(Index rows, Index cols) {
  Rng rng(1);
  Eigen::MatrixXf x(rows, cols);
  for (Index i = 0; i < x.size(); ++i) x.data()[i] = static_cast<float>(rng.normal());
  return x;
}

// ---- machine peers ------------------------------------------------------------------------------

/// FMA throughput: 12 independent FMA chains (enough to cover latency × 2 pipes) of the vector
/// width of `Isa`.
template <class Isa>
void fma_peak(benchmark::State& state) {
  using V = typename Isa::V;
  const long iters = 1 << 20;
  for (auto _ : state) {
    V acc[12];
    for (int k = 0; k < 12; ++k) acc[k] = Isa::set1(0.001f * k);
    const V a = Isa::set1(0.999f), b = Isa::set1(0.0001f);
    for (long i = 0; i < iters; ++i) {
#pragma GCC unroll 12
      for (int k = 0; k < 12; ++k) acc[k] = Isa::fma(acc[k], a, b);
    }
    V s = acc[0];
    for (int k = 1; k < 12; ++k) s = Isa::add(s, acc[k]);
    benchmark::DoNotOptimize(s);
  }
  state.counters["FLOPS"] = benchmark::Counter(double(iters) * 12 * Isa::kLanes * 2 * double(state.iterations()),
                                               benchmark::Counter::kIsRate);
}

struct Avx2Fma {
  using V = __m256;
  static constexpr int kLanes = 8;
  static V set1(float x) { return _mm256_set1_ps(x); }
  static V fma(V a, V b, V c) { return _mm256_fmadd_ps(a, b, c); }
  static V add(V a, V b) { return _mm256_add_ps(a, b); }
};

/// 256-bit FMAs: what OpenBLAS's Haswell/Zen kernels use.
void BM_FmaPeak(benchmark::State& state) { fma_peak<Avx2Fma>(state); }
BENCHMARK(BM_FmaPeak)->Threads(1)->Threads(2)->UseRealTime();

#ifdef __AVX512F__
struct Avx512Fma {
  using V = __m512;
  static constexpr int kLanes = 16;
  static V set1(float x) { return _mm512_set1_ps(x); }
  static V fma(V a, V b, V c) { return _mm512_fmadd_ps(a, b, c); }
  static V add(V a, V b) { return _mm512_add_ps(a, b); }
};

/// 512-bit FMAs: OpenBLAS's SkylakeX/Cooperlake kernels use them. On CPUs with two 512-bit FMA
/// pipes (server Intel) this peak is twice the 256-bit one; on Zen 4 (double-pumped) it is the
/// same. Compare an AVX-512 kernel's GEMM against this row, an AVX2 one against the other.
void BM_FmaPeak512(benchmark::State& state) { fma_peak<Avx512Fma>(state); }
BENCHMARK(BM_FmaPeak512)->Threads(1)->Threads(2)->UseRealTime();
#endif

/// Streaming floor for batch-1 inference: read as many bytes as the network's parameters, split
/// over the benchmark's threads (each sums its share). The 7.8 MB of the big net fit in the 32 MB
/// L3, so in a hot loop this is an L3 floor, not a DRAM one.
void BM_WeightStreamFloor(benchmark::State& state) {
  const MlpSpec spec = state.range(0) == 0 ? big_spec() : small_spec();
  static Eigen::VectorXf w;  // shared by the threads
  if (state.thread_index() == 0) w = Eigen::VectorXf::Ones(spec.num_params());
  const Index n = spec.num_params(), T = state.threads(), t = state.thread_index();
  const Index lo = n * t / T, hi = n * (t + 1) / T;
  for (auto _ : state) {
    float s = w.segment(lo, hi - lo).sum();
    benchmark::DoNotOptimize(s);
  }
  state.counters["bytes"] = double(n) * 4;
}
BENCHMARK(BM_WeightStreamFloor)->Arg(0)->Arg(1)->ArgNames({"small"})->Threads(1)->Threads(2)->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

/// The same two-way split read through maskadapt's ThreadPool: the floor for a batch-1 forward
/// that hands its rows to the pool, wake-up cost included.
void BM_WeightStreamFloorPool(benchmark::State& state) {
  const MlpSpec spec = state.range(0) == 0 ? big_spec() : small_spec();
  const Eigen::VectorXf w = Eigen::VectorXf::Ones(spec.num_params());
  ThreadPool pool(2);
  float part[2];
  const Index n = w.size();
  for (auto _ : state) {
    pool.parallel_for(0, 2, [&](std::size_t t) {
      const Index lo = n * Index(t) / 2, hi = n * Index(t + 1) / 2;
      part[t] = w.segment(lo, hi - lo).sum();
    });
    benchmark::DoNotOptimize(part);
  }
}
BENCHMARK(BM_WeightStreamFloorPool)->Arg(0)->Arg(1)->ArgNames({"small"})->UseRealTime()->Unit(benchmark::kMicrosecond);

/// Parallel scheme of a maskadapt benchmark: range "pool" = 0 → OpenBLAS threads each GEMM
/// (2 threads, no pool); 1 → OpenBLAS at 1 thread and a 2-thread maskadapt ThreadPool runs the
/// Mlp's fixed chunks (nn/chunks.hpp).
ThreadPool* scheme(Index pool_mode) {
  static ThreadPool pool(2);
  set_blas_threads(pool_mode == 1 ? 1 : 2);
  return pool_mode == 1 ? &pool : nullptr;
}

// ---- maskadapt ----------------------------------------------------------------------------------

void BM_MlpForward(benchmark::State& state) {
  const Index batch = state.range(0);
  const MlpSpec spec = state.range(1) == 0 ? big_spec() : small_spec();
  Rng rng(1);
  Mlp<float> net(spec, rng);
  const Eigen::MatrixXf x = random_input(spec.inputs, batch);
  Eigen::MatrixXf y(spec.outputs, batch);
  InferenceWorkspace<float> ws;
  ws.pool = scheme(state.range(2));
  net.forward(x, y, ws);
  for (auto _ : state) {
    net.forward(x, y, ws);
    benchmark::DoNotOptimize(y.data());
  }
  state.counters["FLOPS"] = benchmark::Counter(2 * macs_per_sample(spec) * double(batch) * double(state.iterations()),
                                               benchmark::Counter::kIsRate);
}
BENCHMARK(BM_MlpForward)
    ->ArgsProduct({{4096, 256}, {0}, {0, 1}})->ArgsProduct({{1}, {0, 1}, {0, 1}})
    ->ArgNames({"batch", "small", "pool"})->Unit(benchmark::kMicrosecond)->UseRealTime();

void BM_MlpForwardBackward(benchmark::State& state) {
  const Index batch = state.range(0);
  const MlpSpec spec = big_spec();
  Rng rng(1);
  Mlp<float> net(spec, rng);
  const Eigen::MatrixXf x = random_input(spec.inputs, batch);
  const Eigen::MatrixXf dy = random_input(spec.outputs, batch);
  TrainCache<float> cache;
  cache.pool = scheme(state.range(1));
  for (auto _ : state) {
    net.zero_grad();
    net.forward_train(x, cache);
    net.backward(cache, dy, net.grads());  // no input gradient (as for a policy update)
    benchmark::DoNotOptimize(net.grads().data());
  }
  // forward 1×, backward 2× (weight grad + input grad, minus the first layer's input grad).
  const double macs = 3 * macs_per_sample(spec) - double(spec.inputs) * double(spec.hidden[0]);
  state.counters["FLOPS"] =
      benchmark::Counter(2 * macs * double(batch) * double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_MlpForwardBackward)
    ->ArgsProduct({{4096, 256}, {0, 1}})->ArgNames({"batch", "pool"})->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_KlWithGradient(benchmark::State& state) {
  const Index d = 63, B = state.range(0);
  const Eigen::MatrixXf mp = random_input(d, B), mq = random_input(d, B) * 0.5f;
  const Eigen::MatrixXf lp = Eigen::MatrixXf::Constant(d, 1, -0.5f), lq = Eigen::MatrixXf::Constant(d, 1, -0.3f);
  Eigen::MatrixXf gmq = Eigen::MatrixXf::Zero(d, B), glq = Eigen::MatrixXf::Zero(d, 1);
  for (auto _ : state) {
    gmq.setZero();
    glq.setZero();
    float v = kl_diag_gaussian_mean<float>(mp, lp, mq, lq, {nullptr, nullptr, &gmq, &glq}, {true, 1.0});
    benchmark::DoNotOptimize(v);
    benchmark::DoNotOptimize(gmq.data());
  }
}
BENCHMARK(BM_KlWithGradient)->Arg(4096)->ArgNames({"batch"})->Unit(benchmark::kMicrosecond);

// ---- LibTorch peers -----------------------------------------------------------------------------
#ifdef MASKADAPT_WITH_TORCH
torch::nn::Sequential torch_mlp(const MlpSpec& s) {
  torch::nn::Sequential seq;
  Index in = s.inputs;
  for (Index h : s.hidden) {
    seq->push_back(torch::nn::Linear(in, h));
    seq->push_back(torch::nn::ReLU());
    in = h;
  }
  seq->push_back(torch::nn::Linear(in, s.outputs));
  return seq;
}

/// LibTorch's intra-op threads: 1 is its best setting on this machine (OpenBLAS, which it calls
/// for the GEMMs, still runs 2 threads); its default 2 makes its OpenMP pool and OpenBLAS's threads
/// fight. The torch_threads:2 rows show that.
void torch_setting(Index torch_threads) {
  set_blas_threads(2);
  torch::set_num_threads(static_cast<int>(torch_threads));
}

void BM_TorchMlpForward(benchmark::State& state) {
  torch_setting(1);
  torch::NoGradGuard no_grad;
  const Index batch = state.range(0);
  const MlpSpec spec = state.range(1) == 0 ? big_spec() : small_spec();
  auto net = torch_mlp(spec);
  auto x = torch::randn({batch, spec.inputs});
  for (auto _ : state) {
    auto y = net->forward(x);
    benchmark::DoNotOptimize(y.data_ptr());
  }
  state.counters["FLOPS"] = benchmark::Counter(2 * macs_per_sample(spec) * double(batch) * double(state.iterations()),
                                               benchmark::Counter::kIsRate);
}
BENCHMARK(BM_TorchMlpForward)
    ->Args({4096, 0})->Args({256, 0})->Args({1, 0})->Args({1, 1})
    ->ArgNames({"batch", "small"})->Unit(benchmark::kMicrosecond)->UseRealTime();

void BM_TorchMlpForwardBackward(benchmark::State& state) {
  torch_setting(state.range(1));
  const Index batch = state.range(0);
  const MlpSpec spec = big_spec();
  auto net = torch_mlp(spec);
  auto x = torch::randn({batch, spec.inputs});
  auto dy = torch::randn({batch, spec.outputs});
  for (auto _ : state) {
    net->zero_grad();
    auto y = net->forward(x);
    y.backward(dy);
    benchmark::DoNotOptimize(y.data_ptr());
  }
  const double macs = 3 * macs_per_sample(spec) - double(spec.inputs) * double(spec.hidden[0]);
  state.counters["FLOPS"] =
      benchmark::Counter(2 * macs * double(batch) * double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_TorchMlpForwardBackward)
    ->Args({4096, 1})->Args({256, 1})->Args({4096, 2})->ArgNames({"batch", "torch_threads"})
    ->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_TorchKlWithGradient(benchmark::State& state) {
  torch_setting(1);
  const long d = 63, B = state.range(0);
  auto mp = torch::randn({B, d}), lp = torch::full({d}, -0.5f);
  auto mq = (torch::randn({B, d}) * 0.5).requires_grad_(true);
  auto lq = torch::full({d}, -0.3f).requires_grad_(true);
  for (auto _ : state) {
    if (mq.grad().defined()) {
      mq.grad().zero_();
      lq.grad().zero_();
    }
    auto vq = torch::exp(2 * lq), vp = torch::exp(2 * lp);
    auto kl = (lq - lp + (vp + (mp - mq).pow(2)) / (2 * vq) - 0.5).sum(1).mean();
    kl.backward();
    benchmark::DoNotOptimize(kl.data_ptr());
  }
}
BENCHMARK(BM_TorchKlWithGradient)->Arg(4096)->ArgNames({"batch"})->Unit(benchmark::kMicrosecond);
#endif

}  // namespace

int main(int argc, char** argv) {
  // LibTorch allocates fresh tensors every iteration; with glibc's default mmap threshold its
  // ~1 MB buffers are mmap'ed and page-faulted afresh each time (measured: KL 1.8 ms instead of
  // 0.7 ms, depending on what ran before). Keep big blocks on the heap so it runs at its best
  // whatever the order. maskadapt's kernels allocate nothing per iteration either way.
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  return maskadapt::bench::run_benchmarks(argc, argv);
}
