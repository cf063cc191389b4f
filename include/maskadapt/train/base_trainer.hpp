#pragma once
/// \file base_trainer.hpp
/// The stage-1 trainer: mask-invariant AMP base policy over any `Simulator`.
///
/// One iteration:
///  1. collection — `horizon` control steps of all N envs (ImitationTask): the actor samples PD
///     targets from π(·|s̄, m) on the no-allocation inference path, the critic evaluates the full
///     state, the running input normalisers see every step;
///  2. rewards — the discriminator scores each transition's 5-frame window of unmasked features:
///     r = scale·(−log(max(1 − D, 1e−4))) (or the LSGAN reward);
///  3. GAE (γ, λ) with terminations (no bootstrap) and truncations (bootstrap with V(final s));
///  4. PPO epochs over minibatches: clipped surrogate + critic_weight·value loss + λ_MI·L_MI,
///     L_MI = KL(π(·|s, m⁰) ‖ π(·|s̄, m)); mask.mi_gradient says what the target is (the current
///     policy, with or without its gradient; the pre-update policy; or a moving-average copy,
///     updated after the epochs — rl/mi_loss.hpp);
///  5. discriminator steps: motion-library windows (real) vs fresh + replayed agent windows.
/// Every optimiser step is checked (nn::Adam): a non-finite gradient skips the step, keeps the
/// last good parameters, and is counted in `skipped_updates`.
///
/// All randomness comes from the trainer's Rng (actions, minibatches, discriminator batches)
/// and the task's per-env streams, all checkpointed: `save`/`load` continue bit-exactly when the
/// simulator can save its state (tasks::StateSavingSimulator).
///
/// Distributed (docs/distributed.md): given a Collective of K ranks, each rank steps its own
/// block of the envs (rank r: global envs [r·n, (r+1)·n), n = sim.num_envs(), env.num_envs = K·n)
/// with the random streams those envs have in one process, and draws the action noise of all
/// K·n envs from the (replicated) trainer stream, keeping its own columns. PPO minibatches are
/// drawn over all K·n·horizon samples; each rank computes the gradient of the samples it holds,
/// scaled to its share of the minibatch, and the actor's and critic's gradients are summed over
/// ranks (Collective::all_reduce_sum, rank order) before every Adam step, so every rank takes the
/// same step. Advantages are normalised with the mean and deviation of all ranks; input
/// normalisers merge every rank's batch statistics (Chan); the discriminator's agent windows are
/// gathered from all ranks, so its batches and replay buffer are the same on every rank, and each
/// rank back-propagates its slice of each batch before the ranks' discriminator gradients are
/// summed (rl::Discriminator::update_on_ranks); episode statistics are summed. Rank 0's
/// checkpoint holds every rank's envs in the layout of one process with K·n envs, plus
/// `dist/ranks` = K; `load` refuses a checkpoint of another K.
/// With the default SingleProcess nothing of this runs and the trainer is what it always was.
#include <maskadapt/rl/mi_loss.hpp>
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/collective.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/nn/adam.hpp>
#include <maskadapt/nn/gaussian.hpp>
#include <maskadapt/nn/mlp.hpp>
#include <maskadapt/nn/normalizer.hpp>
#include <maskadapt/rl/actor_critic.hpp>
#include <maskadapt/rl/adaptive_lr.hpp>
#include <maskadapt/rl/amp_loss.hpp>
#include <maskadapt/rl/discriminator.hpp>
#include <maskadapt/rl/gae.hpp>
#include <maskadapt/rl/ppo_loss.hpp>
#include <maskadapt/rl/replay_buffer.hpp>
#include <maskadapt/rl/rollout_buffer.hpp>
#include <maskadapt/tasks/imitation.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/collect.hpp>
#include <maskadapt/train/distributed.hpp>
#include <maskadapt/train/task_state.hpp>
#include <maskadapt/train/config.hpp>
#include <maskadapt/train/progress.hpp>
#include <maskadapt/train/run_provenance.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

