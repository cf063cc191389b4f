#pragma once
/// \file generator.hpp
/// The `TrajectoryGenerator` concept: text + motion history → future kinematic frames, plus the
/// trajectory type, heading-frame canonicalisation and a generic autoregressive rollout.
///
/// ## What a plug-in generator must provide
///
/// A type `G` satisfies `TrajectoryGenerator` when, for `G& g`, `const G& cg`:
///
///  - `cg.skeleton()` → `const Skeleton&`: the skeleton its frames are expressed in (the
///    reference humanoid for everything in maskadapt's tasks: 22 bodies, 63 DoF).
///  - `cg.history_frames()` → H ≥ 1 and `cg.future_frames()` → F ≥ 1 (frame counts at 30 Hz;
///    the built-in generator uses H = 5, F = 15).
///  - `g.generate(const TextCondition& c, const Trajectory& history, Rng& rng)` → `Trajectory`:
///      * `history` holds exactly H frames, **canonicalised** to its first frame (see
///        `canonicalize`): frame 0's root is above the origin (x = y = 0, z = its height) and its
///        heading (yaw of the root's x axis) is 0; z is up.
///      * it returns exactly F frames that **follow** the history in time (frame 0 of the result is
///        1/30 s after the last history frame), expressed in that same canonical frame, with every
///        field of `Trajectory` filled: root_pos (3 × F), root_rot (F unit quaternions),
///        q (num_dofs × F, the skeleton's 3-hinge joint angles), body_pos (3·num_bodies × F,
///        world-like positions of every body in the canonical frame, consistent with FK).
///      * all randomness comes from `rng` (same rng state ⇒ same output).
///      * `c.embedding` is non-empty when the caller has precomputed text features; otherwise
///        `c.text` is the prompt. An empty text with no embedding means "unconditional".
///
/// `check_generated` validates a result; `rollout` drives any generator autoregressively. A
/// generator run elsewhere (e.g. DART in Python) plugs in by wrapping its I/O in such a type.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/humanoid/observation.hpp>  // heading_angle
#include <maskadapt/motion/skeleton.hpp>

#include <cmath>
#include <concepts>
#include <numbers>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace maskadapt::tracking {

/// A kinematic frame sequence (samples are columns; metres, radians; z-up).
struct Trajectory {
  double fps = 30.0;
  Matrix3X root_pos;           ///< (3 × N) root position (m)
  std::vector<Quat> root_rot;  ///< (N) root orientation
  MatrixXd q;                  ///< (num_dofs × N) joint angles (rad), 3 hinges x, y, z per non-root body
  MatrixXd body_pos;           ///< (3·num_bodies × N) positions of every body origin (m); body b at rows 3b..3b+2

  Index num_frames() const { return root_pos.cols(); }

  /// Empty trajectory of n frames for `skel` (identity rotations, zeros).
  static Trajectory zeros(const Skeleton& skel, Index n, double fps = 30.0) {
    Trajectory t;
    t.fps = fps;
    t.root_pos = Matrix3X::Zero(3, n);
    t.root_rot.assign(static_cast<std::size_t>(n), Quat::Identity());
    t.q = MatrixXd::Zero(skel.num_dofs(), n);
    t.body_pos = MatrixXd::Zero(3 * skel.num_bodies(), n);
    return t;
  }

  /// Frame i as a KinematicState (zero velocities).
  KinematicState state(Index i) const {
    KinematicState s;
    s.root_pos = root_pos.col(i);
    s.root_rot = root_rot[static_cast<std::size_t>(i)];
    s.q = q.col(i);
    s.qd = VectorXd::Zero(q.rows());
    return s;
  }

  /// Frames [begin, begin + n).
  Trajectory slice(Index begin, Index n) const {
    require(begin >= 0 && n >= 0 && begin + n <= num_frames(), "trajectory slice out of range", {{}, {}, "slice"});
    Trajectory t;
    t.fps = fps;
    t.root_pos = root_pos.middleCols(begin, n);
    t.root_rot.assign(root_rot.begin() + begin, root_rot.begin() + begin + n);
    t.q = q.middleCols(begin, n);
    t.body_pos = body_pos.middleCols(begin, n);
    return t;
  }

  /// Appends the frames of `o` (same skeleton).
  void append(const Trajectory& o) {
    if (num_frames() == 0) {
      *this = o;
      return;
    }
    require(o.q.rows() == q.rows() && o.body_pos.rows() == body_pos.rows(), "cannot append a trajectory of another skeleton",
            {{}, {}, "trajectory"});
    const Index n = num_frames(), m = o.num_frames();
    root_pos.conservativeResize(3, n + m);
    root_pos.rightCols(m) = o.root_pos;
    root_rot.insert(root_rot.end(), o.root_rot.begin(), o.root_rot.end());
    q.conservativeResize(q.rows(), n + m);
    q.rightCols(m) = o.q;
    body_pos.conservativeResize(body_pos.rows(), n + m);
    body_pos.rightCols(m) = o.body_pos;
  }
};

