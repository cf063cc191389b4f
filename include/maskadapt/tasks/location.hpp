#pragma once
/// \file location.hpp
/// Target location (MaskAdapt supp. §B): move the root to a target on the ground.
///
///  - reward: 1 inside the goal radius R (horizontal root–target distance ≤ R), otherwise
///    exp(−k·(v* − d·v_root)²), d the horizontal unit direction from the root to the target,
///    v_root the root's horizontal velocity, v* the target speed. The paper's k is unreadable in
///    its text; we use k = 4 s²/m², the velocity-error scale of the location task in the prior work
///    it follows (ASE, Peng et al. 2022; 0.25 is ASE's heading scale, which a wave-1 version used
///    here by mistake: standing still then scored exp(−0.25) = 0.78). Unlike ASE we do not clip
///    the error at 0 (the paper's formula does not), so walking faster than v* costs too;
///    With `facing_weight` w > 0 the reward outside R is shaped for turning (not the paper's):
///    (1 − w)·exp(−k·(v* − d·v_root)²) + w·(1 + f·d)/2, f the root's facing direction on the
///    ground. The paper's term is ≈ 0 whenever the target is more than ≈ 90° off the walking
///    direction (d·v ≤ 0 ⇒ exp(−4) ≈ 0.02 for v* = 1 m/s), so half of all targets give no gradient
///    toward turning; (1 + f·d)/2 rises from 0 (target behind) to 1 (target ahead) everywhere.
///    With `position_weight` p > 0 as well (not the paper's; ASE's position term):
///    (1 − w − p)·exp(−k·(v* − d·v_root)²) + w·(1 + f·d)/2 + p·exp(−k_p·‖Δxy‖²), k_p = 0.5 /m².
///    A walker that heads for its target but cannot aim within R passes it by at full speed and
///    loops back (measured: docs/results.md, "Stage 2 recipe"); the velocity and facing terms
///    stay near 1 on such a pass until the target is abeam, while the position term pays for the
///    metres closer it gets;
///    With `arrive_distance` ρ > 0 (not the paper's; an "arrive" behaviour) the velocity term's
///    target speed falls with the distance d to the target: v*(d) = v*·min(1, d/ρ), so that a
///    walker that slows down near the target (and can turn onto it) is paid for it; the goal
///    observation keeps showing v* (evaluation runs the paper's reward, ρ = 0);
///  - reach bonus (training only, not the paper's): with `reach_bonus` B > 0, the step on which
///    the root first comes within R of its target earns B more, the trial closes as a success and
///    the next target is drawn at once (ASE and CML change goals several times an episode). A
///    walker that passes its target at 0.6 m then earns nothing a walker passing at 1.6 m does
///    not; one that hits it earns B. Without it the reward on a pass and on a hit differ by a few
///    per cent (the velocity and facing terms are ≈ 1 on the approach either way);
///  - goal observation g ∈ R⁴: d in the root's heading frame (2), v* (1), distance (1, m);
///  - success: the root comes within R of the target while the trial's goal is held; a trial the
///    episode's time limit cuts short is not counted (censored; goal_task.hpp, "Trials");
///  - schedule: a new target every `schedule` steps (uniform), drawn at a uniform angle and a
///    distance in [min_distance, max_distance] from the root; a trial is one target;
///  - divergence termination (not the paper's; CML's location task ends its episodes so): with
///    `divergence_distance` D > 0 the episode ends, its trial failed unless the target was already
///    reached, once the root is more than D farther from the target than when it was drawn.
#include <maskadapt/tasks/goal_task.hpp>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace maskadapt::tasks {

struct LocationConfig {
  double radius = 0.5;          ///< R (m)
  double speed = 1.0;           ///< v* (m/s)
  double velocity_scale = 4.0;  ///< k (s²/m²)
  double facing_weight = 0.0;   ///< w of the facing shaping term (0: the paper's reward)
  double position_weight = 0.0; ///< p of the position shaping term (0: the paper's reward)
  double position_scale = 0.5;  ///< k_p (1/m², ASE's)
  double min_distance = 1.0, max_distance = 5.0;  ///< target distance from the root when drawn (m)
  GoalSchedule schedule{150, 300};                ///< steps a target is held (5–10 s at 30 Hz)
  double divergence_distance = 0.0;  ///< D (m): end the episode when the target is D farther than when drawn; 0 = never (CML: 3)
  double arrive_distance = 0.0;      ///< ρ (m): v*(d) = v*·min(1, d/ρ) in the velocity term; 0 = v* everywhere (the paper's)
  double reach_bonus = 0.0;          ///< B: reward added on reaching a target, which is then redrawn at once; 0 = none (the paper's)
  std::uint64_t seed = 1;
  /// Global index of env 0: env e draws from the stream of env first_env + e (a distributed run's
  /// rank offset, so each env has its one-process stream; train/distributed.hpp).
  Index first_env = 0;

