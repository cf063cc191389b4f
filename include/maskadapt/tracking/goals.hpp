#pragma once
/// \file goals.hpp
/// Partial tracking: goal extraction, the tracking reward, windowed early termination, and the
/// goal buffer that feeds generated trajectories to training rollouts.
///
/// Designated parts (the arms by default) follow a kinematic target trajectory; every other part
/// is left to the base policy (and judged by an imitation discriminator).
///
/// Goal features (what the residual policy sees), for each of the next `steps` target frames
/// k = 1 … steps and each designated body b (body order):
///   - the 3 hinge angles q*_b (rad; goal bodies need x-y-z hinges, as the humanoid's), and
///   - the body's position relative to the root, in the TARGET frame's heading frame (m),
/// i.e. 6 rows per body per step: goal_dim = steps · 6 · |designated bodies|. Both are invariant
/// to where the target trajectory sits in the world, so drift between the simulated character and
/// the generated root never enters the goal.
///
/// Tracking error / reward: e = Σ_b angle(R*_b⁻¹ R_b)² over designated bodies, with R_b the
/// simulated LOCAL joint rotation R_world(parent)⁻¹ R_world(b) and R*_b = joint_rotation(q*_b)
/// (this is ‖q* − q‖² measured on rotations, so it is independent of the hinge convention);
/// reward r = exp(−k·e), k the reward scale (1: the paper's).
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/motion/skeleton.hpp>
#include <maskadapt/tracking/generator.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

