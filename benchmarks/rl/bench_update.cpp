// The stage-1 update against its GEMM floor, and the discriminator's real-window sampler
// (docs/benchmarks.md, section training).
//
//  - BM_Update: BaseTrainer::update_from_rollout — rewards, GAE, PPO + MI, discriminator with its
//    gradient penalty, input statistics — at the cpu preset (32 envs × horizon 32 = 1,024
//    samples, masking on with the EMA target, the recipe's steady state), on one rollout of the
//    MuJoCo humanoid.
//  - BM_UpdateGemmFloor: the same update's matrix products — every forward, backward and penalty
//    product of the networks at their real shapes and counts (update_gemms below) — run bare,
//    one after another: chunks:0 each product whole on one thread; chunks:1 cut into the Mlp's
//    chunks (nn/chunks.hpp) and run on a pool of 1 or 2 threads, as the trainer runs them. The
//    ratio BM_Update / BM_UpdateGemmFloor at the same thread count is how far the update is from
//    doing nothing but its GEMMs; the floor's own 1 → 2 thread ratio is what the products allow.
//  - BM_RealWindows: 512 real discriminator windows (the batch of one discriminator step) from
//    the library, shared poses (MotionLibrary::amp_window) vs every frame's central difference
//    on its own (the peer: 15 interpolated poses per window instead of 7).
//
//   ./maskadapt_bench_update --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "../bench_main.hpp"

#include <memory>
#include <vector>

#include "maskadapt/core/blas_threads.hpp"
#include "maskadapt/core/thread_pool.hpp"
#include "maskadapt/sim/mujoco/humanoid_sim.hpp"
#include "maskadapt/train/base_trainer.hpp"
#include "maskadapt/train/config.hpp"
#include "maskadapt/train/motion_sources.hpp"

using namespace maskadapt;
using namespace maskadapt::train;

