// `maskadapt train-base`: stage 1, the mask-invariant AMP base policy on the MuJoCo humanoid.
#include "stop_signals.hpp"
#include "cli_checks.hpp"
#include "command_registry.hpp"
#include "rank_envs.hpp"

#include <maskadapt/core/blas_threads.hpp>
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/collective.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/train/base_trainer.hpp>
#include <maskadapt/train/config.hpp>
#include <maskadapt/train/motion_sources.hpp>
#include <maskadapt/train/run_loop.hpp>

#ifdef MASKADAPT_HAS_MUJOCO
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>
#endif

#include <iostream>
#include <memory>
#include <sstream>

namespace {

struct TrainBaseArgs {
  std::string config, preset, out, resume, character;
  std::vector<std::string> motions;
  int envs = -1, threads = -1;
  long long iterations = -1, checkpoint_every = -1;
  double minutes = -1, lambda_mi = -1, mask_prob = -1, mi_target_tau = -1;
  int max_parts = -1, disc_frames = -1;
  long long seed = -1, mask_warmup_samples = -1, mask_ramp_samples = -1;
  bool no_mask = false;
  bool keep_checkpoints = false;
  std::string action_offset, action_scale, actor_lr_schedule, mi_gradient, hidden_value;
};

/// The flags that set a config field, for errors found by BaseTrainConfig::validate().
const std::vector<std::pair<std::string, std::string>> kFieldFlags = {
    {"env.num_envs", "--envs"},         {"run.threads", "--threads"},     {"run.iterations", "--iterations"},
    {"run.minutes", "--minutes"},       {"run.checkpoint_every", "--checkpoint-every"},
    {"run.out_dir", "--out"},           {"env.motions", "--motions"},     {"env.character", "--character"},     {"mask.lambda_mi", "--lambda-mi"},
    {"mask.prob", "--mask-prob"},       {"mask.max_parts", "--max-parts"},
    {"mask.warmup_samples", "--mask-warmup-samples"}, {"mask.mi_gradient", "--mi-gradient"}, {"mask.mi_target_tau", "--mi-target-tau"}, {"mask.hidden_value", "--hidden-value"}, {"mask.ramp_samples", "--mask-ramp-samples"},
    {"net.action_offset", "--action-offset"}, {"net.action_scale", "--action-scale"},
    {"ppo.actor_lr_schedule", "--actor-lr-schedule"}, {"disc.window_frames", "--disc-frames"}};

void run_train_base(const TrainBaseArgs& a) {
  using namespace maskadapt;
  using namespace maskadapt::train;
  // The option values were range-checked while parsing (cli_checks.hpp); −1 means "not given".
  // Under mpirun every rank runs this with the same arguments; rank 0 reads the checkpoint to
  // resume from and sends it to the others, and only rank 0 prints (docs/distributed.md).
  Collective& world = maskadapt::world();
  std::ostringstream quiet;
  std::ostream& out = world.is_root() ? std::cout : quiet;
  BaseTrainConfig cfg = a.preset.empty() ? cpu_preset() : preset(a.preset, "--preset");
  std::unique_ptr<Checkpoint> resume;
  if (!a.resume.empty()) {
    resume = std::make_unique<Checkpoint>(load_checkpoint_on_every_rank(world, a.resume));
    cfg = config_from_string(resume->get_string("config"), a.resume + " (config)");
  }
  const std::uint64_t checkpoint_seed = cfg.run.seed;
  if (!a.config.empty()) cfg = load_config(a.config);
  if (!a.character.empty()) cfg.env.character = a.character;
  if (!a.motions.empty()) cfg.env.motions = a.motions;
  if (a.envs >= 1) cfg.env.num_envs = a.envs;
  if (a.threads >= 0) cfg.run.threads = a.threads;
  if (a.iterations >= 0) cfg.run.iterations = a.iterations;
  if (a.minutes > 0) cfg.run.minutes = a.minutes;
  if (a.minutes > 0 && a.iterations < 0) cfg.run.iterations = 0;  // --minutes alone: time budget only
  if (a.checkpoint_every >= 1) cfg.run.checkpoint_every = a.checkpoint_every;
  if (a.seed >= 0) cfg.run.seed = static_cast<std::uint64_t>(a.seed);
  if (!a.out.empty()) cfg.run.out_dir = a.out;
  if (a.lambda_mi >= 0) cfg.mask.lambda_mi = a.lambda_mi;
  if (a.mask_prob >= 0) cfg.mask.prob = a.mask_prob;
  if (a.max_parts >= 1) cfg.mask.max_parts = a.max_parts;
  if (a.mask_warmup_samples >= 0) cfg.mask.warmup_samples = a.mask_warmup_samples;
  if (a.mask_ramp_samples >= 0) cfg.mask.ramp_samples = a.mask_ramp_samples;
  if (!a.mi_gradient.empty()) cfg.mask.mi_gradient = a.mi_gradient;
  if (a.mi_target_tau > 0) cfg.mask.mi_target_tau = a.mi_target_tau;
  if (!a.hidden_value.empty()) cfg.mask.hidden_value = a.hidden_value;
  if (a.no_mask) cfg.mask.enabled = false;
  if (a.keep_checkpoints) cfg.run.keep_checkpoints = true;
  if (!a.action_offset.empty()) cfg.net.action_offset = a.action_offset;
  if (!a.action_scale.empty()) cfg.net.action_scale = a.action_scale;
  if (!a.actor_lr_schedule.empty()) cfg.ppo.actor_lr_schedule = a.actor_lr_schedule;
  if (a.disc_frames >= 1) {
    // (the discriminator's input size is fixed by its weights: a resumed run keeps its window)
    require(!resume || a.disc_frames == cfg.disc.window_frames,
            "the checkpoint's discriminator sees " + std::to_string(cfg.disc.window_frames) +
                " frames; a resumed run cannot change its window to " + std::to_string(a.disc_frames),
            {a.resume, std::nullopt, "--disc-frames"});
    cfg.disc.window_frames = a.disc_frames;
  }
  cli::validate_naming_flags([&] { cfg.validate("command line"); }, kFieldFlags);
#ifndef MASKADAPT_HAS_MUJOCO
  throw Error("this build has no MuJoCo; train-base needs the maskadapt::mujoco target", {{}, std::nullopt, "train-base"});
#else
  const MujocoCharacter& character = mujoco_character(cfg.env.character, "env.character");
  auto lib = load_motion_library(cfg.env.motions, motion_data_dir(maskadapt::cli::source_dir() + "/../shared/data"), character);
  const std::size_t envs_here = cli::envs_per_rank(world, cfg.env.num_envs);
  out << "train-base: " << character.name << " (" << character.skeleton.num_dofs() << " DoF), " << lib->num_clips()
      << " clip(s), " << lib->total_duration() << " s of motion; "
            << cfg.env.num_envs << " envs, preset " << cfg.preset << ", masking " << (cfg.mask.enabled ? "on" : "off")
            << ", lambda_MI " << cfg.mask.lambda_mi << ", out " << cfg.run.out_dir << ", BLAS kernel " << blas_core_name()
            << (world.distributed() ? ", " + std::to_string(world.size()) + " ranks x " + std::to_string(envs_here) + " envs" : std::string())
            << "\n";
  ThreadPool pool(static_cast<std::size_t>(cfg.run.threads));
  MujocoHumanoidSim sim(envs_here, pool, character);
  resolve_action_space(cfg, sim.skeleton(), lib.get());  // a resumed run's config holds them already
  BaseTrainer<MujocoHumanoidSim> trainer(sim, library_reset_sampler(lib), library_window_sampler(lib, &pool), cfg, &pool,
                                         character.fall_criteria(cfg.env.termination_height), &world);
  if (resume) {
    trainer.load(*resume);
    out << "train-base: resumed at iteration " << trainer.iteration() << " from " << a.resume << "\n";
    if (cfg.run.seed != checkpoint_seed) {  // --seed S on a resume forks the run onto seed S
      trainer.reseed(cfg.run.seed);
      out << "train-base: forked from seed " << checkpoint_seed << " onto seed " << cfg.run.seed
                << " (random streams restart; parameters and env states continue)\n";
    }
  }
  trainer.add_provenance(cli::provenance_line() +
                         (world.distributed() ? " (" + std::to_string(world.size()) + " MPI ranks)" : std::string()) +
                         (resume ? " (resumed at iteration " + std::to_string(trainer.iteration()) +
                                                                ", sample " + std::to_string(trainer.samples()) + ")"
                                                          : std::string()));
  const auto st = run_training(trainer, RunOptions{static_cast<bool>(resume), &std::cout, cli::stop_training_on_signals()});
  out << "train-base: done, " << trainer.iteration() << " iterations, " << trainer.samples()
            << " samples; checkpoint " << cfg.run.out_dir << "/checkpoint.bin, log " << cfg.run.out_dir << "/log.jsonl\n";
  (void)st;
#endif
}

const bool registered = maskadapt::cli::register_command([](CLI::App& app) {
  auto args = std::make_shared<TrainBaseArgs>();
  CLI::App* c = app.add_subcommand("train-base", "Train the mask-invariant AMP base policy (stage 1)");
  using namespace maskadapt::cli;
  CLI::Option* config = c->add_option("--config", args->config, "JSON config file (see docs/training.md)");
  // the config file (or the resumed checkpoint's config) names its own preset
  CLI::Option* preset = c->add_option("--preset", args->preset, "cpu | paper")->check(one_of({"cpu", "paper"}))->excludes(config);
  c->add_option("--motions", args->motions, "motion sources: locomotion | synthetic | DIR | FILE ...");
  CLI::Option* character = c->add_option("--character", args->character,
                                         "humanoid | g1: the simulated character (g1: the sources are retargeted onto the robot)")
                               ->check(one_of(maskadapt::character_names()));
  c->add_option("--envs", args->envs, "number of parallel envs")->transform(integer_in(1, maskadapt::train::kMaxEnvs));
  c->add_option("--threads", args->threads, "threads for simulation and network passes (0 = all cores)")
      ->transform(integer_in(0, maskadapt::train::kMaxThreads));
  c->add_option("--iterations", args->iterations,
                "iteration budget (total, including resumed ones; 0 = none, then a --minutes budget is needed)")
      ->transform(non_negative_integer());
  c->add_option("--minutes", args->minutes, "wall-clock budget in minutes")->check(positive_real());
  c->add_option("--seed", args->seed, "master seed (with --resume: forks the run onto this seed)")->transform(non_negative_integer());
  c->add_option("--out", args->out, "output directory");
  c->add_option("--lambda-mi", args->lambda_mi, "weight of the mask-invariant loss (0 disables)")->check(non_negative_real());
  c->add_option("--mask-prob", args->mask_prob, "probability of a non-empty mask per step")->check(probability());
  c->add_option("--max-parts", args->max_parts, "at most K masked parts (of the 5 body parts)")
      ->transform(integer_in(1, maskadapt::kNumParts));
  c->add_option("--mask-warmup-samples", args->mask_warmup_samples,
                "samples of plain AMP (mask probability 0) before masking starts (docs/training.md)")
      ->transform(non_negative_integer());
  c->add_option("--mask-ramp-samples", args->mask_ramp_samples,
                "samples over which the mask probability then rises linearly to --mask-prob (0 = at once)")
      ->transform(non_negative_integer());
  c->add_option("--mi-gradient", args->mi_gradient,
                "both | target_stopped | target_frozen | target_ema: what L_MI's target is and whether its gradient flows through it (docs/training.md)")
      ->check(one_of({"both", "target_stopped", "target_frozen", "target_ema"}));
  c->add_option("--mi-target-tau", args->mi_target_tau,
                "moving-average rate per iteration of the target_ema MI target, in (0, 1] (mask.mi_target_tau)")
      ->check(real_in(0, 1, /*lo_open=*/true));
  c->add_option("--hidden-value", args->hidden_value,
                "zero | mean: what the policy sees for a hidden observation element (mask.hidden_value, docs/training.md)")
      ->check(one_of({"zero", "mean"}));
  c->add_flag("--no-mask", args->no_mask, "disable masking (plain AMP baseline)");
  CLI::Option* offset = c->add_option("--action-offset", args->action_offset,
                                      "PD target of the zero action: zero | mean_pose (of the motions) | mid_range (of the joint limits)")
                            ->check(one_of({"zero", "mean_pose", "mid_range"}));
  CLI::Option* scale = c->add_option("--action-scale", args->action_scale, "radians per unit action: one | half_range (of the joint limits)")
                           ->check(one_of({"one", "half_range"}));
  c->add_option("--actor-lr-schedule", args->actor_lr_schedule, "fixed | adaptive (the actor's rate follows PPO's KL, docs/training.md)")
      ->check(one_of({"fixed", "adaptive"}));
  c->add_option("--disc-frames", args->disc_frames,
                 "frames of the AMP window the discriminator sees, the last of 5 (2: the paper's D(s, s'); default: the preset's)")
      ->transform(integer_in(1, maskadapt::kAmpWindowFrames));
  c->add_option("--resume", args->resume, "continue from a checkpoint")
      ->excludes(preset)->excludes(offset)->excludes(scale)->excludes(character);
  c->add_option("--checkpoint-every", args->checkpoint_every, "checkpoint period in iterations")->transform(positive_integer());
  c->add_flag("--keep-checkpoints", args->keep_checkpoints,
              "also keep checkpoint_<iteration>.bin at every period (a learning curve over wall time: "
              "scripts/time_to_skill.sh)");
  c->callback([args] { run_train_base(*args); });
});

}  // namespace
