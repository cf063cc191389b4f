#pragma once
/// \file config.hpp
/// One configuration struct for stage 1 (the mask-invariant AMP base policy), with the two
/// presets and strict JSON load/save.
///
/// Presets:
///  - `paper`: the paper's values — hidden sizes [1024, 1024, 512] for actor, critic and
///    discriminator, learning rates actor 1e-5 / critic 1e-4 / discriminator 1e-4, horizon 32,
///    γ 0.99, λ_GAE 0.95, clip 0.2, critic weight 5, gradient penalty 5, λ_MI 1, mask
///    probability 0.8 with at most 3 masked parts, 4096 envs. Needs a GPU-class machine.
///  - `cpu` (default): the recipe that learned to walk on 2 CPU cores (docs/results.md, issue 14),
///    i.e. sizes that train in hours — [256, 256] actor and critic, [256, 128] discriminator,
///    32 envs × horizon 32 = 1,024 samples per iteration — and the levers that made learning
///    work there, each measured:
///      normalised actions (PD target = the motions' mean pose + half the joint range × a);
///      an adaptive actor learning rate (PPO approx-KL held near 0.01, rsl_rl's rule);
///      a masking curriculum: plain AMP until 3 M samples (the unmasked walk is there by then:
///      0 of 32 falls at 3.07 M), then the mask probability ramps 0 → 0.8 over 1 M samples
///      (the shipped walker was trained with 5.53 M; issue 40 measured 3 M reaching the
///      walking bar 14 minutes sooner);
///      hidden elements at their running mean (flags unnormalised);
///      the MI loss against a slow moving-average target (λ_MI 0.3, τ 0.001), which, unlike every
///      stop-gradient or two-sided form at λ ≥ 0.1, did not destroy the walker;
///      7,800 iterations (8.0 M samples, ≈ 1.3 h of one core).
///    The struct's own defaults are the paper's formulation without these levers (no curriculum,
///    λ_MI 1, exact two-sided KL gradient, zeros for hidden elements, radians around the zero
///    pose, fixed rate); `paper` keeps them.
/// docs/training.md explains every field and why the cpu preset has its value.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/motion/amp_window.hpp>
#include <maskadapt/rl/adaptive_lr.hpp>
#include <maskadapt/sim/mujoco/character_names.hpp>
#include <maskadapt/train/json_fields.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace maskadapt::train {

/// Limits shared by validate() and the command-line flags (examples/maskadapt/cli_checks.hpp):
/// beyond them a run would only exhaust memory or threads instead of reporting an error.
inline constexpr int kMaxEnvs = 65536;               ///< env.num_envs ∈ [1, kMaxEnvs] (the paper uses 4096)
inline constexpr int kMaxThreads = 1024;             ///< run.threads ∈ [0, kMaxThreads] (0 = all cores)
inline constexpr double kMaxEpisodeSeconds = 3600;   ///< env.episode_seconds ∈ (0, kMaxEpisodeSeconds]

/// Run control: budget, seed, output.
struct RunConfig {
  std::uint64_t seed = 1;          ///< master seed; env i draws from Rng::stream(seed, i)
  long long iterations = 500;      ///< iteration budget (0 = unlimited, then `minutes` must be > 0)
  double minutes = 0.0;            ///< wall-clock budget in minutes (0 = none); whichever ends first
  long long checkpoint_every = 50; ///< write a checkpoint every K iterations (and always at the end)
  /// Also keep a copy `checkpoint_<it>.bin` of every periodic checkpoint. Off by default: a
  /// checkpoint holds the discriminator's replay buffer (replay_size × 1,640 floats), so copies
  /// add up quickly (a 30-minute run filled tens of GB with the old 100,000-window buffer).
  bool keep_checkpoints = false;
  std::string out_dir = "runs/base";
  int threads = 0;                 ///< simulation threads (0 = hardware concurrency)
};

/// Environment / task.
struct EnvConfig {
  /// The simulated character: "humanoid" (the 22-body reference humanoid) or "g1" (the G1-like
  /// robot; its clips are retargeted from the humanoid's sources). sim/mujoco/character.hpp.
  std::string character = "humanoid";
  int num_envs = 32;
  std::vector<std::string> motions = {"locomotion"};  ///< builtin set name(s), directories or files
  double episode_seconds = 10.0;   ///< episode length limit (truncation, not termination)
  double termination_height = 0.3;  ///< head below this height (m) ⇒ fall (plus ground contacts)
  bool early_termination = true;   ///< terminate on falls
};

