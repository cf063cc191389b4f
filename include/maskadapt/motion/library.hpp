#pragma once
/// \file library.hpp
/// `MotionLibrary`: weighted clips with interpolated queries at any time — poses, velocities,
/// body states, reset states, AMP discriminator windows and visitation features.
///
/// Interpolation at time t (frame u = t·fps between frames i and i+1, weight w = u − i):
///  - root position: lerp; root rotation: slerp;
///  - a joint of three hinges about x, y, z (the humanoid's): slerp of the two joint rotations
///    R_x R_y R_z, converted back to the 3-hinge angles nearest the lerped angles (continuous;
///    equals the lerp for single-axis motion);
///  - any other joint (one or two hinges, or axes other than x, y, z: the G1's links): each
///    hinge angle is lerped — a single hinge's rotation is the lerp of its angle exactly, and a
///    chain of hinges is interpolated per hinge as the robot's own joints would move;
/// Velocities: central differences over ±h with h = 1/fps (one frame each side; one-sided at the
/// ends of a non-looping clip): v = (p(t+h) − p(t−h)) / 2h, ω_root = log(R(t+h) R(t−h)ᵀ) / 2h,
/// q̇ = wrap(q(t+h) − q(t−h)) / 2h; body velocities follow by forward_kinematics.
/// Looping clips (period P = duration): t = kP + τ; the cycle k's root is moved by the
/// transform G^k that takes frame 0 to the last frame (horizontal translation + yaw), so a
/// locomotion loop keeps travelling instead of jumping back.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/thread_pool.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/motion/amp_window.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/observation.hpp>
#include <maskadapt/motion/rotation.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