  void validate() const {
    require(radius > 0 && speed > 0 && velocity_scale > 0, "radius, speed and velocity_scale must be > 0",
            {{}, {}, "location"});
    require(std::isfinite(facing_weight) && facing_weight >= 0 && facing_weight <= 1, "must be in [0, 1]",
            {{}, {}, "location.facing_weight"});
    require(std::isfinite(position_weight) && position_weight >= 0 && facing_weight + position_weight <= 1,
            "must be >= 0, with facing_weight + position_weight <= 1", {{}, {}, "location.position_weight"});
    require(std::isfinite(position_scale) && position_scale > 0, "must be > 0", {{}, {}, "location.position_scale"});
    require(min_distance > 0 && max_distance >= min_distance, "need 0 < min_distance <= max_distance",
            {{}, {}, "location.distance"});
    schedule.validate("location.schedule");
    require(std::isfinite(divergence_distance) && divergence_distance >= 0, "must be finite and >= 0 (0 = never)",
            {{}, {}, "location.divergence_distance"});
    require(std::isfinite(arrive_distance) && arrive_distance >= 0 && arrive_distance <= 100, "must be in [0, 100] m (0 = off)",
            {{}, {}, "location.arrive_distance"});
    require(std::isfinite(reach_bonus) && reach_bonus >= 0 && reach_bonus <= 1000, "must be in [0, 1000] (0 = off)",
            {{}, {}, "location.reach_bonus"});
  }

  /// The velocity term's target speed at horizontal distance d from the target (m/s; see
  /// `arrive_distance`).
  double target_speed(double d) const { return arrive_distance > 0 ? speed * std::min(1.0, d / arrive_distance) : speed; }
};

/// The reward of one step (see the file comment). Positions and velocities in world metres.
inline double location_reward(const Vec3& root_pos, const Vec3& root_vel, const Vec3& target, const LocationConfig& c) {
  const GroundBearing to = ground_bearing(root_pos, target);
  if (to.distance <= c.radius) return 1.0;
  return speed_toward_reward(to.direction, root_vel, c.speed, c.velocity_scale);
}

/// The reward with the facing, position and arrive shaping (see the file comment); `root_rot` gives
/// the facing. facing_weight = position_weight = arrive_distance = 0 is exactly the paper's reward
/// above. (The reach bonus is the task's, paid in LocationTask::after_step.)
inline double location_reward(const Vec3& root_pos, const Quat& root_rot, const Vec3& root_vel, const Vec3& target,
                              const LocationConfig& c) {
  const GroundBearing to = ground_bearing(root_pos, target);
  if (to.distance <= c.radius) return 1.0;
  return (1 - c.facing_weight - c.position_weight) *
             speed_toward_reward(to.direction, root_vel, c.target_speed(to.distance), c.velocity_scale) +
         c.facing_weight * facing_toward_reward(root_rot, to.direction) +
         c.position_weight * std::exp(-c.position_scale * to.distance * to.distance);
}

/// g ∈ R⁴ = [d in the heading frame (2), v*, distance].
inline void location_goal(const Vec3& root_pos, const Quat& root_rot, const Vec3& target, const LocationConfig& c,
                          Eigen::Ref<VectorXf> g) {
  require(g.size() == 4, "location goal has 4 rows", {{}, {}, "goal"});
  Vec3 to = target - root_pos;
  to.z() = 0;
  const double dist = to.norm();
  const Eigen::Vector2d d = dist > 1e-9 ? to_heading_frame(root_rot, to / dist) : Eigen::Vector2d::Zero();
  g << static_cast<float>(d.x()), static_cast<float>(d.y()), static_cast<float>(c.speed), static_cast<float>(dist);
}

class LocationTask {
 public:
  LocationTask(LocationConfig c, Index num_envs) : c_((c.validate(), c)), rngs_(env_streams(c_.seed, 0x10CA7000ULL, num_envs, c_.first_env)) {
    const auto n = static_cast<std::size_t>(num_envs);
    target_.assign(n, Vec3::Zero());
    start_distance_.assign(n, 0.0);
    steps_left_.assign(n, 0);
    reached_.assign(n, 0);
    last_reward_.assign(n, 0.0f);
  }
  std::string name() const { return "location"; }
  Index goal_dim() const { return 4; }
  const LocationConfig& config() const { return c_; }
  void begin_iteration(long long) {}

