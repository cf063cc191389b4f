#pragma once
/// \file goal_task.hpp
/// The `GoalTask` concept: one objective a residual policy (stage 2) learns besides its
/// discriminators — partial tracking (tasks/tracking_task.hpp), target location, heading and
/// strike (tasks/location.hpp, heading.hpp, strike.hpp). `train::ResidualTrainer` runs any of
/// them through one loop; a task adds one reward row (one PPO objective, PopArt-normalised like
/// the discriminators' rows) and a goal observation appended to the policy and critic inputs.
///
/// Requirements, for `T& t`, `const T& ct`, a simulator `Sim& sim` / `const Sim& csim`, env `e`:
///
/// | expression                       | returns                 | meaning |
/// | -------------------------------- | ----------------------- | ------- |
/// | `ct.name()`                      | `std::string`           | "location", "tracking", … (logs, checkpoints) |
/// | `ct.goal_dim()`                  | `Index`                 | rows of the goal observation (0 allowed) |
/// | `t.begin_iteration(it)`          | (any)                   | before iteration `it` collects (e.g. refill a goal buffer) |
/// | `t.new_episode(sim, e)`          | (any)                   | env e has just been reset: draw its goal (may place scene objects) |
/// | `ct.goal(csim, e, g)`            | (any)                   | writes the goal observation (goal_dim), `g` an `Eigen::Ref<VectorXf>` |
/// | `t.after_step(csim, e, end)`     | `GoalStep`              | the step just taken: its reward and whether the task ends the episode. `end` (an `EpisodeEnd`): `none`, or how the imitation task already ended (and reset) the env, whose state must not be read — the task then returns its previous reward and closes the trial (see "Trials") |
/// | `ct.trials()`                    | `const TrialCounter&`   | trials ended and successes since the last `clear_trials()` |
/// | `t.clear_trials()`               | (any)                   | |
/// | `ct.save(ck, prefix)`            | (any)                   | everything needed to resume bit-exactly (goals, schedules, RNG streams) under `prefix` |
/// | `t.load(cck, prefix)`            | (any)                   | restores it (throws naming the section on a mismatch) |
///
/// Trials: a trial is one goal held by one env. It ends when the task resamples the goal, when
/// the episode ends, or when the task ends the episode; it counts as a success when the task's
/// success test held (each task's header says exactly when). A task whose goals are held for a
/// drawn time (location, heading) does not count a trial that the episode's time limit cut
/// short: it is *censored* (`TrialCounter::censored`), because its outcome is unknown — counting
/// it as a failure would make the success rate depend on the episode length rather than on the
/// policy (with 10-s episodes and goals held 5–10 s every second location trial had 0–5 s), and
/// counting only the cut trials that had already succeeded would bias it upward. A fall ends the
/// trial as a failure. (Strike's trial is the episode: its time limit is the trial's own end.)
///
/// Optional: `ct.trial_outcomes()` → `TrialOutcomes`, how the ended trials ended, one count per
/// named outcome (strike: struck, tilted by another body, fell, …), cleared with the trials; a
/// task without it reports none. Evaluation prints them beside the success rate and training
/// logs them, so a low success rate comes with its reason.
///
/// A task may also close a trial and ask for the next goal within an episode
/// (`GoalStep::next_goal`): `advance_goal` then calls `new_episode` for that env without
/// resetting it (strike's `next_box_steps` places a new box this way).
///
/// `AnyGoalTask<Sim>` type-erases a task so a run can pick one at run time (CLI `--task`).
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/sim/simulator.hpp>

#include <cmath>
#include <concepts>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace maskadapt::tasks {

/// How an env's episode ended on the step a goal task is told about (`after_step`).
enum class EpisodeEnd : std::uint8_t {
  none,        ///< it goes on
  terminated,  ///< ended early by the imitation task: a fall (no bootstrap)
  time_limit,  ///< ended by the episode length limit (truncated, bootstrapped)
};

