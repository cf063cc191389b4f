#pragma once
/// \file residual_trainer.hpp
/// Stage 2: trains a residual policy (adapt/residual_policy.hpp) on top of a frozen base policy,
/// for motion composition (ours: one mask-conditioned discriminator; cml: one discriminator per
/// body-part group), for partial tracking (imitation discriminator on the non-designated parts +
/// the tracking task) and for the goal-driven tasks (location, heading, strike).
///
/// The collection loop is stage 1's (train/collect.hpp) with this trainer's agent.
/// Everything is one code path over a list of discriminators (rl::DiscriminatorSet) plus an
/// optional goal task (tasks/goal_task.hpp: tracking, location, heading, strike — any type that
/// models `tasks::GoalTask`); each produces one reward row = one PPO objective. The critic has
/// one output per objective, normalised by PopArt; advantages are normalised per objective and
/// combined with the objective weights (a single objective is just normalised).
///
/// One iteration:
///  1. collection (`horizon` steps × N envs): residual input [s ; a_base(s̄, m) ; m ; g] with the
///     frozen base on the inference path; composite action â (masked DoFs only) in the base's
///     action units, sent to the simulator as the PD targets offset + scale ⊙ â (the base's
///     action space; the identity sends â itself); the critic sees [s ; m ; g]; masks per episode
///     from a set (optionally switching mid-episode); g the goal task's observation; after each
///     step the goal task gives its reward and may end the episode (the env is then reset);
///  2. rewards: row k = −log(max(1 − D_k(window_k | m), 1e−4)); the goal task's row last;
///  3. GAE per objective (PopArt-denormalised values), PPO on the residual and the gain
///     (train/stage2_learner.hpp: the critic, PopArt, Adam and the PPO step live there);
///  4. discriminator steps: real samples from each source (blends for ours), fake = agent windows
///     (+ replay) (+ negative-expert blends with mismatched masks for conditioned members).
/// The base actor is never stepped (test: bit-identical parameters after training).
///
/// Tracking with method cml: the same objectives, but the base runs on the full observation with
/// the null mask (no mask invariance; residual_net_config); scratch: a zero base, every DoF residual.
///
/// Action units: a base trained with normalised actions (tasks/action_space.hpp) comes with its
/// action space (FrozenBase); â = w·a_base + Δa, Δa's σ, the gain and the "only masked DoFs
/// change" rule are all in those normalised units (adapt/residual_policy.hpp). There is no
/// penalty on Δa itself; the one action term, the action-bound penalty, is on the PD targets
/// (beyond ±π rad) exactly as in stage 1, so its gradient reaches μ̂ through `scale`. Scratch has
/// no base: its action space is the run config's net.action_* (identity by default, as before;
/// train-residual resolves mean_pose / half_range from the motion set A when asked, so a scratch
/// run can share a normalised base's mapping for comparisons). Ours / cml: train-residual copies
/// the base's net.action_* into the run config (provenance only; the mapping in use is the
/// FrozenBase's, saved with the policy as base/actor/action_*).
///
/// Checkpoints hold everything needed to continue bit-exactly when the simulator can save its
/// state (tasks::StateSavingSimulator): networks, normalisers, PopArt, Adam moments and step
/// counts, replay buffers, the trainer's, the task's and the mask streams' RNG states, and the goal
/// task's own state (its `save`, under "state/goal_task/").
/// A goal task that ends an episode (tracking's windowed termination, strike's foreign contact)
/// physically resets the env (ImitationTask::restart_env).
///
/// Distributed (docs/distributed.md, train/distributed.hpp): given a Collective of K ranks, rank r
/// steps the global envs [r·n, (r+1)·n) (n = sim.num_envs(), env.num_envs = K·n) with the streams
/// those envs have in one process (imitation task, episode masks; a goal task's per-env streams
/// when the caller built it with `first_env` = r·n) and the action noise one process draws for
/// them. The input normalisers merge every rank's batch at every collection step; advantages,
/// PopArt and the PPO minibatches use all ranks' samples and the actor's and critic's gradients
/// are summed before each Adam step (Stage2Learner); the discriminators see every rank's windows
/// and sum their gradients (RewardDiscriminators); episode statistics, goal-task trials and the
/// logged means are combined. Rank 0's checkpoint holds every rank's env-side state (imitation
/// task, masks and their streams, goal task) under `dist/rank/<r>/`, and `dist/ranks` = K; `load`
/// refuses another K.
#include <maskadapt/adapt/residual_policy.hpp>
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/collective.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/rl/actor_critic.hpp>
#include <maskadapt/rl/discriminator.hpp>
#include <maskadapt/rl/gae.hpp>
#include <maskadapt/rl/replay_buffer.hpp>
#include <maskadapt/rl/rollout_buffer.hpp>
#include <maskadapt/tasks/composition.hpp>
#include <maskadapt/tasks/goal_task.hpp>
#include <maskadapt/tasks/imitation.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/collect.hpp>
#include <maskadapt/train/config.hpp>
#include <maskadapt/train/distributed.hpp>
#include <maskadapt/train/progress.hpp>
#include <maskadapt/train/residual_config.hpp>
#include <maskadapt/train/reward_discriminators.hpp>
#include <maskadapt/train/run_provenance.hpp>
#include <maskadapt/train/stage2_learner.hpp>
#include <maskadapt/train/stage2_policy.hpp>
#include <maskadapt/train/task_state.hpp>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace maskadapt::train {