namespace maskadapt::train {

using RowVectorXf = RowVectorX<float>;

/// Fills `out` (F·obs_dim × B, already sized) with B real discriminator windows drawn with `rng`
/// (motion-library windows of F frames of unmasked features, oldest first, the layout of the
/// last F frames of the task's window; F = disc.window_frames = out.rows() / obs_dim).
using RealWindowSampler = std::function<void(Rng& rng, Eigen::Ref<MatrixXf> out)>;

/// The task configuration implied by a trainer config.
inline tasks::ImitationTaskConfig task_config(const BaseTrainConfig& c, std::optional<FallCriteria> fall = std::nullopt) {
  tasks::ImitationTaskConfig t;
  t.fall = std::move(fall);
  t.episode_seconds = c.env.episode_seconds;
  t.early_termination = c.env.early_termination;
  t.min_head_height = c.env.termination_height;
  t.masking = c.mask.enabled;
  t.mask_prob = mask_prob_at(c.mask, 0);  // (the trainer moves it along mask.warmup/ramp_samples)
  t.max_masked_parts = c.mask.max_parts;
  t.actions = action_space_of(c, -1);
  return t;
}

/// Drops the discriminator's replay buffer from a base-trainer checkpoint — 107 of its 123 MB at
/// the cpu preset — so that a run can be carried between machines or committed and continued
/// (`maskadapt checkpoint compact`). Everything else stays as saved: networks, optimiser moments,
/// learning rate, normalisers, random streams, simulator and episode states. BaseTrainer::load
/// then starts with an empty replay buffer, so the next discriminator batches take their fake
/// half from fresh windows only, as in a run's first iteration, until it has filled again
/// (disc.replay_size windows): the continuation is deterministic given the compact file but not
/// bit-identical to the uninterrupted run. Records the drop in `provenance/history`. Returns
/// whether there was a replay buffer to drop.
inline bool drop_replay_buffer(Checkpoint& c) {
  if (!c.contains("replay/storage")) return false;
  const std::int64_t windows = c.get_int("replay/size");
  for (const char* name : {"replay/storage", "replay/size", "replay/head"}) c.erase(name);
  const std::string history = c.contains("provenance/history") ? c.get_string("provenance/history") : std::string();
  c.put_string("provenance/history", history + "(compacted: replay buffer of " + std::to_string(windows) +
                                         " windows dropped; the continuation refills it)\n");
  return true;
}

template <Simulator Sim>
class BaseTrainer {
 public:
  /// `fall`: fall criteria for a skeleton other than the reference humanoid (default: the
  /// humanoid's feet/toes/hands contacts + head height `env.termination_height`).
  /// `comm`: the ranks of a distributed run (nullptr: this process alone). Collective: every
  /// rank constructs its trainer with the same config and a simulator of env.num_envs / K envs.
  BaseTrainer(Sim& sim, tasks::ResetSampler reset, RealWindowSampler real, BaseTrainConfig config,
              ThreadPool* pool = nullptr, std::optional<FallCriteria> fall = std::nullopt, Collective* comm = nullptr)
      : cfg_((config.validate(), std::move(config))),
        task_(sim, std::move(reset), task_config(cfg_, std::move(fall)), cfg_.run.seed, pool),
        mi_gradient_(rl::mi_gradient_from_string(cfg_.mask.mi_gradient, "mask.mi_gradient")),
        real_(std::move(real)),
        rng_(Rng::stream(cfg_.run.seed, 0xB45E0000ULL)) {
    require(static_cast<bool>(real_), "no real window sampler given", {{}, {}, "real_sampler"});
    Rng init = Rng::stream(cfg_.run.seed, 0x1A17ULL);
    policy_ = make_base_policy(cfg_, dims(), init);
    policy_.actions = action_space_of(cfg_, task_.action_dim());
    apply_hidden_value();
    actor_opt_ = nn::Adam<float>({cfg_.ppo.actor_lr, 0.9, 0.999, 1e-8, 0.0, false, cfg_.ppo.max_grad_norm});
    critic_opt_ = nn::Adam<float>({cfg_.ppo.critic_lr, 0.9, 0.999, 1e-8, 0.0, false, cfg_.ppo.max_grad_norm});
    rl::RolloutSpec spec;
    spec.horizon = cfg_.ppo.horizon;
    spec.num_envs = task_.num_envs();
    spec.obs_dim = task_.obs_dim();
    spec.policy_input_dim = task_.policy_input_dim();
    spec.action_dim = task_.action_dim();
    spec.amp_dim = task_.amp_dim();
    buf_.resize(spec);
    replay_ = rl::ReplayBuffer<float>(disc_dim(), cfg_.disc.replay_size);
    comm_ = comm ? comm : &single_process();
    if (distributed()) join_ranks();
  }

  const BaseTrainConfig& config() const { return cfg_; }
  tasks::ImitationTask<Sim>& task() { return task_; }
  const BasePolicy& policy() const { return policy_; }
  /// The last iteration's rollout (this rank's envs; tests and benchmarks read it).
  const rl::RolloutBuffer<float>& rollout() const { return buf_; }
  long long iteration() const { return iteration_; }
  long long samples() const { return samples_; }
  /// The ranks this trainer runs with (SingleProcess unless a Collective was given).
  Collective& collective() const { return *comm_; }
  bool distributed() const { return comm_->size() > 1; }
  /// Index of this rank's first env among all ranks' envs (0 in one process).
  Index env_offset() const { return env_offset_; }
  /// Network dimensions of this trainer's task (amp_dim: the discriminator's input, disc_dim()).
  PolicyDims dims() const {
    return {task_.obs_dim(), task_.policy_input_dim(), task_.action_dim(), disc_dim()};
  }
  /// The discriminator's input: the last disc.window_frames frames of the task's AMP window
  /// (window_frames × obs_dim rows; 5 frames: the whole window).
  Index disc_dim() const { return disc_input_dim(cfg_, task_.obs_dim()); }

