#pragma once
/// \file retarget_quality.hpp
/// Quality report of a G1 clip retargeted from a humanoid clip (g1/retarget.hpp), in the spirit
/// of motion/quality.hpp's report for humanoid clips.
///
/// Definitions (kinematics only; the clip's frames are the samples):
///  - a foot (ankle-roll link, which carries the sole box) is *in contact* in a frame when its
///    lowest point is below `contact_height` (2.5 cm, as motion_quality); its *skating speed* is
///    the horizontal speed of the link origin between consecutive frames where it is in contact
///    in both; `foot_skating` is the mean of those speeds, `foot_skating_max` the largest (m/s).
///    The contact height is 1 cm rather than motion_quality's 2.5 cm: the G1's stance soles are
///    put on z = 0, while human swing toes pass 1–2 cm above the floor, so 2.5 cm would count
///    most of a walk's swing as contact. Pivoting on the toe (heel-off) and a swing foot skimming
///    the floor before heel strike still count: the link origin moves while the lowest point is
///    low. `flat_skating` is the same mean over pairs of frames where the foot is in contact *and*
///    level in both (sole normal within `flat_angle`, 5°, of vertical): sliding of a planted foot;
///  - *joint-limit violations*: (frame, joint) pairs outside [lower, upper] and the largest excess
///    (rad); 0 by construction of the retargeting;
///  - *ground penetration*: how far the lowest point of any geom is below z = 0 (m), max over
///    frames; 0 by construction when retargeting grounds (the default);
///  - *end-effector error*: |(p_e − root) − (p*_e − root*)| for the five effectors (soles, hand
///    centres, head centre) against the scaled source targets of g1_targets — root-relative, so
///    the per-frame grounding lift does not count; mean over frames and effectors, max, and the
///    mean per effector (m);
///  - *joint speed*: the largest |Δq|·fps over joints and consecutive frames (rad/s), a smoothness
///    check of the warm-started IK.
#include <maskadapt/g1/retarget.hpp>

#include <cstdio>
#include <string>

namespace maskadapt::g1 {

struct G1QualityOptions {
  double contact_height = 0.01;  ///< m
  double flat_angle = 0.0872665;  ///< rad (5°): a foot is level when its sole normal is this close to +z
};

struct G1QualityReport {
  int frames = 0;
  double duration = 0;                  ///< s
  double foot_skating = 0;              ///< m/s, mean horizontal foot speed in contact
  double foot_skating_max = 0;          ///< m/s
  double contact_fraction = 0;          ///< fraction of (frame, foot) in contact
  double flat_skating = 0;              ///< m/s, mean horizontal speed of level feet in contact
  long long limit_violations = 0;       ///< (frame, joint) pairs outside the limits
  double limit_excess_max = 0;          ///< rad
  double penetration_max = 0;           ///< m
  double effector_error_mean = 0;       ///< m
  double effector_error_max = 0;        ///< m
  std::array<double, kNumEffectors> effector_error_by{};  ///< m, mean per effector
  double joint_speed_max = 0;           ///< rad/s
  double root_height_mean = 0;          ///< m