/// Stochastic body-part masking and the mask-invariant loss.
struct MaskConfig {
  bool enabled = true;   ///< false ⇒ plain AMP baseline (null mask always, L_MI unused)
  double prob = 0.8;     ///< probability that a step's mask is non-empty
  int max_parts = 3;     ///< at most K parts masked at once
  double lambda_mi = 1.0;  ///< weight of L_MI = KL(π(·|s,m⁰) ‖ π(·|s̄,m)); 0 disables
  /// "both": exact KL gradient through both distributions (default; stable);
  /// "target_stopped": the unmasked policy is a constant target (the paper's formula, literally —
  /// it diverged in our measurements, see rl/mi_loss.hpp and docs/results.md);
  /// "target_frozen": the target is the pre-update policy of the iteration (rl/mi_loss.hpp);
  /// "target_ema": the target is a moving-average copy of the policy (rate `mi_target_tau` per
  /// iteration), and null-mask samples count too, anchoring the unmasked policy to it.
  std::string mi_gradient = "both";
  /// τ of mi_gradient = "target_ema": θ̄ ← (1 − τ)·θ̄ + τ·θ after every iteration's update, so
  /// the target follows the policy with a time constant of about 1/τ iterations. 0.001 is what
  /// measured best over the Bandai walker (docs/results.md): at 0.01 the unmasked policy drifted
  /// with its target and collapsed once 80 % of the episodes were masked; at 0.0001 it learned
  /// more slowly.
  double mi_target_tau = 0.001;
  /// Masking curriculum (a lever of issue 14, not in the paper): before `warmup_samples` the mask
  /// probability is 0 — plain AMP with the mask bits present and all zero, so L_MI is exactly 0 —
  /// then it rises linearly to `prob` over `ramp_samples` (0: at once). The objective stays
  /// L_PPO + λ_MI·L_MI; only how often a masked episode is drawn changes. Masks are drawn when an
  /// episode starts, so running episodes keep theirs. See mask_prob_at.
  long long warmup_samples = 0;
  long long ramp_samples = 0;
  /// What the policy sees in place of a hidden element: `zero` — s̄ = (1 − m) ⊙ s as the paper
  /// writes it, then normalised like every other input (the running statistics then include the
  /// zeros, and a mask flag that was rarely set normalises to up to +5); `mean` — the element's
  /// running mean (0 after normalisation), the mask flags unnormalised, and the statistics from
  /// unmasked inputs only (rl::GaussianActor::hidden_groups). Measured in docs/results.md.
  std::string hidden_value = "zero";
};

/// The mask probability of an episode that starts after `samples` environment steps of training.
inline double mask_prob_at(const MaskConfig& m, long long samples) {
  if (samples < m.warmup_samples) return 0.0;
  if (m.ramp_samples <= 0) return m.prob;
  const double t = static_cast<double>(samples - m.warmup_samples) / static_cast<double>(m.ramp_samples);
  return t >= 1.0 ? m.prob : m.prob * t;
}

/// Network sizes.
struct NetworkConfig {
  std::vector<Index> actor_hidden = {256, 256};
  std::vector<Index> critic_hidden = {256, 256};
  std::vector<Index> disc_hidden = {256, 128};
  std::string activation = "relu";   ///< relu | elu | silu | tanh
  double init_log_std = -2.9;        ///< log σ of the Gaussian policy (σ ≈ 0.055 rad of PD target; AMP/ASE value)
  bool learn_log_std = false;        ///< AMP keeps σ fixed
  /// PD target = offset + scale ⊙ a (tasks/action_space.hpp). offset: `zero` (a = 0 is the
  /// all-zero pose), `mean_pose` (the training motions' mean joint angles) or `mid_range` (the
  /// middle of each joint's limits); scale: `one` (radians) or `half_range` (±1 spans the
  /// joint's limits). Resolved into the two vectors below when a run starts; a resumed run keeps them.
  std::string action_offset = "zero";
  std::string action_scale = "one";
  std::vector<double> action_offset_rad;  ///< (num_dofs) resolved offset; empty with `zero`
  std::vector<double> action_scale_rad;   ///< (num_dofs) resolved scale; empty with `one`
};

