// `maskadapt train-residual` (stage 2: composition or partial tracking on top of a frozen base,
// --resume continues bit-exactly), `maskadapt play-residual` (mask / text schedules, BVH and
// viewer-rollout export) and `maskadapt eval-residual` (composition H_norm table or tracking
// metrics, JSON). Residual playback lives here as its own subcommand so the trainer engineer's
// `play` stays untouched.
#include "stop_signals.hpp"
#include "cli_checks.hpp"
#include "command_registry.hpp"
#include "rank_envs.hpp"

#include <maskadapt/core/blas_threads.hpp>
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/collective.hpp>
#include <maskadapt/eval/rollout_file.hpp>
#include <maskadapt/motion/bvh.hpp>
#include <maskadapt/nn/chunks.hpp>
#include <maskadapt/humanoid/synthetic.hpp>
#include <maskadapt/humanoid/retarget.hpp>
#include <maskadapt/tracking/builtin_generator.hpp>
#include <maskadapt/tracking/text_pool.hpp>
#include <maskadapt/train/motion_sources.hpp>
#include <maskadapt/train/goal_eval.hpp>
#include <maskadapt/train/goal_recipe.hpp>
#include <maskadapt/train/residual_eval.hpp>
#include <maskadapt/tasks/heading.hpp>
#include <maskadapt/tasks/location.hpp>
#include <maskadapt/tasks/strike.hpp>
#include <maskadapt/tasks/tracking_task.hpp>
#include <maskadapt/train/residual_trainer.hpp>
#include <maskadapt/train/run_loop.hpp>

#ifdef MASKADAPT_HAS_MUJOCO
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>
#endif

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>