  /// Runs one iteration (collection, rewards, GAE, PPO + MI, discriminator) and returns its stats.
  IterationStats iterate() {
    IterationStats st;
    // Network passes (inference batches, PPO, MI, discriminators) run their chunks on the env
    // pool; results do not depend on it (nn/chunks.hpp).
    nn::ScopedPool parallel_networks(task_.pool());
    Stopwatch total;
    task_.stats().clear();
    if (cfg_.mask.enabled) task_.set_mask_prob(mask_prob_at(cfg_.mask, samples_));
    st.extra["mask_prob"] = cfg_.mask.enabled ? task_.config().mask_prob : 0.0;
    collect(st);
    update_from_rollout(st);
    ++iteration_;
    const long long batch = buf_.size() * comm_->size();  // (every rank holds as many samples)
    samples_ += batch;
    if (distributed()) sum_episode_stats_over_ranks(*comm_, task_.stats());
    finish_iteration_stats(st, iteration_, samples_, batch, total.seconds(), task_.stats());
    provenance_.train_seconds += st.time_total;
    return st;
  }

  /// Steps 2–5 of an iteration on the rollout collected last (rewards, GAE, PPO + MI,
  /// discriminator, input statistics), adding their times to `st`. iterate() calls it after
  /// the collection; benchmarks call it alone, to time the update by itself
  /// (benchmarks/rl/bench_update.cpp). Does not advance the iteration counters.
  void update_from_rollout(IterationStats& st) {
    nn::ScopedPool parallel_networks(task_.pool());
    Stopwatch upd;
    Stopwatch disc_rewards;
    compute_rewards(st);
    st.time_disc += disc_rewards.seconds();
    st.time_disc_reward = disc_rewards.seconds();
    Stopwatch ppo;
    rl::compute_gae(buf_, rl::GaeParams{cfg_.ppo.gamma, cfg_.ppo.gae_lambda});
    update_policy(st);
    st.time_ppo = ppo.seconds();  // (GAE, PPO and the MI term)
    Stopwatch disc_update;
    update_discriminator(st);
    st.time_disc += disc_update.seconds();
    // Input statistics change only between iterations, so the behaviour policy that produced
    // buf_.log_probs is exactly the policy at the start of the PPO update.
    auto update_normalizers = [&](const MatrixXf& policy_input) {
      if (!distributed()) {
        policy_.ac.update_normalizers(policy_input, buf_.obs);
        return;
      }
      if (policy_.ac.actor.normalize_inputs) merge_normalizer_over_ranks(*comm_, policy_input, policy_.ac.actor.normalizer);
      if (policy_.ac.critic.normalize_inputs) merge_normalizer_over_ranks(*comm_, buf_.obs, policy_.ac.critic.normalizer);
    };
    if (policy_.ac.actor.hidden_groups.empty()) {
      update_normalizers(buf_.policy_input);
    } else {  // mask.hidden_value = mean: the actor's statistics from the unmasked inputs [s ; 0]
      rl::unmasked_policy_input<float>(buf_.obs, task_.policy_input_dim(), unmasked_inputs_);
      update_normalizers(unmasked_inputs_);
    }
    st.time_update += upd.seconds();
  }

  // ---- checkpoints ------------------------------------------------------------------------

  /// Everything needed to continue bit-exactly (and the config, for play/eval).
  void save(Checkpoint& c) const {
    c.put_string("config", to_json(cfg_).dump());
    save_policy(policy_, c);
    c.put("actor/adam", policy_.ac.actor.mean_net.block().storage());
    c.put("actor/log_std_adam", policy_.ac.actor.log_std.storage());
    c.put("critic/adam", policy_.ac.critic.net.block().storage());
    c.put("disc/adam", policy_.disc.net().block().storage());
    c.put_int("actor/adam_steps", actor_opt_.step_count());
    c.put_double("actor/lr", actor_opt_.config().lr);  // moves under ppo.actor_lr_schedule = adaptive
    c.put_int("critic/adam_steps", critic_opt_.step_count());
    // rl::Discriminator exposes its optimiser only mutably; reading the step count changes nothing
    c.put_int("disc/adam_steps", const_cast<rl::Discriminator<float>&>(policy_.disc).optimizer().step_count());
    c.put("replay/storage", replay_.storage());
    c.put_int("replay/size", replay_.size());
    c.put_int("replay/head", replay_.head());
    if (mi_target_net_.num_params() > 0) c.put("mi_target/params", mi_target_net_.params());
    c.put_rng("trainer/rng", rng_);
    c.put_int("trainer/iteration", iteration_);
    c.put_int("trainer/samples", samples_);
    if (distributed()) {  // every rank's envs, in the layout of one process with all of them
      c.put_int("dist/ranks", comm_->size());
      save_task_states_of_all_ranks(c);
    } else {
      save_task_state(c, "task/", task_);
    }
    // provenance/ sections record how the run came about; they never affect training (and
    // differ between a straight and a resumed run: wall time)
    provenance_.save(c);
  }

  /// Distributed: collective; rank 0 writes the file (every rank's envs), the others write nothing.
  void save(const std::string& path) const {
    Checkpoint c;
    save(c);
    if (comm_->is_root()) save_checkpoint(path, c);
  }