using RowVectorXf = RowVectorX<float>;

/// What a residual run trains against.
template <Simulator Sim>
struct ResidualSetup {
  std::vector<PartMask> masks;       ///< adapted-region set (per episode)
  double switch_rate = 0.0;
  double negative_fraction = 0.25;
  std::vector<DiscriminatorSource> discriminators;
  tasks::AnyGoalTask<Sim> goal;      ///< optional: tracking, location, heading, strike, …
  double goal_weight = 0.5;          ///< the goal task's objective weight
};

template <Simulator Sim, Stage2Policy Policy = adapt::ResidualPolicy<float>>
class ResidualTrainer {
 public:
  /// A base with the identity action space (its actions are the PD targets).
  ResidualTrainer(Sim& sim, tasks::ResetSampler reset, rl::GaussianActor<float> base, ResidualSetup<Sim> setup,
                  ResidualTrainConfig config, ThreadPool* pool = nullptr, std::optional<FallCriteria> fall = std::nullopt,
                  Collective* comm = nullptr)
      : ResidualTrainer(sim, std::move(reset), FrozenBase{std::move(base), {}}, std::move(setup), std::move(config), pool,
                        std::move(fall), comm) {}
  /// `base.actions` maps the composite actions to PD targets (see the file comment). `load`
  /// replaces the base and its action space with the checkpoint's. `comm`: the ranks of a
  /// distributed run (nullptr: this process alone); every rank constructs its trainer with the
  /// same config and setup and a simulator of env.num_envs / K envs (collective).
  ResidualTrainer(Sim& sim, tasks::ResetSampler reset, FrozenBase base, ResidualSetup<Sim> setup,
                  ResidualTrainConfig config, ThreadPool* pool = nullptr, std::optional<FallCriteria> fall = std::nullopt,
                  Collective* comm = nullptr)
      : cfg_((config.validate(), std::move(config))), setup_(std::move(setup)),
        task_(sim, std::move(reset), no_mask_task(cfg_.rl, std::move(fall)), cfg_.rl.run.seed, pool),
        part_elements_(task_.obs_parts()), rng_(Rng::stream(cfg_.rl.run.seed, 0x5E51D000ULL)) {
    require(!setup_.discriminators.empty() || setup_.goal, "a residual run needs at least one objective",
            {{}, {}, "setup"});
    const Index N = task_.num_envs();
    comm_ = comm ? comm : &single_process();
    env_offset_ = comm_->rank() * N;  // (checked against the other ranks below)
    masks_ = tasks::EpisodeMasks(setup_.masks, N, setup_.switch_rate, task_.control_dt(), cfg_.rl.run.seed, env_offset_);
    Rng init = Rng::stream(cfg_.rl.run.seed, 0x2E51ULL);
    const nn::Activation activation = residual_activation(cfg_.rl.net.activation);
    policy_ = make_stage2_policy<Policy>(std::move(base), task_.obs_dim(), sim.skeleton(), cfg_, setup_.goal.goal_dim(), init);
    if constexpr (decaying_std) initial_log_std_ = policy_.residual().log_std.params();  // (before any checkpoint)
    K_ = static_cast<Index>(setup_.discriminators.size()) + (setup_.goal ? 1 : 0);
    for (const auto& d : setup_.discriminators) weights_.push_back(d.weight);
    if (setup_.goal) weights_.push_back(setup_.goal_weight);
    learner_ = Stage2Learner<Policy>(critic_dim(), K_, cfg_.rl, activation, init);
    if (cfg_.has_part_credit())  // per-part credit: each part's DoFs with its own objective weights
      learner_.set_part_credit(make_part_credit(cfg_.part_objective_weights, weights_, action_parts(sim.skeleton())));
    const Index W = task_.amp_dim();
    discs_ = RewardDiscriminators(setup_.discriminators, W, cfg_.rl, activation, setup_.negative_fraction, init);
    rl::RolloutSpec spec;
    spec.horizon = cfg_.rl.ppo.horizon;
    spec.num_envs = N;
    spec.obs_dim = critic_dim();
    spec.policy_input_dim = policy_.input_dim();
    spec.action_dim = policy_.action_dim();
    spec.num_objectives = K_;
    spec.amp_dim = W;
    buf_.resize(spec);
    if (cfg_.noise_hold_steps > 1) {  // (every env draws afresh at its first step)
      held_noise_.setZero(policy_.action_dim(), N);
      hold_left_.assign(static_cast<std::size_t>(N), 0);
    }
    if (distributed()) {  // this rank's envs restart from the streams they have in one process
      join_ranks(*comm_, N, static_cast<std::int64_t>(parameter_count()), cfg_.rl.run.seed, cfg_.rl.env.num_envs);
      restart_env_streams(task_, cfg_.rl.run.seed, env_offset_, /*keep_states=*/false);
    }
    if (setup_.goal)
      for (Index e = 0; e < N; ++e) setup_.goal.new_episode(task_.sim(), e);
  }