/// PPO.
struct PpoConfig {
  int horizon = 32;               ///< steps per env per iteration
  double gamma = 0.99;
  double gae_lambda = 0.95;
  double clip = 0.2;
  double critic_weight = 5.0;
  double entropy_weight = 0.0;
  int epochs = 5;                 ///< passes over each rollout
  int minibatch_size = 512;       ///< samples per gradient step
  double actor_lr = 1e-5;
  double critic_lr = 1e-4;
  double max_grad_norm = 1.0;
  double action_bound_weight = 10.0;  ///< penalty on |μ| beyond ±π (keeps means in a sane range)
  /// `fixed`: actor_lr throughout; `adaptive`: actor_lr is the starting rate, then after every
  /// minibatch it follows PPO's approx-KL against adaptive_lr.desired_kl (rl/adaptive_lr.hpp).
  std::string actor_lr_schedule = "fixed";
  rl::AdaptiveKlSchedule adaptive_lr;  ///< target KL 0.01, factor 1.5, rate in [1e-6, 1e-2] (rsl_rl)
};

/// AMP discriminator.
struct DiscConfig {
  double lr = 1e-4;
  double gradient_penalty = 5.0;  ///< weight of ‖∇ₓD‖² on real samples
  double logit_reg = 0.01;        ///< L2 on the output layer weights
  double weight_decay = 1e-4;
  int replay_size = 16384;        ///< agent windows kept for the replay buffer (16 cpu-preset iterations; 107 MB in a checkpoint)
  int batch_size = 512;           ///< agent (half fresh, half replay) and real samples per step
  int epochs = 1;                 ///< discriminator steps per iteration = epochs·samples/batch
  bool lsgan = false;             ///< least-squares form of the original AMP paper
  double reward_scale = 1.0;      ///< multiplies r = −log(max(1−D, 1e−4))
  /// Frames of the task's AMP window the discriminator sees: the last `window_frames` of the
  /// kAmpWindowFrames (5) kept, 1 ≤ window_frames ≤ 5. The paper's D(s, s′) is 2; every run
  /// before this field existed saw 5, and a config without the field means 5 (not the preset's).
  /// Its input is window_frames × obs_dim (5: 1,640 for the humanoid; 2: 656).
  int window_frames = kAmpWindowFrames;
};

struct BaseTrainConfig {
  std::string preset = "cpu";
  RunConfig run;
  EnvConfig env;
  MaskConfig mask;
  NetworkConfig net;
  PpoConfig ppo;
  DiscConfig disc;