  /// Restores a checkpoint written by `save` for the same network sizes and env count. Throws
  /// naming the section on any mismatch. Distributed: every rank loads the same checkpoint
  /// (the one rank 0 wrote) and takes its own envs from it; a checkpoint written by another
  /// number of ranks is refused (`dist/ranks`).
  void load(const Checkpoint& c) {
    require_same_rank_count(c, *comm_);
    load_policy(c, policy_);
    apply_hidden_value();  // the run's config decides (a checkpoint from before the field has no groups)
    c.copy_to<float>("actor/adam", policy_.ac.actor.mean_net.block().storage());
    c.copy_to<float>("actor/log_std_adam", policy_.ac.actor.log_std.storage());
    c.copy_to<float>("critic/adam", policy_.ac.critic.net.block().storage());
    c.copy_to<float>("disc/adam", policy_.disc.net().block().storage());
    actor_opt_.set_step_count(c.get_int("actor/adam_steps"));
    if (c.contains("actor/lr")) {  // (checkpoints before the adaptive schedule: the config's rate)
      const double lr = c.get_double("actor/lr");
      require(std::isfinite(lr) && lr >= 0, "actor learning rate must be finite and >= 0", {c.source(), std::nullopt, "actor/lr"});
      actor_opt_.config().lr = lr;
    }
    critic_opt_.set_step_count(c.get_int("critic/adam_steps"));
    policy_.disc.optimizer().set_step_count(c.get_int("disc/adam_steps"));
    if (c.contains("replay/storage"))
      replay_.restore(c.get_matrix<float>("replay/storage", disc_dim(), cfg_.disc.replay_size),
                      c.get_int("replay/size"), c.get_int("replay/head"));
    else  // a compacted checkpoint (drop_replay_buffer): the buffer refills from the next iterations
      replay_ = rl::ReplayBuffer<float>(disc_dim(), cfg_.disc.replay_size);
    if (c.contains("mi_target/params")) {  // (absent before masking started: the target starts at the policy then)
      mi_target_net_ = policy_.ac.actor.mean_net;
      c.copy_to<float>("mi_target/params", mi_target_net_.params());
    } else {
      mi_target_net_ = nn::Mlp<float>();
    }
    rng_.set_state(c.get_rng("trainer/rng"));
    iteration_ = c.get_int("trainer/iteration");
    samples_ = c.get_int("trainer/samples");
    if (distributed()) load_task_state(slice_task_state(c, "task/", env_offset_, task_.num_envs()), "task/", task_);
    else load_task_state(c, "task/", task_);
    provenance_.load(c);
  }

  /// Forks a resumed run onto another seed: the trainer's stream (action noise, minibatches,
  /// discriminator samples) and every env's stream restart from `seed`, while parameters,
  /// optimiser moments, replay buffer, env states and counters continue. A run forked at
  /// iteration k with seed s is itself bit-exactly resumable (its checkpoints hold the new
  /// streams and `run.seed` = s).
  void reseed(std::uint64_t seed) {
    cfg_.run.seed = seed;
    rng_ = Rng::stream(seed, 0xB45E0000ULL);
    if (distributed()) restart_env_streams(task_, seed, env_offset_, /*keep_states=*/true);
    else task_.reseed(seed);
  }

  /// Appends one line to the run's history (what started or resumed it: date, git commit,
  /// command line); saved in `provenance/history` and carried into exported models.
  void add_provenance(const std::string& line) { provenance_.add(line); }
  const std::string& provenance() const { return provenance_.history; }
  /// Wall seconds spent in iterate() over the whole run, resumed chunks included (NaN when the
  /// run started from a checkpoint that did not record it).
  double train_seconds() const { return provenance_.train_seconds; }

 private:
  /// mask.hidden_value = mean: the actor puts hidden elements at their running mean
  /// (rl::GaussianActor::hidden_groups, one body part per observation row).
  void apply_hidden_value() {
    if (cfg_.mask.hidden_value != "mean") {
      policy_.ac.actor.hidden_groups.clear();
      return;
    }
    std::vector<std::uint8_t> groups;
    for (BodyPart p : task_.obs_parts()) groups.push_back(static_cast<std::uint8_t>(p));
    policy_.ac.actor.set_hidden_groups(std::move(groups));
  }

  // ---- 1. collection ----------------------------------------------------------------------
  void collect(IterationStats& st) {
    mu_.resize(task_.action_dim(), task_.num_envs());
    values_.resize(1, task_.num_envs());
    Collector agent{*this};
    collect_rollout(task_, buf_, agent, st);
  }
  /// The base policy as the collection loop's agent (train/collect.hpp): actions on [s̄ ; m]
  /// (PD targets through the task's action space), episodes end as the task says.
  struct Collector {
    BaseTrainer& t;
    const MatrixXf& act(Index step, Index /*c0*/) {
      auto& ac = t.policy_.ac;
      if (t.distributed()) t.act_on_my_columns();
      else ac.actor.act(t.task_.policy_inputs(), t.rng_, t.actions_, t.logp_, t.mu_, t.actor_ws_, t.scratch_);
      ac.critic.value(t.task_.observations(), t.values_, t.critic_ws_, t.scratch_);
      t.buf_.record_policy_step(step, t.task_.observations(), t.task_.policy_inputs(), t.task_.masks(), t.actions_, t.logp_,
                                t.values_);
      return t.actions_;
    }
    void end_step(Index, Index, StepEnd&) {}
    const MatrixXf& final_values(const MatrixXf& final_obs) {
      t.policy_.ac.critic.value(final_obs, t.values_, t.critic_ws_, t.scratch_);
      return t.values_;
    }
    const MatrixXf& bootstrap_values() { return final_values(t.task_.observations()); }
  };

