// `maskadapt play`: run a stage-1 base policy on the MuJoCo humanoid with a fixed or scheduled
// part mask and export the rollout (BVH, root XY CSV, viewer JSON).
#include "cli_checks.hpp"
#include "command_registry.hpp"

#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/mask/sampler.hpp>
#include <maskadapt/train/config.hpp>
#include <maskadapt/eval/rollout_file.hpp>
#include <maskadapt/motion/bvh.hpp>
#include <maskadapt/humanoid/retarget.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/motion_sources.hpp>
#include <maskadapt/train/play.hpp>

#ifdef MASKADAPT_HAS_MUJOCO
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>
#endif

#include <filesystem>
#include <iostream>
#include <memory>

namespace {

struct PlayArgs {
  std::string checkpoint, mask, schedule, bvh, csv, rollout;
  std::vector<std::string> motions;
  double seconds = 30.0;
  long long seed = 1;
  bool deterministic = false, reset_on_fall = false;
  std::vector<std::string> argv;
};

void run_play(const PlayArgs& a) {
  using namespace maskadapt;
  using namespace maskadapt::train;
#ifndef MASKADAPT_HAS_MUJOCO
  throw Error("this build has no MuJoCo; play needs the maskadapt::mujoco target", {{}, std::nullopt, "play"});
#else
  require(!(a.mask.size() && a.schedule.size()), "give either --mask or --mask-schedule, not both", {{}, {}, "--mask"});
  require(!a.bvh.empty() || !a.csv.empty() || !a.rollout.empty(), "nothing to write: give --bvh, --csv and/or --rollout",
          {{}, {}, "--bvh"});
  const Checkpoint ck = load_checkpoint(a.checkpoint);
  const MujocoCharacter& character = mujoco_character(checkpoint_character(ck, a.checkpoint), a.checkpoint + " (env.character)");
  MujocoHumanoidSim sim(1, 1, character);
  const PolicyDims dims{observation_dim(sim.skeleton()), observation_dim(sim.skeleton()) + kNumParts,
                        sim.skeleton().num_dofs(), observation_dim(sim.skeleton()) * kAmpWindowFrames};
  const LoadedBasePolicy loaded = load_base_policy(ck, dims, a.checkpoint);
  const auto motions = a.motions.empty() ? loaded.config.env.motions : a.motions;
  auto lib = load_motion_library(motions, motion_data_dir(maskadapt::cli::source_dir() + "/../shared/data"), character);

  PlayOptions opt;
  opt.seconds = a.seconds;
  opt.seed = static_cast<std::uint64_t>(a.seed);
  opt.deterministic = a.deterministic;
  opt.reset_on_fall = a.reset_on_fall;
  if (!a.mask.empty()) opt.masks = MaskSampler::fixed(PartMask::parse(a.mask, "--mask"));
  if (!a.schedule.empty()) opt.masks = MaskSampler::scheduled(parse_mask_schedule(a.schedule, "--mask-schedule"));
  const std::string mask_text = !a.schedule.empty() ? a.schedule : !a.mask.empty() ? a.mask : "none";
  std::cout << "play: " << a.checkpoint << " (iteration " << loaded.iteration << (loaded.policy_only ? ", model (policy only)" : "")
            << "), mask " << mask_text << ", "
            << a.seconds << " s, " << (a.deterministic ? "mean actions" : "sampled actions") << ", seed " << a.seed << "\n";

  eval::Rollout tmpl = eval::make_rollout(sim.character());
  std::string cmd;
  for (const auto& s : a.argv) cmd += (cmd.empty() ? "" : " ") + s;
  tmpl.metadata.command = cmd;
  tmpl.metadata.checkpoint = a.checkpoint;
  tmpl.metadata.seed = a.seed;
  tmpl.metadata.extra["mask"] = mask_text;
  tmpl.metadata.extra["lambda_mi"] = std::to_string(loaded.config.mask.lambda_mi);
  tmpl.metadata.extra["masking"] = loaded.config.mask.enabled ? "true" : "false";
  tmpl.metadata.extra["iteration"] = std::to_string(loaded.iteration);
  tmpl.metadata.extra["character"] = character.name;
  const PlayResult r = play_base_policy(sim, loaded.policy, library_reset_sampler(lib), opt, std::move(tmpl),
                                        character.fall_criteria(loaded.config.env.termination_height),
                                        loaded.config.env.termination_height);

  const Vec3 d = r.root.col(r.root.cols() - 1) - r.root.col(0);
  std::cout << "play: " << r.rollout.num_frames() << " frames; root moved " << std::hypot(d.x(), d.y())
            << " m in the ground plane; " << r.fall_times.size() << " fall(s)";
  if (!r.fall_times.empty()) std::cout << ", first at " << r.fall_times.front() << " s";
  std::cout << "\n";
  auto mkdirs = [](const std::string& p) {
    const auto parent = std::filesystem::path(p).parent_path();
    if (!parent.empty()) std::filesystem::create_directories(parent);
  };
  if (!a.bvh.empty()) {
    mkdirs(a.bvh);
    bvh::write(a.bvh, clip_to_bvh(r.clip, sim.skeleton()));
    std::cout << "play: BVH           " << a.bvh << " (Y-up, metres; Blender: File > Import > Motion Capture)\n";
  }
  if (!a.csv.empty()) {
    mkdirs(a.csv);
    write_root_xy_csv(a.csv, r.root, r.dt);
    std::cout << "play: root XY CSV   " << a.csv << " (t,x,y)\n";
  }
  if (!a.rollout.empty()) {
    mkdirs(a.rollout);
    eval::write_rollout(r.rollout, a.rollout);
    std::cout << "play: viewer JSON   " << a.rollout << " (open it in tools/viewer)\n";
  }
#endif
}

const bool registered = maskadapt::cli::register_command([](CLI::App& app) {
  auto args = std::make_shared<PlayArgs>();
  CLI::App* c = app.add_subcommand("play", "Run a stage-1 base policy with a part mask and export the rollout");
  using namespace maskadapt::cli;
  c->add_option("checkpoint", args->checkpoint, "stage-1 checkpoint (train-base output) or its policy-only export")->required();
  c->add_option("--mask", args->mask, "fixed mask: comma-separated parts/groups (left_leg,right_leg | arms | none ...)")
      ->check(parsed_by([](const std::string& t) { (void)maskadapt::PartMask::parse(t); }, "MASK"));
  c->add_option("--mask-schedule", args->schedule, "masks over time, e.g. \"0:none,5:lower_body\"")
      ->check(parsed_by([](const std::string& t) {
        (void)maskadapt::MaskSampler::scheduled(maskadapt::parse_mask_schedule(t, "--mask-schedule"));
      }, "SCHEDULE"));
  c->add_option("--seconds", args->seconds, "length of the rollout (s)")
      ->check(positive_real(maskadapt::train::kMaxEpisodeSeconds));
  c->add_option("--bvh", args->bvh, "write the rollout as BVH");
  c->add_option("--csv", args->csv, "write the root XY trajectory as CSV (t,x,y)");
  c->add_option("--rollout", args->rollout, "write the viewer JSON rollout (per-frame mask and contacts)");
  c->add_option("--motions", args->motions, "motion sources for the initial state (default: the checkpoint's)");
  c->add_option("--seed", args->seed, "seed of the initial state and the action noise")->transform(non_negative_integer());
  c->add_flag("--deterministic", args->deterministic, "use the policy mean instead of sampling");
  c->add_flag("--reset-on-fall", args->reset_on_fall, "reset to a reference state after a fall");
  c->callback([args] {
    auto& v = args->argv;
    v = {"maskadapt", "play", args->checkpoint, "--seconds", std::to_string(args->seconds), "--seed", std::to_string(args->seed)};
    if (!args->mask.empty()) v.insert(v.end(), {"--mask", args->mask});
    if (!args->schedule.empty()) v.insert(v.end(), {"--mask-schedule", "\"" + args->schedule + "\""});
    if (args->deterministic) v.push_back("--deterministic");
    if (args->reset_on_fall) v.push_back("--reset-on-fall");
    run_play(*args);
  });
});

}  // namespace