  const BaseTrainConfig& config() const { return cfg_.rl; }
  const ResidualTrainConfig& residual_config() const { return cfg_; }
  const Policy& policy() const { return policy_; }
  /// Groups of per-part credit (0: off, one advantage for every DoF).
  Index part_credit_groups() const { return learner_.part_credit().enabled() ? learner_.part_credit().groups() : 0; }
  /// The last iteration's rollout (actions: the composite â, base units).
  const rl::RolloutBuffer<float>& rollout() const { return buf_; }
  tasks::ImitationTask<Sim>& task() { return task_; }
  const rl::DiscriminatorSet<float>& discriminators() const { return discs_.set(); }
  Index num_objectives() const { return K_; }
  long long iteration() const { return iteration_; }
  long long samples() const { return samples_; }
  /// Mean goal-task reward of the last iteration (NaN without a goal task; tracking: exp(−‖q* − q‖²)).
  double last_goal_reward() const { return last_goal_reward_; }
  /// Appends one line to the run's history (what started or resumed it: date, git commit,
  /// command line); saved in `provenance/history` and carried into exported models.
  void add_provenance(const std::string& line) { provenance_.add(line); }
  const std::string& provenance() const { return provenance_.history; }
  /// Wall seconds spent in iterate() over the whole run, resumed chunks included (NaN when the
  /// run started from a checkpoint that did not record it).
  double train_seconds() const { return provenance_.train_seconds; }
  /// The goal task (empty without one).
  tasks::AnyGoalTask<Sim>& goal_task() { return setup_.goal; }
  /// Critic input rows [s ; m ; g].
  Index critic_dim() const { return task_.obs_dim() + kNumParts + policy_goal_dim(); }
  /// The ranks this trainer runs with (SingleProcess unless a Collective was given).
  Collective& collective() const { return *comm_; }
  bool distributed() const { return comm_->size() > 1; }
  /// Index of this rank's first env among all ranks' envs (0 in one process).
  Index env_offset() const { return env_offset_; }