namespace maskadapt::tracking {

/// Non-root bodies whose part is in `parts`, in body order.
inline std::vector<int> designated_bodies(const Skeleton& skel, PartMask parts) {
  std::vector<int> b;
  for (int i = 1; i < skel.num_bodies(); ++i)
    if (parts.has(skel.parts[static_cast<std::size_t>(i)])) b.push_back(i);
  return b;
}

/// Rows of the goal vector: steps · 6 · |designated bodies|.
inline Index goal_dim(const Skeleton& skel, PartMask parts, Index steps) {
  return steps * 6 * static_cast<Index>(designated_bodies(skel, parts).size());
}

/// Root-relative position of `body` in the heading frame of a frame with root (p0, R0).
inline Vec3 heading_local(const Vec3& p_body, const Vec3& p_root, const Quat& root_rot) {
  return heading_rotation(root_rot).conjugate() * (p_body - p_root);
}

/// Goal features (goal_dim × 1) of target frames `frame + 1 … frame + steps` of `traj` (clamped to
/// its last frame) into `out`. See the file comment for the layout.
inline void extract_goals(const Skeleton& skel, const std::vector<int>& bodies, const Trajectory& traj, Index frame,
                          Index steps, Eigen::Ref<VectorXf> out) {
  const Index per = 6 * static_cast<Index>(bodies.size());
  require(out.size() == steps * per, "goal vector has " + std::to_string(out.size()) + " rows, expected " +
                                         std::to_string(steps * per), {{}, {}, "goals"});
  require(traj.num_frames() > 0 && traj.q.rows() == skel.num_dofs() && traj.body_pos.rows() == 3 * skel.num_bodies(),
          "target trajectory does not match the skeleton", {{}, {}, "goals.trajectory"});
  for (Index k = 0; k < steps; ++k) {
    const Index f = std::clamp<Index>(frame + 1 + k, 0, traj.num_frames() - 1);
    const Vec3 p0 = traj.root_pos.col(f);
    const Quat& R0 = traj.root_rot[static_cast<std::size_t>(f)];
    for (std::size_t j = 0; j < bodies.size(); ++j) {
      const int b = bodies[j];
      if (k == 0) skel.require_xyz_hinges(b, "extract_goals (3 hinge angles per goal body)");
      const Index r = k * per + 6 * static_cast<Index>(j);
      out.segment<3>(r) = traj.q.col(f).segment<3>(skel.dof_offset(b)).cast<float>();
      out.segment<3>(r + 3) = heading_local(traj.body_pos.block<3, 1>(3 * b, f), p0, R0).cast<float>();
    }
  }
}

/// angle(R*_b⁻¹ R_b) (rad) of body `b`: its target hinge angles q* (num_dofs) vs its simulated
/// local joint rotation R_b = R_world(parent)⁻¹ R_world(b).
inline double rotation_error(const Skeleton& skel, int b, const Eigen::Ref<const VectorXd>& q_target, const BodyStates& sim) {
  const int p = skel.parents[static_cast<std::size_t>(b)];
  const Quat local = (sim.rot[static_cast<std::size_t>(p)].conjugate() * sim.rot[static_cast<std::size_t>(b)]).normalized();
  return joint_rotation(skel, b, q_target).angularDistance(local);
}

/// Σ_b angle(R*_b⁻¹ R_b)² over `bodies` (rad²), `rotation_error` of each.
inline double rotation_error_sq(const Skeleton& skel, const std::vector<int>& bodies,
                                const Eigen::Ref<const VectorXd>& q_target, const BodyStates& sim) {
  double e = 0;
  for (int b : bodies) {
    const double a = rotation_error(skel, b, q_target, sim);
    e += a * a;
  }
  return e;
}

/// The tracking reward exp(−k·Σ_b angle²), k = `scale` (1: the paper's; a smaller k keeps the
/// reward away from 0 while the arms are still far from their targets).
inline double tracking_reward(const Skeleton& skel, const std::vector<int>& bodies,
                              const Eigen::Ref<const VectorXd>& q_target, const BodyStates& sim, double scale = 1.0) {
  return std::exp(-scale * rotation_error_sq(skel, bodies, q_target, sim));
}

/// Mean over `bodies` of the distance (m) between the simulated and the target root-relative
/// heading-frame positions (the evaluation's tracking error; 0.5 m is the success threshold).
inline double position_error(const std::vector<int>& bodies, const Trajectory& traj, Index frame, const BodyStates& sim) {
  if (bodies.empty()) return 0.0;
  const Vec3 p0 = traj.root_pos.col(frame);
  const Quat& R0 = traj.root_rot[static_cast<std::size_t>(frame)];
  double s = 0;
  for (int b : bodies) {
    const Vec3 t = heading_local(traj.body_pos.block<3, 1>(3 * b, frame), p0, R0);
    const Vec3 c = heading_local(sim.pos.col(b), sim.pos.col(0), sim.rot[0]);
    s += (t - c).norm();
  }
  return s / static_cast<double>(bodies.size());
}

/// Early termination on a windowed average: an episode ends when the mean of its last `window`
/// rewards drops below `threshold` (only once `window` rewards have been seen).
class WindowedTermination {
 public:
  WindowedTermination() = default;
  WindowedTermination(Index num_envs, Index window, double threshold)
      : window_(window), threshold_(threshold), buf_(static_cast<std::size_t>(num_envs), std::vector<double>(static_cast<std::size_t>(std::max<Index>(1, window)), 0.0)),
        count_(static_cast<std::size_t>(num_envs), 0), sum_(static_cast<std::size_t>(num_envs), 0.0) {
    require(window >= 1, "termination window must be ≥ 1 step", {{}, {}, "tracking.term_window"});
    require(std::isfinite(threshold), "termination threshold must be finite", {{}, {}, "tracking.term_threshold"});
  }
  /// Records env e's reward; returns true when the windowed mean is below the threshold.
  bool push(Index e, double r) {
    const auto ue = static_cast<std::size_t>(e);
    auto& b = buf_[ue];
    const auto slot = static_cast<std::size_t>(count_[ue] % window_);
    if (count_[ue] >= window_) sum_[ue] -= b[slot];
    b[slot] = r;
    sum_[ue] += r;
    ++count_[ue];
    return count_[ue] >= window_ && sum_[ue] / static_cast<double>(window_) < threshold_;
  }
  /// Forgets env e's history (call at episode start).
  void reset(Index e) {
    count_[static_cast<std::size_t>(e)] = 0;
    sum_[static_cast<std::size_t>(e)] = 0.0;
  }