  /// The rows of (task AMP windows × n) the discriminator sees: the last disc.window_frames frames.
  auto disc_rows(const MatrixXf& windows) const { return windows.bottomRows(disc_dim()); }

  // ---- 2. discriminator rewards -----------------------------------------------------------
  void compute_rewards(IterationStats& st) {
    const MatrixXf no_cond;  // (empty: allocates nothing)
    auto r = buf_.rewards.row(0);  // (1 × N·H), includes reward_scale
    policy_.disc.reward(disc_rows(buf_.amp_windows), no_cond, r, reward_ws_);
    if (distributed())
      st.disc_reward = all_reduce_sum(*comm_, r.template cast<double>().sum()) / static_cast<double>(r.size() * comm_->size());
    else
      st.disc_reward = r.template cast<double>().mean();
  }

  // ---- 4. PPO + MI --------------------------------------------------------------------------
  void update_policy(IterationStats& st) {
    auto& actor = policy_.ac.actor;
    auto& critic = policy_.ac.critic;
    // minibatch scratch: members, so that an update allocates no matrix once sized
    auto& [adv, pin, act, obs, full, norm_in, norm_obs, dmu, dls, dv, target, vold, mu_target, lp_old, a_mb, lp_new,
           dlogp] = mb_;
    adv = buf_.advantages;
    const bool dist = distributed();
    if (dist) normalize_rows_over_ranks(*comm_, adv);
    else rl::normalize_rows(adv);
    // n: samples of all ranks (minibatches are drawn over all of them); columns of buf_ are this rank's
    const Index n = buf_.size() * comm_->size();
    const Index nmb = std::max<Index>(1, std::min<Index>(n, n / std::max<Index>(1, cfg_.ppo.minibatch_size)));
    PpoMinibatchMeans means;
    // No target while no episode is masked (the warm-up): the warm-up stays bit-identical to plain
    // AMP in every gradient mode, and the EMA target starts from the policy where masking starts.
    const bool fixed_target =
        cfg_.mask.enabled && task_.config().mask_prob > 0 && rl::has_fixed_target(mi_gradient_);
    const bool ema_target = fixed_target && mi_gradient_ == rl::MiGradient::TargetEma;
    if (fixed_target) {  // μ(s, m⁰) of the target policy for every sample, computed before the update
      rl::unmasked_policy_input<float>(buf_.obs, task_.policy_input_dim(), unmasked_inputs_);
      frozen_mu_.resize(actor.action_dim(), buf_.size());
      if (ema_target) {
        if (mi_target_net_.num_params() == 0) mi_target_net_ = actor.mean_net;  // starts at the policy
        actor.normalize(unmasked_inputs_, scratch_);
        mi_target_net_.forward(scratch_, frozen_mu_, actor_ws_);
      } else {
        actor.mean(unmasked_inputs_, frozen_mu_, actor_ws_, scratch_);
      }
      // mi_kl then measures the distance to the target; the log also gets the pre-update policy's
      // own masked/unmasked KL over the rollout (what mi_kl is in the other modes)
      diag_full_mu_.resize(actor.action_dim(), ema_target ? buf_.size() : 0);
      if (ema_target) actor.mean(unmasked_inputs_, diag_full_mu_, actor_ws_, scratch_);
      diag_masked_mu_.resize(actor.action_dim(), buf_.size());
      actor.mean(buf_.policy_input, diag_masked_mu_, actor_ws_, scratch_);
      st.extra["kl_masked_unmasked"] = static_cast<double>(
          nn::kl_diag_gaussian_mean<float>(ema_target ? diag_full_mu_ : frozen_mu_, actor.log_std_col(), diag_masked_mu_,
                                           actor.log_std_col(), {}));
      if (ema_target)  // how far the unmasked policy is from its target: the drift the anchor holds back
        st.extra["kl_target_unmasked"] = static_cast<double>(
            nn::kl_diag_gaussian_mean<float>(frozen_mu_, actor.log_std_col(), diag_full_mu_, actor.log_std_col(), {}));
      if (dist)  // (means over equal shares: the mean of the ranks' means)
        for (const char* key : {"kl_masked_unmasked", "kl_target_unmasked"})
          if (st.extra.count(key)) st.extra[key] = all_reduce_sum(*comm_, st.extra[key]) / comm_->size();
    }
    for (int epoch = 0; epoch < cfg_.ppo.epochs; ++epoch) {
      for (const auto& all_idx : rl::minibatch_indices(n, nmb, rng_)) {
        // this rank's samples of the minibatch (all of them in one process) and their share of it:
        // the losses below are means over the B samples here, so their gradients are scaled by
        // B / B_all, and the ranks' gradients then add up to the minibatch mean
        if (dist) my_columns(all_idx, task_.num_envs(), comm_->size(), env_offset_, my_idx_);
        const auto& idx = dist ? my_idx_ : all_idx;
        const Index B_all = static_cast<Index>(all_idx.size());
        const double share = static_cast<double>(idx.size()) / static_cast<double>(B_all);
        MinibatchResult mr = idx.empty() ? empty_minibatch() : minibatch_gradients(idx, B_all, share, fixed_target, ema_target);
        if (dist) mr = sum_minibatch_over_ranks(mr, share);
        const auto ar = actor_opt_.step(actor.trainable_blocks());
        if (!ar.applied) ++st.skipped_updates;
        if (cfg_.ppo.actor_lr_schedule == "adaptive")  // next minibatch's step sized by this one's KL
          actor_opt_.config().lr = rl::adapt_learning_rate(actor_opt_.config().lr, mr.approx_kl, cfg_.ppo.adaptive_lr);
        const auto cr = critic_opt_.step(critic.net.block());
        if (!cr.applied) ++st.skipped_updates;
        means.add(mr.policy_loss, mr.value_loss, mr.approx_kl, mr.clip_frac, mr.mi_kl, ar.grad_norm);
      }
    }
    means.write(st);
    st.entropy = nn::gaussian_entropy_of_column<float>(actor.log_std_col());
    st.actor_lr = actor_opt_.config().lr;
    if (ema_target) rl::update_ema_target(mi_target_net_, actor.mean_net, cfg_.mask.mi_target_tau);
  }

