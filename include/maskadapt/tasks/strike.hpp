#pragma once
/// \file strike.hpp
/// Strike (MaskAdapt supp. §B): approach a box and knock it over — with the hands.
///
///  - needs a `SceneSimulator` (sim/scene.hpp) whose object `object` is the box;
///  - reward: 1 − u_world·u_box, u_world = (0, 0, 1), u_box the box's up axis (0 upright, 1 on its
///    side);
///  - goal observation g ∈ R¹⁵, the box's state in the root's heading frame H (yaw only):
///    position relative to the root H^T(p_box − p_root) (3, m), orientation H^T R_box as its first
///    two columns (6), linear velocity H^T v (3, m/s), angular velocity H^T ω (3, rad/s);
///  - success: the box tilts beyond 78° (u_world·u_box < 0.2) in a trial whose first contact
///    between character and box was by a strike body (the hands: the paper requires a wrist
///    strike; a box kicked or shouldered over does not count). The trial is the episode; the box
///    is placed upright and at rest at a uniform angle and a distance in [min_distance,
///    max_distance] from the root when an episode starts.
///    With `approach_weight` w > 0 the reward is shaped for the approach (not the paper's; ASE's
///    strike mixes an approach term 0.4 / 0.6 the same way): (1 − w)·(1 − u_world·u_box) +
///    w·approach, approach = 1 within `reach` of the box (horizontal, root to box centre) or once
///    the box has tilted past the success angle, else 0.5·exp(−4·(v* − d·v)²) + 0.5·(1 + f·d)/2
///    (d the direction to the box, v the root's horizontal velocity, f its facing; v* =
///    `approach_speed`): the paper's reward is 0 until the box tilts, so a walker that has not yet
///    found the box gets no gradient toward it.
///    With `end_on_foreign_contact`, a first contact by any other body ends the episode (ASE's
///    strike task does this); off by default, as the paper lets other bodies touch the box.
///  - training only, `next_box_steps` k > 0 (not the paper's; ASE and CML change goals several
///    times an episode): k control steps after the box tilted past the success angle the trial
///    closes (a success if the hands touched first) and a new box is placed, as at an episode's
///    start but from where the character now is (`GoalStep::next_goal`). With k = 0 (the default,
///    and always in evaluation) a tilted box lies there until the episode ends, and every step
///    after the tilt earns the same reward whatever the policy does.
///  - trial outcomes (`trial_outcomes()`, for the logs and `eval-residual`), each ended trial
///    counted once, in this order of precedence: `struck` (the success), `tilted_other_first`
///    (the box tilted, but another body touched it first), `fell` (a fall ended it, box upright),
///    `hands_no_tilt`, `other_no_tilt` (touched first by the hands / by another body, still
///    upright; a trial ended by `end_on_foreign_contact` is `other_no_tilt`), `untouched`.
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/sim/scene.hpp>
#include <maskadapt/tasks/goal_task.hpp>

#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace maskadapt::tasks {

struct StrikeConfig {
  std::size_t object = 0;          ///< index of the box among the simulator's objects
  double box_half_height = 0.6;    ///< m: the box is placed standing on the floor
  double min_distance = 1.0, max_distance = 3.0;  ///< box distance from the root when placed (m)
  double success_cos = 0.2;        ///< success: u_world·u_box below this (cos 78.5°)
  std::vector<int> strike_bodies;  ///< skeleton bodies whose contact counts as a strike (the hands)
  bool end_on_foreign_contact = false;
  double approach_weight = 0.0;    ///< w of the approach shaping term (0: the paper's reward)
  double approach_speed = 1.0;     ///< v* of the approach term (m/s)
  double reach = 1.0;              ///< approach = 1 within this horizontal distance of the box (m)
  int next_box_steps = 0;          ///< training only: a new box this many steps after a tilt (0: one box per episode)
  std::uint64_t seed = 1;
  /// Global index of env 0: env e draws from the stream of env first_env + e (a distributed run's
  /// rank offset, so each env has its one-process stream; train/distributed.hpp).
  Index first_env = 0;