/// Fills `t.body_pos` from the root and joint angles by forward kinematics.
inline void compute_body_positions(const Skeleton& skel, Trajectory& t) {
  require(t.q.rows() == skel.num_dofs(), "trajectory joint angles do not match the skeleton", {{}, {}, "q"});
  t.body_pos.resize(3 * skel.num_bodies(), t.num_frames());
  BodyStates b;
  for (Index i = 0; i < t.num_frames(); ++i) {
    KinematicState s = t.state(i);
    s.qd.resize(0);  // positions only
    forward_kinematics(skel, s, b);
    for (int k = 0; k < skel.num_bodies(); ++k) t.body_pos.block<3, 1>(3 * k, i) = b.pos.col(k);
  }
}

/// A heading frame: origin on the ground below a root, x axis along its heading.
/// p_local = R_z(−yaw)·(p − origin), R_local = R_z(−yaw)·R.
struct HeadingFrame {
  Vec3 origin = Vec3::Zero();  ///< (x, y, 0) of the reference root (m)
  double yaw = 0.0;            ///< heading of the reference root (rad)

  Quat rotation() const { return Quat(Eigen::AngleAxisd(yaw, Vec3::UnitZ())); }
  Vec3 to_local(const Vec3& p) const { return rotation().conjugate() * (p - origin); }
  Vec3 to_world(const Vec3& p) const { return rotation() * p + origin; }
  Quat to_local(const Quat& r) const { return (rotation().conjugate() * r).normalized(); }
  Quat to_world(const Quat& r) const { return (rotation() * r).normalized(); }

  /// The heading frame of frame i of t.
  static HeadingFrame of(const Trajectory& t, Index i) {
    HeadingFrame f;
    f.origin = Vec3(t.root_pos(0, i), t.root_pos(1, i), 0.0);
    f.yaw = heading_angle(t.root_rot[static_cast<std::size_t>(i)]);
    return f;
  }
};

/// Expresses every frame of t in `f` (to_local) or back in the world (to_world). Joint angles
/// are unchanged; root and body positions and root orientations are transformed.
inline Trajectory transform_to_local(const Trajectory& t, const HeadingFrame& f) {
  Trajectory o = t;
  const Mat3 Rt = f.rotation().conjugate().toRotationMatrix();
  for (Index i = 0; i < t.num_frames(); ++i) {
    o.root_pos.col(i) = Rt * (t.root_pos.col(i) - f.origin);
    o.root_rot[static_cast<std::size_t>(i)] = f.to_local(t.root_rot[static_cast<std::size_t>(i)]);
    for (Index k = 0; k < t.body_pos.rows() / 3; ++k)
      o.body_pos.block<3, 1>(3 * k, i) = Rt * (t.body_pos.block<3, 1>(3 * k, i) - f.origin);
  }
  return o;
}
inline Trajectory transform_to_world(const Trajectory& t, const HeadingFrame& f) {
  Trajectory o = t;
  const Mat3 R = f.rotation().toRotationMatrix();
  for (Index i = 0; i < t.num_frames(); ++i) {
    o.root_pos.col(i) = R * t.root_pos.col(i) + f.origin;
    o.root_rot[static_cast<std::size_t>(i)] = f.to_world(t.root_rot[static_cast<std::size_t>(i)]);
    for (Index k = 0; k < t.body_pos.rows() / 3; ++k)
      o.body_pos.block<3, 1>(3 * k, i) = R * t.body_pos.block<3, 1>(3 * k, i) + f.origin;
  }
  return o;
}

/// Canonicalises t to its frame `ref` (default 0): returns the local trajectory and the frame.
inline std::pair<Trajectory, HeadingFrame> canonicalize(const Trajectory& t, Index ref = 0) {
  require(ref >= 0 && ref < t.num_frames(), "reference frame out of range", {{}, {}, "ref"});
  const HeadingFrame f = HeadingFrame::of(t, ref);
  return {transform_to_local(t, f), f};
}

/// A text condition: a prompt, or features computed elsewhere (then `embedding` is non-empty and
/// takes precedence). Empty text and empty embedding = unconditional.
struct TextCondition {
  std::string text;
  VectorXf embedding;  ///< (text feature dim) or empty

  TextCondition() = default;
  TextCondition(std::string t) : text(std::move(t)) {}                     // NOLINT: implicit from a prompt
  TextCondition(const char* t) : text(t) {}                                // NOLINT
  static TextCondition from_embedding(VectorXf e) {
    TextCondition c;
    c.embedding = std::move(e);
    return c;
  }
};

template <class G>
concept TrajectoryGenerator = requires(G& g, const G& cg, const TextCondition& c, const Trajectory& history, Rng& rng) {
  { cg.skeleton() } -> std::same_as<const Skeleton&>;
  { cg.history_frames() } -> std::convertible_to<Index>;
  { cg.future_frames() } -> std::convertible_to<Index>;
  { g.generate(c, history, rng) } -> std::same_as<Trajectory>;
};