/// What a goal task says about one env's step.
struct GoalStep {
  float reward = 0.0f;     ///< the task's reward row for this step
  bool terminate = false;  ///< the task ends the episode (the trainer resets the env)
  bool next_goal = false;  ///< the task closed its trial: draw the next goal now (`new_episode`, env not reset)
};

/// How ended trials ended: (outcome name, count) in the task's own order; the counts sum to the
/// trials ended (`TrialCounter::trials`).
using TrialOutcomes = std::vector<std::pair<std::string, long long>>;

/// Ended trials and successes; `censored`: trials the episode's time limit cut short, counted in
/// neither (see "Trials" above).
struct TrialCounter {
  long long trials = 0, successes = 0, censored = 0;
  void add(bool success) {
    ++trials;
    successes += success ? 1 : 0;
  }
  void censor() { ++censored; }
  double rate() const { return trials > 0 ? static_cast<double>(successes) / static_cast<double>(trials) : NAN; }
  /// Wilson score interval at z = 1.96 (95 %): {low, high}; {0, 1} without trials.
  std::pair<double, double> wilson95() const {
    if (trials == 0) return {0.0, 1.0};
    const double n = static_cast<double>(trials), p = rate(), z = 1.96, z2 = z * z;
    const double centre = (p + z2 / (2 * n)) / (1 + z2 / n);
    const double half = z * std::sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n);
    return {std::max(0.0, centre - half), std::min(1.0, centre + half)};
  }
};

template <class T, class Sim>
concept GoalTask = Simulator<Sim> &&
    requires(T& t, const T& ct, Sim& sim, const Sim& csim, Index e, EpisodeEnd end, long long it, Eigen::Ref<VectorXf> g,
             Checkpoint& ck, const Checkpoint& cck, const std::string& prefix) {
      { ct.name() } -> std::convertible_to<std::string>;
      { ct.goal_dim() } -> std::convertible_to<Index>;
      t.begin_iteration(it);
      t.new_episode(sim, e);
      ct.goal(csim, e, g);
      { t.after_step(csim, e, end) } -> std::same_as<GoalStep>;
      { ct.trials() } -> std::same_as<const TrialCounter&>;
      t.clear_trials();
      ct.save(ck, prefix);
      t.load(cck, prefix);
    };

/// A goal task of any type behind one interface (a run picks its task at run time). A value:
/// copying it copies the task and its state.
template <Simulator Sim>
class AnyGoalTask {
 public:
  AnyGoalTask() = default;
  template <class T>
    requires GoalTask<T, Sim> && (!std::same_as<std::remove_cvref_t<T>, AnyGoalTask>)
  AnyGoalTask(T task) : self_(std::make_unique<Model<T>>(std::move(task))) {}  // NOLINT: implicit by design
  AnyGoalTask(const AnyGoalTask& o) : self_(o.self_ ? o.self_->clone() : nullptr) {}
  AnyGoalTask(AnyGoalTask&&) noexcept = default;
  AnyGoalTask& operator=(const AnyGoalTask& o) {
    if (this != &o) self_ = o.self_ ? o.self_->clone() : nullptr;
    return *this;
  }
  AnyGoalTask& operator=(AnyGoalTask&&) noexcept = default;

  explicit operator bool() const { return self_ != nullptr; }
  std::string name() const { return get().name(); }
  Index goal_dim() const { return self_ ? get().goal_dim() : 0; }
  void begin_iteration(long long it) { get().begin_iteration(it); }
  void new_episode(Sim& sim, Index e) { get().new_episode(sim, e); }
  void goal(const Sim& sim, Index e, Eigen::Ref<VectorXf> g) const { get().goal(sim, e, g); }
  GoalStep after_step(const Sim& sim, Index e, EpisodeEnd end) { return get().after_step(sim, e, end); }
  const TrialCounter& trials() const { return get().trials(); }
  /// The task's `trial_outcomes()`, or none if it has no such member.
  TrialOutcomes trial_outcomes() const { return get().trial_outcomes(); }
  void clear_trials() { get().clear_trials(); }
  void save(Checkpoint& c, const std::string& prefix) const { get().save(c, prefix); }
  void load(const Checkpoint& c, const std::string& prefix) { get().load(c, prefix); }
  /// The task itself (nullptr if it is not a T).
  template <class T>
  T* as() {
    auto* m = dynamic_cast<Model<T>*>(self_.get());
    return m ? &m->task : nullptr;
  }

