#pragma once
/// \file heading.hpp
/// Heading (MaskAdapt supp. §B): move in a target direction d at a target speed s*.
///
///  - reward: 0.7·exp(−0.25·((s* − v_d)² + 0.1·‖v_⊥‖²)) + 0.3·max(d·f, 0), with v the root's
///    horizontal velocity, v_d = d·v its component along d, v_⊥ = v − v_d·d, f the root's facing
///    direction on the ground;
///  - goal observation g ∈ R³: d in the root's heading frame (2), s* (1, m/s);
///  - success: |s* − v̄_d| < 0.5 m/s at the end of the trial, v̄_d the mean of v_d over the trial's
///    last `success_window` steps (1 s: a gait's velocity swings within a stride); a trial shorter
///    than the window fails. The paper states the threshold, not the averaging; we average so the
///    test does not depend on the gait phase at which the goal happens to change. A trial the
///    episode's time limit cuts short is not counted (censored; goal_task.hpp, "Trials");
///  - schedule: a new (d, s*) every `schedule` steps: d at a uniform angle within ±max_turn of the
///    root's facing, s* uniform in [min_speed, max_speed]; a trial is one (d, s*).
#include <maskadapt/tasks/goal_task.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace maskadapt::tasks {

struct HeadingConfig {
  double min_speed = 0.5, max_speed = 1.5;  ///< s* range (m/s)
  double max_turn = M_PI;                   ///< d within ±max_turn of the facing when drawn (rad)
  double tolerance = 0.5;                   ///< success: |s* − v̄_d| < tolerance (m/s)
  Index success_window = 30;                ///< steps averaged for the success test
  GoalSchedule schedule{150, 300};
  std::uint64_t seed = 1;
  /// Global index of env 0: env e draws from the stream of env first_env + e (a distributed run's
  /// rank offset, so each env has its one-process stream; train/distributed.hpp).
  Index first_env = 0;

  void validate() const {
    require(min_speed >= 0 && max_speed >= min_speed, "need 0 <= min_speed <= max_speed", {{}, {}, "heading.speed"});
    require(max_turn >= 0 && max_turn <= M_PI, "max_turn must be in [0, pi]", {{}, {}, "heading.max_turn"});
    require(tolerance > 0 && success_window >= 1, "tolerance > 0 and success_window >= 1", {{}, {}, "heading"});
    schedule.validate("heading.schedule");
  }
};

/// The reward of one step; `dir` a horizontal unit vector (world), velocities in m/s.
inline double heading_reward(const Vec3& root_vel, const Quat& root_rot, const Vec3& dir, double speed) {
  const Vec3 v(root_vel.x(), root_vel.y(), 0.0);
  const double vd = dir.dot(v);
  const double vperp2 = (v - vd * dir).squaredNorm();
  const double e = speed - vd;
  return 0.7 * std::exp(-0.25 * (e * e + 0.1 * vperp2)) + 0.3 * std::max(dir.dot(facing_direction(root_rot)), 0.0);
}

/// g ∈ R³ = [d in the heading frame (2), s*].
inline void heading_goal(const Quat& root_rot, const Vec3& dir, double speed, Eigen::Ref<VectorXf> g) {
  require(g.size() == 3, "heading goal has 3 rows", {{}, {}, "goal"});
  const Eigen::Vector2d d = to_heading_frame(root_rot, dir);
  g << static_cast<float>(d.x()), static_cast<float>(d.y()), static_cast<float>(speed);
}

class HeadingTask {
 public:
  HeadingTask(HeadingConfig c, Index num_envs) : c_((c.validate(), c)), rngs_(env_streams(c_.seed, 0x4EAD0000ULL, num_envs, c_.first_env)) {
    const auto n = static_cast<std::size_t>(num_envs);
    dir_.assign(n, Vec3::UnitX());
    speed_.assign(n, 0.0);
    steps_left_.assign(n, 0);
    recent_.assign(n, std::vector<double>(static_cast<std::size_t>(c_.success_window), 0.0));
    count_.assign(n, 0);
    last_reward_.assign(n, 0.0f);
  }
  std::string name() const { return "heading"; }
  Index goal_dim() const { return 3; }
  const HeadingConfig& config() const { return c_; }
  void begin_iteration(long long) {}

