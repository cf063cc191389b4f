#pragma once
/// \file imitation.hpp
/// The imitation task of stage 1 (AMP + stochastic body-part masking) over any simulator.
///
/// `ImitationTask<Sim>` owns the per-env bookkeeping around a simulator that satisfies the
/// `Simulator` concept; it never includes MuJoCo. Per control step it
///  1. sends the actions (PD targets, radians, (num_dofs × N)) to the simulator and steps it;
///  2. computes the next full observation s (observation_dim rows; humanoid: 328) of every env
///     and appends it to the env's history of the last 5 frames of *unmasked* discriminator
///     features; the transition's discriminator input is that window, oldest frame first
///     (5·obs_dim rows);
///  3. decides termination (fall, from the library's fall detector on body states + contacts)
///     and truncation (episode length limit) — distinct, because GAE bootstraps truncations;
///  4. records episode statistics, keeps the pre-reset observation of finished envs (for the
///     truncation bootstrap), and resets them by reference state initialisation (RSI) from the
///     reference motion, seeding their feature history with the reference frames before the
///     reset time;
///  5. samples every env's part mask for the next step (probability p of a non-empty subset of
///     at most K parts; masking off ⇒ always the null mask = plain AMP) and builds the policy
///     input [s̄ ; m] with s̄ = (1−m)⊙s ((obs_dim + 5) rows).
///
/// Env i draws resets and masks from its own stream Rng::stream(seed, i), so results do not
/// depend on the number of threads. Everything needed to continue bit-exactly (RNG states,
/// counters, histories, masks, and the simulator's state when it can save it) is exposed through
/// `save_state` / `load_state`.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/thread_pool.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/mask/apply.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/mask/sampler.hpp>
#include <maskadapt/motion/amp_window.hpp>
#include <maskadapt/motion/skeleton.hpp>
#include <maskadapt/tasks/action_space.hpp>
#include <maskadapt/sim/simulator.hpp>
#include <maskadapt/sim/termination.hpp>

#include <cmath>
#include <concepts>
#include <cstdint>
#include <functional>
#include <optional>
#include <utility>
#include <vector>

namespace maskadapt::tasks {

/// A simulator that can save and restore the exact state of one env (for bit-exact resume).
/// `save_state(env)` returns a flat vector; `load_state(env, v)` restores it.
template <class S>
concept StateSavingSimulator = Simulator<S> && requires(S& s, const S& cs, std::size_t env, const std::vector<double>& v) {
  { cs.save_state(env) } -> std::convertible_to<std::vector<double>>;
  { s.load_state(env, v) };
};

/// One reference-state-initialisation sample: the pose to reset to and the full observations of
/// the kAmpWindowFrames − 1 reference frames before it (obs_dim × 4, oldest first), which seed the
/// discriminator history so the first windows after a reset are real motion, not a frozen frame.
struct ResetSample {
  KinematicState pose;
  MatrixXf history;  ///< (obs_dim × (kAmpWindowFrames − 1)); empty ⇒ repeat the reset frame
};

/// Draws a reset sample (must be thread-safe for concurrent calls with distinct `Rng`s).
using ResetSampler = std::function<ResetSample(Rng&)>;

struct ImitationTaskConfig {
  double episode_seconds = 10.0;      ///< episode length limit (truncation)
  bool early_termination = true;      ///< end episodes on falls
  /// Fall criteria (sim/termination.hpp); nullopt ⇒ FallCriteria::for_skeleton(skel) with
  /// `min_head_height` (fits the reference humanoid).
  std::optional<FallCriteria> fall;
  double min_head_height = 0.4;       ///< m, used when `fall` is not given
  bool masking = true;                ///< false ⇒ null mask always (plain AMP)
  double mask_prob = 0.8;             ///< p
  int max_masked_parts = 3;           ///< K
  std::optional<PartMask> fixed_mask; ///< if set, every step uses this mask (play / evaluation)
  ActionSpace actions;                ///< step(a) drives the PD targets offset + scale ⊙ a (identity by default)
};

/// Statistics of the episodes that ended since the last `clear()`.
struct EpisodeStats {
  long long episodes = 0;     ///< ended episodes (falls + truncations)
  long long falls = 0;        ///< ended by a fall (terminated)
  long long truncations = 0;  ///< ended by the time limit
  double total_seconds = 0;   ///< summed length of ended episodes (s)
  long long steps = 0;        ///< env steps taken
  long long masked_steps = 0; ///< steps whose mask was non-empty
  long long sim_resets = 0;   ///< envs the simulator itself reset (non-finite physics)
  void clear() { *this = {}; }
  double mean_length() const { return episodes > 0 ? total_seconds / static_cast<double>(episodes) : NAN; }
  double fall_rate() const { return episodes > 0 ? static_cast<double>(falls) / static_cast<double>(episodes) : NAN; }
};

template <Simulator Sim>
class ImitationTask {
 public:
  /// `sim` must outlive the task. `pool` (optional) parallelises per-env work over envs.
  ImitationTask(Sim& sim, ResetSampler reset_sampler, ImitationTaskConfig config, std::uint64_t seed,
                ThreadPool* pool = nullptr)
      : sim_(sim), reset_sampler_(std::move(reset_sampler)), cfg_(std::move(config)), pool_(pool),
        obs_parts_(observation_parts(sim.skeleton())),
        part_elements_(obs_parts_),
        sampler_(MaskSampler::random(cfg_.mask_prob, cfg_.max_masked_parts)) {
    require(static_cast<bool>(reset_sampler_), "no reset sampler given", {{}, {}, "reset_sampler"});
    require(sim.control_dt() > 0, "the simulator's control_dt must be > 0", {{}, {}, "control_dt"});
    if (!cfg_.fall)  // (the reference humanoid's, humanoid/description.hpp)
      cfg_.fall = FallCriteria::for_skeleton(sim.skeleton(), humanoid_ground_contacts(), humanoid_head(), cfg_.min_head_height);
    require(cfg_.episode_seconds > 0, "episode_seconds must be > 0", {{}, {}, "episode_seconds"});
    cfg_.actions.validate(sim.skeleton().num_dofs(), "ImitationTaskConfig.actions");
    const Index n = num_envs();
    const Index d = obs_dim();
    rngs_.reserve(static_cast<std::size_t>(n));
    for (Index e = 0; e < n; ++e) rngs_.push_back(Rng::stream(seed, static_cast<std::uint64_t>(e)));
    obs_.setZero(d, n);
    final_obs_.setZero(d, n);
    policy_input_.setZero(d + kNumParts, n);
    amp_.setZero(d * kAmpWindowFrames, n);
    history_.assign(static_cast<std::size_t>(n), MatrixXf::Zero(d, kAmpWindowFrames));
    masks_.assign(static_cast<std::size_t>(n), PartMask::none());
    steps_.assign(static_cast<std::size_t>(n), 0);
    terminated_.assign(static_cast<std::size_t>(n), 0);
    truncated_.assign(static_cast<std::size_t>(n), 0);
    physics_reset_.assign(static_cast<std::size_t>(n), 0);
    reset_all();
  }