namespace maskadapt {


/// Pose (no velocities) of a clip on `skel` at time t (s). Non-looping clips clamp t to
/// [0, duration].
inline void clip_pose(const Skeleton& skel, const MotionClip& c, double t, KinematicState& out) {
  const int T = c.num_frames();
  require(T >= 1, "clip '" + c.name + "' has no frames", {{}, {}, "clip"});
  require(std::isfinite(t), "time is not finite", {{}, {}, "time"});
  const double P = c.duration();
  long long cycle = 0;
  if (c.loop && P > 0) {
    cycle = static_cast<long long>(std::floor(t / P));
    t -= static_cast<double>(cycle) * P;
  }
  t = std::clamp(t, 0.0, P);
  const double u = t * c.fps;
  const int i0 = std::min(static_cast<int>(std::floor(u)), T - 1);
  const int i1 = std::min(i0 + 1, T - 1);
  const double w = i1 == i0 ? 0.0 : u - i0;
  out.root_pos = (1 - w) * c.root_pos.col(i0) + w * c.root_pos.col(i1);
  out.root_rot = slerp(c.rot(i0), c.rot(i1), w);
  if (c.num_dofs() != skel.num_dofs())
    throw Error("clip '" + c.name + "' has " + std::to_string(c.num_dofs()) + " joint angles, the skeleton " +
                    std::to_string(skel.num_dofs()),
                {{}, {}, "clip"});
  out.q.resize(c.num_dofs());
  for (int b = 1; b < skel.num_bodies(); ++b) {
    const int k = skel.dof_offset(b), n = skel.num_dofs_of(b);
    if (n == 3 && skel.has_xyz_hinges(b)) {
      const Vec3 a0 = c.q.col(i0).segment<3>(k), a1 = c.q.col(i1).segment<3>(k);
      if (w == 0.0 || a0 == a1) {
        out.q.segment<3>(k) = a0;
        continue;
      }
      const Quat L = slerp(joint_rotation(a0), joint_rotation(a1), w);
      out.q.segment<3>(k) = joint_angles_near(L, (1 - w) * a0 + w * a1);
    } else {
      for (int j = k; j < k + n; ++j) out.q[j] = w == 0.0 ? c.q(j, i0) : (1 - w) * c.q(j, i0) + w * c.q(j, i1);
    }
  }
  if (cycle != 0) {
    // apply G^cycle: yaw by cycle·Δψ about the first frame's ground point, then translate
    const double dpsi = wrap_angle(yaw_of(c.rot(T - 1)) - yaw_of(c.rot(0)));
    const Vec3 p0(c.root_pos(0, 0), c.root_pos(1, 0), 0.0), pT(c.root_pos(0, T - 1), c.root_pos(1, T - 1), 0.0);
    const Quat G(Eigen::AngleAxisd(dpsi, Vec3::UnitZ()));
    const long long n = cycle > 0 ? cycle : -cycle;
    const Quat Gi = G.conjugate();
    for (long long k = 0; k < n; ++k) {
      Vec3 flat(out.root_pos.x(), out.root_pos.y(), 0.0);
      if (cycle > 0) {
        flat = G * (flat - p0) + pT;
        out.root_rot = G * out.root_rot;
      } else {
        flat = Gi * (flat - pT) + p0;
        out.root_rot = Gi * out.root_rot;
      }
      out.root_pos.x() = flat.x();
      out.root_pos.y() = flat.y();
    }
  }
}

/// The times t − h and t + h of the central difference at t (h = 1/fps), clamped to the clip on a
/// non-looping clip. Their difference is the difference's time step (≤ 1e−12: no velocity).
inline std::pair<double, double> central_difference_times(const MotionClip& c, double t) {
  const double h = 1.0 / c.fps;
  double t1 = t - h, t2 = t + h;
  if (!c.loop) {
    t1 = std::clamp(t1, 0.0, c.duration());
    t2 = std::clamp(t2, 0.0, c.duration());
  }
  return {t1, t2};
}

/// Sets `out`'s velocities from the poses `a` at t1 and `b` at t2 (central_difference_times);
/// zero when t2 − t1 ≤ 1e−12.
inline void velocities_from_poses(const KinematicState& a, const KinematicState& b, double t1, double t2,
                                  KinematicState& out) {
  out.root_lin_vel.setZero();
  out.root_ang_vel.setZero();
  out.qd.setZero(out.q.size());
  if (t2 - t1 <= 1e-12) return;
  const double dt = t2 - t1;
  out.root_lin_vel = (b.root_pos - a.root_pos) / dt;
  out.root_ang_vel = angular_velocity(a.root_rot, b.root_rot, dt);
  for (Index k = 0; k < out.qd.size(); ++k) out.qd[k] = wrap_angle(b.q[k] - a.q[k]) / dt;
}

/// Pose and velocities of a clip on `skel` at time t (see file comment).
inline void clip_state(const Skeleton& skel, const MotionClip& c, double t, KinematicState& out) {
  clip_pose(skel, c, t, out);
  const auto [t1, t2] = central_difference_times(c, t);
  if (t2 - t1 <= 1e-12) {
    velocities_from_poses(out, out, t1, t2, out);
    return;
  }
  KinematicState a, b;
  clip_pose(skel, c, t1, a);
  clip_pose(skel, c, t2, b);
  velocities_from_poses(a, b, t1, t2, out);
}

/// Root-relative body positions in the root's heading frame for the bodies (≥ 1) of the parts
/// in `parts`, body order, 3 rows each — the per-frame feature of the visitation metric.
inline VectorXf visitation_features(const Skeleton& skel, const BodyStates& bs, PartMask parts = PartMask::all()) {
  int n = 0;
  for (int i = 1; i < skel.num_bodies(); ++i) n += parts.has(skel.parts[i]);
  VectorXf f(3 * n);
  const Mat3 Ht = heading_rotation(bs.rot[0]).toRotationMatrix().transpose();
  int r = 0;
  for (int i = 1; i < skel.num_bodies(); ++i)
    if (parts.has(skel.parts[i])) {
      f.segment<3>(3 * r++) = (Ht * (bs.pos.col(i) - bs.pos.col(0))).cast<float>();
    }
  return f;
}

/// A clip and a time in it.
struct ClipTime {
  int clip = 0;
  double time = 0.0;  ///< s
};

class MotionLibrary {
 public:
  /// A library of clips on `skel` (e.g. `humanoid_skeleton()`, humanoid/description.hpp, or
  /// `g1::g1_skeleton()`): any hinge layout (see the file comment for how joints interpolate).
  explicit MotionLibrary(const Skeleton& skel) : skel_(skel) { skel_.validate(); }

  /// Adds a clip (validated against the skeleton) with a sampling weight > 0; returns its index.
  int add(MotionClip clip, double weight = 1.0) {
    clip.validate(skel_);
    require(std::isfinite(weight) && weight > 0, "clip weight must be positive", {{}, {}, clip.name});
    clips_.push_back(std::move(clip));
    weights_.push_back(weight);
    return num_clips() - 1;
  }