 private:
  struct Concept {
    virtual ~Concept() = default;
    virtual std::unique_ptr<Concept> clone() const = 0;
    virtual std::string name() const = 0;
    virtual Index goal_dim() const = 0;
    virtual void begin_iteration(long long it) = 0;
    virtual void new_episode(Sim& sim, Index e) = 0;
    virtual void goal(const Sim& sim, Index e, Eigen::Ref<VectorXf> g) const = 0;
    virtual GoalStep after_step(const Sim& sim, Index e, EpisodeEnd end) = 0;
    virtual const TrialCounter& trials() const = 0;
    virtual TrialOutcomes trial_outcomes() const = 0;
    virtual void clear_trials() = 0;
    virtual void save(Checkpoint& c, const std::string& prefix) const = 0;
    virtual void load(const Checkpoint& c, const std::string& prefix) = 0;
  };
  template <class T>
  struct Model final : Concept {
    explicit Model(T t) : task(std::move(t)) {}
    std::unique_ptr<Concept> clone() const override { return std::make_unique<Model>(task); }
    std::string name() const override { return task.name(); }
    Index goal_dim() const override { return task.goal_dim(); }
    void begin_iteration(long long it) override { task.begin_iteration(it); }
    void new_episode(Sim& sim, Index e) override { task.new_episode(sim, e); }
    void goal(const Sim& sim, Index e, Eigen::Ref<VectorXf> g) const override { task.goal(sim, e, g); }
    GoalStep after_step(const Sim& sim, Index e, EpisodeEnd end) override { return task.after_step(sim, e, end); }
    const TrialCounter& trials() const override { return task.trials(); }
    TrialOutcomes trial_outcomes() const override {
      if constexpr (requires { { task.trial_outcomes() } -> std::convertible_to<TrialOutcomes>; })
        return task.trial_outcomes();
      else
        return {};
    }
    void clear_trials() override { task.clear_trials(); }
    void save(Checkpoint& c, const std::string& prefix) const override { task.save(c, prefix); }
    void load(const Checkpoint& c, const std::string& prefix) override { task.load(c, prefix); }
    T task;
  };
  Concept& get() const {
    require(self_ != nullptr, "no goal task", {{}, {}, "task"});
    return *self_;
  }
  std::unique_ptr<Concept> self_;
};

/// One env after an imitation-task step (`task`: tasks::ImitationTask or anything with
/// terminated(), truncated(), sim() and restart_env(e)), with a goal task beside it.
struct GoalOutcome {
  float reward = 0.0f;         ///< the goal task's reward row
  bool terminated = false;     ///< the episode ended without bootstrapping (a fall, or the goal task ended it)
  bool truncated = false;      ///< the episode hit its time limit
  bool by_goal_task = false;   ///< the goal task ended it (the env was restarted here)
};

/// The goal task's side of one env's step, the same in training and evaluation: its reward; if
/// it ends the episode, the env is restarted; when the episode ended (either way), or the task
/// asked for its next goal, the goal task draws it (`new_episode`: new goal, scene objects placed).
template <Simulator Sim, class ImitationLike>
GoalOutcome advance_goal(AnyGoalTask<Sim>& goal, ImitationLike& task, Index e) {
  const auto u = static_cast<std::size_t>(e);
  GoalOutcome o;
  o.terminated = task.terminated()[u] != 0;
  o.truncated = !o.terminated && task.truncated()[u] != 0;
  const GoalStep g = goal.after_step(task.sim(), e,
                                     o.terminated ? EpisodeEnd::terminated : o.truncated ? EpisodeEnd::time_limit : EpisodeEnd::none);
  o.reward = g.reward;
  if (g.terminate && !o.terminated && !o.truncated) {
    task.restart_env(e);
    o.terminated = o.by_goal_task = true;
  }
  if (o.terminated || o.truncated || g.next_goal) goal.new_episode(task.sim(), e);
  return o;
}