  IterationStats iterate() {
    IterationStats st;
    // Network passes (inference batches, PPO, MI, discriminators) run their chunks on the env
    // pool; results do not depend on it (nn/chunks.hpp).
    nn::ScopedPool parallel_networks(task_.pool());
    Stopwatch total;
    task_.stats().clear();
    goal_terminations_ = 0;
    if (setup_.goal) {
      setup_.goal.begin_iteration(iteration_);
      setup_.goal.clear_trials();
    }
    apply_std_decay();
    collect(st);
    if (setup_.goal) {
      tasks::TrialCounter tr = setup_.goal.trials();
      double counts[3] = {static_cast<double>(goal_terminations_), static_cast<double>(tr.trials), static_cast<double>(tr.successes)};
      if (distributed()) comm_->all_reduce_sum(std::span<double>(counts, 3));
      tr.trials = static_cast<long long>(counts[1]);
      tr.successes = static_cast<long long>(counts[2]);
      st.extra[setup_.goal.name() + "_terminations"] = counts[0];
      if (tr.trials > 0) {
        st.extra["trials"] = static_cast<double>(tr.trials);
        st.extra["success_rate"] = tr.rate();
      }
      // how the trials ended, where the task says (strike: struck, fell, untouched, ...)
      const tasks::TrialOutcomes outcomes = setup_.goal.trial_outcomes();
      std::vector<double> oc;
      for (const auto& [name, n] : outcomes) oc.push_back(static_cast<double>(n));
      if (distributed() && !oc.empty()) comm_->all_reduce_sum(std::span<double>(oc));
      for (std::size_t k = 0; k < oc.size(); ++k) st.extra["trials_" + outcomes[k].first] = oc[k];
    }
    Stopwatch upd;
    Stopwatch disc_rewards;
    compute_rewards(st);  // (the tracking task's reward terms are timed with the discriminators')
    st.time_disc_reward = disc_rewards.seconds();
    st.time_disc += st.time_disc_reward;
    Stopwatch ppo;
    rl::compute_gae(buf_, rl::GaeParams{cfg_.rl.ppo.gamma, cfg_.rl.ppo.gae_lambda});
    learner_.update(policy_, buf_, weights_, cfg_.rl.ppo, rng_, st, ranks());  // 3. PPO on the residual
    st.time_ppo = ppo.seconds();  // (GAE and PPO)
    Stopwatch disc_update;
    discs_.update(buf_.amp_windows, buf_.masks, rng_, st, ranks());
    st.time_disc += disc_update.seconds();
    st.time_update += upd.seconds();
    ++iteration_;
    const long long batch = buf_.size() * comm_->size();  // (every rank holds as many samples)
    samples_ += batch;
    if (distributed()) sum_episode_stats_over_ranks(*comm_, task_.stats());
    finish_iteration_stats(st, iteration_, samples_, batch, total.seconds(), task_.stats());
    provenance_.train_seconds += st.time_total;
    st.mask_fraction = 1.0;  // the residual task's own masks, not the imitation task's (which has none)
    return st;
  }

