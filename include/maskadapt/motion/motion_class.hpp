#pragma once
/// \file motion_class.hpp
/// What kind of locomotion a clip shows at a frame — stand, walk, run, backward, sideways or turn —
/// read from the root's own motion, so that an evaluation can start episodes from one kind of
/// frame and compare what the policy does with what the clips do there (`eval-base --per-class`).
///
/// The root motion at frame f is averaged over the window [f − w, f + w] (w = `window_s`, clamped
/// to the clip): the horizontal displacement of the root over the window, divided by its duration,
/// expressed in the heading frame of frame f (heading_angle: the root's x axis on the ground, which
/// is the humanoid's facing direction), and the heading's change over the window per second.
/// Classes, first rule that holds:
///   speed < stand_speed                       → stand
///   speed ≥ run_speed                         → run
///   forward < 0 and |forward| ≥ |sideways|    → backward
///   |sideways| > |forward|                    → sideways
///   |yaw rate| ≥ turn_rate                    → turn
///   otherwise                                 → walk
/// The defaults fit human locomotion: the Bandai walks go at ≈ 1.1 m/s, its runs at ≈ 3 m/s, and
/// its 90° walking turns at ≈ 0.8 rad/s of heading change.
#include <maskadapt/core/error.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/observation.hpp>

#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <string_view>
#include <vector>

namespace maskadapt {

enum class MotionClass : int { stand = 0, walk, run, backward, sideways, turn };
inline constexpr int kNumMotionClasses = 6;
inline constexpr std::array<std::string_view, kNumMotionClasses> kMotionClassNames{"stand", "walk", "run", "backward",
                                                                                  "sideways", "turn"};
inline std::string to_string(MotionClass c) { return std::string(kMotionClassNames[static_cast<std::size_t>(c)]); }

struct MotionClassThresholds {
  double window_s = 0.5;     ///< s, half-width of the averaging window
  double stand_speed = 0.3;  ///< m/s: below it, standing
  double run_speed = 2.0;    ///< m/s: at or above it, running
  double turn_rate = 0.5;    ///< rad/s: |heading change| at or above it, turning
};

/// The root's motion around one frame, in that frame's heading frame.
struct RootMotion {
  double forward = 0;   ///< m/s, along the heading (negative: backwards)
  double sideways = 0;  ///< m/s, to the left of the heading
  double speed = 0;     ///< m/s, horizontal: √(forward² + sideways²)
  double yaw_rate = 0;  ///< rad/s, counter-clockwise seen from above
};

/// Root motion of `clip` at `frame`, averaged over ±window_s (clamped to the clip). Throws for a
/// frame outside the clip, a clip of one frame or a window that is not positive.
inline RootMotion root_motion_at(const MotionClip& clip, int frame, double window_s) {
  require(clip.num_frames() >= 2, "a clip needs 2 frames for its root motion", {{}, {}, clip.name});
  require(frame >= 0 && frame < clip.num_frames(), "frame " + std::to_string(frame) + " is outside the clip's " +
                                                       std::to_string(clip.num_frames()) + " frames",
          {{}, {}, clip.name});
  require(std::isfinite(window_s) && window_s > 0, "the window must be positive", {{}, {}, "window_s"});
  const int w = std::max(1, static_cast<int>(std::lround(window_s * clip.fps)));
  const int a = std::max(0, frame - w), b = std::min(clip.num_frames() - 1, frame + w);
  const double seconds = (b - a) / clip.fps;
  const Eigen::Vector2d d = clip.root_pos.col(b).head<2>() - clip.root_pos.col(a).head<2>();
  const double h = heading_angle(clip.rot(frame));
  RootMotion m;
  m.forward = (d.x() * std::cos(h) + d.y() * std::sin(h)) / seconds;
  m.sideways = (-d.x() * std::sin(h) + d.y() * std::cos(h)) / seconds;
  m.speed = std::hypot(m.forward, m.sideways);
  double turned = 0;  // frame-to-frame increments, each wrapped, so a turn past ±π is followed
  for (int f = a; f < b; ++f) {
    double dh = heading_angle(clip.rot(f + 1)) - heading_angle(clip.rot(f));
    dh = std::remainder(dh, 2 * std::numbers::pi);
    turned += dh;
  }
  m.yaw_rate = turned / seconds;
  return m;
}

/// The class of a root motion (rules in the file comment).
inline MotionClass classify_root_motion(const RootMotion& m, const MotionClassThresholds& t = {}) {
  if (m.speed < t.stand_speed) return MotionClass::stand;
  if (m.speed >= t.run_speed) return MotionClass::run;
  if (m.forward < 0 && -m.forward >= std::abs(m.sideways)) return MotionClass::backward;
  if (std::abs(m.sideways) > std::abs(m.forward)) return MotionClass::sideways;
  if (std::abs(m.yaw_rate) >= t.turn_rate) return MotionClass::turn;
  return MotionClass::walk;
}

/// The class of every frame of `clip` (num_frames entries).
inline std::vector<MotionClass> classify_frames(const MotionClip& clip, const MotionClassThresholds& t = {}) {
  std::vector<MotionClass> out(static_cast<std::size_t>(clip.num_frames()));
  for (int f = 0; f < clip.num_frames(); ++f) out[static_cast<std::size_t>(f)] = classify_root_motion(root_motion_at(clip, f, t.window_s), t);
  return out;
}

}  // namespace maskadapt