/// Throws unless `t` has `frames` frames of `skel` with every field filled and finite.
inline void check_generated(const Skeleton& skel, const Trajectory& t, Index frames, const std::string& who = "generator") {
  require(t.num_frames() == frames, who + " returned " + std::to_string(t.num_frames()) + " frames, expected " +
                                        std::to_string(frames), {{}, {}, "frames"});
  require(static_cast<Index>(t.root_rot.size()) == frames, who + ": root_rot has the wrong length", {{}, {}, "root_rot"});
  require(t.q.rows() == skel.num_dofs() && t.q.cols() == frames, who + ": q has the wrong shape", {{}, {}, "q"});
  require(t.body_pos.rows() == 3 * skel.num_bodies() && t.body_pos.cols() == frames,
          who + ": body_pos has the wrong shape", {{}, {}, "body_pos"});
  require_finite(t.root_pos, "root_pos");
  require_finite(t.q, "q");
  require_finite(t.body_pos, "body_pos");
  for (const auto& r : t.root_rot) require(std::isfinite(r.norm()) && std::abs(r.norm() - 1.0) < 1e-3,
                                           who + ": root_rot is not a unit quaternion", {{}, {}, "root_rot"});
}

/// Text schedule "0:wave hands,5:raise arms": (start time in seconds, prompt), sorted by time.
struct TimedText {
  double start_s = 0.0;
  std::string text;
};
inline std::vector<TimedText> parse_text_schedule(std::string_view spec) {
  std::vector<TimedText> out;
  std::size_t start = 0;
  while (start <= spec.size()) {
    std::size_t end = spec.find(',', start);
    if (end == std::string_view::npos) end = spec.size();
    std::string_view item = spec.substr(start, end - start);
    start = end + 1;
    while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
    if (item.empty()) continue;
    const std::size_t colon = item.find(':');
    TimedText tt;
    if (colon == std::string_view::npos) {
      tt.start_s = out.empty() ? 0.0 : out.back().start_s;
      tt.text = std::string(item);
    } else {
      const std::string num(item.substr(0, colon));
      char* endp = nullptr;
      tt.start_s = std::strtod(num.c_str(), &endp);
      require(endp && *endp == '\0' && !num.empty() && std::isfinite(tt.start_s) && tt.start_s >= 0,
              "bad start time '" + num + "' (expected seconds ≥ 0 as in \"0:wave hands,5:raise arms\")", {{}, {}, "text"});
      tt.text = std::string(item.substr(colon + 1));
    }
    require(out.empty() || tt.start_s >= out.back().start_s, "text schedule times must not decrease", {{}, {}, "text"});
    out.push_back(std::move(tt));
  }
  require(!out.empty(), "empty text schedule", {{}, {}, "text"});
  return out;
}

/// The prompt active at time `t_s` (the last entry with start ≤ t_s; the first one before it).
inline const std::string& text_at(const std::vector<TimedText>& schedule, double t_s) {
  std::size_t k = 0;
  for (std::size_t i = 0; i < schedule.size(); ++i)
    if (schedule[i].start_s <= t_s) k = i;
  return schedule[k].text;
}

/// Autoregressive rollout of any generator: starting from `history_world` (≥ H frames, world
/// frame, fps 30), repeatedly canonicalises the last H frames, asks for F more, maps them back to
/// the world and appends. The prompt of each primitive is text_at(schedule, time of its first
/// new frame), times measured from the end of the history. Returns the `num_frames` new frames
/// (world frame); the history is not included.
template <TrajectoryGenerator G>
Trajectory rollout(G& g, const std::vector<TimedText>& schedule, const Trajectory& history_world, Index num_frames,
                   Rng& rng) {
  const Index H = static_cast<Index>(g.history_frames());
  const Index F = static_cast<Index>(g.future_frames());
  require(H >= 1 && F >= 1, "generator must have H ≥ 1 and F ≥ 1", {{}, {}, "generator"});
  require(history_world.num_frames() >= H, "rollout needs at least H = " + std::to_string(H) + " history frames",
          {{}, {}, "history"});
  require(num_frames >= 0, "number of frames must be ≥ 0", {{}, {}, "num_frames"});
  Trajectory all = history_world.slice(history_world.num_frames() - H, H);
  Index produced = 0;
  while (produced < num_frames) {
    const Trajectory hist = all.slice(all.num_frames() - H, H);
    auto [local, frame] = canonicalize(hist, 0);
    const TextCondition cond(text_at(schedule, static_cast<double>(produced) / history_world.fps));
    const Trajectory fut = g.generate(cond, local, rng);
    check_generated(g.skeleton(), fut, F);
    all.append(transform_to_world(fut, frame));
    produced += F;
  }
  return all.slice(H, num_frames);
}

}  // namespace maskadapt::tracking