  /// Everything needed to continue training (see the file comment) plus both configs.
  void save(Checkpoint& c) const {
    c.put_string("residual_config", to_json(cfg_).dump());
    c.put_string("config", to_json(cfg_.rl).dump());
    policy_.save(c, true);
    learner_.save(c);
    discs_.save(c);
    c.put_int("trainer/iteration", iteration_);
    c.put_int("trainer/samples", samples_);
    provenance_.save(c);  // (how the run came about; never read back into training)
    save_training_state(c);
  }
  /// Distributed: collective; rank 0 writes the file (every rank's envs), the others write nothing.
  void save(const std::string& path) const {
    Checkpoint c;
    save(c);
    if (comm_->is_root()) save_checkpoint(path, c);
  }
  /// Restores what `save` wrote (same sizes and env count; throws naming the section otherwise).
  /// A checkpoint without the "state/" sections (networks only) restores the networks and
  /// counters; training then continues from fresh optimiser and RNG states. Distributed: every
  /// rank loads the checkpoint rank 0 wrote and takes its own envs' state from it; the training
  /// state of another number of ranks is refused (`dist/ranks`).
  void load(const Checkpoint& c) {
    if (c.contains("state/rng")) require_same_rank_count(c, *comm_);
    policy_.load(c, true);
    learner_.load(c);
    discs_.load(c);
    iteration_ = c.get_int("trainer/iteration");
    samples_ = c.get_int("trainer/samples");
    provenance_.load(c);
    if (c.contains("state/rng")) load_training_state(c);
  }

  /// σ_ψ of this iteration under the config's decay (ResidualTrainConfig::residual_std_decay_*):
  /// log σ = log σ(0) + min(1, it / iterations)·log factor on every residual DoF. No-op without one.
  void apply_std_decay() {
    if constexpr (decaying_std) {
      if (!cfg_.decays_std()) return;
      const double progress = std::min(1.0, static_cast<double>(iteration_) / cfg_.residual_std_decay_iterations);
      const auto shift = static_cast<float>(progress * std::log(cfg_.residual_std_decay_factor));
      policy_.residual().log_std.params() = (initial_log_std_.array() + shift).matrix();
    }
  }

 private:
  /// Whether the policy has a residual σ the decay can set (ResidualPolicy; not AdaptNet).
  static constexpr bool decaying_std = requires(Policy& p) { p.residual().log_std.params(); };
  VectorXf initial_log_std_;  ///< the residual's log σ at construction (the decay's σ(0))
  // ---- checkpoint: optimiser, RNG, task and tracking state ---------------------------------
  void save_training_state(Checkpoint& c) const {
    auto& self = const_cast<ResidualTrainer&>(*this);  // block accessors are non-const only; nothing changes
    learner_.save_state(c, self.policy_.trainable_blocks());
    discs_.save_state(c);
    c.put_rng("state/rng", rng_);
    if (!distributed()) {
      save_env_state(c);
      return;
    }
    // every rank's envs under dist/rank/<r>/ (a goal task's layout is its own), after checking
    // that the replicated state agrees on every rank
    require_same_parameters(*comm_, parameter_fingerprint(), iteration_);
    Checkpoint mine;
    save_env_state(mine);
    gather_rank_sections(*comm_, mine, c);
    c.put_int("dist/ranks", comm_->size());
  }
  /// This rank's env-side state: episode masks and their streams, the imitation task, the goal task.
  void save_env_state(Checkpoint& c) const {
    const Index N = task_.num_envs();
    VectorX<std::int64_t> masks(N);
    for (Index e = 0; e < N; ++e) {
      masks[e] = masks_.masks()[static_cast<std::size_t>(e)].bits;
      c.put_rng("state/mask_rng/" + std::to_string(e), masks_.rngs()[static_cast<std::size_t>(e)]);
    }
    c.put("state/masks", masks);
    save_task_state(c, "state/task/", task_);
    if (setup_.goal) setup_.goal.save(c, "state/goal_task/");
    if (cfg_.noise_hold_steps > 1) {  // (held deviations: A × N, steps each env still holds)
      VectorX<std::int64_t> left(N);
      for (Index e = 0; e < N; ++e) left[e] = hold_left_[static_cast<std::size_t>(e)];
      c.put("state/noise_hold/deviation", held_noise_);
      c.put("state/noise_hold/steps_left", left);
    }
  }