  Index num_envs() const { return static_cast<Index>(sim_.num_envs()); }
  /// The pool per-env work runs on (nullptr: the calling thread).
  ThreadPool* pool() const { return pool_; }
  Index obs_dim() const { return observation_dim(sim_.skeleton()); }
  Index policy_input_dim() const { return obs_dim() + kNumParts; }
  Index action_dim() const { return sim_.skeleton().num_dofs(); }
  Index amp_dim() const { return obs_dim() * kAmpWindowFrames; }
  const ImitationTaskConfig& config() const { return cfg_; }

  /// Changes p for the episodes that start from now on (a masking curriculum; running episodes
  /// keep their masks). The draw consumes the env's RNG the same way for every p.
  void set_mask_prob(double p) {
    if (p == cfg_.mask_prob) return;
    sampler_ = MaskSampler::random(p, cfg_.max_masked_parts);
    cfg_.mask_prob = p;
  }
  const Sim& sim() const { return sim_; }
  Sim& sim() { return sim_; }
  /// Part of every observation element (obs_dim).
  const std::vector<BodyPart>& obs_parts() const { return obs_parts_; }
  /// Seconds per control step.
  double control_dt() const { return sim_.control_dt(); }

  /// Full unmasked observation s_t of every env, (obs_dim × N).
  const MatrixXf& observations() const { return obs_; }
  /// Policy input [s̄_t ; m_t], ((obs_dim + 5) × N).
  const MatrixXf& policy_inputs() const { return policy_input_; }
  /// Mask m_t of every env (N).
  const std::vector<PartMask>& masks() const { return masks_; }
  /// After `step`: the discriminator window of the transition just taken, (5·obs_dim × N).
  const MatrixXf& amp_windows() const { return amp_; }
  /// After `step`: s_{t+1} before any reset (obs_dim × N); differs from `observations()` only
  /// in the columns of envs that ended (needed to bootstrap truncated episodes).
  const MatrixXf& final_observations() const { return final_obs_; }
  /// After `step`: 1 where the env's episode ended by a fall (no bootstrap).
  const std::vector<std::uint8_t>& terminated() const { return terminated_; }
  /// After `step`: 1 where the env's episode hit the time limit (bootstrap with V(final obs)).
  const std::vector<std::uint8_t>& truncated() const { return truncated_; }
  /// Steps taken in the current episode of each env.
  const std::vector<long long>& episode_steps() const { return steps_; }
  EpisodeStats& stats() { return stats_; }
  const EpisodeStats& stats() const { return stats_; }