  /// Env e's state for checkpoints: [count, sum, ring buffer (window)].
  std::vector<double> env_state(Index e) const {
    const auto ue = static_cast<std::size_t>(e);
    std::vector<double> v{static_cast<double>(count_[ue]), sum_[ue]};
    v.insert(v.end(), buf_[ue].begin(), buf_[ue].end());
    return v;
  }
  /// Restores what `env_state` returned (same window; throws otherwise).
  void set_env_state(Index e, const std::vector<double>& v) {
    const auto ue = static_cast<std::size_t>(e);
    require(v.size() == buf_[ue].size() + 2, "windowed-termination state has the wrong size",
            {{}, {}, "tracking.term_state"});
    count_[ue] = static_cast<Index>(v[0]);
    sum_[ue] = v[1];
    std::copy(v.begin() + 2, v.end(), buf_[ue].begin());
  }

 private:
  Index window_ = 1;
  double threshold_ = 0.0;
  std::vector<std::vector<double>> buf_;
  std::vector<Index> count_;
  std::vector<double> sum_;
};

/// Stored future trajectories from a generator; rollouts consume them one frame per control step.
///
/// Training: every `sample_every` iterations call `refill` (texts drawn from the pool, histories
/// from `history`), then give each episode `draw` → one trajectory whose frames are its goals in
/// order. Inference: run the generator online instead (tracking::rollout with a text schedule).
struct GoalBuffer {
  std::vector<Trajectory> trajectories;  ///< world-frame futures, ≥ `frames` frames each
  std::vector<std::string> texts;        ///< the prompt of each

  /// Draws the history a trajectory continues (≥ H frames, world frame, 30 fps).
  using HistorySource = std::function<Trajectory(Rng&)>;

  /// Replaces the contents with `count` trajectories of `frames` frames each.
  template <TrajectoryGenerator G>
  void refill(G& gen, const std::vector<std::string>& pool, const HistorySource& history, Index count, Index frames,
              Rng& rng) {
    require(!pool.empty(), "the text pool is empty", {{}, {}, "tracking.texts"});
    require(count >= 1 && frames >= 1, "goal buffer needs count ≥ 1 and frames ≥ 1", {{}, {}, "tracking.goal_buffer"});
    trajectories.clear();
    texts.clear();
    for (Index i = 0; i < count; ++i) {
      const std::string& t = pool[static_cast<std::size_t>(rng.uniform_int(pool.size()))];
      const std::vector<TimedText> sched{{0.0, t}};
      trajectories.push_back(rollout(gen, sched, history(rng), frames, rng));
      texts.push_back(t);
    }
  }
  bool empty() const { return trajectories.empty(); }
  /// Index of a uniformly drawn trajectory.
  std::size_t draw(Rng& rng) const {
    require(!trajectories.empty(), "the goal buffer is empty (call refill first)", {{}, {}, "tracking.goal_buffer"});
    return static_cast<std::size_t>(rng.uniform_int(trajectories.size()));
  }
};

/// A world-frame trajectory of `frames` frames of a motion library clip starting at `t0` (s), 30 fps
/// (body positions by FK) — the history source / reference for goal generation.
template <class Library>
Trajectory trajectory_from_library(const Library& lib, int clip, double t0, Index frames) {
  const Skeleton& skel = lib.skeleton();
  Trajectory t = Trajectory::zeros(skel, frames);
  for (Index i = 0; i < frames; ++i) {
    const KinematicState s = lib.state(clip, t0 + static_cast<double>(i) / 30.0);
    t.root_pos.col(i) = s.root_pos;
    t.root_rot[static_cast<std::size_t>(i)] = s.root_rot;
    t.q.col(i) = s.q;
  }
  compute_body_positions(skel, t);
  return t;
}

}  // namespace maskadapt::tracking