  void validate() const {
    require(box_half_height > 0, "box_half_height must be > 0", {{}, {}, "strike.box_half_height"});
    require(min_distance > 0 && max_distance >= min_distance, "need 0 < min_distance <= max_distance",
            {{}, {}, "strike.distance"});
    require(success_cos > -1 && success_cos < 1, "success_cos must be in (-1, 1)", {{}, {}, "strike.success_cos"});
    require(std::isfinite(approach_weight) && approach_weight >= 0 && approach_weight <= 1, "must be in [0, 1]",
            {{}, {}, "strike.approach_weight"});
    require(approach_speed > 0 && reach > 0, "approach_speed and reach must be > 0", {{}, {}, "strike.approach"});
    require(!strike_bodies.empty(), "strike needs at least one strike body (the hands)", {{}, {}, "strike.strike_bodies"});
    require(next_box_steps >= 0 && next_box_steps <= 100000, "must be in [0, 100000] steps (0: one box per episode)",
            {{}, {}, "strike.next_box_steps"});
  }
};

/// Body indices of `names` in `skel` (throws naming the missing one).
inline std::vector<int> bodies_by_name(const Skeleton& skel, const std::vector<std::string>& names) {
  std::vector<int> out;
  for (const auto& n : names) {
    int found = -1;
    for (int i = 0; i < skel.num_bodies(); ++i)
      if (skel.names[static_cast<std::size_t>(i)] == n) found = i;
    require(found >= 0, "the skeleton has no body '" + n + "'", {{}, {}, "strike.strike_bodies"});
    out.push_back(found);
  }
  return out;
}

/// u_world·u_box: the cosine of the box's tilt.
inline double box_uprightness(const Quat& box_rot) { return (box_rot * Vec3::UnitZ()).z(); }

/// The reward 1 − u_world·u_box.
inline double strike_reward(const Quat& box_rot) { return 1.0 - box_uprightness(box_rot); }

/// The approach term (see the file comment): 1 within `reach` of the box or once it has tilted,
/// else half velocity toward the box, half facing it. World positions and velocities.
inline double strike_approach(const Vec3& root_pos, const Quat& root_rot, const Vec3& root_vel, const Vec3& box_pos,
                              bool tilted, const StrikeConfig& c) {
  const GroundBearing to = ground_bearing(root_pos, box_pos);
  if (tilted || to.distance <= c.reach) return 1.0;
  return 0.5 * speed_toward_reward(to.direction, root_vel, c.approach_speed, 4.0) +
         0.5 * facing_toward_reward(root_rot, to.direction);
}

/// The shaped reward (1 − w)·(1 − u_world·u_box) + w·approach; w = 0 is strike_reward.
inline double strike_reward(const Quat& box_rot, double approach, const StrikeConfig& c) {
  return (1 - c.approach_weight) * strike_reward(box_rot) + c.approach_weight * approach;
}

/// g ∈ R¹⁵ (see the file comment).
inline void strike_goal(const Vec3& root_pos, const Quat& root_rot, const RigidState& box, Eigen::Ref<VectorXf> g) {
  require(g.size() == 15, "strike goal has 15 rows", {{}, {}, "goal"});
  const Mat3 Ht = heading_rotation(root_rot).toRotationMatrix().transpose();
  const Vec3 p = Ht * (box.pos - root_pos);
  const Mat3 R = Ht * box.rot.toRotationMatrix();
  const Vec3 v = Ht * box.lin_vel, w = Ht * box.ang_vel;
  g << static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()),
      static_cast<float>(R(0, 0)), static_cast<float>(R(1, 0)), static_cast<float>(R(2, 0)),
      static_cast<float>(R(0, 1)), static_cast<float>(R(1, 1)), static_cast<float>(R(2, 1)),
      static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z()),
      static_cast<float>(w.x()), static_cast<float>(w.y()), static_cast<float>(w.z());
}

/// Who touched the box first in a trial.
enum class FirstContact : std::uint8_t { None = 0, Strike = 1, Foreign = 2 };