  /// Throws naming the first field with an invalid value.
  void validate(const std::string& file = {}) const {
    auto check = [&](bool ok, const char* field, const std::string& msg) {
      if (!ok) throw Error(msg, {file, std::nullopt, field});
    };
    check(preset == "cpu" || preset == "paper" || preset == "custom", "preset", "expected cpu, paper or custom");
    {
      std::string known;
      for (const auto& n : character_names()) known += (known.empty() ? "" : ", ") + n;
      const auto& names = character_names();
      check(std::find(names.begin(), names.end(), env.character) != names.end(), "env.character",
            "expected one of " + known + ", got '" + env.character + "'");
    }
    // Every real-valued field must be finite (a JSON literal such as 1e999 reads as +inf).
    const std::pair<const char*, double> reals[] = {
        {"run.minutes", run.minutes},
        {"env.episode_seconds", env.episode_seconds},
        {"env.termination_height", env.termination_height},
        {"mask.prob", mask.prob},
        {"mask.lambda_mi", mask.lambda_mi},
        {"mask.mi_target_tau", mask.mi_target_tau},
        {"net.init_log_std", net.init_log_std},
        {"ppo.gamma", ppo.gamma},
        {"ppo.gae_lambda", ppo.gae_lambda},
        {"ppo.clip", ppo.clip},
        {"ppo.critic_weight", ppo.critic_weight},
        {"ppo.entropy_weight", ppo.entropy_weight},
        {"ppo.actor_lr", ppo.actor_lr},
        {"ppo.critic_lr", ppo.critic_lr},
        {"ppo.max_grad_norm", ppo.max_grad_norm},
        {"ppo.action_bound_weight", ppo.action_bound_weight},
        {"disc.lr", disc.lr},
        {"disc.gradient_penalty", disc.gradient_penalty},
        {"disc.logit_reg", disc.logit_reg},
        {"disc.weight_decay", disc.weight_decay},
        {"disc.reward_scale", disc.reward_scale}};
    for (const auto& [field, v] : reals) check(std::isfinite(v), field, "must be a finite number");
    check(run.iterations >= 0, "run.iterations", "must be ≥ 0");
    check(run.minutes >= 0, "run.minutes", "must be ≥ 0");
    check(run.iterations > 0 || run.minutes > 0, "run.iterations", "need an iteration or a minute budget");
    check(run.checkpoint_every >= 1, "run.checkpoint_every", "must be ≥ 1");
    check(!run.out_dir.empty(), "run.out_dir", "must not be empty");
    check(run.threads >= 0 && run.threads <= kMaxThreads, "run.threads", "must be in [0, " + std::to_string(kMaxThreads) + "] (0 = all cores)");
    check(env.num_envs >= 1 && env.num_envs <= kMaxEnvs, "env.num_envs", "must be in [1, " + std::to_string(kMaxEnvs) + "]");
    check(!env.motions.empty(), "env.motions", "must name at least one motion set, directory or file");
    check(env.episode_seconds > 0 && env.episode_seconds <= kMaxEpisodeSeconds, "env.episode_seconds", "must be in (0, 3600]");
    check(mask.prob >= 0 && mask.prob <= 1, "mask.prob", "must be in [0, 1]");
    check(mask.max_parts >= 1 && mask.max_parts <= 5, "mask.max_parts", "must be in [1, 5] (there are 5 body parts)");
    check(mask.lambda_mi >= 0, "mask.lambda_mi", "must be ≥ 0");
    check(mask.warmup_samples >= 0, "mask.warmup_samples", "must be ≥ 0");
    check(mask.hidden_value == "zero" || mask.hidden_value == "mean", "mask.hidden_value", "expected zero or mean");
    check(mask.ramp_samples >= 0, "mask.ramp_samples", "must be ≥ 0");
    check(mask.mi_gradient == "both" || mask.mi_gradient == "target_stopped" || mask.mi_gradient == "target_frozen" ||
              mask.mi_gradient == "target_ema",
          "mask.mi_gradient", "must be \"both\", \"target_stopped\", \"target_frozen\" or \"target_ema\"");
    check(mask.mi_target_tau > 0 && mask.mi_target_tau <= 1, "mask.mi_target_tau", "must be in (0, 1]");
    for (const auto* h : {&net.actor_hidden, &net.critic_hidden, &net.disc_hidden})
      for (Index n : *h) check(n >= 1, h == &net.actor_hidden ? "net.actor_hidden" : h == &net.critic_hidden ? "net.critic_hidden" : "net.disc_hidden", "layer sizes must be ≥ 1");
    check(net.action_offset == "zero" || net.action_offset == "mean_pose" || net.action_offset == "mid_range",
          "net.action_offset", "expected zero, mean_pose or mid_range");
    check(net.action_scale == "one" || net.action_scale == "half_range", "net.action_scale", "expected one or half_range");
    for (double v : net.action_offset_rad) check(std::isfinite(v), "net.action_offset_rad", "must be finite numbers");
    for (double v : net.action_scale_rad) check(std::isfinite(v) && v > 0, "net.action_scale_rad", "must be finite and > 0");
    check(net.action_offset_rad.empty() || net.action_scale_rad.empty() ||
              net.action_offset_rad.size() == net.action_scale_rad.size(),
          "net.action_scale_rad", "must have as many entries as net.action_offset_rad");
    check(net.activation == "relu" || net.activation == "elu" || net.activation == "silu" || net.activation == "tanh",
          "net.activation", "expected relu, elu, silu or tanh");
    check(ppo.horizon >= 1, "ppo.horizon", "must be ≥ 1");
    check(ppo.gamma > 0 && ppo.gamma <= 1, "ppo.gamma", "must be in (0, 1]");
    check(ppo.gae_lambda >= 0 && ppo.gae_lambda <= 1, "ppo.gae_lambda", "must be in [0, 1]");
    check(ppo.clip > 0, "ppo.clip", "must be > 0");
    check(ppo.epochs >= 1, "ppo.epochs", "must be ≥ 1");
    check(ppo.minibatch_size >= 1, "ppo.minibatch_size", "must be ≥ 1");
    check(ppo.actor_lr >= 0, "ppo.actor_lr", "must be ≥ 0");
    check(ppo.critic_lr >= 0, "ppo.critic_lr", "must be ≥ 0");
    check(ppo.max_grad_norm > 0, "ppo.max_grad_norm", "must be > 0");
    check(ppo.actor_lr_schedule == "fixed" || ppo.actor_lr_schedule == "adaptive", "ppo.actor_lr_schedule",
          "expected fixed or adaptive");
    ppo.adaptive_lr.validate("ppo.adaptive_lr", file);  // (also rejects non-finite values)
    check(disc.lr >= 0, "disc.lr", "must be ≥ 0");
    check(disc.gradient_penalty >= 0, "disc.gradient_penalty", "must be ≥ 0");
    check(disc.replay_size >= 1, "disc.replay_size", "must be ≥ 1");
    check(disc.batch_size >= 2, "disc.batch_size", "must be ≥ 2");
    check(disc.epochs >= 1, "disc.epochs", "must be ≥ 1");
    check(disc.window_frames >= 1 && disc.window_frames <= kAmpWindowFrames, "disc.window_frames",
          "must be 1 to " + std::to_string(kAmpWindowFrames) + " (frames of the AMP window the discriminator sees)");
  }
};

