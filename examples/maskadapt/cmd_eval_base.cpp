// `maskadapt eval-base`: the H_norm table of a stage-1 base policy (null mask, every mask of one
// or two parts; random and shared initial states) with fall rates and episode lengths.
// `maskadapt hnorm-threshold`: H_norm of kinematic probes of the reference data (replay, a frozen
// pose, one clip) over a range of thresholds, to choose eval-base's --threshold.
#include "cli_checks.hpp"
#include "command_registry.hpp"

#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/eval/threshold_probes.hpp>
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
#include <iomanip>
#include <iostream>
#include <memory>

namespace {

struct EvalBaseArgs {
  std::string checkpoint, json;
  std::vector<std::string> motions;
  int envs = 10, threads = 0;
  long long frames = 1000, seed = 1;
  double threshold = 0.5, episode_seconds = 10.0;
  std::string counting = "nearest";
  bool deterministic = false, per_class = false;
  std::vector<std::string> masks;  ///< --masks: evaluate only these (empty: all 16)
};

void write_json(const std::string& path, const nlohmann::json& j);

void run_eval_base(const EvalBaseArgs& a) {
  using namespace maskadapt;
  using namespace maskadapt::train;
#ifndef MASKADAPT_HAS_MUJOCO
  throw Error("this build has no MuJoCo; eval-base needs the maskadapt::mujoco target", {{}, std::nullopt, "eval-base"});
#else
  require(a.envs >= 1, "must be >= 1", {{}, {}, "--envs"});
  std::vector<PartMask> masks;  // --masks, checked before anything is loaded
  for (const std::string& text : a.masks) {
    const PartMask m = PartMask::parse(text, "--masks");
    for (PartMask seen : masks)
      require(!(seen == m), "mask '" + text + "' is given twice (as " + m.to_string() + ")", {{}, {}, "--masks"});
    masks.push_back(m);
  }
  const Checkpoint ck = load_checkpoint(a.checkpoint);
  ThreadPool pool(static_cast<std::size_t>(a.threads));
  const MujocoCharacter& character = mujoco_character(checkpoint_character(ck, a.checkpoint), a.checkpoint + " (env.character)");
  MujocoHumanoidSim sim(static_cast<std::size_t>(a.envs), pool, character);
  const Index d = observation_dim(sim.skeleton());
  const LoadedBasePolicy loaded =
      load_base_policy(ck, {d, d + kNumParts, sim.skeleton().num_dofs(), d * kAmpWindowFrames}, a.checkpoint);
  const auto motions = a.motions.empty() ? loaded.config.env.motions : a.motions;
  auto lib = load_motion_library(motions, motion_data_dir(maskadapt::cli::source_dir() + "/../shared/data"), character);
  const MatrixXf reference = reference_visitation_features(*lib);

  EvalBaseOptions opt;
  opt.frames = a.frames;
  opt.threshold = a.threshold;
  opt.counting = eval::visit_counting_from_string(a.counting, "--counting");
  opt.episode_seconds = a.episode_seconds;
  opt.deterministic = a.deterministic;
  opt.seed = static_cast<std::uint64_t>(a.seed);
  opt.masks = masks;
  opt.rise_height = clips_median_root_height(*lib);  // rising seconds: issue 41's jump measure
  std::cout << "eval-base: " << a.checkpoint << " (" << character.name << ", iteration " << loaded.iteration
            << (loaded.policy_only ? ", model (policy only)" : "") << ", masking "
            << (loaded.config.mask.enabled ? "on" : "off") << ", lambda_MI " << loaded.config.mask.lambda_mi << "); "
            << reference.cols() << " reference frames from " << lib->num_clips() << " clip(s); "
            << (opt.masks.empty() ? std::size_t{16} : opt.masks.size()) << " masks x 2 starts x "
            << a.envs << " envs x " << a.frames << " frames; threshold " << a.threshold << " m, counting " << a.counting << "\n";
  Stopwatch clock;
  BaseEvaluation ev = evaluate_base_policy(sim, loaded.policy, library_reset_sampler(lib), reference, opt,
                                           character.fall_criteria(loaded.config.env.termination_height),
                                           loaded.config.env.termination_height, &pool, &std::cout);
  ev.reference_speed = reference_mean_speed(*lib);
  ev.reference_rise_fraction = clips_rise_fraction(*lib, opt.rise_height, opt.rise_clearance);
  std::cout << "\n";
  if (opt.masks.empty()) std::cout << format_hnorm_table(ev, false) << "\n" << format_hnorm_table(ev, true) << "\n";
  std::cout << format_episode_table(ev);
  std::vector<ClassEvaluation> by_class;
  if (a.per_class) {
    std::cout << "\neval-base: per starting class (episodes start only from frames of the class; "
              << (opt.masks.empty() ? "null mask and both legs" : "the masks above") << ")\n";
    by_class = evaluate_by_start_class(sim, loaded.policy, lib, opt, character.fall_criteria(loaded.config.env.termination_height),
                                       loaded.config.env.termination_height, &pool, &std::cout);
    std::cout << "\n" << format_class_table(by_class);
  }
  std::cout << "eval-base: " << clock.seconds() << " s\n";
  if (!a.json.empty()) {
    nlohmann::json j = to_json(ev);
    j["checkpoint"] = a.checkpoint;
    j["character"] = character.name;
    j["iteration"] = loaded.iteration;
    j["envs"] = a.envs;
    j["motions"] = motions;
    j["lambda_mi"] = loaded.config.mask.lambda_mi;
    j["masking"] = loaded.config.mask.enabled;
    if (a.per_class) j["per_class"] = to_json(by_class);
    write_json(a.json, j);
    std::cout << "eval-base: table written to " << a.json << "\n";
  }
#endif
}

void write_json(const std::string& path, const nlohmann::json& j) {
  using maskadapt::require;
  const auto parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  std::ofstream f(path);
  require(static_cast<bool>(f), "cannot open for writing", {path, std::nullopt, {}});
  f << j.dump(2) << "\n";
  require(static_cast<bool>(f), "write failed", {path, std::nullopt, {}});
}

struct ThresholdArgs {
  std::vector<std::string> motions = {"locomotion"};
  std::vector<double> thresholds = {0.05, 0.1, 0.15, 0.2, 0.3, 0.5, 1.0};
  int windows = 32;
  long long frames = 300, seed = 1;
  int probes = 8;
  std::string json, counting = "nearest";
};

void run_hnorm_threshold(const ThresholdArgs& a) {
  using namespace maskadapt;
  auto lib = train::load_motion_library(a.motions, motion_data_dir(maskadapt::cli::source_dir() + "/../shared/data"));
  const MatrixXf reference = train::reference_visitation_features(*lib);
  std::vector<Index> clip_frames;
  for (int c = 0; c < lib->num_clips(); ++c) clip_frames.push_back(lib->clip(c).num_frames());
  eval::ThresholdProbeOptions opt;
  opt.windows = a.windows;
  opt.window_frames = a.frames;
  opt.probes = a.probes;
  opt.counting = eval::visit_counting_from_string(a.counting, "--counting");
  opt.seed = static_cast<std::uint64_t>(a.seed);
  std::cout << "hnorm-threshold: " << reference.cols() << " reference frames from " << lib->num_clips()
            << " clip(s); replay " << a.windows << " windows x " << a.frames << " frames; frozen pose and one clip: mean (max) of "
            << a.probes << " draws; counting " << a.counting << "\n\n";
  const auto probes = eval::probe_thresholds(reference, clip_frames, a.thresholds, opt);
  std::cout << "| threshold (m) | replay | frozen pose | one clip |\n| --- | --- | --- | --- |\n" << std::fixed
            << std::setprecision(3);
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& p : probes) {
    std::cout << "| " << p.threshold << " | " << p.replay << " | " << p.frozen << " (" << p.frozen_max << ") | "
              << p.one_clip << " (" << p.one_clip_max << ") |\n";
    rows.push_back({{"threshold", p.threshold}, {"replay", p.replay}, {"frozen", p.frozen}, {"frozen_max", p.frozen_max},
                    {"one_clip", p.one_clip}, {"one_clip_max", p.one_clip_max}});
  }
  if (!a.json.empty()) {
    const nlohmann::json j = {{"motions", a.motions}, {"reference_frames", reference.cols()}, {"clips", lib->num_clips()},
                              {"windows", a.windows}, {"frames", a.frames}, {"probes", a.probes}, {"counting", a.counting},
                              {"seed", a.seed}, {"rows", rows}};
    write_json(a.json, j);
    std::cout << "hnorm-threshold: written to " << a.json << "\n";
  }
}