  void load_training_state(const Checkpoint& c) {
    learner_.load_state(c, policy_.trainable_blocks());
    discs_.load_state(c);
    rng_.set_state(c.get_rng("state/rng"));
    if (distributed()) load_env_state(rank_sections(c, comm_->rank()));
    else load_env_state(c);
  }
  void load_env_state(const Checkpoint& c) {
    const Index N = task_.num_envs();
    const auto masks = c.get_vector<std::int64_t>("state/masks", N);
    for (Index e = 0; e < N; ++e) {
      masks_.set(e, PartMask{static_cast<std::uint8_t>(masks[e])});
      masks_.rngs()[static_cast<std::size_t>(e)].set_state(c.get_rng("state/mask_rng/" + std::to_string(e)));
    }
    load_task_state(c, "state/task/", task_);
    if (setup_.goal) setup_.goal.load(c, "state/goal_task/");
    if (cfg_.noise_hold_steps > 1) {
      held_noise_ = c.get_matrix<float>("state/noise_hold/deviation", policy_.action_dim(), N);
      const auto left = c.get_vector<std::int64_t>("state/noise_hold/steps_left", N);
      for (Index e = 0; e < N; ++e) hold_left_[static_cast<std::size_t>(e)] = static_cast<int>(left[e]);
    }
  }

  static tasks::ImitationTaskConfig no_mask_task(const BaseTrainConfig& c, std::optional<FallCriteria> fall) {
    tasks::ImitationTaskConfig t;
    t.fall = std::move(fall);
    t.episode_seconds = c.env.episode_seconds;
    t.early_termination = c.env.early_termination;
    t.min_head_height = c.env.termination_height;
    t.masking = false;  // masks are the residual's (EpisodeMasks), not the task's
    return t;
  }
  Index policy_goal_dim() const { return policy_.goal_dim(); }

  /// Goals (goal_dim × N) for the current step of every env.
  void current_goals(MatrixXf& g) const {
    const Index N = task_.num_envs(), G = policy_goal_dim();
    g.resize(G, N);
    if (G == 0) return;
    for (Index e = 0; e < N; ++e) setup_.goal.goal(task_.sim(), e, g.col(e));
  }

  void critic_input(const MatrixXf& obs, const std::vector<PartMask>& masks, const MatrixXf& goals, MatrixXf& out) const {
    const Index d = task_.obs_dim(), G = policy_goal_dim();
    out.resize(critic_dim(), obs.cols());
    out.topRows(d) = obs;
    out.middleRows(d, kNumParts) = tasks::mask_bits(masks);
    if (G > 0) out.bottomRows(G) = goals;
  }

  // ---- distributed runs --------------------------------------------------------------------
  RankLayout ranks() const { return distributed() ? RankLayout{comm_, task_.num_envs(), env_offset_} : RankLayout{}; }
  /// Parameters of everything every rank holds a copy of and steps (residual, critic, discriminators).
  std::size_t parameter_count() {
    std::size_t n = static_cast<std::size_t>(learner_.critic().net.num_params());
    for (nn::ParameterBlock<float>* b : policy_.trainable_blocks()) n += static_cast<std::size_t>(b->params().size());
    for (auto& d : discs_.set().members) n += static_cast<std::size_t>(d.net().num_params());
    return n;
  }
  std::uint64_t parameter_fingerprint() const {
    auto& self = const_cast<ResidualTrainer&>(*this);  // block accessors are non-const only; nothing changes
    ParameterFingerprint f;
    for (nn::ParameterBlock<float>* b : self.policy_.trainable_blocks()) f.add(b->params());
    f.add(learner_.critic().net.params());
    for (const auto& d : discs_.set().members) f.add(d.net().params());
    return f.value();
  }