/// The `cpu` preset: the walking recipe (file comment; docs/training.md, "Presets").
inline BaseTrainConfig cpu_preset() {
  BaseTrainConfig c;
  c.run.iterations = 7800;
  c.run.checkpoint_every = 300;
  c.mask.lambda_mi = 0.3;
  c.mask.mi_gradient = "target_ema";
  c.mask.mi_target_tau = 0.001;
  c.mask.warmup_samples = 3'000'000;  // masking from 3 M samples (docs/training.md, "When to switch it on")
  c.mask.ramp_samples = 1'000'000;
  c.mask.hidden_value = "mean";
  c.net.action_offset = "mean_pose";
  c.net.action_scale = "half_range";
  c.ppo.actor_lr_schedule = "adaptive";
  return c;
}

/// The paper's sizes and rates (4096 envs; meant for large machines).
inline BaseTrainConfig paper_preset() {
  BaseTrainConfig c;
  c.preset = "paper";
  c.env.num_envs = 4096;
  c.net.actor_hidden = {1024, 1024, 512};
  c.net.critic_hidden = {1024, 1024, 512};
  c.net.disc_hidden = {1024, 1024, 512};
  c.ppo.actor_lr = 1e-5;
  c.ppo.critic_lr = 1e-4;
  c.ppo.minibatch_size = 16384;
  c.disc.lr = 1e-4;
  c.disc.batch_size = 4096;
  c.disc.replay_size = 100000;
  c.run.iterations = 20000;
  c.run.checkpoint_every = 500;
  return c;
}

/// `cpu` or `paper`; throws naming `field` for anything else.
inline BaseTrainConfig preset(const std::string& name, const std::string& field = "preset") {
  if (name == "cpu") return cpu_preset();
  if (name == "paper") return paper_preset();
  throw Error("unknown preset '" + name + "' (expected cpu or paper)", {{}, std::nullopt, field});
}

// ---- JSON ---------------------------------------------------------------------------------