const bool registered_threshold = maskadapt::cli::register_command([](CLI::App& app) {
  auto args = std::make_shared<ThresholdArgs>();
  CLI::App* c = app.add_subcommand("hnorm-threshold",
                                   "H_norm of kinematic probes (replay, frozen pose, one clip) per threshold, to choose eval-base --threshold");
  using namespace maskadapt::cli;
  c->add_option("--motions", args->motions, "reference motions (builtin set names, directories or files)");
  c->add_option("--thresholds", args->thresholds, "distances to probe (m)")->check(positive_real())->delimiter(',');
  c->add_option("--windows", args->windows, "replay windows (eval-base: --envs)")->transform(integer_in(1, 65536));
  c->add_option("--frames", args->frames, "frames per replay window (eval-base: --frames)")->transform(positive_integer());
  c->add_option("--probes", args->probes, "frozen poses and single clips averaged")->transform(integer_in(1, 1024));
  c->add_option("--seed", args->seed, "seed")->transform(non_negative_integer());
  c->add_option("--counting", args->counting, "visits: nearest (one per frame) or all_within (every frame within the threshold)")
      ->check(CLI::IsMember({"nearest", "all_within"}));
  c->add_option("--json", args->json, "write the table as JSON");
  c->callback([args] { run_hnorm_threshold(*args); });
});

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
  c->add_option("--counting", args->counting,
                "visits: nearest (each frame visits its nearest reference frame within the threshold) or all_within "
                "(every reference frame within the threshold, the paper's wording)")
      ->check(CLI::IsMember({"nearest", "all_within"}));
  c->add_flag("--deterministic", args->deterministic, "use the policy mean instead of sampling");
  c->add_flag("--per-class", args->per_class,
              "also start episodes from each class of the clips' frames (stand, walk, run, backward, sideways, turn: "
              "motion/motion_class.hpp) and report falls and speed per class beside the clips'");
  c->add_option("--masks", args->masks,
                "evaluate only these masks, e.g. --masks none legs left_arm,right_arm (default: the null mask and "
                "every mask of one or two parts)")
      ->check(parsed_by([](const std::string& t) { (void)maskadapt::PartMask::parse(t, "--masks"); }, "MASK"));
  c->callback([args] { run_eval_base(*args); });
});

}  // namespace
