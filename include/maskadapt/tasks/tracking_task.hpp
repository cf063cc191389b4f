#pragma once
/// \file tracking_task.hpp
/// Partial tracking (stage 2b) as a `GoalTask`: the designated parts follow trajectories from a
/// goal buffer that a text-conditioned generator refills (tracking/goals.hpp).
///
///  - each env follows one buffered trajectory from its first frame, one frame per control step;
///  - goal observation: the next `goal_steps` target frames of the designated bodies, in the
///    root's heading frame (tracking::extract_goals);
///  - reward: exp(−k·‖q* − q‖²) on the designated bodies at the target frame the step reached
///    (k = reward_scale, 1 the paper's);
///  - windowed early termination: when the mean reward over the last `term_window` steps falls
///    below `term_threshold`, the task ends the episode (the trainer resets the env);
///  - the goal buffer is refilled before every `sample_every`-th iteration (and at construction);
///  - trials: tracking has no success test of its own (it is judged by tracking error and DTW,
///    eval/tracking_metrics.hpp), so it reports no trials.
#include <maskadapt/tasks/goal_task.hpp>
#include <maskadapt/tracking/goals.hpp>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

namespace maskadapt::tasks {

struct TrackingTaskConfig {
  PartMask designated;           ///< parts that follow the trajectory
  Index goal_steps = 2;          ///< target frames in the goal
  int sample_every = 20;         ///< refill the goal buffer every N iterations
  Index term_window = 30;        ///< steps
  double term_threshold = 0.05;  ///< windowed mean reward below this ends the episode
  double reward_scale = 1.0;     ///< k of the reward exp(−k·e) (> 0)
  /// Refills the goal buffer (at construction and every `sample_every` iterations).
  std::function<void(Rng&, tracking::GoalBuffer&)> refill;
  std::uint64_t seed = 1;
  /// Which goal stream: stream(seed, 0x7EAC0000 + stream). A distributed run gives rank r stream
  /// r, so the ranks refill and draw their own goals (one stream shared by every env is drawn in
  /// env order; across ranks that order does not exist, so tracking on K ranks is its own run,
  /// not one process's; docs/distributed.md).
  std::uint64_t stream = 0;
};

class TrackingTask {
 public:
  TrackingTask(const Skeleton& skel, TrackingTaskConfig c, Index num_envs)
      : skel_(skel), c_(std::move(c)), rng_(Rng::stream(c_.seed, 0x7EAC0000ULL + c_.stream)) {
    require(!c_.designated.empty(), "tracking needs designated parts", {{}, {}, "designated"});
    require(c_.goal_steps >= 1 && c_.sample_every >= 1, "tracking counts must be >= 1", {{}, {}, "tracking"});
    require(static_cast<bool>(c_.refill), "tracking needs a goal-buffer refill function", {{}, {}, "setup"});
    require(std::isfinite(c_.reward_scale) && c_.reward_scale > 0, "the tracking reward scale must be finite and > 0",
            {{}, {}, "tracking_reward_scale"});
    bodies_ = tracking::designated_bodies(skel_, c_.designated);
    term_ = tracking::WindowedTermination(num_envs, c_.term_window, c_.term_threshold);
    c_.refill(rng_, goals_);
    const auto n = static_cast<std::size_t>(num_envs);
    goal_index_.assign(n, 0);
    goal_frame_.assign(n, 0);
    last_reward_.assign(n, 0.0f);
  }
  std::string name() const { return "tracking"; }
  Index goal_dim() const { return tracking::goal_dim(skel_, c_.designated, c_.goal_steps); }
  const TrackingTaskConfig& config() const { return c_; }
  const tracking::GoalBuffer& goals() const { return goals_; }

  void begin_iteration(long long it) {
    if (it <= 0 || it % c_.sample_every != 0) return;
    c_.refill(rng_, goals_);
    for (auto& g : goal_index_) g = std::min<std::size_t>(g, goals_.trajectories.size() - 1);
  }
  template <Simulator Sim>
  void new_episode(Sim&, Index e) {
    goal_index_[idx(e)] = goals_.draw(rng_);
    goal_frame_[idx(e)] = 0;
    term_.reset(e);
  }
  template <Simulator Sim>
  void goal(const Sim&, Index e, Eigen::Ref<VectorXf> g) const {
    tracking::extract_goals(skel_, bodies_, goals_.trajectories[goal_index_[idx(e)]], static_cast<Index>(goal_frame_[idx(e)]),
                            c_.goal_steps, g);
  }
  /// Reward of the target frame this step reached. An env the imitation task already reset has no
  /// post-step state left: it keeps its previous reward.
  template <Simulator Sim>
  GoalStep after_step(const Sim& sim, Index e, EpisodeEnd end) {
    const auto u = idx(e);
    if (end != EpisodeEnd::none) return {last_reward_[u], false};
    const auto& traj = goals_.trajectories[goal_index_[u]];
    const Index f = std::min<Index>(static_cast<Index>(goal_frame_[u] + 1), traj.num_frames() - 1);
    last_reward_[u] = static_cast<float>(tracking::tracking_reward(skel_, bodies_, traj.q.col(f), sim.body_states(u), c_.reward_scale));
    if (term_.push(e, last_reward_[u])) return {last_reward_[u], true};
    ++goal_frame_[u];
    return {last_reward_[u], false};
  }
  const TrialCounter& trials() const { return trials_; }
  void clear_trials() {}