  int num_clips() const { return static_cast<int>(clips_.size()); }
  const MotionClip& clip(int i) const { return clips_.at(static_cast<std::size_t>(i)); }
  double weight(int i) const { return weights_.at(static_cast<std::size_t>(i)); }
  const Skeleton& skeleton() const { return skel_; }
  /// Sum of all clip durations (s).
  double total_duration() const {
    double d = 0;
    for (const auto& c : clips_) d += c.duration();
    return d;
  }

  /// A clip by weight (or uniformly over clips when `by_weight` is false) and a uniform time in
  /// [min_time, duration] (clamped when the clip is shorter than min_time).
  ClipTime sample(Rng& rng, bool by_weight = true, double min_time = 0.0) const {
    require(!clips_.empty(), "the motion library is empty", {{}, {}, "library"});
    const int c = by_weight ? static_cast<int>(draw_weighted(weights_, rng))
                            : static_cast<int>(rng.uniform_int(static_cast<std::uint64_t>(num_clips())));
    const double D = clips_[static_cast<std::size_t>(c)].duration();
    const double lo = std::min(min_time, D);
    return {c, rng.uniform(lo, D)};
  }

  /// Interpolated pose + velocities (see file comment).
  void state(int clip, double time, KinematicState& out) const { clip_state(skel_, this->clip(clip), time, out); }
  KinematicState state(int clip, double time) const {
    KinematicState s;
    state(clip, time, s);
    return s;
  }
  /// World positions, rotations and velocities of every body.
  void body_states(int clip, double time, BodyStates& out) const {
    KinematicState s;
    state(clip, time, s);
    forward_kinematics(skel_, s, out);
  }
  BodyStates body_states(int clip, double time) const {
    BodyStates b;
    body_states(clip, time, b);
    return b;
  }

  /// Reference state initialisation: a sampled (clip, time) and its state.
  KinematicState reset_state(Rng& rng, ClipTime* where = nullptr) const {
    const ClipTime ct = sample(rng);
    if (where) *where = ct;
    return state(ct.clip, ct.time);
  }

  /// Dimension of one AMP window: kAmpWindowFrames × observation_dim.
  Index amp_window_dim() const { return kAmpWindowFrames * observation_dim(skel_); }
  /// Dimension of a window of `frames` consecutive frames (1 ≤ frames ≤ kAmpWindowFrames):
  /// frames × observation_dim. A discriminator may see fewer frames than the task keeps
  /// (BaseTrainConfig::disc.window_frames: the paper's D(s, s′) is 2).
  Index amp_window_dim(int frames) const {
    require(frames >= 1 && frames <= kAmpWindowFrames,
            "an AMP window holds 1 to " + std::to_string(kAmpWindowFrames) + " frames, not " + std::to_string(frames),
            {{}, {}, "window_frames"});
    return frames * observation_dim(skel_);
  }

  /// The AMP sample ending at `t_end`: observations (motion/observation.hpp) of the F frames at
  /// t_end − (F−1)Δ, …, t_end (Δ = 1/30 s), oldest first, stacked into `out`, whose size gives F
  /// (F · observation_dim, 1 ≤ F ≤ kAmpWindowFrames; the default window is F = 5). A window of F
  /// frames is the last F frames of the longer one ending at the same time, bit for bit.
  ///
  /// On a clip recorded at 1/Δ = 30 fps, the central differences of neighbouring window frames share
  /// their poses (frame k's t + h is frame k+1's time), so the window interpolates F + 2 poses, not
  /// 3F: t_end − FΔ … t_end + Δ. The shared pose's time differs from t_k ± h by rounding only
  /// (≤ 1e−15 s); clamping at the ends of a non-looping clip is the same as clip_state's.
  void amp_window(int clip, double t_end, Eigen::Ref<VectorXf> out) const {
    const Index d = observation_dim(skel_);
    const int frames = window_frames_of(out.size(), "amp_window");
    const MotionClip& c = this->clip(clip);
    // per-thread pose buffers: a batch of windows allocates nothing once each thread has seen one
    thread_local WindowScratch scratch;
    BodyStates& bs = scratch.bodies;
    const auto frame_time = [&](int k) { return t_end - (frames - 1 - k) * kAmpFrameDt; };
    if (std::abs(c.fps * kAmpFrameDt - 1.0) > 1e-12) {  // other frame rates: every frame on its own
      for (int k = 0; k < frames; ++k) {
        body_states(clip, frame_time(k), bs);
        compute_observation(skel_, bs, out.segment(k * d, d));
      }
      return;
    }
    // grid pose j at t_end − (frames − j)·Δ, j = 0 … frames + 1
    auto& grid = scratch.grid;
    for (int j = 0; j < frames + 2; ++j) clip_pose(skel_, c, frame_time(j - 1), grid[static_cast<std::size_t>(j)]);
    KinematicState& s = scratch.state;
    for (int k = 0; k < frames; ++k) {
      const KinematicState& pose = grid[static_cast<std::size_t>(k + 1)];
      s.root_pos = pose.root_pos;  // (the pose only: s keeps its velocity buffers)
      s.root_rot = pose.root_rot;
      s.q = pose.q;
      const auto [t1, t2] = central_difference_times(c, frame_time(k));
      // (clip_pose clamps a non-looping clip's time itself, so the grid pose at t_k − h is the pose at t1)
      velocities_from_poses(grid[static_cast<std::size_t>(k)], grid[static_cast<std::size_t>(k + 2)], t1, t2, s);
      forward_kinematics(skel_, s, bs);
      compute_observation(skel_, bs, out.segment(k * d, d));
    }
  }