// ---- helpers shared by the goal tasks ----------------------------------------------------------

/// Per-env RNG streams of a task: stream(seed, salt + first_env + e) for env e.
inline std::vector<Rng> env_streams(std::uint64_t seed, std::uint64_t salt, Index num_envs, Index first_env = 0) {
  require(first_env >= 0, "first_env must be >= 0", {{}, {}, "first_env"});
  std::vector<Rng> r;
  for (Index e = 0; e < num_envs; ++e) r.push_back(Rng::stream(seed, salt + static_cast<std::uint64_t>(first_env + e)));
  return r;
}

/// The root's facing direction on the ground (unit, from its orientation's x axis; +x if it points
/// straight up or down).
inline Vec3 facing_direction(const Quat& root_rot) {
  Vec3 f = root_rot * Vec3::UnitX();
  f.z() = 0;
  const double n = f.norm();
  return n > 1e-9 ? Vec3(f / n) : Vec3(Vec3::UnitX());
}

/// The horizontal offset from a root position to a target: its length (m) and unit direction
/// (meaningful only when the distance is > 0).
struct GroundBearing {
  double distance = 0;
  Vec3 direction = Vec3::Zero();
};
inline GroundBearing ground_bearing(const Vec3& root_pos, const Vec3& target) {
  Vec3 to = target - root_pos;
  to.z() = 0;
  const double dist = to.norm();
  return {dist, dist > 0 ? Vec3(to / dist) : Vec3(Vec3::Zero())};
}

/// exp(−k·(v* − d·v)²): how well the horizontal part of `root_vel` moves along the unit ground
/// direction d at speed v* (1 exactly at v*, the location task's term and the strike approach's).
inline double speed_toward_reward(const Vec3& d, const Vec3& root_vel, double speed, double k) {
  const double err = speed - d.dot(Vec3(root_vel.x(), root_vel.y(), 0.0));
  return std::exp(-k * err * err);
}

/// (1 + f·d)/2 for the root's facing f and a unit ground direction d: 0 facing away, 1 facing it.
inline double facing_toward_reward(const Quat& root_rot, const Vec3& d) {
  return 0.5 * (1 + facing_direction(root_rot).dot(d));
}

/// A horizontal world vector in the root's heading frame (x forward, y left): 2 numbers.
inline Eigen::Vector2d to_heading_frame(const Quat& root_rot, const Vec3& v) {
  const Vec3 f = facing_direction(root_rot);
  const Vec3 l(-f.y(), f.x(), 0.0);
  return {f.dot(v), l.dot(v)};
}

/// Saves / loads per-env RNG streams and small per-env vectors under a prefix.
inline void save_streams(Checkpoint& c, const std::string& prefix, const std::vector<Rng>& rngs) {
  for (std::size_t e = 0; e < rngs.size(); ++e) c.put_rng(prefix + "rng/" + std::to_string(e), rngs[e]);
}
inline void load_streams(const Checkpoint& c, const std::string& prefix, std::vector<Rng>& rngs) {
  for (std::size_t e = 0; e < rngs.size(); ++e) rngs[e].set_state(c.get_rng(prefix + "rng/" + std::to_string(e)));
}

/// Goal resampling schedule: each env holds a goal for a uniform number of control steps in
/// [min_steps, max_steps].
struct GoalSchedule {
  Index min_steps = 150, max_steps = 300;
  void validate(const std::string& field) const {
    require(min_steps >= 1 && max_steps >= min_steps, "goal schedule needs 1 <= min_steps <= max_steps", {{}, {}, field});
  }
  Index draw(Rng& r) const { return min_steps + static_cast<Index>(r.uniform_int(static_cast<std::uint64_t>(max_steps - min_steps + 1))); }
};

}  // namespace maskadapt::tasks