  /// Resets every env by RSI and samples fresh masks (episode statistics are not touched).
  void reset_all() {
    for_envs([&](Index e) { reset_env(e); });
    for (Index e = 0; e < num_envs(); ++e) sample_mask(e);
    build_policy_input();
  }

  /// Overrides the mask of every env from now on (nullopt ⇒ back to sampling); rebuilds the input.
  void set_fixed_mask(std::optional<PartMask> m) {
    cfg_.fixed_mask = m;
    for (Index e = 0; e < num_envs(); ++e) sample_mask(e);
    build_policy_input();
  }

  /// Ends env e's episode now (a task-specific early termination decided by the caller, e.g.
  /// stage-2 tracking) and resets it by RSI: new observation, seeded feature history, fresh mask.
  /// Call after `step`; episode statistics are the caller's. (Added for stage 2 by residual2.)
  void restart_env(Index e) {
    require(e >= 0 && e < num_envs(), "env index out of range", {{}, {}, "env"});
    reset_env(e);
    sample_mask(e);
    build_policy_input();
  }

  /// One control step with `actions` (action_dim × N): the PD targets (radians) are
  /// config.actions.to_targets(actions), the actions themselves with the identity action space.
  void step(const Eigen::Ref<const MatrixXf>& actions) {
    const Index n = num_envs();
    require(actions.rows() == action_dim() && actions.cols() == n,
            "actions must be (" + std::to_string(action_dim()) + " × " + std::to_string(n) + "), got (" +
                std::to_string(actions.rows()) + " × " + std::to_string(actions.cols()) + ")",
            {{}, {}, "actions"});
    require_finite(actions, "actions");
    if (cfg_.actions.identity()) {
      sim_.step(actions);
    } else {
      targets_.resize(action_dim(), n);  // (no allocation once sized)
      cfg_.actions.to_targets(actions, targets_);
      sim_.step(targets_);
    }
    const StepStats& sim_stats = sim_.step_stats();
    const bool any_physics_reset = sim_stats.physics_reset.size() == static_cast<std::size_t>(n);

    const Skeleton& skel = sim_.skeleton();
    const double dt = sim_.control_dt();
    const long long max_steps = std::max<long long>(1, std::llround(cfg_.episode_seconds / dt));
    for_envs([&](Index e) {
      const auto ue = static_cast<std::size_t>(e);
      const BodyStates& b = sim_.body_states(ue);
      auto s = final_obs_.col(e);
      compute_observation(skel, b, s);
      push_history(e, s);
      amp_.col(e) = history_[ue].reshaped();
      ++steps_[ue];
      // An env the engine had to reset (failed physics) ends its episode without bootstrap:
      // its "next state" is not a consequence of the action.
      const bool physics_reset = any_physics_reset && sim_stats.physics_reset[ue];
      physics_reset_[ue] = physics_reset ? 1 : 0;
      const bool fell = cfg_.early_termination && has_fallen(*cfg_.fall, b, sim_.contacts(ue));
      terminated_[ue] = (fell || physics_reset) ? 1 : 0;
      truncated_[ue] = (!terminated_[ue] && steps_[ue] >= max_steps) ? 1 : 0;
      obs_.col(e) = s;
    });
    for (Index e = 0; e < n; ++e) {
      const auto ue = static_cast<std::size_t>(e);
      ++stats_.steps;
      if (!masks_[ue].empty()) ++stats_.masked_steps;
      if (terminated_[ue] || truncated_[ue]) {
        ++stats_.episodes;
        stats_.sim_resets += physics_reset_[ue];
        stats_.falls += terminated_[ue] && !physics_reset_[ue];
        stats_.truncations += truncated_[ue];
        stats_.total_seconds += static_cast<double>(steps_[ue]) * dt;
      }
    }
    for_envs([&](Index e) {
      const auto ue = static_cast<std::size_t>(e);
      if (terminated_[ue] || truncated_[ue]) reset_env(e);
    });
    for (Index e = 0; e < n; ++e) sample_mask(e);
    build_policy_input();
  }

  // ---- state for bit-exact resume ---------------------------------------------------------

  /// Everything that determines the task's future besides the policy.
  struct State {
    std::vector<Rng::State> rngs;
    std::vector<long long> steps;
    std::vector<std::uint8_t> masks;
    MatrixXf obs;                        ///< (obs_dim × N)
    std::vector<MatrixXf> history;       ///< N × (obs_dim × 5)
    std::vector<std::vector<double>> sim;  ///< per-env simulator state (empty if unsupported)
  };