  // ---- 1. collection ----------------------------------------------------------------------
  void collect(IterationStats& st) {
    goal_rewards_.setZero(buf_.size());
    Collector agent(*this);
    collect_rollout(task_, buf_, agent, st);
  }
  /// The policy on the frozen base as the collection loop's agent (train/collect.hpp): input
  /// [s ; a_base(s̄, m) ; m ; g], critic [s ; m ; g]; the goal task rewards every step and may end
  /// an episode; masks change at episode ends (or switch mid-episode).
  struct Collector {
    explicit Collector(ResidualTrainer& trainer) : t(trainer) {}
    ResidualTrainer& t;
    std::vector<PartMask> masks;  ///< of the step being collected (the critic's final values use them)
    MatrixXf goals, x, cin, v;
    const MatrixXf& act(Index step, Index /*c0*/) {
      masks = t.masks_.masks();
      t.current_goals(goals);
      t.policy_.build_input(t.part_elements_, t.task_.observations(), masks, goals, x, t.ws_);
      t.critic_input(t.task_.observations(), masks, goals, cin);
      if (t.distributed()) {  // every rank's batch into the statistics; this rank's envs' noise
        merge_normalizer_over_ranks(*t.comm_, x, t.policy_.residual().normalizer);
        merge_normalizer_over_ranks(*t.comm_, cin, t.learner_.critic().normalizer);
        const Index N = t.task_.num_envs(), A = t.policy_.action_dim(), all = N * t.comm_->size();
        skip_normals(t.rng_, t.env_offset_ * A);
        t.policy_.act(x, masks, t.rng_, t.actions_, t.logp_, t.mu_, t.ws_);
        skip_normals(t.rng_, (all - t.env_offset_ - N) * A);
      } else {
        t.policy_.residual().normalizer.update(x);
        t.learner_.critic().normalizer.update(cin);
        t.policy_.act(x, masks, t.rng_, t.actions_, t.logp_, t.mu_, t.ws_);
      }
      t.hold_noise(x, masks);
      t.learner_.values(cin, v);
      t.buf_.record_policy_step(step, cin, x, masks, t.actions_, t.logp_, v);
      // The task's action space is the identity: â becomes PD targets here, through the base's
      // action space held by the policy (so a loaded checkpoint brings its own mapping along).
      if (t.policy_.actions().identity()) return t.actions_;
      t.policy_.to_targets(t.actions_, t.targets_);
      return t.targets_;
    }
    void end_step(Index e, Index column, StepEnd& end) {
      if (t.setup_.goal) {  // (its reward; it may end the episode; a new episode gets a new goal)
        const tasks::GoalOutcome g = tasks::advance_goal(t.setup_.goal, t.task_, e);
        t.goal_rewards_(0, column) = g.reward;
        end = {g.terminated, g.truncated};
        t.goal_terminations_ += g.by_goal_task ? 1 : 0;
      }
      const std::uint8_t mask_before = t.masks_.masks()[static_cast<std::size_t>(e)].bits;
      if (end.terminated || end.truncated) t.masks_.new_episode(e);
      else t.masks_.maybe_switch(e);
      // a new episode or a new mask draws fresh exploration noise at its first step
      if (end.terminated || end.truncated || t.masks_.masks()[static_cast<std::size_t>(e)].bits != mask_before)
        t.restart_noise_hold(e);
    }
    const MatrixXf& final_values(const MatrixXf& final_obs) {
      t.critic_input(final_obs, masks, goals, cin);
      t.learner_.values(cin, v);
      return v;
    }
    const MatrixXf& bootstrap_values() {
      t.current_goals(goals);
      t.critic_input(t.task_.observations(), t.masks_.masks(), goals, cin);
      t.learner_.values(cin, v);
      return v;
    }
  };

