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
      clip_pose(bl, tb, s);
    }
    for (int body = 1; body < skel.num_bodies(); ++body) {
      if (!mask.has(skel.parts[body])) continue;
      const int k = Skeleton::dof_offset(body);
      out.q.col(t).segment<3>(k) = frame >= 0 ? Vec3(bl.q.col(frame).segment<3>(k)) : Vec3(s.q.segment<3>(k));
    }
  }
  return out;
}

}  // namespace maskadapt