  /// Per-minibatch means (over this rank's samples until sum_minibatch_over_ranks, then over all ranks').
  struct MinibatchResult {
    double policy_loss = 0, value_loss = 0, approx_kl = 0, clip_frac = 0, mi_kl = 0;
  };
  MinibatchResult empty_minibatch() {
    policy_.ac.actor.zero_grad();
    policy_.ac.critic.net.zero_grad();
    return {};
  }

  /// The actor's and critic's gradients of one minibatch (this rank's columns `idx` of a
  /// minibatch of B_all samples, `share` = |idx| / B_all) into their grads(); returns the losses.
  /// In one process (share 1) the arithmetic is that of the trainer before distribution.
  MinibatchResult minibatch_gradients(const std::vector<Index>& idx, Index B_all, double share, bool fixed_target,
                                      bool ema_target) {
    auto& actor = policy_.ac.actor;
    auto& critic = policy_.ac.critic;
    auto& [adv, pin, act, obs, full, norm_in, norm_obs, dmu, dls, dv, target, vold, mu_target, lp_old, a_mb, lp_new,
           dlogp] = mb_;
    const bool scaled = share != 1.0;
    rl::gather_columns(buf_.policy_input, idx, pin);
    rl::gather_columns(buf_.actions, idx, act);
    rl::gather_columns(buf_.obs, idx, obs);
    rl::gather_columns(buf_.returns, idx, target);
    rl::gather_columns(buf_.values, idx, vold);
    const Index B = static_cast<Index>(idx.size());
    lp_old.resize(B);
    a_mb.resize(B);
    for (Index j = 0; j < B; ++j) {
      lp_old[j] = buf_.log_probs[idx[static_cast<std::size_t>(j)]];
      a_mb[j] = adv(0, idx[static_cast<std::size_t>(j)]);
    }
    // actor: clipped surrogate (+ action-bound penalty) + λ_MI·L_MI
    actor.zero_grad();
    actor.normalize(pin, norm_in);
    const MatrixXf& mu = actor.mean_net.forward_train(norm_in, actor_cache_);
    lp_new.resize(B);
    nn::gaussian_log_prob<float>(mu, actor.log_std_col(), act, lp_new);
    const auto sur = rl::clipped_surrogate<float>(lp_new, lp_old, a_mb, cfg_.ppo.clip, dlogp);
    if (scaled) dlogp *= static_cast<float>(share);
    dmu.setZero(mu.rows(), B);
    nn::gaussian_log_prob_backward<float>(mu, actor.log_std_col(), act, dlogp, &dmu,
                                          actor.learn_log_std ? &dls : nullptr);
    // action-bound penalty on the PD targets beyond ±π rad (target = offset + scale ⊙ μ)
    const float wb = static_cast<float>(cfg_.ppo.action_bound_weight);
    policy_.actions.add_bound_penalty_grad(mu, static_cast<float>(M_PI), wb / static_cast<float>(B_all), bound_targets_, dmu);
    // λ_MI·L_MI reuses the surrogate's masked pass: its ∂/∂μ joins dmu before the one backward
    double mi_kl = 0;
    const double lambda_mi = scaled ? cfg_.mask.lambda_mi * share : cfg_.mask.lambda_mi;
    if (fixed_target) {
      rl::gather_columns(frozen_mu_, idx, mu_target);
      mi_kl = rl::mi_loss_on_fixed_target<float>(actor, mu_target, pin, mu, lambda_mi, mi_ws_, dmu,
                                                 ema_target ? rl::MiColumns::All : rl::MiColumns::Masked)
                  .kl;
    } else if (cfg_.mask.enabled && !rl::has_fixed_target(mi_gradient_)) {
      rl::unmasked_policy_input<float>(obs, task_.policy_input_dim(), full);
      mi_kl = rl::mi_loss_on_masked_pass<float>(actor, full, pin, mu, lambda_mi, mi_ws_, mi_gradient_, dmu)
                  .kl;
    }
    actor.mean_net.backward(actor_cache_, dmu, actor.mean_net.grads());
    if (actor.learn_log_std && dls.size()) actor.log_std.grads() += dls.col(0);
    // critic (its gradient does not depend on the actor's step, which the caller takes after
    // both gradients are complete — and summed over ranks)
    critic.net.zero_grad();
    critic.normalize(obs, norm_obs);
    const MatrixXf& v = critic.net.forward_train(norm_obs, critic_cache_);
    const double vl = rl::value_loss<float>(v, vold, target, 0.0, dv);
    dv *= static_cast<float>(scaled ? cfg_.ppo.critic_weight * share : cfg_.ppo.critic_weight);
    critic.net.backward(critic_cache_, dv, critic.net.grads());
    return {sur.loss, vl, sur.approx_kl, sur.clip_frac, mi_kl};
  }