inline nlohmann::json to_json(const BaseTrainConfig& c) {
  using nlohmann::json;
  json j;
  j["preset"] = c.preset;
  j["run"] = {{"seed", c.run.seed},         {"iterations", c.run.iterations},
              {"minutes", c.run.minutes},   {"checkpoint_every", c.run.checkpoint_every},
              {"keep_checkpoints", c.run.keep_checkpoints},
              {"out_dir", c.run.out_dir},   {"threads", c.run.threads}};
  j["env"] = {{"character", c.env.character},
              {"num_envs", c.env.num_envs},
              {"motions", c.env.motions},
              {"episode_seconds", c.env.episode_seconds},
              {"termination_height", c.env.termination_height},
              {"early_termination", c.env.early_termination}};
  j["mask"] = {{"enabled", c.mask.enabled}, {"prob", c.mask.prob}, {"max_parts", c.mask.max_parts},
               {"lambda_mi", c.mask.lambda_mi}, {"mi_gradient", c.mask.mi_gradient}, {"mi_target_tau", c.mask.mi_target_tau},
               {"warmup_samples", c.mask.warmup_samples}, {"ramp_samples", c.mask.ramp_samples},
               {"hidden_value", c.mask.hidden_value}};
  j["net"] = {{"actor_hidden", c.net.actor_hidden}, {"critic_hidden", c.net.critic_hidden},
              {"disc_hidden", c.net.disc_hidden},   {"activation", c.net.activation},
              {"init_log_std", c.net.init_log_std}, {"learn_log_std", c.net.learn_log_std},
              {"action_offset", c.net.action_offset}, {"action_scale", c.net.action_scale},
              {"action_offset_rad", c.net.action_offset_rad}, {"action_scale_rad", c.net.action_scale_rad}};
  j["ppo"] = {{"horizon", c.ppo.horizon},
              {"gamma", c.ppo.gamma},
              {"gae_lambda", c.ppo.gae_lambda},
              {"clip", c.ppo.clip},
              {"critic_weight", c.ppo.critic_weight},
              {"entropy_weight", c.ppo.entropy_weight},
              {"epochs", c.ppo.epochs},
              {"minibatch_size", c.ppo.minibatch_size},
              {"actor_lr", c.ppo.actor_lr},
              {"critic_lr", c.ppo.critic_lr},
              {"max_grad_norm", c.ppo.max_grad_norm},
              {"action_bound_weight", c.ppo.action_bound_weight},
              {"actor_lr_schedule", c.ppo.actor_lr_schedule},
              {"adaptive_lr", {{"desired_kl", c.ppo.adaptive_lr.desired_kl},
                               {"factor", c.ppo.adaptive_lr.factor},
                               {"min_lr", c.ppo.adaptive_lr.min_lr},
                               {"max_lr", c.ppo.adaptive_lr.max_lr}}}};
  j["disc"] = {{"lr", c.disc.lr},
               {"gradient_penalty", c.disc.gradient_penalty},
               {"logit_reg", c.disc.logit_reg},
               {"weight_decay", c.disc.weight_decay},
               {"replay_size", c.disc.replay_size},
               {"batch_size", c.disc.batch_size},
               {"epochs", c.disc.epochs},
               {"lsgan", c.disc.lsgan},
               {"reward_scale", c.disc.reward_scale},
               {"window_frames", c.disc.window_frames}};
  return j;
}

