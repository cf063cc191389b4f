// Control steps per second of MujocoHumanoidSim (stepping + observation + masked policy input)
// against a bare loop of mj_step on the same model in the same binary.
//
//   maskadapt_bench_sim --benchmark_min_time=2
//
// items_per_second = env control steps per second (one control step = 4 physics steps at 1/120 s).
#include <maskadapt/core/blas_threads.hpp>
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/mask/apply.hpp>
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>

#include <benchmark/benchmark.h>

using namespace maskadapt;

namespace {

/// Bare MuJoCo: N mjData stepped sequentially, ctrl = 0 (hold the standing pose), no read-out.
void BM_BareMjStep(benchmark::State& state) {
  const auto num_envs = static_cast<std::size_t>(state.range(0));
  const HumanoidDescription& desc = humanoid_description();
  auto model = mujoco_detail::load_model_from_string(humanoid_mjcf(desc));
  std::vector<mujoco_detail::DataPtr> data;
  for (std::size_t e = 0; e < num_envs; ++e) {
    data.emplace_back(mj_makeData(model.get()));
    mj_forward(model.get(), data.back().get());
  }
  for (auto _ : state) {
    for (auto& d : data)
      for (int s = 0; s < desc.substeps; ++s) mj_step(model.get(), d.get());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(num_envs));
}

/// The library: step all envs on the thread pool, compute s for every env, build [s̄; m].
void BM_SimStepWithFeatures(benchmark::State& state) {
  const auto num_envs = static_cast<std::size_t>(state.range(0));
  const auto threads = static_cast<std::size_t>(state.range(1));
  MujocoHumanoidSim sim(num_envs, threads);
  const MatrixXf targets = MatrixXf::Zero(63, static_cast<Index>(num_envs));
  MatrixXf obs(kObservationDim, static_cast<Index>(num_envs));
  MatrixXf input(policy_input_dim(kObservationDim), static_cast<Index>(num_envs));
  const PartElements pe(observation_parts(sim.skeleton()));
  std::vector<PartMask> masks(num_envs, PartMask::parse("left_arm,right_leg"));
  ThreadPool pool(threads);
  for (auto _ : state) {
    sim.step(targets);
    pool.parallel_for(0, num_envs, [&](std::size_t e) {
      compute_observation(sim.skeleton(), sim.body_states(e), obs.col(static_cast<Index>(e)));
    });
    build_policy_input<float>(pe, obs, masks, input);
    benchmark::DoNotOptimize(input.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(num_envs));
  state.counters["resets"] = static_cast<double>(sim.step_stats().physics_resets);
}

/// Features alone (observation + policy input), to isolate the library's overhead.
void BM_FeaturesOnly(benchmark::State& state) {
  const auto num_envs = static_cast<std::size_t>(state.range(0));
  MujocoHumanoidSim sim(num_envs, 1);
  MatrixXf obs(kObservationDim, static_cast<Index>(num_envs));
  MatrixXf input(policy_input_dim(kObservationDim), static_cast<Index>(num_envs));
  const PartElements pe(observation_parts(sim.skeleton()));
  std::vector<PartMask> masks(num_envs, PartMask::parse("left_arm,right_leg"));
  for (auto _ : state) {
    for (std::size_t e = 0; e < num_envs; ++e)
      compute_observation(sim.skeleton(), sim.body_states(e), obs.col(static_cast<Index>(e)));
    build_policy_input<float>(pe, obs, masks, input);
    benchmark::DoNotOptimize(input.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(num_envs));
}

}  // namespace

BENCHMARK(BM_BareMjStep)->Arg(1)->Arg(16)->Arg(64)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SimStepWithFeatures)
    ->Args({1, 1})->Args({16, 1})->Args({64, 1})->Args({16, 2})->Args({64, 2})
    ->Unit(benchmark::kMillisecond)->UseRealTime()
    ->MeasureProcessCPUTime();  // CPU column = all threads: 2-thread CPU ≈ 1-thread CPU ⇒ no parallel overhead
BENCHMARK(BM_FeaturesOnly)->Arg(64)->Unit(benchmark::kMicrosecond)->UseRealTime();

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::AddCustomContext("openblas_core", maskadapt::blas_core_name());  // MuJoCo itself uses no BLAS
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