  void save(Checkpoint& c, const std::string& prefix) const {
    c.put_rng(prefix + "rng", rng_);
    c.put_int(prefix + "count", static_cast<std::int64_t>(goals_.trajectories.size()));
    for (std::size_t i = 0; i < goals_.trajectories.size(); ++i) {
      const auto& t = goals_.trajectories[i];
      const std::string p = prefix + std::to_string(i);
      MatrixXd rot(4, t.num_frames());
      for (Index f = 0; f < t.num_frames(); ++f) rot.col(f) = t.root_rot[static_cast<std::size_t>(f)].coeffs();
      c.put(p + "/root_pos", MatrixXd(t.root_pos));
      c.put(p + "/root_rot", rot);
      c.put(p + "/q", t.q);
      c.put(p + "/body_pos", t.body_pos);
      c.put_string(p + "/text", goals_.texts[i]);
    }
    const auto n = static_cast<Index>(goal_index_.size());
    VectorX<std::int64_t> gi(n), gf(n);
    VectorXf lt(n);
    for (Index e = 0; e < n; ++e) {
      gi[e] = static_cast<std::int64_t>(goal_index_[idx(e)]);
      gf[e] = static_cast<std::int64_t>(goal_frame_[idx(e)]);
      lt[e] = last_reward_[idx(e)];
      const auto ws = term_.env_state(e);
      c.put(prefix + "term/" + std::to_string(e), Eigen::Map<const VectorXd>(ws.data(), static_cast<Index>(ws.size())));
    }
    c.put(prefix + "goal_index", gi);
    c.put(prefix + "goal_frame", gf);
    c.put(prefix + "last_reward", lt);
  }
  void load(const Checkpoint& c, const std::string& prefix) {
    const auto count = static_cast<std::size_t>(c.get_int(prefix + "count"));
    require(count >= 1, "checkpoint holds an empty goal buffer", {c.source(), std::nullopt, prefix + "count"});
    tracking::GoalBuffer goals;
    for (std::size_t i = 0; i < count; ++i) {
      const std::string p = prefix + std::to_string(i);
      tracking::Trajectory t;
      t.root_pos = c.get_matrix<double>(p + "/root_pos", 3);
      const MatrixXd rot = c.get_matrix<double>(p + "/root_rot", 4, t.root_pos.cols());
      for (Index f = 0; f < rot.cols(); ++f) t.root_rot.emplace_back(rot(3, f), rot(0, f), rot(1, f), rot(2, f));
      t.q = c.get_matrix<double>(p + "/q", skel_.num_dofs(), t.root_pos.cols());
      t.body_pos = c.get_matrix<double>(p + "/body_pos", 3 * skel_.num_bodies(), t.root_pos.cols());
      goals.trajectories.push_back(std::move(t));
      goals.texts.push_back(c.get_string(p + "/text"));
    }
    const auto n = static_cast<Index>(goal_index_.size());
    const auto gi = c.get_vector<std::int64_t>(prefix + "goal_index", n);
    const auto gf = c.get_vector<std::int64_t>(prefix + "goal_frame", n);
    const auto lt = c.get_vector<float>(prefix + "last_reward", n);
    for (Index e = 0; e < n; ++e)
      require(gi[e] >= 0 && static_cast<std::size_t>(gi[e]) < count && gf[e] >= 0, "goal position out of range",
              {c.source(), std::nullopt, prefix + "goal_index"});
    rng_.set_state(c.get_rng(prefix + "rng"));
    goals_ = std::move(goals);
    for (Index e = 0; e < n; ++e) {
      goal_index_[idx(e)] = static_cast<std::size_t>(gi[e]);
      goal_frame_[idx(e)] = static_cast<std::size_t>(gf[e]);
      last_reward_[idx(e)] = lt[e];
      const VectorXd ws = c.get_vector<double>(prefix + "term/" + std::to_string(e));
      term_.set_env_state(e, std::vector<double>(ws.data(), ws.data() + ws.size()));
    }
  }

 private:
  static std::size_t idx(Index e) { return static_cast<std::size_t>(e); }
  Skeleton skel_;
  TrackingTaskConfig c_;
  Rng rng_;
  std::vector<int> bodies_;
  tracking::GoalBuffer goals_;
  std::vector<std::size_t> goal_index_, goal_frame_;
  tracking::WindowedTermination term_;
  std::vector<float> last_reward_;
  TrialCounter trials_;
};

}  // namespace maskadapt::tasks
