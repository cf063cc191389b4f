// Control steps per second of MujocoHumanoidSim (stepping + observation + masked policy input)
// against a bare loop of mj_step on the same model in the same binary, and the cost of one
// control step under MuJoCo 2.2.2's solver/integrator options (BM_Options/...).
//
//   maskadapt_bench_sim --benchmark_min_time=2
//   maskadapt_bench_sim --benchmark_filter=BM_Options --benchmark_repetitions=5 \
//       --benchmark_enable_random_interleaving=true --benchmark_format=json > options.json
//   python3 benchmarks/sim/option_ratios.py options.json   # medians and ratios against "old"
//
// items_per_second = env control steps per second (one control step = 1/30 s of physics:
// desc.substeps physics steps of desc.physics_dt).
#include <maskadapt/core/blas_threads.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/mask/apply.hpp>
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>

#include <benchmark/benchmark.h>

#include "../bench_main.hpp"

#include <functional>
#include <string>
#include <utility>
#include <vector>

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

// ---- physics options ---------------------------------------------------------------------------
// One control step (1/30 s) of MujocoHumanoidSim::step for 8 envs on 1 thread, per option set.
// "old" is the setting before issue 13 (1/120 s × 4, armature 0.02/0.01, Newton, 100 iterations,
// tolerance 1e-8, pyramidal, jacobian auto = sparse at nv = 69); "default" is
// humanoid_description(). Two motions: "stand" holds the zero pose (16 contacts, solver
// converges in ~1 iteration from its warm start) and "random" follows a fixed cycle of uniform
// random targets inside the joint ranges, each held 5 control steps (flailing, falling, lying on
// the floor: the contact load of early training). resets counts physics failures in the run.

using PO = PhysicsOptions;
constexpr int kOptionEnvs = 8;

/// The random-target cycle: 40 targets, each held 5 control steps (63 × kOptionEnvs each).
const std::vector<MatrixXf>& random_target_cycle() {
  static const std::vector<MatrixXf> cycle = [] {
    const Skeleton& s = humanoid_skeleton();
    Rng r(2024);
    std::vector<MatrixXf> c;
    for (int k = 0; k < 40; ++k) {
      MatrixXf t(s.num_dofs(), kOptionEnvs);
      for (Index e = 0; e < kOptionEnvs; ++e)
        for (int i = 1; i < s.num_bodies(); ++i)
          for (int j = 0; j < 3; ++j)
            t(s.dof_offset(i) + j, e) = static_cast<float>(r.uniform(s.dof_lower(s.dof_offset(i) + j), s.dof_upper(s.dof_offset(i) + j)));
      c.push_back(std::move(t));
    }
    return c;
  }();
  return cycle;
}

void BM_Options(benchmark::State& state, HumanoidDescription desc, bool random) {
  MujocoHumanoidSim sim(kOptionEnvs, 1, desc);
  const MatrixXf zero = MatrixXf::Zero(63, kOptionEnvs);
  const auto& cycle = random_target_cycle();
  std::size_t k = 0;
  for (auto _ : state) {
    sim.step(random ? cycle[(k / 5) % cycle.size()] : zero);
    ++k;
  }
  state.SetItemsProcessed(state.iterations() * kOptionEnvs);
  state.counters["us_per_control_step"] =
      benchmark::Counter(static_cast<double>(state.iterations() * kOptionEnvs) * 1e-6,
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["resets"] = static_cast<double>(sim.step_stats().physics_resets);
}

void register_option_benchmarks() {
  const HumanoidDescription old = legacy_humanoid_description_120hz();
  const HumanoidDescription now = humanoid_description();
  std::vector<std::pair<std::string, std::function<void(HumanoidDescription&)>>> tweaks = {
      {"", [](HumanoidDescription&) {}},
      {"+dense", [](HumanoidDescription& d) { d.physics.jacobian = PO::Jacobian::Dense; }},
      {"+sparse", [](HumanoidDescription& d) { d.physics.jacobian = PO::Jacobian::Sparse; }},
      {"+CG", [](HumanoidDescription& d) { d.physics.solver = PO::Solver::CG; }},
      {"+PGS", [](HumanoidDescription& d) { d.physics.solver = PO::Solver::PGS; }},
      {"+iter10", [](HumanoidDescription& d) { d.physics.iterations = 10; }},
      {"+iter3", [](HumanoidDescription& d) { d.physics.iterations = 3; }},
      {"+tol1e-6", [](HumanoidDescription& d) { d.physics.tolerance = 1e-6; }},
      {"+elliptic", [](HumanoidDescription& d) { d.physics.cone = PO::Cone::Elliptic; }},
  };
  std::vector<std::pair<std::string, HumanoidDescription>> sets;
  for (const auto& [name, f] : tweaks) {
    HumanoidDescription d = old;
    f(d);
    sets.emplace_back("old" + name, d);
  }
  for (const auto& [name, f] : tweaks) {
    HumanoidDescription d = now;
    f(d);
    sets.emplace_back("default" + name, d);
  }
  {
    HumanoidDescription d = now;
    d.physics.integrator = PO::Integrator::Implicit;
    sets.emplace_back("default+implicit", d);
    d = old;
    d.physics.integrator = PO::Integrator::Implicit;
    sets.emplace_back("old+implicit", d);
  }
  for (const bool random : {false, true})
    for (const auto& [name, d] : sets)
      benchmark::RegisterBenchmark(("BM_Options/" + std::string(random ? "random/" : "stand/") + name).c_str(),
                                   [d = d, random](benchmark::State& st) { BM_Options(st, d, random); })
          ->Unit(benchmark::kMicrosecond)
          ->UseRealTime()
          ->MinTime(0.3);
}

}  // namespace

BENCHMARK(BM_BareMjStep)->Arg(1)->Arg(16)->Arg(64)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SimStepWithFeatures)
    ->Args({1, 1})->Args({16, 1})->Args({64, 1})->Args({16, 2})->Args({64, 2})
    ->Unit(benchmark::kMillisecond)->UseRealTime()
    ->MeasureProcessCPUTime();  // CPU column = all threads: 2-thread CPU ≈ 1-thread CPU ⇒ no parallel overhead
BENCHMARK(BM_FeaturesOnly)->Arg(64)->Unit(benchmark::kMicrosecond)->UseRealTime();

int main(int argc, char** argv) {
  register_option_benchmarks();
  return maskadapt::bench::run_benchmarks(argc, argv);  // (MuJoCo itself uses no BLAS)
}