namespace {

/// One matrix product C (m × n) = op(A) · op(B) with inner dimension k.
struct Gemm {
  enum Kind { NN, NT, TN } kind;  ///< W·a (forward), δ·aᵀ (weight gradient), Wᵀ·δ (input gradient)
  Index m, n, k;
  double flops() const { return 2.0 * static_cast<double>(m) * static_cast<double>(n) * static_cast<double>(k); }
};

void forward(const nn::Mlp<float>& net, Index B, std::vector<Gemm>& out) {
  for (Index l = 0; l < net.num_layers(); ++l)
    out.push_back({Gemm::NN, net.spec().layer_outputs(l), B, net.spec().layer_inputs(l)});
}
/// Weight gradients of every layer, input gradients of every layer but the first.
void backward(const nn::Mlp<float>& net, Index B, std::vector<Gemm>& out) {
  for (Index l = net.num_layers() - 1; l >= 0; --l) {
    out.push_back({Gemm::NT, net.spec().layer_outputs(l), net.spec().layer_inputs(l), B});
    if (l > 0) out.push_back({Gemm::TN, net.spec().layer_inputs(l), B, net.spec().layer_outputs(l)});
  }
}
/// The gradient penalty on B real samples (rl/gradient_penalty.hpp, piecewise-linear layers):
/// q_l = W_lᵀ g_l for every layer; then ∂P/∂W_l += g_l q̄_lᵀ for every layer and ḡ_l = W_l q̄_l below
/// the output.
void penalty(const nn::Mlp<float>& net, Index B, std::vector<Gemm>& out) {
  const auto& s = net.spec();
  for (Index l = net.num_layers() - 1; l >= 0; --l) out.push_back({Gemm::TN, s.layer_inputs(l), B, s.layer_outputs(l)});
  for (Index l = 0; l < net.num_layers(); ++l) {
    out.push_back({Gemm::NT, s.layer_outputs(l), s.layer_inputs(l), B});
    if (l + 1 < net.num_layers()) out.push_back({Gemm::NN, s.layer_outputs(l), B, s.layer_inputs(l)});
  }
}

/// Every product of one BaseTrainer update at this config (base_trainer.hpp, update_policy and
/// update_discriminator), masking on with a fixed (EMA) target.
std::vector<Gemm> update_gemms(const BaseTrainConfig& c, const BasePolicy& p, Index n) {
  std::vector<Gemm> g;
  const auto& actor = p.ac.actor.mean_net;
  const auto& critic = p.ac.critic.net;
  const auto& disc = p.disc.net();
  forward(disc, n, g);  // rewards
  // MI target μ(s, m⁰) of the EMA copy, and the logged masked / unmasked KL's two actor passes
  for (int i = 0; i < 3; ++i) forward(actor, n, g);
  const Index nmb = std::max<Index>(1, n / c.ppo.minibatch_size), B = n / nmb;
  for (int e = 0; e < c.ppo.epochs; ++e)
    for (Index b = 0; b < nmb; ++b) {
      forward(actor, B, g);
      backward(actor, B, g);
      forward(critic, B, g);
      backward(critic, B, g);
    }
  const Index Bd = c.disc.batch_size, steps = std::max<Index>(1, c.disc.epochs * n / Bd);
  for (Index s = 0; s < steps; ++s) {
    forward(disc, 2 * Bd, g);  // [real | fake]
    backward(disc, 2 * Bd, g);
    penalty(disc, Bd, g);
  }
  return g;
}

BaseTrainConfig bench_config(int threads) {
  BaseTrainConfig c = cpu_preset();
  c.run.threads = threads;
  c.mask.warmup_samples = 0;  // masking and the MI target from the start: the recipe's steady state
  c.mask.ramp_samples = 0;
  return c;
}

/// A trainer at the cpu preset on the MuJoCo humanoid that has run one iteration.
struct Setup {
  std::shared_ptr<MotionLibrary> lib;
  BaseTrainConfig config;
  ThreadPool pool;
  MujocoHumanoidSim sim;
  BaseTrainer<MujocoHumanoidSim> trainer;
  explicit Setup(int threads)
      : lib(load_motion_library(bench_config(threads).env.motions)),
        config(resolved(bench_config(threads), *lib)),
        pool(static_cast<std::size_t>(threads)),
        sim(static_cast<std::size_t>(config.env.num_envs), pool),
        trainer(sim, library_reset_sampler(lib), library_window_sampler(lib, &pool), config, &pool) {
    trainer.iterate();
  }
  static BaseTrainConfig resolved(BaseTrainConfig c, const MotionLibrary& lib) {
    resolve_action_space(c, lib.skeleton(), &lib);  // the preset's mean-pose action offset
    return c;
  }
};

void BM_Update(benchmark::State& state) {
  Setup s(static_cast<int>(state.range(0)));
  const auto gemms = update_gemms(s.trainer.config(), s.trainer.policy(), 1024);
  double flops = 0;
  for (const auto& g : gemms) flops += g.flops();
  IterationStats st;
  for (auto _ : state) s.trainer.update_from_rollout(st);
  state.counters["GEMM_FLOPS"] = benchmark::Counter(flops * static_cast<double>(state.iterations()),
                                                    benchmark::Counter::kIsRate);
  state.counters["disc_share"] = st.time_disc / st.time_update;
}
BENCHMARK(BM_Update)->Arg(1)->Arg(2)->ArgNames({"threads"})->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_UpdateGemmFloor(benchmark::State& state) {
  const bool chunked = state.range(0) == 1;
  const auto threads = static_cast<std::size_t>(state.range(1));
  Setup s(1);  // (for the networks' shapes)
  const BaseTrainConfig& c = s.trainer.config();
  const BasePolicy& p = s.trainer.policy();
  const auto gemms = update_gemms(c, p, 1024);
  struct Operands {
    Eigen::MatrixXf a, b, out;
  };
  std::vector<Operands> ops;
  double flops = 0;
  for (const auto& g : gemms) {
    flops += g.flops();
    Operands o;
    o.a = Eigen::MatrixXf::Random(g.kind == Gemm::TN ? g.k : g.m, g.kind == Gemm::TN ? g.m : g.k);
    o.b = Eigen::MatrixXf::Random(g.kind == Gemm::NT ? g.n : g.k, g.kind == Gemm::NT ? g.k : g.n);
    o.out = Eigen::MatrixXf::Zero(g.m, g.n);
    ops.push_back(std::move(o));
  }
  ThreadPool pool(threads);
  for (auto _ : state) {
    for (std::size_t i = 0; i < gemms.size(); ++i) {
      auto& o = ops[i];
      const Gemm& g = gemms[i];
      // the block (r0, nr) × (c0, nc) of the result, as one single-threaded GEMM
      auto block = [&](Index r0, Index nr, Index c0, Index nc) {
        auto out = o.out.block(r0, c0, nr, nc);
        switch (g.kind) {
          case Gemm::NN: out.noalias() = o.a.middleRows(r0, nr) * o.b.middleCols(c0, nc); break;
          case Gemm::NT: out.noalias() += o.a.middleRows(r0, nr) * o.b.middleRows(c0, nc).transpose(); break;
          case Gemm::TN: out.noalias() = o.a.middleCols(r0, nr).transpose() * o.b.middleCols(c0, nc); break;
        }
      };
      if (!chunked) block(0, g.m, 0, g.n);
      else  // the Mlp's partition (nn/chunks.hpp): weight gradients split by rows on a tie
        nn::for_each_block(&pool, g.m, g.n, nn::worth_chunking(g.m, g.k, g.n), block, g.kind == Gemm::NT);
    }
    benchmark::ClobberMemory();
  }
  state.counters["GEMM_FLOPS"] = benchmark::Counter(flops * static_cast<double>(state.iterations()),
                                                    benchmark::Counter::kIsRate);
  state.counters["gemms"] = static_cast<double>(gemms.size());
  state.counters["GFLOP_per_update"] = flops * 1e-9;
}
// chunks:0 — every product whole on one thread (the floor of BM_Update/threads:1); chunks:1 — cut
// into the Mlp's chunks and run on a pool of 1 or 2 threads (the floor of BM_Update/threads:2).
BENCHMARK(BM_UpdateGemmFloor)
    ->Args({0, 1})
    ->Args({1, 1})
    ->Args({1, 2})
    ->ArgNames({"chunks", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

/// The peer of MotionLibrary::amp_window: every frame's pose and central difference on its own.
void amp_window_per_frame(const MotionLibrary& lib, int clip, double t_end, Eigen::Ref<VectorXf> out) {
  const Index d = observation_dim(lib.skeleton());
  BodyStates bs;
  for (int k = 0; k < kAmpWindowFrames; ++k) {
    lib.body_states(clip, t_end - (kAmpWindowFrames - 1 - k) * kAmpFrameDt, bs);
    compute_observation(lib.skeleton(), bs, out.segment(k * d, d));
  }
}

void BM_RealWindows(benchmark::State& state) {
  const auto lib = load_motion_library({"locomotion"});
  const bool shared = state.range(0) == 1;
  MatrixXf out(lib->amp_window_dim(), 512);
  Rng rng(1);
  std::vector<ClipTime> times(512);
  for (auto _ : state) {
    for (auto& ct : times) ct = lib->sample(rng, true, (kAmpWindowFrames - 1) * kAmpFrameDt);
    for (Index b = 0; b < 512; ++b) {
      const ClipTime& ct = times[static_cast<std::size_t>(b)];
      if (shared) lib->amp_window(ct.clip, ct.time, out.col(b));
      else amp_window_per_frame(*lib, ct.clip, ct.time, out.col(b));
    }
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["windows_per_s"] =
      benchmark::Counter(512.0 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RealWindows)->Arg(0)->Arg(1)->ArgNames({"shared_poses"})->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  maskadapt::limit_blas_threads(1);  // as the maskadapt command does: the pool parallelises, not OpenBLAS
  return maskadapt::bench::run_benchmarks(argc, argv);
}