namespace {

using namespace maskadapt;
using namespace maskadapt::train;

struct Args {
  std::string task = "composition", method = "ours", base, out = "runs/residual", preset, config, resume, generator,
              gain = "scalar";
  std::vector<std::string> new_motion, masks, motions, texts;
  std::string designated = "arms", goal_parts, character;
  // Numeric values were range-checked while parsing (cli_checks.hpp); −1 means "not given".
  int envs = -1, threads = -1, goal_trajectories = -1, sample_every = -1, noise_hold_steps = -1, strike_next_box = -1, disc_frames = -1;
  int strike_end_on_foreign_contact = 0;  ///< +1 given, -1 its --no- form, 0 neither (the preset's)
  std::vector<double> objective_weights;
  long long iterations = -1, seed = -1;
  double minutes = -1, switch_rate = -1, episode_seconds = -1, term_threshold = -1, tracking_reward_scale = -1, residual_std = -1, blend_resets = -1,
         location_facing_weight = -1, location_position_weight = -1, strike_approach_weight = -1, location_divergence = -1,
         location_arrive_distance = -1, location_reach_bonus = -1;
  std::vector<double> location_distance;  ///< [min, max] (m)
  std::vector<double> residual_std_decay;  ///< [factor, iterations]
  std::vector<double> strike_distance;    ///< [min, max] (m)
  std::vector<std::string> part_std;      ///< "PARTS=σ" items
  std::vector<std::string> part_objective_weights;  ///< "PARTS=w1,w2,…" items
  std::vector<Index> hidden;
  std::vector<std::string> composition_only, tracking_only;  ///< such flags given on the command line
};

/// Flags that only one task reads; giving one for the other task is an error, not a no-op.
const char* const kCompositionFlags[] = {"--new-motion", "--masks", "--switch-rate"};
const char* const kTrackingFlags[] = {"--designated", "--generator", "--texts", "--goal-trajectories", "--sample-every",
                                      "--term-threshold", "--tracking-reward-scale"};

/// Throws naming the first flag of `given` (flags of `other_task`) when the run's task is not it.
[[maybe_unused]] void require_task_flags(const std::vector<std::string>& given, const std::string& task, const std::string& other_task) {
  require(given.empty(), "applies to --task " + other_task + " only, and this run's task is " + task,
          {{}, {}, given.empty() ? std::string() : given.front()});
}

/// A MIN MAX flag's two values into `min`, `max`; left as they are when the flag was not given
/// (empty), refused naming `flag` for any other count.
void assign_min_max(const std::vector<double>& given, const std::string& flag, double& min, double& max) {
  if (given.empty()) return;
  require(given.size() == 2, "expected two values, MIN MAX (m)", {{}, {}, flag});
  min = given[0];
  max = given[1];
}

/// One line on how the composite actions become PD targets (the base's action space; scratch:
/// the run config's).
std::string describe_actions(const tasks::ActionSpace& s, const NetworkConfig& net) {
  if (s.identity()) return "actions are the PD targets (identity action space)";
  return "PD targets = offset + scale * action (net.action_offset " + net.action_offset + ", net.action_scale " +
         net.action_scale + ")";
}

std::string data_dir() { return motion_data_dir(maskadapt::cli::source_dir() + "/../shared/data"); }

/// The default tracking prompts: the arms-related labels of the labelled clips (the shared CMU
/// clips when present, plus the built-in synthetic clips); the fixed list when none is found.
std::vector<std::string> default_text_pool(const Skeleton& skel) {
  std::vector<tracking::LabelledTrajectory> clips;
  const std::string dir = data_dir() + "/motions/cmu";
  try {
    if (std::filesystem::is_directory(dir)) clips = tracking::load_labelled_clips(dir, skel);
    for (const MotionClip& c : builtin_motion_set("synthetic", data_dir())) clips.push_back(tracking::labelled_from_clip(c, skel));
    return tracking::arms_text_pool(clips);
  } catch (const Error& e) {
    std::cerr << "text pool: " << e.what() << "; using the fixed list\n";
    return {"raise arms", "wave hands", "punch", "wash self"};
  }
}

/// The goal-driven tasks (tasks/location.hpp, heading.hpp, strike.hpp).
bool is_goal_task(const std::string& task) { return task == "location" || task == "heading" || task == "strike"; }

/// The scene objects a task needs: strike's box (sim/scene.hpp; 0.4 × 0.4 × 1.2 m, 5 kg).
std::vector<BoxObject> task_objects(const std::string& task) {
  if (task == "strike") return {BoxObject{}};
  return {};
}

#ifdef MASKADAPT_HAS_MUJOCO
/// The goal task of a run (tasks/location.hpp, heading.hpp, strike.hpp; their defaults), for
/// `sim`'s envs; `seed` seeds its goal streams, env e drawing from that of env first_env + e (a
/// distributed run's rank offset). Strike bodies: the hands.
/// The goal task `task` of a run with config `c` (its reward options), drawing from `seed`.
tasks::AnyGoalTask<MujocoHumanoidSim> make_goal_task(const std::string& task, const ResidualTrainConfig& c,
                                                     const MujocoHumanoidSim& sim, std::uint64_t seed, Index first_env = 0) {
  const auto N = static_cast<Index>(sim.num_envs());
  if (task == "location") {
    tasks::LocationConfig lc;
    lc.facing_weight = c.location_facing_weight;
    lc.position_weight = c.location_position_weight;
    lc.min_distance = c.location_min_distance;
    lc.max_distance = c.location_max_distance;
    lc.divergence_distance = c.location_divergence;
    lc.arrive_distance = c.location_arrive_distance;
    lc.reach_bonus = c.location_reach_bonus;
    lc.seed = seed;
    lc.first_env = first_env;
    return tasks::LocationTask(lc, N);
  }
  if (task == "heading") {
    tasks::HeadingConfig hc;
    hc.seed = seed;
    hc.first_env = first_env;
    return tasks::HeadingTask(hc, N);
  }
  require(task == "strike" && sim.num_objects() == 1, "no goal task '" + task + "' for this scene", {{}, {}, "--task"});
  tasks::StrikeConfig sc;
  sc.approach_weight = c.strike_approach_weight;
  sc.min_distance = c.strike_min_distance;
  sc.max_distance = c.strike_max_distance;
  sc.end_on_foreign_contact = c.strike_end_on_foreign_contact;
  sc.next_box_steps = c.strike_next_box_steps;
  sc.seed = seed;
  sc.first_env = first_env;
  sc.box_half_height = sim.objects().front().half_size.z();
  sc.strike_bodies = tasks::bodies_by_name(sim.skeleton(), sim.character().hands);
  return tasks::StrikeTask(sc, N);
}
#endif

/// Builds the reward sources of a run.
template <Simulator Sim>
ResidualSetup<Sim> make_setup(const ResidualTrainConfig& c, const std::shared_ptr<MotionLibrary>& base_lib,
                              const std::shared_ptr<MotionLibrary>& new_lib, const std::vector<BodyPart>& obs_parts,
                              std::shared_ptr<const tasks::BlendedMotionSet> blends) {
  ResidualSetup<Sim> s;
  s.masks = tasks::parse_mask_set(c.masks, "--masks");
  s.switch_rate = c.switch_rate;
  s.negative_fraction = c.negative_fraction;
  // Real windows are computed on the pool of the trainer's iteration (nn::ScopedPool), the same
  // numbers for any number of threads.
  auto from = [](std::shared_ptr<MotionLibrary> lib) {
    return [lib](Rng& r, Index B, MatrixXf& w, MatrixXf&) { w = lib->sample_amp_windows(r, static_cast<int>(B), nn::default_pool()); };
  };
  const std::vector<double> w = c.objective_weights;
  // a goal on the base's own motion: imitate A
  if (is_goal_task(c.task) && c.new_motions.empty()) {
    s.masks = {c.method == "scratch" ? PartMask::all() : s.masks.front()};
    s.switch_rate = 0;
    s.discriminators.push_back({"imitation", w.size() > 0 ? w[0] : 0.5, {}, false, from(base_lib), {}});
    return s;
  }
  if (c.task == "tracking") {
    const PartMask d = PartMask::parse(c.designated, "--designated");
    s.masks = {c.method == "scratch" ? PartMask::all() : d};
    s.switch_rate = 0;
    s.discriminators.push_back({"imitation", w.size() > 0 ? w[0] : 0.5, tasks::window_rows(obs_parts, ~d), false, from(base_lib), {}});
    return s;
  }
  if (c.method == "ours") {
    auto set = blends ? blends : std::make_shared<const tasks::BlendedMotionSet>(*base_lib, *new_lib, s.masks);
    DiscriminatorSource src{"composition", w.size() > 0 ? w[0] : 1.0, {}, true,
                            [set](Rng& r, Index B, MatrixXf& x, MatrixXf& m) { set->sample_real(r, B, x, m, nullptr, nn::default_pool()); },
                            [set](Rng& r, Index B, MatrixXf& x, MatrixXf& m) { set->sample_negative(r, B, x, m, nn::default_pool()); }};
    s.discriminators.push_back(src);
  } else {  // cml / scratch / adaptnet: fixed region = the first mask; one discriminator per group
    // (AdaptNet acts on every DoF and sees no mask: it gets the same part-wise rewards as cml)
    const PartMask adapted = s.masks.front();
    s.masks = {c.method == "scratch" ? PartMask::all() : adapted};
    s.switch_rate = 0;
    s.discriminators.push_back({"adapted", w.size() > 0 ? w[0] : 0.5, tasks::window_rows(obs_parts, adapted), false, from(new_lib), {}});
    s.discriminators.push_back({"rest", w.size() > 1 ? w[1] : 0.5, tasks::window_rows(obs_parts, ~adapted), false, from(base_lib), {}});
  }
  return s;
}

#ifdef MASKADAPT_HAS_MUJOCO
/// The tracking objective: goal-buffer refills from the generator with prompts from `texts`,
/// histories from the base motion set; `stream` picks the goal stream (a distributed run's rank).
tasks::TrackingTask make_tracking(const ResidualTrainConfig& c, std::shared_ptr<tracking::BuiltinGenerator> gen,
                                  std::shared_ptr<MotionLibrary> base_lib, std::vector<std::string> texts,
                                  const MujocoHumanoidSim& sim, std::uint64_t stream) {
  const double control_dt = sim.control_dt();
  tasks::TrackingTaskConfig t;
  t.designated = PartMask::parse(c.designated, "--designated");
  t.goal_steps = c.goal_steps;
  t.sample_every = c.sample_every;
  t.seed = c.rl.run.seed;
  t.stream = stream;
  t.term_window = std::max<Index>(1, std::llround(c.term_window_s / control_dt));
  t.term_threshold = c.term_threshold;
  t.reward_scale = c.tracking_reward_scale;
  const Index frames = std::llround(c.rl.env.episode_seconds / control_dt) + c.goal_steps + 1;
  const int n = c.goal_trajectories;
  t.refill = [gen, base_lib, texts, frames, n](Rng& r, tracking::GoalBuffer& b) {
    b.refill(*gen, texts, [&](Rng& rr) {
      const ClipTime ct = base_lib->sample(rr, true, static_cast<double>(gen->history_frames()) / 30.0);
      return tracking::trajectory_from_library(*base_lib, ct.clip, ct.time - static_cast<double>(gen->history_frames() - 1) / 30.0,
                                               gen->history_frames());
    }, n, frames, r);
  };
  return tasks::TrackingTask(sim.skeleton(), std::move(t), static_cast<Index>(sim.num_envs()));
}
#endif

void run_train_residual(const Args& a) {
#ifndef MASKADAPT_HAS_MUJOCO
  (void)a;
  throw Error("this build has no MuJoCo; train-residual needs the maskadapt::mujoco target", {{}, std::nullopt, "train-residual"});
#else
  // Under mpirun every rank runs this with the same arguments; rank 0 reads the checkpoints and
  // sends them to the others, and only rank 0 prints and writes files (docs/distributed.md).
  Collective& world = maskadapt::world();
  std::ostringstream quiet;
  std::ostream& out = world.is_root() ? std::cout : quiet;
  ResidualTrainConfig c;
  std::unique_ptr<Checkpoint> resume;
  std::unique_ptr<Checkpoint> base_file;  // --base, read once: its config here, its actor below
  if (!a.resume.empty()) {  // the run's own config; only budgets and the output directory may change
    resume = std::make_unique<Checkpoint>(load_checkpoint_on_every_rank(world, a.resume));
    require(!resume->contains("model/kind"),
            "a policy-only model file cannot be resumed (it has no critic, discriminator or optimiser state); resume from the "
            "run's checkpoint.bin",
            {a.resume, std::nullopt, "model/kind"});
    c = residual_config_from_json(nlohmann::json::parse(resume->get_string("residual_config")), a.resume);
  } else {
    c.rl = a.config.empty() ? (a.preset.empty() ? cpu_preset() : preset(a.preset, "--preset")) : load_config(a.config);
    c.task = a.task;
    c.method = a.method;
    c.base_checkpoint = a.base;
    c.gain = a.gain;
    c.designated = a.designated;
    c.texts = a.texts;
    c.generator = a.generator;
    c.goal_parts = a.goal_parts;
    require(a.goal_parts.empty() || is_goal_task(c.task),
            "applies to the goal tasks (location, heading, strike) only, and this run's task is " + c.task, {{}, {}, "--goal-parts"});
    if (!a.new_motion.empty()) c.new_motions = a.new_motion;
    if (!a.masks.empty()) c.masks = a.masks;
    if (a.envs > 0) c.rl.env.num_envs = a.envs;
    if (a.threads >= 0) c.rl.run.threads = a.threads;
    if (a.seed >= 0) c.rl.run.seed = static_cast<std::uint64_t>(a.seed);
    if (a.switch_rate >= 0) c.switch_rate = a.switch_rate;
    if (a.episode_seconds > 0) c.rl.env.episode_seconds = a.episode_seconds;
    if (a.goal_trajectories > 0) c.goal_trajectories = a.goal_trajectories;
    if (a.sample_every > 0) c.sample_every = a.sample_every;
    if (a.term_threshold >= 0) c.term_threshold = a.term_threshold;
    if (a.tracking_reward_scale > 0) c.tracking_reward_scale = a.tracking_reward_scale;
    if (!a.hidden.empty()) c.residual_hidden = a.hidden;
    if (a.residual_std >= 0) c.residual_std = a.residual_std;
    if (a.blend_resets >= 0) c.blend_resets = a.blend_resets;
    if (a.noise_hold_steps > 0) c.noise_hold_steps = a.noise_hold_steps;
    if (a.disc_frames > 0) c.rl.disc.window_frames = a.disc_frames;
    if (!a.residual_std_decay.empty()) {
      require(a.residual_std_decay.size() == 2, "expected two values, FACTOR ITERATIONS", {{}, {}, "--residual-std-decay"});
      const double n = a.residual_std_decay[1];
      require(n >= 1 && n <= 1e9 && n == std::floor(n), "ITERATIONS must be a whole number >= 1, got " + nlohmann::json(n).dump(),
              {{}, {}, "--residual-std-decay"});
      c.residual_std_decay_factor = a.residual_std_decay[0];
      c.residual_std_decay_iterations = static_cast<int>(n);
    }
    if (a.location_facing_weight >= 0) c.location_facing_weight = a.location_facing_weight;
    if (a.location_position_weight >= 0) c.location_position_weight = a.location_position_weight;
    assign_min_max(a.location_distance, "--location-distance", c.location_min_distance, c.location_max_distance);
    if (a.location_divergence >= 0) c.location_divergence = a.location_divergence;
    if (a.location_arrive_distance >= 0) c.location_arrive_distance = a.location_arrive_distance;
    if (a.location_reach_bonus >= 0) c.location_reach_bonus = a.location_reach_bonus;
    if (!a.part_std.empty()) c.residual_part_std = parse_part_std(a.part_std, "--part-std");
    if (!a.part_objective_weights.empty())
      c.part_objective_weights = parse_part_weights(a.part_objective_weights, "--part-objective-weights");
    if (a.strike_approach_weight >= 0) c.strike_approach_weight = a.strike_approach_weight;
    assign_min_max(a.strike_distance, "--strike-distance", c.strike_min_distance, c.strike_max_distance);
    if (a.strike_end_on_foreign_contact != 0) c.strike_end_on_foreign_contact = a.strike_end_on_foreign_contact > 0;
    if (a.strike_next_box >= 0) c.strike_next_box_steps = a.strike_next_box;
    if (!a.objective_weights.empty()) c.objective_weights = a.objective_weights;
    if (is_goal_task(c.task)) {  // the preset's goal rewards where no flag says otherwise (train/goal_recipe.hpp)
      const GoalRewards g = goal_rewards(a.preset.empty() ? "cpu" : a.preset, c.task, c.method, !c.new_motions.empty());
      if (a.objective_weights.empty()) c.objective_weights = g.objective_weights;
      if (a.location_facing_weight < 0) c.location_facing_weight = g.location_facing_weight;
      if (a.strike_approach_weight < 0) c.strike_approach_weight = g.strike_approach_weight;
      if (a.strike_end_on_foreign_contact == 0) c.strike_end_on_foreign_contact = g.strike_end_on_foreign_contact;
      if (a.strike_next_box < 0) c.strike_next_box_steps = g.strike_next_box_steps;
    }
    if (c.task == "tracking") {  // the preset's tracking settings where no flag says otherwise (train/goal_recipe.hpp)
      const TrackingRecipe t = tracking_recipe(a.preset.empty() ? "cpu" : a.preset);
      if (a.objective_weights.empty()) c.objective_weights = t.objective_weights;
      if (a.tracking_reward_scale <= 0) c.tracking_reward_scale = t.reward_scale;
      if (a.term_threshold < 0) c.term_threshold = t.term_threshold;
      if (a.residual_std < 0 && a.part_std.empty() && t.designated_std > 0) {  // (--residual-std 0: the base's σ)
        const PartMask designated = PartMask::parse(c.designated, "--designated");
        for (int p = 0; p < kNumParts; ++p)
          if (designated.has(static_cast<BodyPart>(p))) c.residual_part_std[static_cast<std::size_t>(p)] = t.designated_std;
      }
    }
    require(c.method == "scratch" || !a.base.empty(), "a base checkpoint is needed (or --method scratch)", {{}, {}, "--base"});
    if (c.method != "scratch") {
      // The frozen base's architecture and, unless --motions, its motion set A come from its checkpoint.
      base_file = std::make_unique<Checkpoint>(load_checkpoint_on_every_rank(world, a.base));
      require(!base_file->contains("residual_config"),
              "a stage-2 (train-residual) checkpoint or export; --base takes a stage-1 checkpoint (train-base output) or its export",
              {a.base, std::nullopt, "residual_config"});
      const BaseTrainConfig bc = config_from_string(base_file->get_string("config"), a.base + " (config)");
      c.rl.net.actor_hidden = bc.net.actor_hidden;
      c.rl.net.activation = bc.net.activation;
      c.rl.net.init_log_std = bc.net.init_log_std;
      // (provenance: the mapping in use is the checkpoint's actor/action_* sections, read by load_base_actor)
      c.rl.net.action_offset = bc.net.action_offset;
      c.rl.net.action_scale = bc.net.action_scale;
      c.rl.net.action_offset_rad = bc.net.action_offset_rad;
      c.rl.net.action_scale_rad = bc.net.action_scale_rad;
      c.rl.env.motions = bc.env.motions;
      require(a.character.empty() || a.character == bc.env.character,
              "the base was trained on the " + bc.env.character + ", not the " + a.character, {{}, {}, "--character"});
      c.rl.env.character = bc.env.character;
    } else if (!a.character.empty()) {
      c.rl.env.character = a.character;
    }
    if (!a.motions.empty()) c.rl.env.motions = a.motions;
    require_task_flags(c.task == "tracking" ? a.composition_only : a.tracking_only, c.task,
                       c.task == "tracking" ? "composition (and the goal tasks)" : "tracking");
  }
  if (a.iterations >= 0) c.rl.run.iterations = a.iterations;
  if (a.minutes > 0) c.rl.run.minutes = a.minutes;
  if (a.minutes > 0 && a.iterations < 0) c.rl.run.iterations = 0;
  c.rl.run.out_dir = a.out;
  cli::validate_naming_flags([&] { c.validate(); },
                             {{"env.num_envs", "--envs"}, {"run.threads", "--threads"}, {"run.iterations", "--iterations"},
                              {"run.minutes", "--minutes"}, {"run.out_dir", "--out"}, {"env.motions", "--motions"},
                              {"env.episode_seconds", "--episode-seconds"}, {"switch_rate", "--switch-rate"},
                              {"masks", "--masks"}, {"task", "--task"}, {"method", "--method"}, {"blend_resets", "--blend-resets"},
                              {"noise_hold_steps", "--noise-hold-steps"}, {"objective_weights", "--objective-weights"},
                              {"residual_std_decay", "--residual-std-decay"},
                              {"location_facing_weight", "--location-facing-weight"},
                              {"location_position_weight", "--location-position-weight"},
                              {"strike_approach_weight", "--strike-approach-weight"},
                              {"strike_distance", "--strike-distance"},
                              {"strike_end_on_foreign_contact", "--strike-end-on-foreign-contact"},
                              {"strike_next_box_steps", "--strike-next-box"},
                              {"location_distance", "--location-distance"}, {"location_divergence", "--location-divergence"},
                              {"location_arrive_distance", "--location-arrive-distance"},
                              {"location_reach_bonus", "--location-reach-bonus"},
                              {"residual_part_std", "--part-std"}, {"part_objective_weights", "--part-objective-weights"},
                              {"tracking_reward_scale", "--tracking-reward-scale"}});
  require(c.task != "composition" || !c.new_motions.empty(), "composition needs --new-motion", {{}, {}, "--new-motion"});

  const MujocoCharacter& character = mujoco_character(c.rl.env.character, "env.character");
  require(c.task != "tracking" || character.name == "humanoid",
          "tracking runs on the humanoid only: the text generator is trained on the humanoid's skeleton (the " +
              character.name + " has no generator)",
          {{}, {}, "--task"});
  auto base_lib = load_motion_library(c.rl.env.motions, data_dir(), character);
  std::shared_ptr<MotionLibrary> new_lib =
      c.task != "tracking" && !c.new_motions.empty() ? load_motion_library(c.new_motions, data_dir(), character) : base_lib;
  const std::size_t envs_here = cli::envs_per_rank(world, c.rl.env.num_envs);
  const Index first_env = static_cast<Index>(envs_here) * world.rank();
  ThreadPool pool(static_cast<std::size_t>(c.rl.run.threads));
  MujocoHumanoidSim sim(envs_here, pool, character, task_objects(c.task));
  const Index obs_dim = observation_dim(sim.skeleton()), A = sim.skeleton().num_dofs();
  // The frozen base and its action space (PD target = offset + scale ⊙ â). Resume: placeholders,
  // replaced by the checkpoint's base/ sections (action space included) in trainer.load. Scratch:
  // the zero base with the config's net.action_* (identity unless the config asks otherwise).
  if (c.method == "scratch" && !resume) resolve_action_space(c.rl, sim.skeleton(), base_lib.get());
  FrozenBase base = resume ? FrozenBase{base_actor_like(c, obs_dim, A), {}}
                    : c.method == "scratch" ? scratch_base(c, obs_dim, A)
                                            : load_base_actor(*base_file, obs_dim, A);
  // resets from the part-wise blends (--blend-resets) use the set ours' discriminator samples
  // from: the training masks (cml: its one fixed region)
  std::shared_ptr<const tasks::BlendedMotionSet> blends;
  if (c.task == "composition" && (c.method == "ours" || c.blend_resets > 0)) {
    const std::vector<PartMask> masks = tasks::parse_mask_set(c.masks, "--masks");
    blends = std::make_shared<const tasks::BlendedMotionSet>(
        *base_lib, *new_lib, c.method == "ours" ? masks : std::vector<PartMask>{masks.front()});
  }
  ResidualSetup<MujocoHumanoidSim> setup =
      make_setup<MujocoHumanoidSim>(c, base_lib, new_lib, observation_parts(sim.skeleton()), blends);
  if (c.task == "tracking") {
    require(!c.generator.empty(), "tracking needs --generator (train one with `maskadapt train-generator`)", {{}, {}, "--generator"});
    auto gen = std::make_shared<tracking::BuiltinGenerator>(tracking::BuiltinGenerator::load(c.generator, sim.skeleton()));
    // prompts: --texts (kept in the config, so --resume samples the same), else the arms pool stored
    // in the generator (issue 19), else from the clips
    std::vector<std::string> texts = !c.texts.empty()           ? c.texts
                                     : !gen->arms_pool().empty() ? gen->arms_pool()
                                                                 : default_text_pool(sim.skeleton());
    out << "train-residual: text pool (" << texts.size() << "):";
    for (const auto& t : texts) out << " '" << t << "'";
    out << "\n";
    setup.goal = make_tracking(c, gen, base_lib, texts, sim, static_cast<std::uint64_t>(world.rank()));
    setup.goal_weight = c.objective_weights.size() > 1 ? c.objective_weights[1] : 0.5;
  }
  if (is_goal_task(c.task)) {
    setup.goal = make_goal_task(c.task, c, sim, c.rl.run.seed, first_env);
    setup.goal_weight = c.objective_weights.empty() ? 0.5 : c.objective_weights.back();
  }
  {
    const std::size_t objectives = setup.discriminators.size() + (setup.goal ? 1 : 0);
    require(c.objective_weights.empty() || c.objective_weights.size() == objectives,
            "this run has " + std::to_string(objectives) + " objective(s) (" + std::to_string(setup.discriminators.size()) +
                " discriminator(s)" + (setup.goal ? " and the goal task" : "") + "), so it needs that many weights, not " +
                std::to_string(c.objective_weights.size()),
            {{}, {}, "--objective-weights"});
    for (std::size_t p = 0; p < c.part_objective_weights.size(); ++p)
      require(c.part_objective_weights[p].empty() || c.part_objective_weights[p].size() == objectives,
              std::string(kPartNames[p]) + " has " + std::to_string(c.part_objective_weights[p].size()) +
                  " weights; this run has " + std::to_string(objectives) + " objective(s)",
              {{}, {}, "--part-objective-weights"});
  }
  out << "train-residual: " << character.name << ", task " << c.task << ", method " << c.method << ", masks";
  for (const auto& m : setup.masks) out << " " << m.to_string();
  if (!c.goal_parts.empty()) out << " (and for the goal " << PartMask::parse(c.goal_parts).to_string() << ")";
  out << ", " << setup.discriminators.size() << " discriminator(s), out " << c.rl.run.out_dir << ", BLAS kernel "
      << blas_core_name()
      << (world.distributed() ? ", " + std::to_string(world.size()) + " ranks x " + std::to_string(envs_here) + " envs" : std::string())
      << "\n";
  // the policy on the frozen base: the residual (ours, cml, scratch) or AdaptNet
  auto train = [&]<class Policy>() {
    ResidualTrainer<MujocoHumanoidSim, Policy> trainer(sim, blended_reset_sampler(base_lib, blends, c.blend_resets),
                                                       std::move(base), std::move(setup), c,
                                                       &pool, character.fall_criteria(c.rl.env.termination_height), &world);
    if (resume) {
      trainer.load(*resume);
      out << "train-residual: resumed at iteration " << trainer.iteration() << " from " << a.resume << "\n";
    }
    trainer.add_provenance(cli::provenance_line() +
                           (world.distributed() ? " (" + std::to_string(world.size()) + " MPI ranks)" : std::string()) +
                           (resume ? " (resumed at iteration " + std::to_string(trainer.iteration()) + ", sample " +
                                         std::to_string(trainer.samples()) + ")"
                                   : std::string()));
    out << "train-residual: " << describe_actions(trainer.policy().actions(), c.rl.net) << "\n";
    if (world.is_root()) {
      std::filesystem::create_directories(c.rl.run.out_dir);
      std::ofstream(c.rl.run.out_dir + "/residual_config.json") << to_json(c).dump(2) << "\n";
    }
    run_training(trainer, RunOptions{static_cast<bool>(resume), &std::cout, cli::stop_training_on_signals()});
    out << "train-residual: done, " << trainer.iteration() << " iterations; checkpoint " << c.rl.run.out_dir << "/checkpoint.bin";
    // (a resume that ran no iteration has no last reward to report)
    if (trainer.goal_task() && std::isfinite(trainer.last_goal_reward()))
      out << "; last " << c.task << " reward " << trainer.last_goal_reward();
    out << "\n";
  };
  if (c.method == "adaptnet") train.template operator()<adapt::AdaptNetPolicy<float>>();
  else train.template operator()<adapt::ResidualPolicy<float>>();
#endif
}

#ifdef MASKADAPT_HAS_MUJOCO
/// One frame of a goal task's scene for the viewer: the location target, the heading arrow from
/// the root, the strike box's pose.
void add_scene_frame(eval::RolloutScene& scene, tasks::AnyGoalTask<MujocoHumanoidSim>& goal, const MujocoHumanoidSim& sim,
                     const BodyStates& b) {
  if (auto* loc = goal.as<tasks::LocationTask>()) scene.targets.push_back({{loc->target(0), loc->config().radius}});
  if (auto* head = goal.as<tasks::HeadingTask>())
    scene.arrows.push_back({eval::heading_arrow(b.pos.col(0), head->direction(0), head->speed(0))});
  if (goal.as<tasks::StrikeTask>()) {
    const RigidState& box = sim.object_state(0, 0);
    scene.objects[0].positions.push_back(box.pos);
    scene.objects[0].rotations.push_back(box.rot);
  }
}
#endif

struct PlayArgs {
  std::string checkpoint, mask_schedule, text, bvh, rollout, generator;  ///< mask_schedule "": the run's first training mask
  double seconds = 10.0;
  long long seed = 1;
  std::vector<std::string> composition_only, tracking_only;  ///< such flags given on the command line
};

void run_play(const PlayArgs& a, const std::string& command_line) {
#ifndef MASKADAPT_HAS_MUJOCO
  (void)a;
  (void)command_line;
  throw Error("this build has no MuJoCo; play-residual needs the maskadapt::mujoco target", {{}, std::nullopt, "play-residual"});
#else
  require(!a.bvh.empty() || !a.rollout.empty(), "nothing to write: give --bvh and/or --rollout", {{}, {}, "play-residual"});
  const Checkpoint ck = load_checkpoint(a.checkpoint);
  const ResidualTrainConfig c = residual_config_from_json(nlohmann::json::parse(ck.get_string("residual_config")), a.checkpoint);
  const MujocoCharacter& character = mujoco_character(c.rl.env.character, a.checkpoint + " (env.character)");
  MujocoHumanoidSim sim(1, 1, character, task_objects(c.task));  // (strike: with its box)
  const Skeleton& skel = sim.skeleton();
  const Index obs_dim = observation_dim(skel), A = skel.num_dofs();
  const PartMask designated = PartMask::parse(c.designated);
  const bool tracking_task = c.task == "tracking";
  require_task_flags(tracking_task ? a.composition_only : a.tracking_only, c.task, tracking_task ? "composition" : "tracking");
  // the mask the policy runs with: tracking adapts the designated parts; scratch drives every DoF;
  // else --mask-schedule, by default the run's first training mask (as eval-residual)
  const std::string mask_spec = c.method == "scratch" ? "0:all"
                                : tracking_task        ? "0:" + designated.to_string()
                                : !a.mask_schedule.empty() ? a.mask_schedule
                                                           : "0:" + PartMask::parse(c.masks.front(), "masks").to_string();
  const auto schedule = MaskSampler::scheduled(mask_spec);
  auto lib = load_motion_library(c.rl.env.motions, data_dir(), character);
  Rng rng(static_cast<std::uint64_t>(a.seed));
  const std::vector<int> bodies = tracking::designated_bodies(skel, designated);
  std::unique_ptr<tracking::BuiltinGenerator> gen;
  tracking::Trajectory targets;
  std::vector<tracking::TimedText> texts;
  const Index steps = std::max<Index>(1, std::llround(a.seconds / sim.control_dt()));
  const double t0 = 4 * kAmpFrameDt;
  sim.reset(0, lib->state(0, t0));
  // goal tasks: the run's task draws goals on its schedule from this seed (target, heading, box)
  tasks::AnyGoalTask<MujocoHumanoidSim> goal;
  if (is_goal_task(c.task)) {
    goal = make_goal_task(c.task, c, sim, static_cast<std::uint64_t>(a.seed));
    goal.new_episode(sim, 0);
  }
  if (tracking_task) {
    require(!a.generator.empty() || !c.generator.empty(), "tracking playback needs a generator", {{}, {}, "--generator"});
    gen = std::make_unique<tracking::BuiltinGenerator>(tracking::BuiltinGenerator::load(a.generator.empty() ? c.generator : a.generator, skel));
    texts = tracking::parse_text_schedule(a.text.empty() ? "0:raise arms" : a.text);
    const Index H = gen->history_frames();
    // the history ends at the reset pose; the generator runs online on the text schedule
    targets = tracking::rollout(*gen, texts, tracking::trajectory_from_library(*lib, 0, t0 - static_cast<double>(H - 1) / 30.0, H),
                                steps + c.goal_steps + 1, rng);
  }
  MotionClip out;
  out.name = "play_residual";
  out.resize(static_cast<int>(steps), A);
  eval::Rollout roll = eval::make_rollout(sim.character(), 1.0 / sim.control_dt());
  roll.metadata.command = command_line;
  roll.metadata.checkpoint = a.checkpoint;
  roll.metadata.seed = a.seed;
  roll.metadata.extra["task"] = c.task;
  roll.metadata.extra["method"] = c.method;
  if (tracking_task) {
    roll.metadata.extra["designated"] = designated.to_string();
    for (const auto& t : texts) roll.texts.push_back({t.start_s, t.text});
    roll.goals = eval::RolloutGoals{bodies, {}};
  } else {
    roll.metadata.extra["mask_schedule"] = mask_spec;
  }
  if (goal) {
    roll.scene.emplace();
    if (c.task == "strike") roll.scene->objects.push_back({"strike_box", sim.objects().front().half_size, {}, {}});
  }
  double track_err = 0, goal_reward = 0;
  // the policy on the frozen base: the residual (ours, cml, scratch) or AdaptNet (which runs every
  // DoF and ignores the mask; the mask is still written into the rollout)
  auto play = [&]<class Policy>() {
    const auto pol = stage2_policy_from_checkpoint<Policy>(ck, skel);
    MatrixXf obs(obs_dim, 1), x, mu, targets_rad, goals(pol.goal_dim(), 1);
    typename Stage2Types<Policy>::Workspace ws;
    const PartElements pe(observation_parts(skel));
    PartMask last = PartMask::none();
    for (Index t = 0; t < steps; ++t) {
      const double time = static_cast<double>(t) * sim.control_dt();
      const std::vector<PartMask> m{schedule.sample(rng, time)};
      if (t == 0 || m[0] != last) std::cout << "play-residual: t=" << time << " s, adapted parts " << m[0].to_string() << "\n";
      last = m[0];
      compute_observation(skel, sim.body_states(0), obs.col(0));
      if (tracking_task) tracking::extract_goals(skel, bodies, targets, t, c.goal_steps, goals.col(0));
      if (goal) goal.goal(sim, 0, goals.col(0));
      pol.build_input(pe, obs, m, goals, x, ws);
      pol.mean(x, m, mu, ws);
      pol.to_targets(mu, targets_rad);  // offset + scale ⊙ â (the base's action space)
      sim.step(targets_rad);
      const BodyStates& b = sim.body_states(0);
      out.root_pos.col(static_cast<int>(t)) = b.pos.col(0);
      out.set_rot(static_cast<int>(t), b.rot[0]);
      out.q.col(static_cast<int>(t)) = sim.joint_angles(0);
      eval::add_frame(roll, b, m[0], sim.contacts(0));
      if (goal) {  // what the policy was asked this step, then the task's bookkeeping
        add_scene_frame(*roll.scene, goal, sim, b);
        const tasks::GoalStep g = goal.after_step(sim, 0, tasks::EpisodeEnd::none);
        goal_reward += g.reward;
        // a play never resets the character: where the task closes its trial (its next goal, or
        // an end it would train with: strike's foreign contact) the next goal is drawn at once
        if (g.next_goal || g.terminate) goal.new_episode(sim, 0);
      }
      if (tracking_task) {
        track_err += tracking::position_error(bodies, targets, t + 1, b);
        // the targets as the character should reach them: root-relative heading-frame positions
        // placed at the simulated root (the generated root drifts from the simulated one)
        Matrix3X g(3, static_cast<Index>(bodies.size()));
        const Quat Hs = heading_rotation(b.rot[0]);
        for (std::size_t j = 0; j < bodies.size(); ++j) {
          const int bi = bodies[j];
          g.col(static_cast<Index>(j)) = b.pos.col(0) + Hs * tracking::heading_local(targets.body_pos.block<3, 1>(3 * bi, t + 1),
                                                                                     targets.root_pos.col(t + 1),
                                                                                     targets.root_rot[static_cast<std::size_t>(t + 1)]);
        }
        roll.goals->targets.push_back(g);
      }
    }
  };
  if (c.method == "adaptnet") play.template operator()<adapt::AdaptNetPolicy<float>>();
  else play.template operator()<adapt::ResidualPolicy<float>>();
  std::cout << "play-residual: " << steps << " steps, final root height " << sim.body_states(0).pos(2, 0) << " m";
  if (tracking_task) std::cout << ", mean tracking error " << track_err / static_cast<double>(steps) << " m";
  if (goal) std::cout << ", mean " << c.task << " reward " << goal_reward / static_cast<double>(steps) << ", trials ended "
                      << goal.trials().trials << " (successes " << goal.trials().successes << ")";  // (a play has no time limit)
  std::cout << "\n";
  if (!a.bvh.empty()) {
    bvh::write(a.bvh, clip_to_bvh(out, skel));
    std::cout << "wrote " << a.bvh << "\n";
  }
  if (!a.rollout.empty()) {
    eval::write_rollout(roll, a.rollout);
    std::cout << "wrote " << a.rollout << " (viewer rollout)\n";
  }
#endif
}

struct EvalArgs {
  std::string checkpoint, task, out, generator, mask;
  std::vector<std::string> new_motion, motions, prompts;
  int envs = 10, repeats = 3, num_prompts = 10;
  long long frames = 1000, seed = 1, trials = 100;
  double seconds = 5.0, threshold_per_body = 0.1;
  bool stochastic = false, oracle_targets = false;
  std::vector<std::string> composition_only, tracking_only, goal_only;  ///< such flags given on the command line
};

void run_eval(const EvalArgs& a) {
#ifndef MASKADAPT_HAS_MUJOCO
  (void)a;
  throw Error("this build has no MuJoCo; eval-residual needs the maskadapt::mujoco target", {{}, std::nullopt, "eval-residual"});
#else
  const Checkpoint ck = load_checkpoint(a.checkpoint);
  const ResidualTrainConfig c = residual_config_from_json(nlohmann::json::parse(ck.get_string("residual_config")), a.checkpoint);
  const std::string task = a.task.empty() ? c.task : a.task;
  require(task == c.task, "this checkpoint was trained for " + c.task + ", not " + task, {{}, {}, "--task"});
  if (is_goal_task(task)) {  // goal tasks read --envs, --mask and --threshold of the composition flags
    require_task_flags(a.tracking_only, task, "tracking");
    std::vector<std::string> refused;
    for (const auto& f : a.composition_only)
      if (f != "--envs" && f != "--mask" && f != "--threshold") refused.push_back(f);
    require_task_flags(refused, task, "composition");
  } else {
    require_task_flags(task == "tracking" ? a.composition_only : a.tracking_only, task,
                       task == "tracking" ? "composition" : "tracking");
    require_task_flags(a.goal_only, task, "location / heading / strike");
  }
  const MujocoCharacter& character = mujoco_character(c.rl.env.character, a.checkpoint + " (env.character)");
  const FallCriteria fall = character.fall_criteria(c.rl.env.termination_height);
  auto base_lib = load_motion_library(a.motions.empty() ? c.rl.env.motions : a.motions, data_dir(), character);
  nlohmann::json j;
  j["checkpoint"] = a.checkpoint;
  j["task"] = task;
  j["method"] = c.method;
  if (is_goal_task(task)) {
    ThreadPool pool(static_cast<std::size_t>(c.rl.run.threads));
    MujocoHumanoidSim sim(static_cast<std::size_t>(a.envs), pool, character, task_objects(task));
    // the mask the policy runs with: --mask, else the first training mask (scratch: every part;
    // AdaptNet ignores masks)
    const PartMask mask = c.method == "scratch" ? PartMask::all() : PartMask::parse(a.mask.empty() ? c.masks.front() : a.mask, "--mask");
    GoalEvalOptions opt;
    opt.min_trials = a.trials;
    opt.deterministic = !a.stochastic;
    opt.seed = static_cast<std::uint64_t>(a.seed);
    opt.episode_seconds = c.rl.env.episode_seconds;
    // the paper's reward whatever shaping the run trained with, so that mean rewards compare
    // across runs (the success test does not depend on it)
    const ResidualTrainConfig paper_rewards;
    // the cell's composed motion B on its first training mask, measured beside the success rate
    std::shared_ptr<MotionLibrary> new_lib;
    std::optional<ComposedMotion> composed;
    if (!c.new_motions.empty()) {
      new_lib = load_motion_library(c.new_motions, data_dir(), character);
      composed = ComposedMotion{new_lib.get(), PartMask::parse(c.masks.front(), "masks"), a.threshold_per_body};
    }
    auto evaluate = [&]<class Policy>() {
      const auto pol = stage2_policy_from_checkpoint<Policy>(ck, sim.skeleton());
      return evaluate_goal_task(sim, pol, make_goal_task(task, paper_rewards, sim, opt.seed), mask,
                                library_reset_sampler(base_lib), fall, opt, &pool, composed);
    };
    const GoalEvalResult r = c.method == "adaptnet" ? evaluate.template operator()<adapt::AdaptNetPolicy<float>>()
                                                    : evaluate.template operator()<adapt::ResidualPolicy<float>>();
    std::printf("eval-residual %s: success %.1f %% (95 %% CI %.1f-%.1f %%) over %lld trials (%lld cut short by the "
                "episode's time limit, not counted); %d envs x %lld steps, mask %s, mean %s reward %.3f, fall rate %.3f\n",
                task.c_str(), 100 * r.trials.rate(), 100 * r.ci_low, 100 * r.ci_high, r.trials.trials, r.trials.censored,
                a.envs, r.steps, mask.to_string().c_str(), task.c_str(), r.mean_reward, r.fall_rate);
    if (!r.outcomes.empty()) {
      std::printf("trial outcomes:");
      for (const auto& [name, n] : r.outcomes)
        std::printf(" %s %lld (%.1f %%)", name.c_str(), n, r.trials.trials > 0 ? 100.0 * static_cast<double>(n) / static_cast<double>(r.trials.trials) : 0.0);
      std::printf("\n");
    }
    if (r.composed)
      std::printf("composed motion on %s: H_norm %.3f vs B, %.1f %% of frames within %.2f m per body of a frame of B\n",
                  r.composed->parts.to_string().c_str(), r.composed->h_norm, 100 * r.composed->matched,
                  r.composed->threshold_per_body);
    j["envs"] = a.envs;
    j["mask"] = mask.to_string();
    j["trials"] = r.trials.trials;
    j["successes"] = r.trials.successes;
    j["censored_trials"] = r.trials.censored;  // cut short by the episode's time limit, in neither count
    j["success_rate"] = r.trials.rate();
    j["ci95"] = {r.ci_low, r.ci_high};
    if (!r.outcomes.empty()) {
      j["trial_outcomes"] = nlohmann::json::object();
      for (const auto& [name, n] : r.outcomes) j["trial_outcomes"][name] = n;
    }
    j["steps"] = r.steps;
    j["mean_reward"] = r.mean_reward;
    j["fall_rate"] = std::isfinite(r.fall_rate) ? nlohmann::json(r.fall_rate) : nlohmann::json(nullptr);
    if (r.composed)
      j["composed_motion"] = {{"parts", r.composed->parts.to_string()},
                              {"threshold_per_body_m", r.composed->threshold_per_body},
                              {"h_norm", r.composed->h_norm},
                              {"matched", r.composed->matched},
                              {"new_motion_clips", clip_list_json(*new_lib)}};
  } else if (task == "composition") {
    auto new_lib = load_motion_library(a.new_motion.empty() ? c.new_motions : a.new_motion, data_dir(), character);
    ThreadPool pool(static_cast<std::size_t>(c.rl.run.threads));
    MujocoHumanoidSim sim(static_cast<std::size_t>(a.envs), pool, character);
    const auto pol = residual_policy_from_checkpoint(ck, sim.skeleton());
    // ours: every training mask; cml / scratch: the adapted group (the first mask)
    std::vector<PartMask> masks;
    if (!a.mask.empty()) masks = {PartMask::parse(a.mask, "--mask")};
    else if (c.method == "ours")
      for (const auto& m : c.masks) masks.push_back(PartMask::parse(m, "masks"));
    else masks = {PartMask::parse(c.masks.front(), "masks")};
    const std::optional<PartMask> run_mask = c.method == "scratch" ? std::optional<PartMask>(PartMask::all()) : std::nullopt;
    CompositionEvalOptions opt;
    opt.frames = a.frames;
    opt.threshold_per_body = a.threshold_per_body;
    opt.deterministic = !a.stochastic;
    opt.seed = static_cast<std::uint64_t>(a.seed);
    opt.episode_seconds = c.rl.env.episode_seconds;
    std::vector<CompositionResult> rows;
    for (PartMask m : masks) {
      rows.push_back(evaluate_composition(sim, pol, m, *base_lib, *new_lib, library_reset_sampler(base_lib), fall, opt, &pool,
                                          run_mask));
    }
    std::cout << "eval-residual composition: " << a.envs << " envs x " << a.frames << " frames, threshold "
              << a.threshold_per_body << " m per body\n"
              << format_composition_table(rows);
    j["envs"] = a.envs;
    j["frames"] = a.frames;
    j["threshold_per_body_m"] = a.threshold_per_body;
    j["new_motion_clips"] = clip_list_json(*new_lib);  // the frames of rows[i].visits_adapted_vs_new
    j["rows"] = nlohmann::json::array();
    for (const auto& r : rows) j["rows"].push_back(to_json(r));
  } else {
    MujocoHumanoidSim sim(static_cast<std::size_t>(a.repeats), 1, character);
    const auto pol = residual_policy_from_checkpoint(ck, sim.skeleton());
    const std::string gpath = a.generator.empty() ? c.generator : a.generator;
    require(!gpath.empty(), "tracking evaluation needs a generator", {{}, {}, "--generator"});
    auto gen = tracking::BuiltinGenerator::load(gpath, sim.skeleton());
    TrackingEvalOptions opt;
    opt.prompts = a.prompts;
    if (opt.prompts.empty() && !c.texts.empty()) opt.prompts = c.texts;  // the run's own prompts
    if (opt.prompts.empty()) opt.prompts = gen.arms_pool();                 // else the generator's (issue 19)
    if (opt.prompts.empty()) {  // else the clips' pool, topped up with the fixed prompts it lacks
      opt.prompts = default_text_pool(sim.skeleton());
      for (const char* t : {"raise arms", "wave hands", "punch", "wash self"})
        if (std::find(opt.prompts.begin(), opt.prompts.end(), t) == opt.prompts.end()) opt.prompts.push_back(t);
    }
    if (static_cast<int>(opt.prompts.size()) > a.num_prompts) opt.prompts.resize(static_cast<std::size_t>(a.num_prompts));
    opt.repeats = a.repeats;
    opt.seconds = a.seconds;
    opt.deterministic = !a.stochastic;
    opt.seed = static_cast<std::uint64_t>(a.seed);
    opt.oracle_targets = a.oracle_targets;
    const auto ev = evaluate_tracking(sim, pol, gen, PartMask::parse(c.designated), c.goal_steps, *base_lib, fall, opt,
                                      c.method == "scratch" ? std::optional<PartMask>(PartMask::all()) : std::nullopt);
    std::cout << "eval-residual tracking: " << opt.prompts.size() << " prompts x " << a.seconds << " s x " << a.repeats
              << " repeats (designated " << c.designated << ")"
              << (a.oracle_targets ? "; oracle: the designated joints' PD targets are the target's angles" : "") << "\n"
              << format_tracking_table(ev);
    j["seconds"] = a.seconds;
    j["repeats"] = a.repeats;
    j["oracle_targets"] = a.oracle_targets;
    j["result"] = to_json(ev);
  }
  if (!a.out.empty()) {
    std::ofstream f(a.out);
    require(static_cast<bool>(f), "cannot open for writing", {a.out, std::nullopt, {}});
    f << j.dump(2) << "\n";
    std::cout << "wrote " << a.out << "\n";
  }
#endif
}

const bool registered = maskadapt::cli::register_command([](CLI::App& app) {
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand("train-residual", "Train a residual policy on a frozen base (stage 2)");
  using namespace maskadapt::cli;
  const CLI::Validator mask_name = parsed_by([](const std::string& t) { (void)PartMask::parse(t); }, "MASK");
  const CLI::Validator training_mask =
      parsed_by([](const std::string& t) { (void)tasks::parse_mask_set({t}); }, "MASK");
  std::vector<CLI::Option*> fixed_by_resume;  // the run's own config decides these on --resume
  auto keep = [&](CLI::Option* o) { fixed_by_resume.push_back(o); return o; };
  keep(c->add_option("--task", a->task, "composition | tracking | location | heading | strike (goal tasks: --new-motion optional)"))
      ->check(one_of({"composition", "tracking", "location", "heading", "strike"}));
  keep(c->add_option("--method", a->method, "ours | cml | scratch | adaptnet (goal tasks)"))
      ->check(one_of({"ours", "cml", "scratch", "adaptnet"}));
  keep(c->add_option("--base", a->base, "stage-1 checkpoint (train-base output)"));
  keep(c->add_option("--new-motion", a->new_motion, "new motion set B: builtin name | DIR | FILE ..."));
  keep(c->add_option("--motions", a->motions, "base motion set A (default: the preset's env.motions)"));
  keep(c->add_option("--character", a->character,
                     "humanoid | g1 (default: the base's character; with --method scratch: humanoid)"))
      ->check(one_of(maskadapt::character_names()));
  keep(c->add_option("--masks", a->masks, "training mask set, e.g. lower_body arms (cml: the first is the fixed region)"))
      ->check(training_mask);
  keep(c->add_option("--switch-rate", a->switch_rate, "mid-episode mask switches per second"))->check(non_negative_real());
  keep(c->add_option("--designated", a->designated, "tracking: parts that follow the generated trajectory"))
      ->check(training_mask);
  keep(c->add_option("--goal-parts", a->goal_parts,
                     "goal tasks: parts the residual also moves for the goal, visible to the base (e.g. lower_body)"))
      ->check(mask_name);
  keep(c->add_option("--generator", a->generator, "tracking: generator checkpoint (train-generator output)"));
  keep(c->add_option("--texts", a->texts, "tracking: text pool"));
  keep(c->add_option("--gain", a->gain, "fixed | scalar | per_dof"))->check(one_of({"fixed", "scalar", "per_dof"}));
  keep(c->add_option("--hidden", a->hidden, "residual hidden sizes"))->transform(integer_in(1, 16384));
  keep(c->add_option("--residual-std", a->residual_std,
                     "σ of the residual's exploration on the adapted DoFs (action units; 0: the base's σ, the default; tracking "
                     "with the cpu preset: 0.5 on the designated parts)"))
      ->check(real_in(0.0, 10.0));
  keep(c->add_option("--disc-frames", a->disc_frames,
                     "frames of the 5-frame window the reward discriminators see, the last ones (2: the paper's "
                     "D(s, s'|m); default: the preset's, 5)"))
      ->transform(integer_in(1, maskadapt::kAmpWindowFrames));
  keep(c->add_option("--noise-hold-steps", a->noise_hold_steps,
                     "control steps each draw of exploration noise is held (default 1: fresh every step)"))
      ->transform(integer_in(1, 100000));
  keep(c->add_option("--residual-std-decay", a->residual_std_decay,
                     "FACTOR ITERATIONS: the residual's σ falls geometrically to FACTOR (in (0, 1]) times its initial value "
                     "over the first ITERATIONS iterations (default: a fixed σ, the paper's)"))
      ->expected(2)
      ->check(positive_real(1e9));
  keep(c->add_option("--location-facing-weight", a->location_facing_weight,
                     "location: weight of the facing shaping term (1 + f·d)/2 in the reward (default 0: the paper's)"))
      ->check(probability());
  keep(c->add_option("--location-position-weight", a->location_position_weight,
                     "location: weight of the position shaping term exp(-0.5 d²) in the reward (default 0: the paper's; "
                     "with the facing weight at most 1)"))
      ->check(probability());
  keep(c->add_option("--part-std", a->part_std,
                     "σ of the residual's exploration per body part, PARTS=σ items (e.g. arms=0.15 lower_body=0.05; "
                     "default: --residual-std on every part; tracking with the cpu preset: the designated parts at 0.5)"));
  keep(c->add_option("--part-objective-weights", a->part_objective_weights,
                     "per-part credit: the objective weights each part's DoFs are credited with, PARTS=w1,w2,... items, one "
                     "weight per objective as --objective-weights (e.g. arms=1,0 lower_body=0.1,0.9: the arms learn from the "
                     "composition discriminator alone, the legs mostly from the goal; default: every DoF with --objective-weights)"));
  keep(c->add_option("--location-distance", a->location_distance,
                     "location, training only: MIN MAX distance of the drawn targets (m; default 1 5, as evaluated)"))
      ->expected(2)
      ->check(positive_real(100.0));
  keep(c->add_option("--location-divergence", a->location_divergence,
                     "location: end the episode when the target is this much farther than when drawn (m; default 0: never)"))
      ->check(non_negative_real());
  keep(c->add_option("--location-arrive-distance", a->location_arrive_distance,
                     "location, training only: the velocity term's target speed falls to 0 at the target, "
                     "v*·min(1, d/RHO) (m; default 0: v* everywhere, the paper's)"))
      ->check(real_in(0, 100));
  keep(c->add_option("--location-reach-bonus", a->location_reach_bonus,
                     "location, training only: reward on reaching a target, which is then redrawn at once "
                     "(default 0: none, the paper's)"))
      ->check(real_in(0, 1000));
  keep(c->add_option("--strike-approach-weight", a->strike_approach_weight,
                     "strike: weight of the approach shaping term in the reward (default 0: the paper's)"))
      ->check(probability());
  keep(c->add_option("--strike-distance", a->strike_distance,
                     "strike, training only: MIN MAX distance of the placed boxes (m; default 1 3, as evaluated)"))
      ->expected(2)
      ->check(positive_real(100.0));
  keep(c->add_flag("--strike-end-on-foreign-contact,!--no-strike-end-on-foreign-contact", a->strike_end_on_foreign_contact,
                   "strike, training only: a first contact by a body other than the hands ends the episode (ASE's rule; "
                   "default: on with the cpu preset, off with the paper's)"));
  keep(c->add_option("--strike-next-box", a->strike_next_box,
                     "strike, training only: a new box STEPS control steps after the box tilted (0: one box per "
                     "episode, the paper's; default: 15 with the cpu preset, 0 with the paper's)"))
      ->transform(non_negative_integer(100000));
  keep(c->add_option("--objective-weights", a->objective_weights,
                     "weights of the objectives' normalised advantages: one per discriminator, then the goal task's "
                     "(default: composition ours 1, cml 0.5 0.5; goal tasks and tracking: each 0.5 with --preset paper, the goal 0.9 "
                     "against 0.1 for the discriminators together with cpu)"))
      ->check(non_negative_real());
  keep(c->add_option("--blend-resets", a->blend_resets,
                     "composition: share of resets from the part-wise blends of A and B (B's pose on the adapted "
                     "parts; default 0: every reset from A)"))
      ->check(probability());
  CLI::Option* preset = keep(c->add_option("--preset", a->preset,
                                                "cpu (default): the CPU settings and, on a goal task or tracking, the stage-2 recipe "
                                                "(goal weighted 0.9, location facing 0.5, strike approach 0.4, tracking σ 0.5 on the "
                                                "designated parts) | paper: the paper's "
                                                "settings and formulation; explicit reward flags win over either"))->check(one_of({"cpu", "paper"}));
  keep(c->add_option("--envs", a->envs, "parallel envs"))->transform(integer_in(1, kMaxEnvs));
  keep(c->add_option("--threads", a->threads, "threads for simulation and network passes (0 = all cores)"))
      ->transform(integer_in(0, kMaxThreads));
  c->add_option("--iterations", a->iterations, "iteration budget (0 = none, then a --minutes budget is needed)")
      ->transform(non_negative_integer());
  c->add_option("--minutes", a->minutes, "wall-clock budget in minutes")->check(positive_real());
  keep(c->add_option("--seed", a->seed, "master seed"))->transform(non_negative_integer());
  c->add_option("--out", a->out, "output directory");
  keep(c->add_option("--config", a->config, "stage-1-format JSON for the run/env/ppo/disc/net sections (e.g. configs/smoke.json)"))
      ->excludes(preset);  // the file names its own preset
  CLI::Option* resume =
      c->add_option("--resume", a->resume, "continue a train-residual checkpoint (its own config; budgets and --out may change)");
  keep(c->add_option("--episode-seconds", a->episode_seconds, "episode length limit (s)"))
      ->check(positive_real(kMaxEpisodeSeconds));
  keep(c->add_option("--goal-trajectories", a->goal_trajectories, "tracking: trajectories per goal-buffer refill"))
      ->transform(positive_integer(std::numeric_limits<int>::max()));
  keep(c->add_option("--sample-every", a->sample_every, "tracking: refill the goal buffer every N iterations"))
      ->transform(positive_integer(std::numeric_limits<int>::max()));
  keep(c->add_option("--term-threshold", a->term_threshold,
                     "tracking: windowed mean tracking reward (in (0, 1]) below which an episode ends; 0 = never"))
      ->check(probability());
  keep(c->add_option("--tracking-reward-scale", a->tracking_reward_scale,
                     "tracking: k of the reward exp(-k * sum of the designated bodies' squared rotation errors); 1 = the paper's"))
      ->check(positive_real(100.0));
  for (CLI::Option* o : fixed_by_resume) resume->excludes(o);
  c->callback([a, c] {
    for (const char* f : kCompositionFlags)
      if (c->count(f) > 0) a->composition_only.push_back(f);
    for (const char* f : kTrackingFlags)
      if (c->count(f) > 0) a->tracking_only.push_back(f);
    run_train_residual(*a);
  });

  auto p = std::make_shared<PlayArgs>();
  CLI::App* q = app.add_subcommand("play-residual", "Run a residual checkpoint with a mask or text schedule, export BVH");
  q->add_option("checkpoint", p->checkpoint, "train-residual checkpoint")->required();
  q->add_option("--mask-schedule", p->mask_schedule,
                "e.g. \"0:lower_body,5:upper_body\" (default: the run's first training mask throughout)")
      ->check(parsed_by([](const std::string& t) { (void)MaskSampler::scheduled(parse_mask_schedule(t, "--mask-schedule")); },
                        "SCHEDULE"));
  q->add_option("--text", p->text, "tracking: e.g. \"0:wave hands,5:raise arms\"")
      ->check(parsed_by([](const std::string& t) { (void)tracking::parse_text_schedule(t); }, "SCHEDULE"));
  q->add_option("--generator", p->generator, "tracking: generator checkpoint (default: the one trained with)");
  q->add_option("--seconds", p->seconds, "length (s)")->check(positive_real(kMaxEpisodeSeconds));
  q->add_option("--bvh", p->bvh, "write the motion as BVH");
  q->add_option("--rollout", p->rollout, "write the viewer rollout JSON (masks, contacts, texts, goals)");
  q->add_option("--seed", p->seed, "seed")->transform(non_negative_integer());
  q->callback([p, q] {
    if (q->count("--mask-schedule") > 0) p->composition_only.push_back("--mask-schedule");
    for (const char* f : {"--text", "--generator"})
      if (q->count(f) > 0) p->tracking_only.push_back(f);
    std::string cmd = "maskadapt play-residual " + p->checkpoint + " --seconds " + std::to_string(p->seconds) +
                      " --seed " + std::to_string(p->seed);
    if (!p->text.empty()) cmd += " --text \"" + p->text + "\"";
    else if (!p->mask_schedule.empty()) cmd += " --mask-schedule \"" + p->mask_schedule + "\"";
    run_play(*p, cmd);
  });

  auto e = std::make_shared<EvalArgs>();
  CLI::App* v = app.add_subcommand("eval-residual", "Evaluate a residual checkpoint: composition H_norm or tracking metrics");
  v->add_option("checkpoint", e->checkpoint, "train-residual checkpoint")->required();
  v->add_option("--task", e->task, "composition | tracking | location | heading | strike (default: the checkpoint's)")
      ->check(one_of({"composition", "tracking", "location", "heading", "strike"}));
  v->add_option("--mask", e->mask, "composition: evaluate this adapted mask (default: each training mask)")
      ->check(mask_name);
  v->add_option("--new-motion", e->new_motion, "composition: new motion set B (default: the training set)");
  v->add_option("--motions", e->motions, "base motion set A / reference walk (default: the training set)");
  v->add_option("--envs", e->envs, "composition: envs (default 10)")->transform(integer_in(1, kMaxEnvs));
  v->add_option("--frames", e->frames, "composition: frames per env (default 1000)")->transform(positive_integer());
  v->add_option("--threshold", e->threshold_per_body, "composition, and a goal task's composed motion: visitation threshold per body (m, default 0.1)")
      ->check(positive_real());
  v->add_option("--prompts", e->prompts, "tracking: prompts (default: the run's --texts, else the generator's arms pool)");
  v->add_option("--num-prompts", e->num_prompts, "tracking: at most this many prompts (default 10)")
      ->transform(positive_integer(std::numeric_limits<int>::max()));
  v->add_option("--seconds", e->seconds, "tracking: seconds per episode (default 5)")->check(positive_real(kMaxEpisodeSeconds));
  v->add_option("--repeats", e->repeats, "tracking: repeats per prompt (default 3; one env each)")
      ->transform(integer_in(1, kMaxEnvs));
  v->add_option("--generator", e->generator, "tracking: generator checkpoint (default: the one trained with)");
  v->add_flag("--oracle-targets", e->oracle_targets,
              "tracking: drive the designated joints with the target's own angles as PD targets (the floor no policy can beat)");
  v->add_option("--trials", e->trials, "location / heading / strike: trials to end before reporting (default 100)")
      ->transform(positive_integer());
  v->add_flag("--stochastic", e->stochastic, "sample actions instead of the policy mean");
  v->add_option("--seed", e->seed, "seed")->transform(non_negative_integer());
  v->add_option("--out", e->out, "write the results as JSON");
  v->callback([e, v] {
    for (const char* f : {"--mask", "--new-motion", "--envs", "--frames", "--threshold"})
      if (v->count(f) > 0) e->composition_only.push_back(f);
    for (const char* f : {"--prompts", "--num-prompts", "--seconds", "--repeats", "--generator", "--oracle-targets"})
      if (v->count(f) > 0) e->tracking_only.push_back(f);
    if (v->count("--trials") > 0) e->goal_only.push_back("--trials");
    run_eval(*e);
  });
});

}  // namespace