class StrikeTask {
 public:
  StrikeTask(StrikeConfig c, Index num_envs) : c_((c.validate(), std::move(c))), rngs_(env_streams(c_.seed, 0x57121000ULL, num_envs, c_.first_env)) {
    const auto n = static_cast<std::size_t>(num_envs);
    first_.assign(n, FirstContact::None);
    tilted_.assign(n, 0);
    since_tilt_.assign(n, 0);
    last_reward_.assign(n, 0.0f);
  }
  std::string name() const { return "strike"; }
  Index goal_dim() const { return 15; }
  const StrikeConfig& config() const { return c_; }
  void begin_iteration(long long) {}

  template <SceneSimulator Sim>
  void new_episode(Sim& sim, Index e) {
    require(c_.object < sim.num_objects(), "the simulator has no object " + std::to_string(c_.object) + " for the strike box",
            {{}, {}, "strike.object"});
    auto& r = rngs_[idx(e)];
    const Vec3 root = sim.body_states(idx(e)).pos.col(0);
    const double angle = r.uniform(-M_PI, M_PI), dist = r.uniform(c_.min_distance, c_.max_distance);
    RigidState box;
    box.pos = Vec3(root.x() + dist * std::cos(angle), root.y() + dist * std::sin(angle), c_.box_half_height);
    box.rot = Quat(Eigen::AngleAxisd(r.uniform(-M_PI, M_PI), Vec3::UnitZ()));
    sim.place_object(idx(e), c_.object, box);
    first_[idx(e)] = FirstContact::None;
    tilted_[idx(e)] = 0;
    since_tilt_[idx(e)] = 0;
  }
  template <SceneSimulator Sim>
  void goal(const Sim& sim, Index e, Eigen::Ref<VectorXf> g) const {
    const BodyStates& b = sim.body_states(idx(e));
    strike_goal(b.pos.col(0), b.rot[0], sim.object_state(idx(e), c_.object), g);
  }
  template <SceneSimulator Sim>
  GoalStep after_step(const Sim& sim, Index e, EpisodeEnd end) {
    const auto u = idx(e);
    if (end != EpisodeEnd::none) {  // the trial ends with the episode: its time limit is the trial's end
      close_trial(u, end == EpisodeEnd::terminated);
      return {last_reward_[u], false};
    }
    const RigidState& box = sim.object_state(u, c_.object);
    if (first_[u] == FirstContact::None) first_[u] = classify_contact(sim.object_contacts(u, c_.object));
    if (box_uprightness(box.rot) < c_.success_cos) tilted_[u] = 1;
    const BodyStates& b = sim.body_states(u);
    const double approach = strike_approach(b.pos.col(0), b.rot[0], b.lin_vel.col(0), box.pos, tilted_[u] != 0, c_);
    last_reward_[u] = static_cast<float>(strike_reward(box.rot, approach, c_));  // (w = 0: exactly 1 − u·u_box)
    if (c_.end_on_foreign_contact && first_[u] == FirstContact::Foreign) {
      close_trial(u, false);
      return {last_reward_[u], true};
    }
    if (c_.next_box_steps > 0 && tilted_[u] != 0 && ++since_tilt_[u] >= c_.next_box_steps) {
      close_trial(u, false);
      return {last_reward_[u], false, true};  // the next box: new_episode, the env goes on
    }
    return {last_reward_[u], false};
  }
  /// The success test on env e's current trial.
  bool success(Index e) const { return tilted_[idx(e)] != 0 && first_[idx(e)] == FirstContact::Strike; }
  FirstContact first_contact(Index e) const { return first_[idx(e)]; }
  /// First contact of a step's flags: Strike if a strike body touched (even with others), Foreign
  /// if only others did, None if nobody did.
  FirstContact classify_contact(const ContactFlags& flags) const {
    bool strike = false, other = false;
    for (std::size_t b = 0; b < flags.size(); ++b) {
      if (!flags[b]) continue;
      bool is_strike = false;
      for (int s : c_.strike_bodies) is_strike |= (static_cast<std::size_t>(s) == b);
      (is_strike ? strike : other) = true;
    }
    return strike ? FirstContact::Strike : other ? FirstContact::Foreign : FirstContact::None;
  }
  const TrialCounter& trials() const { return trials_; }
  /// How the trials since clear_trials() ended (see the file comment).
  TrialOutcomes trial_outcomes() const {
    static constexpr const char* kNames[kOutcomes] = {"struck", "tilted_other_first", "fell",
                                                      "hands_no_tilt", "other_no_tilt", "untouched"};
    TrialOutcomes out;
    for (std::size_t k = 0; k < kOutcomes; ++k) out.emplace_back(kNames[k], outcomes_[k]);
    return out;
  }
  void clear_trials() {
    trials_ = {};
    outcomes_ = {};
  }