  std::string to_string() const {
    char buf[1024];
    std::snprintf(buf, sizeof(buf),
                  "frames %d, duration %.2f s, root height %.3f m\n"
                  "foot skating %.1f cm/s mean, %.1f cm/s max (feet in contact %.0f%% of frames), level feet %.1f cm/s\n"
                  "joint-limit violations %lld, max excess %.4f rad\n"
                  "ground penetration %.2f cm max\n"
                  "end-effector error %.1f cm mean, %.1f cm max (feet %.1f/%.1f, hands %.1f/%.1f, head %.1f cm)\n"
                  "max joint speed %.1f rad/s",
                  frames, duration, root_height_mean, 100 * foot_skating, 100 * foot_skating_max,
                  100 * contact_fraction, 100 * flat_skating, limit_violations, limit_excess_max, 100 * penetration_max,
                  100 * effector_error_mean, 100 * effector_error_max, 100 * effector_error_by[0],
                  100 * effector_error_by[1], 100 * effector_error_by[2], 100 * effector_error_by[3],
                  100 * effector_error_by[4], joint_speed_max);
    return buf;
  }
};

/// Joint-limit check alone: (frame, joint) pairs outside the limits; `max_excess` (rad) optional.
inline long long g1_limit_violations(const G1Clip& c, const G1Description& d = g1_description(),
                                     double* max_excess = nullptr) {
  const VectorXd lo = d.joint_vector(&Link::lower), hi = d.joint_vector(&Link::upper);
  long long n = 0;
  double mx = 0;
  for (int t = 0; t < c.num_frames(); ++t)
    for (int j = 0; j < kNumJoints; ++j) {
      const double ex = std::max(c.q(j, t) - hi[j], lo[j] - c.q(j, t));
      if (ex > 0) {
        ++n;
        mx = std::max(mx, ex);
      }
    }
  if (max_excess) *max_excess = mx;
  return n;
}

/// The report of `clip`, retargeted from `source` with `opt` (the same options, so that the
/// effector targets are the ones the IK aimed at).
inline G1QualityReport g1_retarget_quality(const G1Clip& clip, const MotionClip& source, const G1RetargetOptions& opt = {},
                                           const G1QualityOptions& qopt = {}, const G1Description& d = g1_description(),
                                           const HumanoidDescription& h = humanoid_description()) {
  clip.validate();
  detail::check_g1_source(source, h);
  require(clip.num_frames() == source.num_frames(),
          "G1 quality: the G1 clip has " + std::to_string(clip.num_frames()) + " frames, its source " +
              std::to_string(source.num_frames()),
          {{}, {}, "frames"});
  const IkModel m = make_ik_model(d);
  const HumanoidPoints hp = humanoid_points(h);
  const double rs = opt.root_scale > 0 ? opt.root_scale : g1_leg_ratio(d, h);
  const double es = opt.effector_scale > 0 ? opt.effector_scale : g1_height_ratio(d, h);
  const double hs = opt.head_scale > 0 ? opt.head_scale : g1_head_ratio(d, h);
  const Vec3 origin(source.root_pos(0, 0), source.root_pos(1, 0), 0.0);
  G1QualityReport r;
  const int T = clip.num_frames();
  r.frames = T;
  r.duration = clip.duration();
  r.limit_violations = g1_limit_violations(clip, d, &r.limit_excess_max);
  const std::array<int, 2> feet = {d.link_index("left_ankle_roll_link"), d.link_index("right_ankle_roll_link")};
  std::array<Vec3, 2> prev_pos = {Vec3::Zero(), Vec3::Zero()};
  std::array<bool, 2> prev_contact{false, false}, prev_flat{false, false};
  double skate_sum = 0, flat_sum = 0;
  long long skate_n = 0, contact_n = 0, flat_n = 0;
  const double cos_flat = std::cos(qopt.flat_angle);
  BodyStates bs;
  std::array<Vec3, kNumEffectors> pos;
  std::array<Vec3, kNumDirections> dir;
  for (int t = 0; t < T; ++t) {
    const LinkPoses p = clip.poses(d, t);
    r.root_height_mean += clip.root_pos(2, t) / T;
    for (std::size_t f = 0; f < feet.size(); ++f) {
      const bool contact = g1_lowest_point(d, p, feet[f]) < qopt.contact_height;
      const Vec3 x = p.pos[static_cast<std::size_t>(feet[f])];
      const bool flat = contact && (p.rot[static_cast<std::size_t>(feet[f])] * Vec3::UnitZ()).z() >= cos_flat;
      if (contact) ++contact_n;
      if (t > 0 && contact && prev_contact[f]) {
        const double v = (x - prev_pos[f]).head<2>().norm() * clip.fps;
        skate_sum += v;
        ++skate_n;
        r.foot_skating_max = std::max(r.foot_skating_max, v);
        if (flat && prev_flat[f]) flat_sum += v, ++flat_n;
      }
      prev_contact[f] = contact;
      prev_flat[f] = flat;
      prev_pos[f] = x;
    }
    r.penetration_max = std::max(r.penetration_max, -g1_lowest_point(d, p));
    forward_kinematics(h.skeleton, source.frame(t), bs);
    const IkTargets tg = g1_targets(hp, bs, origin, rs, es, hs);
    g1_features(m, p, pos, dir);
    for (int e = 0; e < kNumEffectors; ++e) {
      const auto u = static_cast<std::size_t>(e);
      const double err = ((pos[u] - p.pos[0]) - (tg.pos[u] - tg.root_pos)).norm();
      r.effector_error_by[u] += err / T;
      r.effector_error_mean += err / (double(T) * double(kNumEffectors));
      r.effector_error_max = std::max(r.effector_error_max, err);
    }
    if (t > 0)
      r.joint_speed_max = std::max(r.joint_speed_max, (clip.q.col(t) - clip.q.col(t - 1)).cwiseAbs().maxCoeff() * clip.fps);
  }
  r.foot_skating = skate_n ? skate_sum / skate_n : 0.0;
  r.flat_skating = flat_n ? flat_sum / flat_n : 0.0;
  r.contact_fraction = double(contact_n) / (2.0 * T);
  return r;
}

}  // namespace maskadapt::g1