  /// Exploration noise held for cfg_.noise_hold_steps control steps (residual_config.hpp): env e
  /// keeps the deviation a − μ̂ drawn at the first step of a hold and adds it to the mean of the
  /// next k − 1 steps; the held actions' log-probabilities are taken under each step's own
  /// Gaussian (the training pass's, as PPO's ratio will see them). k = 1: nothing changes.
  void hold_noise(const MatrixXf& x, std::span<const PartMask> masks) {
    const int k = cfg_.noise_hold_steps;
    if (k <= 1) return;
    const Index N = actions_.cols();
    bool any_held = false;
    for (Index e = 0; e < N; ++e) {
      int& left = hold_left_[static_cast<std::size_t>(e)];
      if (left <= 0) {
        held_noise_.col(e) = actions_.col(e) - mu_.col(e);
        left = k;
      } else {
        actions_.col(e) = mu_.col(e) + held_noise_.col(e);
        any_held = true;
      }
      --left;
    }
    if (any_held) {
      policy_.forward_train(x, masks, hold_cache_);
      policy_.log_prob(hold_cache_, actions_, logp_);
    }
  }
  void restart_noise_hold(Index e) {
    if (cfg_.noise_hold_steps > 1) hold_left_[static_cast<std::size_t>(e)] = 0;
  }

  // ---- 2. rewards -------------------------------------------------------------------------
  void compute_rewards(IterationStats& st) {
    discs_.rewards(buf_.amp_windows, buf_.masks, buf_.rewards, K_ > 1, st);
    if (distributed()) {  // (means over equally many samples on every rank: the mean of the ranks' means)
      st.disc_reward = mean_over_ranks(*comm_, st.disc_reward);
      for (const auto& src : discs_.sources())
        if (st.extra.count("reward_" + src.name)) st.extra["reward_" + src.name] = mean_over_ranks(*comm_, st.extra["reward_" + src.name]);
    }
    if (setup_.goal) {
      buf_.rewards.row(K_ - 1) = goal_rewards_;
      last_goal_reward_ = goal_rewards_.cast<double>().mean();
      if (distributed()) last_goal_reward_ = mean_over_ranks(*comm_, last_goal_reward_);
      st.extra[setup_.goal.name() + "_reward"] = last_goal_reward_;
    }
  }

  Collective* comm_ = nullptr;  ///< never null after construction (SingleProcess by default)
  Index env_offset_ = 0;        ///< global index of this rank's first env

  ResidualTrainConfig cfg_;
  ResidualSetup<Sim> setup_;
  tasks::ImitationTask<Sim> task_;
  PartElements part_elements_;
  Rng rng_;
  tasks::EpisodeMasks masks_;
  Policy policy_;
  Stage2Learner<Policy> learner_;  ///< critic, PopArt, Adam, the PPO step
  RewardDiscriminators discs_;
  std::vector<double> weights_;
  Index K_ = 1;
  rl::RolloutBuffer<float> buf_;
  long long iteration_ = 0, samples_ = 0;
  double last_goal_reward_ = NAN;
  RunProvenance provenance_;  ///< start / resume lines and training wall time (provenance/*)
  long long goal_terminations_ = 0;
  RowVectorXf goal_rewards_;
  // workspaces
  typename Stage2Types<Policy>::Workspace ws_;
  MatrixXf actions_, mu_;
  MatrixXf targets_;  ///< PD targets of a non-identity action space
  RowVectorXf logp_;
  // held exploration noise (cfg_.noise_hold_steps > 1)
  MatrixXf held_noise_;            ///< (action_dim × N) deviation a − μ̂ each env holds
  std::vector<int> hold_left_;     ///< steps each env still holds it (0: draw afresh)
  typename Stage2Types<Policy>::Cache hold_cache_;
};

}  // namespace maskadapt::train