  void save(Checkpoint& c, const std::string& prefix) const {
    const auto n = static_cast<Index>(first_.size());
    VectorX<std::int64_t> f(n), t(n);
    VectorXf lr(n);
    for (Index e = 0; e < n; ++e) {
      f[e] = static_cast<std::int64_t>(first_[idx(e)]);
      t[e] = tilted_[idx(e)];
      lr[e] = last_reward_[idx(e)];
    }
    c.put(prefix + "first_contact", f);
    c.put(prefix + "tilted", t);
    c.put(prefix + "last_reward", lr);
    VectorX<std::int64_t> st(n);
    for (Index e = 0; e < n; ++e) st[e] = since_tilt_[idx(e)];
    c.put(prefix + "since_tilt", st);
    save_streams(c, prefix, rngs_);
  }
  void load(const Checkpoint& c, const std::string& prefix) {
    const auto n = static_cast<Index>(first_.size());
    const auto f = c.get_vector<std::int64_t>(prefix + "first_contact", n), t = c.get_vector<std::int64_t>(prefix + "tilted", n);
    const auto lr = c.get_vector<float>(prefix + "last_reward", n);
    // (absent before next_box_steps existed, when it was always 0)
    const auto st = c.contains(prefix + "since_tilt") ? c.get_vector<std::int64_t>(prefix + "since_tilt", n)
                                                       : VectorX<std::int64_t>::Zero(n).eval();
    for (Index e = 0; e < n; ++e) {
      require(f[e] >= 0 && f[e] <= 2, "first-contact code out of range", {c.source(), std::nullopt, prefix + "first_contact"});
      require(st[e] >= 0 && st[e] <= 100000, "steps since the tilt out of range", {c.source(), std::nullopt, prefix + "since_tilt"});
    }
    load_streams(c, prefix, rngs_);
    for (Index e = 0; e < n; ++e) {
      since_tilt_[idx(e)] = static_cast<int>(st[e]);
      first_[idx(e)] = static_cast<FirstContact>(f[e]);
      tilted_[idx(e)] = static_cast<std::uint8_t>(t[e] != 0);
      last_reward_[idx(e)] = lr[e];
    }
  }

 private:
  static constexpr std::size_t kOutcomes = 6;
  static std::size_t idx(Index e) { return static_cast<std::size_t>(e); }
  /// Counts env u's trial (`fell`: a fall ended it) under its outcome (see the file comment).
  void close_trial(std::size_t u, bool fell) {
    const bool ok = success(static_cast<Index>(u));
    trials_.add(ok);
    const std::size_t k = ok ? 0 : tilted_[u] != 0 ? 1 : fell ? 2 : first_[u] == FirstContact::Strike ? 3
                                   : first_[u] == FirstContact::Foreign ? 4 : 5;
    ++outcomes_[k];
  }
  StrikeConfig c_;
  std::vector<Rng> rngs_;
  std::vector<FirstContact> first_;
  std::vector<std::uint8_t> tilted_;
  std::vector<int> since_tilt_;  ///< control steps since the box tilted (next_box_steps)
  std::vector<float> last_reward_;
  TrialCounter trials_;
  std::array<long long, kOutcomes> outcomes_{};
};

}  // namespace maskadapt::tasks
