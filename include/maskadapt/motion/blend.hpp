#pragma once
/// \file blend.hpp
/// Part-wise blending for motion composition: the "real" samples of the mask-conditioned
/// discriminator.
///
/// blend_parts(A, B, m): a clip with A's timing, frame rate, root and loop flag; the joints of
/// bodies whose part is in m carry B's joint angles, every other joint A's. Frame t of the result
/// is at time τ = t / fps_A; B is sampled at τ·speed + b_offset — looping when B loops or when
/// `loop_b` is set (B is shorter than A), otherwise held at its last frame. When A and B share a
/// frame rate, speed = 1 and offset = 0, the masked joints are B's frames exactly.
#include <maskadapt/core/error.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/library.hpp>

#include <algorithm>
#include <cmath>
#include <string>

namespace maskadapt {

struct BlendOptions {
  double b_offset = 0.0;  ///< time in B of A's first frame (s)
  double b_speed = 1.0;   ///< B's playback speed relative to A
  bool loop_b = true;     ///< loop B's joint motion when it is shorter than A
};

inline MotionClip blend_parts(const MotionClip& a, const MotionClip& b, PartMask mask, const Skeleton& skel,
                              const BlendOptions& opt = {}) {
  a.validate(skel);
  b.validate(skel);
  require(std::isfinite(opt.b_offset) && std::isfinite(opt.b_speed) && opt.b_speed > 0,
          "blend offset/speed must be finite (speed > 0)", {{}, {}, "blend"});
  MotionClip out = a;
  out.name = a.name + "+" + b.name + "@" + mask.to_string();
  out.labels = a.labels;
  for (const auto& l : b.labels) out.labels.push_back(l + " (" + mask.to_string() + ")");
  out.description = "part-wise blend: " + mask.to_string() + " from '" + b.name + "', the rest from '" + a.name + "'";
  MotionClip bl = b;
  bl.loop = b.loop || opt.loop_b;
  KinematicState s;
  const double P = bl.duration();
  for (int t = 0; t < a.num_frames(); ++t) {
    double tb = t / a.fps * opt.b_speed + opt.b_offset;
    // exact frame when it falls on one (avoids slerp round-off)
    const double u = tb * bl.fps;
    const double ur = std::round(u);
    const bool on_frame = std::abs(u - ur) < 1e-9;
    if (bl.loop && P > 0) tb = tb - std::floor(tb / P) * P;
    int frame = -1;
    if (on_frame) {
      long long f = static_cast<long long>(ur);
      const int T = bl.num_frames();
      if (bl.loop && T > 1) f = ((f % (T - 1)) + (T - 1)) % (T - 1);
      f = std::clamp<long long>(f, 0, T - 1);
      frame = static_cast<int>(f);
    } else {
      clip_pose(skel, bl, tb, s);
    }
    for (int body = 1; body < skel.num_bodies(); ++body) {
      if (!mask.has(skel.parts[body])) continue;
      const int k = skel.dof_offset(body), n = skel.num_dofs_of(body);
      out.q.col(t).segment(k, n) = frame >= 0 ? VectorXd(bl.q.col(frame).segment(k, n)) : VectorXd(s.q.segment(k, n));
    }
  }
  return out;
}

/// One switch of the masked parts between A's own motion and B's, for training data in which
/// the parts change behaviour on command (tracking/arm_data.hpp): w(τ) = 0 before `on_s`, ramps
/// linearly to 1 over `fade_s`, stays 1 until `off_s`, then ramps back to 0 over `fade_s`
/// (τ = t / fps_A, seconds from A's first frame; off_s = +∞ never switches back).
struct PartSwitch {
  double on_s = 0.0;        ///< B's motion starts fading in (s)
  double off_s = INFINITY;  ///< B's motion starts fading out (s), ≥ on_s
  double fade_s = 0.3;      ///< linear cross-fade length (s), ≥ 0
  /// Weight of B at time τ (s), in [0, 1].
  double weight(double tau) const {
    auto ramp = [&](double x) { return fade_s <= 0 ? (x >= 0 ? 1.0 : 0.0) : std::clamp(x / fade_s, 0.0, 1.0); };
    return std::min(ramp(tau - on_s), 1.0 - ramp(tau - off_s));
  }
};

/// blend_parts(A, B, m, skel, opt) whose masked joints are cross-faded between A's and B's
/// angles with the weight of `sw` (q = (1 − w)·q_A + w·q_B per hinge angle, rad); the other
/// joints and the root are A's. With w ≡ 1 (on_s ≤ 0, fade 0, off_s = ∞) it equals blend_parts.
/// Labels: A's labels; the caller labels the segments (the blend alone cannot say which frames
/// show which behaviour).
inline MotionClip blend_parts_switched(const MotionClip& a, const MotionClip& b, PartMask mask, const Skeleton& skel,
                                       const PartSwitch& sw, const BlendOptions& opt = {}) {
  require(std::isfinite(sw.on_s) && !std::isnan(sw.off_s) && sw.off_s >= sw.on_s && std::isfinite(sw.fade_s) &&
              sw.fade_s >= 0,
          "part switch needs finite on_s ≤ off_s and fade_s ≥ 0", {{}, {}, "PartSwitch"});
  MotionClip out = blend_parts(a, b, mask, skel, opt);
  out.labels = a.labels;
  out.description = "part-wise switch: " + mask.to_string() + " from '" + b.name + "' between " +
                    std::to_string(sw.on_s) + " s and " + std::to_string(sw.off_s) + " s, the rest from '" + a.name + "'";
  for (int t = 0; t < a.num_frames(); ++t) {
    const double w = sw.weight(t / a.fps);
    for (int body = 1; body < skel.num_bodies(); ++body) {
      if (!mask.has(skel.parts[body])) continue;
      for (int k = skel.dof_offset(body); k < skel.dof_offset(body) + skel.num_dofs_of(body); ++k)
        out.q(k, t) = (1.0 - w) * a.q(k, t) + w * out.q(k, t);
    }
  }
  return out;
}

}  // namespace maskadapt