  template <Simulator Sim>
  void new_episode(Sim& sim, Index e) {
    draw_goal(sim.body_states(static_cast<std::size_t>(e)).rot[0], e);
  }
  template <Simulator Sim>
  void goal(const Sim& sim, Index e, Eigen::Ref<VectorXf> g) const {
    heading_goal(sim.body_states(static_cast<std::size_t>(e)).rot[0], dir_[idx(e)], speed_[idx(e)], g);
  }
  template <Simulator Sim>
  GoalStep after_step(const Sim& sim, Index e, EpisodeEnd end) {
    const auto u = idx(e);
    if (end == EpisodeEnd::time_limit) {  // cut short: censored (goal_task.hpp, "Trials")
      trials_.censor();
      return {last_reward_[u], false};
    }
    if (end == EpisodeEnd::terminated) {  // a fall
      trials_.add(success(e));
      return {last_reward_[u], false};
    }
    const BodyStates& b = sim.body_states(u);
    const Vec3 v = b.lin_vel.col(0);
    last_reward_[u] = static_cast<float>(heading_reward(v, b.rot[0], dir_[u], speed_[u]));
    recent_[u][static_cast<std::size_t>(count_[u] % c_.success_window)] = dir_[u].dot(Vec3(v.x(), v.y(), 0.0));
    ++count_[u];
    if (--steps_left_[u] <= 0) {
      trials_.add(success(e));
      draw_goal(b.rot[0], e);
    }
    return {last_reward_[u], false};
  }
  /// The success test on env e's current trial (see the file comment).
  bool success(Index e) const {
    const auto u = idx(e);
    if (count_[u] < c_.success_window) return false;
    double mean = 0;
    for (double x : recent_[u]) mean += x;
    mean /= static_cast<double>(c_.success_window);
    return std::abs(speed_[u] - mean) < c_.tolerance;
  }
  const TrialCounter& trials() const { return trials_; }
  void clear_trials() { trials_ = {}; }
  const Vec3& direction(Index e) const { return dir_[idx(e)]; }
  double speed(Index e) const { return speed_[idx(e)]; }
  /// Sets env e's goal (tests, play schedules); the trial restarts.
  void set_goal(Index e, const Vec3& dir, double speed, Index steps) {
    require(std::abs(dir.z()) < 1e-12 && std::abs(dir.norm() - 1) < 1e-9, "heading direction must be a horizontal unit vector",
            {{}, {}, "heading.direction"});
    dir_[idx(e)] = dir;
    speed_[idx(e)] = speed;
    steps_left_[idx(e)] = steps;
    count_[idx(e)] = 0;
  }

  void save(Checkpoint& c, const std::string& prefix) const {
    const auto n = static_cast<Index>(dir_.size()), W = c_.success_window;
    MatrixXd d(3, n), rec(W, n);
    VectorXd s(n);
    VectorX<std::int64_t> left(n), cnt(n);
    VectorXf lr(n);
    for (Index e = 0; e < n; ++e) {
      d.col(e) = dir_[idx(e)];
      s[e] = speed_[idx(e)];
      left[e] = steps_left_[idx(e)];
      cnt[e] = count_[idx(e)];
      lr[e] = last_reward_[idx(e)];
      for (Index k = 0; k < W; ++k) rec(k, e) = recent_[idx(e)][static_cast<std::size_t>(k)];
    }
    c.put(prefix + "direction", d);
    c.put(prefix + "speed", s);
    c.put(prefix + "steps_left", left);
    c.put(prefix + "count", cnt);
    c.put(prefix + "recent", rec);
    c.put(prefix + "last_reward", lr);
    save_streams(c, prefix, rngs_);
  }
  void load(const Checkpoint& c, const std::string& prefix) {
    const auto n = static_cast<Index>(dir_.size()), W = c_.success_window;
    const MatrixXd d = c.get_matrix<double>(prefix + "direction", 3, n), rec = c.get_matrix<double>(prefix + "recent", W, n);
    const VectorXd s = c.get_vector<double>(prefix + "speed", n);
    const auto left = c.get_vector<std::int64_t>(prefix + "steps_left", n), cnt = c.get_vector<std::int64_t>(prefix + "count", n);
    const auto lr = c.get_vector<float>(prefix + "last_reward", n);
    load_streams(c, prefix, rngs_);
    for (Index e = 0; e < n; ++e) {
      dir_[idx(e)] = d.col(e);
      speed_[idx(e)] = s[e];
      steps_left_[idx(e)] = left[e];
      count_[idx(e)] = cnt[e];
      last_reward_[idx(e)] = lr[e];
      for (Index k = 0; k < W; ++k) recent_[idx(e)][static_cast<std::size_t>(k)] = rec(k, e);
    }
  }

 private:
  static std::size_t idx(Index e) { return static_cast<std::size_t>(e); }
  void draw_goal(const Quat& root_rot, Index e) {
    auto& r = rngs_[idx(e)];
    const Vec3 f = facing_direction(root_rot);
    const double a = std::atan2(f.y(), f.x()) + r.uniform(-c_.max_turn, c_.max_turn);
    dir_[idx(e)] = Vec3(std::cos(a), std::sin(a), 0.0);
    speed_[idx(e)] = r.uniform(c_.min_speed, c_.max_speed);
    steps_left_[idx(e)] = c_.schedule.draw(r);
    count_[idx(e)] = 0;
  }

  HeadingConfig c_;
  std::vector<Rng> rngs_;
  std::vector<Vec3> dir_;
  std::vector<double> speed_;
  std::vector<Index> steps_left_;
  std::vector<std::vector<double>> recent_;  ///< (num_envs) ring of the last success_window v_d (m/s)
  std::vector<Index> count_;                 ///< steps of the current trial
  std::vector<float> last_reward_;
  TrialCounter trials_;
};

}  // namespace maskadapt::tasks