  // ---- 5. discriminator -------------------------------------------------------------------
  // BCE (or LSGAN) on real motion-library windows vs agent windows (half fresh, half replayed),
  // + gradient penalty on the real samples, logit regularisation and weight decay
  // (rl::Discriminator::update; a non-finite loss or gradient skips the step).
  void update_discriminator(IterationStats& st) {
    auto& disc = policy_.disc;
    // the agent windows of all ranks (distributed: gathered, so that every rank draws the same
    // batches, keeps the same replay buffer and takes the same steps)
    if (distributed()) gather_step_major(*comm_, buf_.amp_windows, task_.num_envs(), global_amp_, "discriminator windows");
    const auto amp = disc_rows(distributed() ? global_amp_ : buf_.amp_windows);  // (D × n)
    const Index n = amp.cols(), B = cfg_.disc.batch_size, half = B / 2, D = disc_dim();
    const Index steps = std::max<Index>(1, cfg_.disc.epochs * n / B);
    MatrixXf &real = disc_real_, &fake = disc_fake_, &rep = disc_replayed_;
    real.resize(D, B);
    fake.resize(D, B);
    const MatrixXf no_cond;  // (empty: allocates nothing)
    double sum_real = 0, sum_fake = 0, sum_loss = 0, sum_gp = 0, real_seconds = 0;
    for (Index s = 0; s < steps; ++s) {
      Stopwatch real_windows;
      real_(rng_, real);
      real_seconds += real_windows.seconds();
      // the draws in order, then the column copies (on the pool)
      const Index fresh = replay_.empty() ? B : B - half;
      fake_picked_.resize(static_cast<std::size_t>(fresh));
      for (Index& i : fake_picked_) i = static_cast<Index>(rng_.uniform_int(static_cast<std::uint64_t>(n)));
      rl::copy_columns(amp, fake_picked_, fake.leftCols(fresh));
      if (!replay_.empty()) {
        replay_.sample(half, rng_, rep);
        fake.rightCols(half) = rep;
      }
      if (s == 0) {
        disc.update_normalizer(real);
        disc.update_normalizer(fake.leftCols(B - half));
      }
      // (distributed: each rank back-propagates its slice of the batch; gradients summed over ranks)
      const rl::DiscriminatorStats ds =
          distributed() ? disc.update_on_ranks(real, fake, *comm_) : disc.update(real, no_cond, fake, no_cond);
      if (ds.skipped) ++st.skipped_updates;
      sum_real += ds.real_mean;
      sum_fake += ds.fake_mean;
      sum_loss += ds.loss;
      sum_gp += ds.grad_penalty;
    }
    replay_.push(amp);
    st.time_disc_real_windows = real_seconds;  // (part of time_disc: drawing the real windows)
    st.disc_real = sum_real / static_cast<double>(steps);
    st.disc_fake = sum_fake / static_cast<double>(steps);
    st.disc_loss = sum_loss / static_cast<double>(steps);
    st.disc_grad_penalty = sum_gp / static_cast<double>(steps);
  }

  // ---- distributed runs (nothing here runs in one process) ---------------------------------

  /// Checks the ranks agree, finds this rank's env block and restarts its envs from the streams
  /// those envs have in one process (the task seeded them as envs 0…n−1).
  void join_ranks() {
    env_offset_ = train::join_ranks(*comm_, task_.num_envs(),
                                    static_cast<std::int64_t>(policy_.ac.actor.mean_net.num_params() +
                                                              policy_.ac.critic.net.num_params() + policy_.disc.net().num_params()),
                                    cfg_.run.seed, cfg_.env.num_envs);
    restart_env_streams(task_, cfg_.run.seed, env_offset_, /*keep_states=*/false);
  }