/// Parses a config. Fields absent from `j` keep the values of the preset named by `j["preset"]`
/// (default `cpu`); unknown keys and wrongly typed values throw an Error naming `file` and the
/// dotted field path. The result is validated.
inline BaseTrainConfig config_from_json(const nlohmann::json& j, const std::string& file = {}) {
  JsonObjectReader top(j, "", file);
  std::string preset_name = "cpu";
  top.get("preset", preset_name);
  BaseTrainConfig c;
  if (preset_name == "custom") {  // the cpu values, labelled as the user's own
    c = cpu_preset();
    c.preset = "custom";
  } else {
    try {
      c = preset(preset_name);
    } catch (const Error& e) {
      throw Error(e.message(), {file, std::nullopt, "preset"});
    }
  }
  {
    auto r = top.child("run");
    r.get("seed", c.run.seed);
    r.get("iterations", c.run.iterations);
    r.get("minutes", c.run.minutes);
    r.get("checkpoint_every", c.run.checkpoint_every);
    r.get("keep_checkpoints", c.run.keep_checkpoints);
    r.get("out_dir", c.run.out_dir);
    r.get("threads", c.run.threads);
    r.finish();
  }
  {
    auto r = top.child("env");
    r.get("character", c.env.character);  // (absent in configs written before the G1: the humanoid)
    r.get("num_envs", c.env.num_envs);
    r.get("motions", c.env.motions);
    r.get("episode_seconds", c.env.episode_seconds);
    r.get("termination_height", c.env.termination_height);
    r.get("early_termination", c.env.early_termination);
    r.finish();
  }
  {
    auto r = top.child("mask");
    r.get("enabled", c.mask.enabled);
    r.get("prob", c.mask.prob);
    r.get("max_parts", c.mask.max_parts);
    r.get("lambda_mi", c.mask.lambda_mi);
    r.get("mi_gradient", c.mask.mi_gradient);
    r.get("mi_target_tau", c.mask.mi_target_tau);
    r.get("warmup_samples", c.mask.warmup_samples);
    r.get("ramp_samples", c.mask.ramp_samples);
    r.get("hidden_value", c.mask.hidden_value);
    r.finish();
  }
  {
    auto r = top.child("net");
    r.get("actor_hidden", c.net.actor_hidden);
    r.get("critic_hidden", c.net.critic_hidden);
    r.get("disc_hidden", c.net.disc_hidden);
    r.get("activation", c.net.activation);
    r.get("init_log_std", c.net.init_log_std);
    r.get("learn_log_std", c.net.learn_log_std);
    r.get("action_offset", c.net.action_offset);
    r.get("action_scale", c.net.action_scale);
    r.get("action_offset_rad", c.net.action_offset_rad);
    r.get("action_scale_rad", c.net.action_scale_rad);
    r.finish();
  }
  {
    auto r = top.child("ppo");
    r.get("horizon", c.ppo.horizon);
    r.get("gamma", c.ppo.gamma);
    r.get("gae_lambda", c.ppo.gae_lambda);
    r.get("clip", c.ppo.clip);
    r.get("critic_weight", c.ppo.critic_weight);
    r.get("entropy_weight", c.ppo.entropy_weight);
    r.get("epochs", c.ppo.epochs);
    r.get("minibatch_size", c.ppo.minibatch_size);
    r.get("actor_lr", c.ppo.actor_lr);
    r.get("critic_lr", c.ppo.critic_lr);
    r.get("max_grad_norm", c.ppo.max_grad_norm);
    r.get("action_bound_weight", c.ppo.action_bound_weight);
    r.get("actor_lr_schedule", c.ppo.actor_lr_schedule);
    {
      auto a = r.child("adaptive_lr");
      a.get("desired_kl", c.ppo.adaptive_lr.desired_kl);
      a.get("factor", c.ppo.adaptive_lr.factor);
      a.get("min_lr", c.ppo.adaptive_lr.min_lr);
      a.get("max_lr", c.ppo.adaptive_lr.max_lr);
      a.finish();
    }
    r.finish();
  }
  {
    auto r = top.child("disc");
    r.get("lr", c.disc.lr);
    r.get("gradient_penalty", c.disc.gradient_penalty);
    r.get("logit_reg", c.disc.logit_reg);
    r.get("weight_decay", c.disc.weight_decay);
    r.get("replay_size", c.disc.replay_size);
    r.get("batch_size", c.disc.batch_size);
    r.get("epochs", c.disc.epochs);
    r.get("lsgan", c.disc.lsgan);
    r.get("reward_scale", c.disc.reward_scale);
    // absent: 5, the window of every config and checkpoint written before the field existed
    c.disc.window_frames = kAmpWindowFrames;
    r.get("window_frames", c.disc.window_frames);
    r.finish();
  }
  top.finish();
  c.validate(file);
  return c;
}

/// Parses JSON text (syntax errors name `file` and the line).
inline BaseTrainConfig config_from_string(const std::string& text, const std::string& file = {}) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte is the 1-based offset of the error; turn it into a line number.
    long long line = 1;
    for (std::size_t i = 0; i < text.size() && i + 1 < e.byte; ++i) line += text[i] == '\n';
    throw Error(std::string("invalid JSON: ") + e.what(), {file, line, {}});
  } catch (const nlohmann::json::out_of_range& e) {  // e.g. a number that overflows a double: 1e999
    throw Error(std::string("invalid JSON: ") + e.what(), {file, std::nullopt, {}});
  }
  return config_from_json(j, file);
}

inline BaseTrainConfig load_config(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot open config file", {path, std::nullopt, {}});
  std::stringstream ss;
  ss << in.rdbuf();
  return config_from_string(ss.str(), path);
}

inline void save_config(const BaseTrainConfig& c, const std::string& path) {
  std::ofstream out(path);
  if (!out) throw Error("cannot write config file", {path, std::nullopt, {}});
  out << to_json(c).dump(2) << "\n";
  if (!out) throw Error("failed writing config file", {path, std::nullopt, {}});
}

}  // namespace maskadapt::train