  /// A batch of AMP windows from sampled (clip, time): (amp_window_dim() × batch). The times
  /// are drawn in order from `rng`; the windows (5 poses, forward kinematics and features each)
  /// are then computed on `pool` when one is given — the same numbers for any pool size.
  /// The times are drawn with the 5-frame window's margin for any window length, so a batch of
  /// F-frame windows is the last F frames of the 5-frame batch drawn with the same `rng`.
  MatrixXf sample_amp_windows(Rng& rng, int batch, ThreadPool* pool = nullptr) const {
    MatrixXf out(amp_window_dim(), std::max(batch, 0));
    sample_amp_windows(rng, out, pool);
    return out;
  }
  /// The same into `out` (amp_window_dim(F) × batch), one window of F frames per column.
  void sample_amp_windows(Rng& rng, Eigen::Ref<MatrixXf> out, ThreadPool* pool = nullptr) const {
    (void)window_frames_of(out.rows(), "amp_windows");
    const auto batch = static_cast<int>(out.cols());
    std::vector<ClipTime> times(static_cast<std::size_t>(batch));
    for (auto& ct : times) ct = sample(rng, true, (kAmpWindowFrames - 1) * kAmpFrameDt);
    auto window = [&](std::size_t b) { amp_window(times[b].clip, times[b].time, out.col(static_cast<Index>(b))); };
    for_each_index(pool, times.size(), window);
  }

  /// Visitation features of every frame of a clip: (3·bodies-in-parts × num_frames).
  MatrixXf clip_visitation_features(int clip, PartMask parts = PartMask::all()) const {
    const MotionClip& c = this->clip(clip);
    BodyStates bs;
    MatrixXf out;
    for (int t = 0; t < c.num_frames(); ++t) {
      forward_kinematics(skel_, c.frame(t), bs);
      const VectorXf f = visitation_features(skel_, bs, parts);
      if (t == 0) out.resize(f.size(), c.num_frames());
      out.col(t) = f;
    }
    return out;
  }

 private:
  /// F of an AMP window of `rows` features (F · observation_dim, 1 ≤ F ≤ kAmpWindowFrames); throws
  /// naming `field` otherwise.
  int window_frames_of(Index rows, const char* field) const {
    const Index d = observation_dim(skel_);
    require(rows % d == 0 && rows / d >= 1 && rows / d <= kAmpWindowFrames,
            "AMP window has the wrong number of rows (" + std::to_string(rows) + "; expected 1 to " +
                std::to_string(kAmpWindowFrames) + " times " + std::to_string(d) + ")",
            {{}, {}, field});
    return static_cast<int>(rows / d);
  }

  struct WindowScratch {  ///< amp_window's buffers (one per thread)
    std::array<KinematicState, kAmpWindowFrames + 2> grid;  ///< poses t_end − 5Δ … t_end + Δ
    KinematicState state;
    BodyStates bodies;
  };

  Skeleton skel_;
  std::vector<MotionClip> clips_;
  std::vector<double> weights_;
};

}  // namespace maskadapt