  template <Simulator Sim>
  void new_episode(Sim& sim, Index e) {
    draw_target(sim.body_states(static_cast<std::size_t>(e)).pos.col(0), e);
  }
  template <Simulator Sim>
  void goal(const Sim& sim, Index e, Eigen::Ref<VectorXf> g) const {
    const BodyStates& b = sim.body_states(static_cast<std::size_t>(e));
    location_goal(b.pos.col(0), b.rot[0], target_[idx(e)], c_, g);
  }
  template <Simulator Sim>
  GoalStep after_step(const Sim& sim, Index e, EpisodeEnd end) {
    const auto u = idx(e);
    if (end == EpisodeEnd::time_limit) {  // cut short: censored (goal_task.hpp, "Trials")
      trials_.censor();
      return {last_reward_[u], false};
    }
    if (end == EpisodeEnd::terminated) {  // a fall: failed unless already reached
      trials_.add(reached_[u] != 0);
      return {last_reward_[u], false};
    }
    const BodyStates& b = sim.body_states(u);
    const Vec3 p = b.pos.col(0);
    last_reward_[u] = static_cast<float>(location_reward(p, b.rot[0], b.lin_vel.col(0), target_[u], c_));
    Vec3 to = target_[u] - p;
    to.z() = 0;
    const double dist = to.norm();  // horizontal distance to the target (m)
    if (dist <= c_.radius && c_.reach_bonus > 0) {  // reached: paid, a success, the next target
      trials_.add(true);
      draw_target(p, e);
      return {last_reward_[u] + static_cast<float>(c_.reach_bonus), false};
    }
    if (dist <= c_.radius) reached_[u] = 1;
    if (c_.divergence_distance > 0 && dist > start_distance_[u] + c_.divergence_distance) {
      trials_.add(reached_[u] != 0);  // the episode ends here; new_episode draws the next target
      return {last_reward_[u], true};
    }
    if (--steps_left_[u] <= 0) {
      trials_.add(reached_[u] != 0);
      draw_target(p, e);
    }
    return {last_reward_[u], false};
  }
  const TrialCounter& trials() const { return trials_; }
  void clear_trials() { trials_ = {}; }
  /// Env e's current target (world, m).
  const Vec3& target(Index e) const { return target_[idx(e)]; }
  /// Places env e's target (tests, play schedules); the trial restarts.
  void set_target(Index e, const Vec3& t, Index steps) {
    target_[idx(e)] = t;
    start_distance_[idx(e)] = std::numeric_limits<double>::infinity();  // (no root here: no divergence test)
    steps_left_[idx(e)] = steps;
    reached_[idx(e)] = 0;
  }

  void save(Checkpoint& c, const std::string& prefix) const {
    const auto n = static_cast<Index>(target_.size());
    MatrixXd t(3, n);
    VectorX<std::int64_t> s(n), r(n);
    VectorXf lr(n);
    VectorXd sd(n);
    for (Index e = 0; e < n; ++e) {
      t.col(e) = target_[idx(e)];
      sd[e] = start_distance_[idx(e)];
      s[e] = steps_left_[idx(e)];
      r[e] = reached_[idx(e)];
      lr[e] = last_reward_[idx(e)];
    }
    c.put(prefix + "target", t);
    c.put(prefix + "steps_left", s);
    c.put(prefix + "reached", r);
    c.put(prefix + "last_reward", lr);
    c.put(prefix + "start_distance", sd);
    save_streams(c, prefix, rngs_);
  }
  void load(const Checkpoint& c, const std::string& prefix) {
    const auto n = static_cast<Index>(target_.size());
    const MatrixXd t = c.get_matrix<double>(prefix + "target", 3, n);
    const auto s = c.get_vector<std::int64_t>(prefix + "steps_left", n);
    const auto r = c.get_vector<std::int64_t>(prefix + "reached", n);
    const auto lr = c.get_vector<float>(prefix + "last_reward", n);
    // (absent in checkpoints written before the divergence test existed: no test until the next target)
    const VectorXd sd = c.contains(prefix + "start_distance") ? c.get_vector<double>(prefix + "start_distance", n)
                                                              : VectorXd::Constant(n, std::numeric_limits<double>::infinity());
    load_streams(c, prefix, rngs_);
    for (Index e = 0; e < n; ++e) {
      target_[idx(e)] = t.col(e);
      steps_left_[idx(e)] = s[e];
      reached_[idx(e)] = static_cast<std::uint8_t>(r[e] != 0);
      last_reward_[idx(e)] = lr[e];
      start_distance_[idx(e)] = sd[e];
    }
  }

 private:
  static std::size_t idx(Index e) { return static_cast<std::size_t>(e); }
  void draw_target(const Vec3& root, Index e) {
    auto& r = rngs_[idx(e)];
    const double angle = r.uniform(-M_PI, M_PI), dist = r.uniform(c_.min_distance, c_.max_distance);
    target_[idx(e)] = Vec3(root.x() + dist * std::cos(angle), root.y() + dist * std::sin(angle), 0.0);
    start_distance_[idx(e)] = dist;
    steps_left_[idx(e)] = c_.schedule.draw(r);
    reached_[idx(e)] = 0;
  }

  LocationConfig c_;
  std::vector<Rng> rngs_;
  std::vector<Vec3> target_;
  std::vector<double> start_distance_;  ///< horizontal root–target distance when the target was drawn (m)
  std::vector<Index> steps_left_;
  std::vector<std::uint8_t> reached_;
  std::vector<float> last_reward_;
  TrialCounter trials_;
};

}  // namespace maskadapt::tasks