  State save_state() const {
    State st;
    for (const auto& r : rngs_) st.rngs.push_back(r.state());
    st.steps = steps_;
    for (auto m : masks_) st.masks.push_back(m.bits);
    st.obs = obs_;
    st.history = history_;
    if constexpr (StateSavingSimulator<Sim>)
      for (Index e = 0; e < num_envs(); ++e) st.sim.push_back(sim_.save_state(static_cast<std::size_t>(e)));
    return st;
  }

  /// Restarts every env's random stream from `seed` (env e: Rng::stream(seed, e)), keeping the
  /// envs' physical state, step counts and masks: a resumed run forked onto another seed draws
  /// its future resets and masks from the new streams.
  void reseed(std::uint64_t seed) {
    for (std::size_t e = 0; e < rngs_.size(); ++e) rngs_[e] = Rng::stream(seed, static_cast<std::uint64_t>(e));
  }

  /// Restores a saved state. Throws naming the field if the sizes do not match this task.
  /// Without simulator states (a simulator that cannot save them), every env is reset by RSI
  /// instead, from the restored RNG streams: training continues, but not bit-exactly.
  void load_state(const State& st) {
    const auto n = static_cast<std::size_t>(num_envs());
    require(st.rngs.size() == n && st.steps.size() == n && st.masks.size() == n && st.history.size() == n,
            "saved task state is for " + std::to_string(st.rngs.size()) + " envs, this task has " + std::to_string(n),
            {{}, {}, "task.num_envs"});
    require(st.obs.rows() == obs_dim() && st.obs.cols() == num_envs(), "saved observations have the wrong shape",
            {{}, {}, "task.obs"});
    for (std::size_t e = 0; e < n; ++e) {
      rngs_[e].set_state(st.rngs[e]);
      require(st.history[e].rows() == obs_dim() && st.history[e].cols() == kAmpWindowFrames,
              "saved feature history has the wrong shape", {{}, {}, "task.history"});
    }
    if constexpr (StateSavingSimulator<Sim>) {
      if (st.sim.size() == n) {
        for (std::size_t e = 0; e < n; ++e) sim_.load_state(e, st.sim[e]);
        steps_ = st.steps;
        for (std::size_t e = 0; e < n; ++e) masks_[e].bits = st.masks[e];
        obs_ = st.obs;
        history_ = st.history;
        build_policy_input();
        return;
      }
    }
    reset_all();
  }

 private:
  template <class F>
  void for_envs(F&& f) {
    for_each_index(pool_, static_cast<std::size_t>(num_envs()), [&](std::size_t e) { f(static_cast<Index>(e)); });
  }

  void push_history(Index e, const Eigen::Ref<const VectorXf>& s) {
    auto& h = history_[static_cast<std::size_t>(e)];
    for (Index k = 0; k + 1 < kAmpWindowFrames; ++k) h.col(k) = h.col(k + 1);
    h.col(kAmpWindowFrames - 1) = s;
  }

  void reset_env(Index e) {
    const auto ue = static_cast<std::size_t>(e);
    ResetSample r = reset_sampler_(rngs_[ue]);
    sim_.reset(ue, r.pose);
    auto s = obs_.col(e);
    compute_observation(sim_.skeleton(), sim_.body_states(ue), s);
    auto& h = history_[ue];
    if (r.history.cols() == kAmpWindowFrames - 1 && r.history.rows() == obs_dim()) {
      h.leftCols(kAmpWindowFrames - 1) = r.history;
    } else {
      require(r.history.size() == 0, "reset history must be (obs_dim × 4) or empty", {{}, {}, "ResetSample.history"});
      for (Index k = 0; k + 1 < kAmpWindowFrames; ++k) h.col(k) = s;
    }
    h.col(kAmpWindowFrames - 1) = s;
    steps_[ue] = 0;
  }

  void sample_mask(Index e) {
    const auto ue = static_cast<std::size_t>(e);
    if (cfg_.fixed_mask) masks_[ue] = *cfg_.fixed_mask;
    else if (!cfg_.masking) masks_[ue] = PartMask::none();
    else masks_[ue] = sampler_.sample(rngs_[ue]);
  }

  void build_policy_input() { maskadapt::build_policy_input<float>(part_elements_, obs_, masks_, policy_input_); }

  Sim& sim_;
  ResetSampler reset_sampler_;
  ImitationTaskConfig cfg_;
  ThreadPool* pool_;
  std::vector<BodyPart> obs_parts_;
  PartElements part_elements_;
  MaskSampler sampler_;
  std::vector<Rng> rngs_;
  MatrixXf obs_, final_obs_, policy_input_, amp_;
  MatrixXf targets_;  ///< (action_dim × N) PD targets of a non-identity action space
  std::vector<MatrixXf> history_;
  std::vector<PartMask> masks_;
  std::vector<long long> steps_;
  std::vector<std::uint8_t> terminated_, truncated_;
  std::vector<std::uint8_t> physics_reset_;
  EpisodeStats stats_;
};

}  // namespace maskadapt::tasks
