// `maskadapt eval-base`: the H_norm table of a stage-1 base policy (null mask, every mask of one
// or two parts; random and shared initial states) with fall rates and episode lengths.
#include "cli_checks.hpp"
#include "command_registry.hpp"

#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/mask/sampler.hpp>
#include <maskadapt/train/config.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/eval_base.hpp>
#include <maskadapt/train/motion_sources.hpp>
#include <maskadapt/train/progress.hpp>

#ifdef MASKADAPT_HAS_MUJOCO
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>
#endif

#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

namespace {

struct EvalBaseArgs {
  std::string checkpoint, json;
  std::vector<std::string> motions;
  int envs = 10, threads = 0;
  long long frames = 1000, seed = 1;
  double threshold = 0.5, episode_seconds = 10.0;
  bool deterministic = false;
};

void run_eval_base(const EvalBaseArgs& a) {
  using namespace maskadapt;
  using namespace maskadapt::train;
#ifndef MASKADAPT_HAS_MUJOCO
  throw Error("this build has no MuJoCo; eval-base needs the maskadapt::mujoco target", {{}, std::nullopt, "eval-base"});
#else
  require(a.envs >= 1, "must be >= 1", {{}, {}, "--envs"});
  const Checkpoint ck = load_checkpoint(a.checkpoint);
  ThreadPool pool(static_cast<std::size_t>(a.threads));
  MujocoHumanoidSim sim(static_cast<std::size_t>(a.envs), pool);
  const Index d = observation_dim(sim.skeleton());
  const LoadedBasePolicy loaded =
      load_base_policy(ck, {d, d + kNumParts, sim.skeleton().num_dofs(), d * tasks::kAmpWindowFrames}, a.checkpoint);
  const auto motions = a.motions.empty() ? loaded.config.env.motions : a.motions;
  auto lib = load_motion_library(motions, motion_data_dir(MASKADAPT_SOURCE_DIR "/../shared/data"));
  const MatrixXf reference = reference_visitation_features(*lib);

  EvalBaseOptions opt;
  opt.frames = a.frames;
  opt.threshold = a.threshold;
  opt.episode_seconds = a.episode_seconds;
  opt.deterministic = a.deterministic;
  opt.seed = static_cast<std::uint64_t>(a.seed);
  std::cout << "eval-base: " << a.checkpoint << " (iteration " << loaded.iteration
            << (loaded.policy_only ? ", model (policy only)" : "") << ", masking "
            << (loaded.config.mask.enabled ? "on" : "off") << ", lambda_MI " << loaded.config.mask.lambda_mi << "); "
            << reference.cols() << " reference frames from " << lib->num_clips() << " clip(s); 16 masks x 2 starts x "
            << a.envs << " envs x " << a.frames << " frames; threshold " << a.threshold << " m\n";
  Stopwatch clock;
  BaseEvaluation ev = evaluate_base_policy(sim, loaded.policy, library_reset_sampler(lib), reference, opt, std::nullopt,
                                                 loaded.config.env.termination_height, &pool, &std::cout);
  ev.reference_speed = reference_mean_speed(*lib);
  std::cout << "\n" << format_hnorm_table(ev, false) << "\n" << format_hnorm_table(ev, true) << "\n"
            << format_episode_table(ev) << "eval-base: " << clock.seconds() << " s\n";
  if (!a.json.empty()) {
    nlohmann::json j = to_json(ev);
    j["checkpoint"] = a.checkpoint;
    j["iteration"] = loaded.iteration;
    j["envs"] = a.envs;
    j["motions"] = motions;
    j["lambda_mi"] = loaded.config.mask.lambda_mi;
    j["masking"] = loaded.config.mask.enabled;
    const auto parent = std::filesystem::path(a.json).parent_path();
    if (!parent.empty()) std::filesystem::create_directories(parent);
    std::ofstream f(a.json);
    require(static_cast<bool>(f), "cannot open for writing", {a.json, std::nullopt, {}});
    f << j.dump(2) << "\n";
    require(static_cast<bool>(f), "write failed", {a.json, std::nullopt, {}});
    std::cout << "eval-base: table written to " << a.json << "\n";
  }
#endif
}

const bool registered = maskadapt::cli::register_command([](CLI::App& app) {
  auto args = std::make_shared<EvalBaseArgs>();
  CLI::App* c = app.add_subcommand("eval-base", "H_norm table, fall rate, episode length and speed of a stage-1 base policy");
  c->add_option("checkpoint", args->checkpoint, "stage-1 checkpoint (train-base output) or its policy-only export")->required();
  using namespace maskadapt::cli;
  c->add_option("--envs", args->envs, "parallel envs per (mask, start)")->transform(integer_in(1, maskadapt::train::kMaxEnvs));
  c->add_option("--frames", args->frames, "control steps per env per (mask, start)")->transform(positive_integer());
  c->add_option("--threshold", args->threshold, "visitation distance threshold (m, Euclidean over all body features)")
      ->check(positive_real());
  c->add_option("--episode-seconds", args->episode_seconds, "episode length limit (s)")
      ->check(positive_real(maskadapt::train::kMaxEpisodeSeconds));
  c->add_option("--motions", args->motions, "reference motions (default: the checkpoint's)");
  c->add_option("--seed", args->seed, "seed (the same for every mask)")->transform(non_negative_integer());
  c->add_option("--threads", args->threads, "simulation threads (0 = all cores)")
      ->transform(integer_in(0, maskadapt::train::kMaxThreads));
  c->add_option("--json", args->json, "write the table as JSON");
  c->add_flag("--deterministic", args->deterministic, "use the policy mean instead of sampling");
  c->callback([args] { run_eval_base(*args); });
});

}  // namespace