  /// The action draw of the collection: this rank's envs get the noise they get in one process
  /// (the replicated trainer stream skips the other ranks' draws, in one process's order).
  void act_on_my_columns() {
    const Index N = task_.num_envs(), A = task_.action_dim(), all = N * comm_->size();
    skip_normals(rng_, env_offset_ * A);
    policy_.ac.actor.act(task_.policy_inputs(), rng_, actions_, logp_, mu_, actor_ws_, scratch_);
    skip_normals(rng_, (all - env_offset_ - N) * A);
  }

  /// Sums the actor's and critic's minibatch gradients over ranks (one all-reduce) and turns
  /// this rank's loss means into means over the whole minibatch.
  MinibatchResult sum_minibatch_over_ranks(const MinibatchResult& mine, double share) {
    auto& actor = policy_.ac.actor;
    auto ga = actor.mean_net.grads();
    auto gs = actor.log_std.grads();
    auto gc = policy_.ac.critic.net.grads();
    all_reduce_gradients(*comm_, {{ga.data(), static_cast<std::size_t>(ga.size())}, {gs.data(), static_cast<std::size_t>(gs.size())},
                                  {gc.data(), static_cast<std::size_t>(gc.size())}},
                         reduce_f_);
    double m[5] = {mine.policy_loss * share, mine.value_loss * share, mine.approx_kl * share, mine.clip_frac * share,
                   mine.mi_kl * share};
    comm_->all_reduce_sum(std::span<double>(m, 5));
    return {m[0], m[1], m[2], m[3], m[4]};
  }

  /// Rank 0's `c` gets every rank's task state (checkpoint layout of one process with all envs).
  /// Also checks that the replicated state (parameters) is the same on every rank.
  void save_task_states_of_all_ranks(Checkpoint& c) const {
    Checkpoint mine;
    save_task_state(mine, "task/", task_);
    const Bytes bytes = serialize_checkpoint(mine);
    const auto parts = comm_->gather(bytes, 0);
    require_same_parameters(*comm_,
                            ParameterFingerprint()
                                .add(policy_.ac.actor.mean_net.params())
                                .add(policy_.ac.critic.net.params())
                                .add(policy_.disc.net().params())
                                .value(),
                            iteration_);
    if (!comm_->is_root()) return;
    std::vector<Checkpoint> ranks;
    for (std::size_t r = 0; r < parts.size(); ++r) ranks.push_back(parse_checkpoint(parts[r], "rank " + std::to_string(r) + " task state"));
    concat_task_states(ranks, "task/", c);
  }

  Collective* comm_ = nullptr;  ///< never null after construction (SingleProcess by default)
  Index env_offset_ = 0;        ///< global index of this rank's first env
  std::vector<Index> my_idx_;   ///< this rank's columns of the current minibatch
  std::vector<float> reduce_f_; ///< gradients of one minibatch, packed for the all-reduce
  MatrixXf global_amp_;         ///< (amp_dim × N_all·horizon) all ranks' discriminator windows

  BaseTrainConfig cfg_;
  tasks::ImitationTask<Sim> task_;
  rl::MiGradient mi_gradient_;
  RealWindowSampler real_;
  Rng rng_;
  BasePolicy policy_;
  nn::Adam<float> actor_opt_, critic_opt_;
  rl::RolloutBuffer<float> buf_;
  rl::ReplayBuffer<float> replay_;
  long long iteration_ = 0, samples_ = 0;
  MatrixXf unmasked_inputs_;  ///< [s ; 0] of the rollout (policy_input_dim × N·H), hidden_value = mean
  MatrixXf frozen_mu_;        ///< (action_dim × N·H) the MI target's μ(s, m⁰) (target_frozen, target_ema)
  nn::Mlp<float> mi_target_net_;  ///< target_ema: moving average of actor.mean_net (empty until masking starts)
  MatrixXf diag_full_mu_, diag_masked_mu_;  ///< (action_dim × N·H) μ(s, m⁰), μ(s̄, m): the logged masked/unmasked KL
  RunProvenance provenance_;  ///< start / resume lines and training wall time (provenance/*)
  // workspaces (collection path allocates nothing once sized)
  nn::InferenceWorkspace<float> actor_ws_, critic_ws_;
  nn::TrainCache<float> actor_cache_, critic_cache_;
  rl::MiWorkspace<float> mi_ws_;
  MatrixXf actions_, mu_, values_, scratch_;
  struct MinibatchScratch {  ///< update_policy's buffers (sized on the first update, then reused)
    MatrixXf adv, pin, act, obs, full, norm_in, norm_obs, dmu, dls, dv, target, vold, mu_target;
    RowVectorXf lp_old, a_mb, lp_new, dlogp;
  } mb_;
  MatrixXf disc_real_, disc_fake_, disc_replayed_;  ///< update_discriminator's batches
  std::vector<Index> fake_picked_;                   ///< update_discriminator's draws of fresh agent windows
  rl::Discriminator<float>::RewardWorkspace reward_ws_;
  MatrixXf bound_targets_;  ///< (action_dim × minibatch) PD targets of μ, for the bound penalty
  RowVectorXf logp_;
};

}  // namespace maskadapt::train
