#pragma once
/// \file retarget.hpp
/// Retargeting reference-humanoid motion (a `MotionClip` on the 22-body skeleton, what
/// humanoid/retarget.hpp makes of CMU/Bandai/styles BVH and AMASS) onto the G1-like robot, by an
/// optimisation-based inverse kinematics per frame.
///
/// Per frame t (docs/characters.md, "Retargeting onto the G1"):
///  1. the humanoid's forward kinematics gives its points and bone directions;
///  2. the G1 root (pelvis) is placed at the humanoid root, its translation scaled by the
///     *leg-length ratio* s_leg = (G1 pelvis height) / (humanoid pelvis height) at the zero poses
///     (0.838), about the first frame's ground point; the root orientation is copied (both
///     characters face +x with z up at their zero pose, so the frames agree);
///  3. targets, world frame:
///       end-effectors  p*_e = root_G1 + s_e · (p_e^hum − root_hum)      (5 points)
///     for the two soles (the point of the sole under the ankle), the two hand centres and the
///     head centre. s_e is the *height ratio* s_h = 1.3199 / 1.7510 (0.754, head tops) for the
///     hands; the feet use s_leg, the root's ratio, so that the sole targets are s_leg × the
///     humanoid's soles about a fixed point (a foot planted in the source stays planted, a
///     straight humanoid leg gives a straight G1 leg; with s_h the feet would float 10 cm under a
///     straight-legged pelvis); the head uses the ratio of the head-centre heights above the
///     pelvis, 0.649 (the G1 has no neck and a short trunk: with s_h an upright G1's head would
///     miss by 7.7 cm in every frame);
///       directions     d*_k = unit humanoid direction                  (18 unit vectors)
///     upper arms, forearms, thighs, shanks (bone vectors between joint centres), hands (wrist →
///     hand centre, and the back-of-hand normal, which fixes the otherwise free wrist roll), the
///     chest's up and forward axes against the G1 torso link's, each foot's forward and up axes
///     against the ankle-roll link's;
///  4. foot contact cleanup (detail::lock_feet, on by default): stance phases of each source sole
///     are detected (low and slow), the foot's constant stance tilt is removed, its ground level
///     becomes z = 0, and in stance the sole target is held flat on the floor at the phase's mean
///     position (blended in and out over 3 frames);
///  5. the 29 joint angles minimise, inside the joint limits (box constraints),
///       f(q) = ½ Σ_e w_e² |p_e(q) − p*_e|² + ½ Σ_k v_k² |d_k(q) − d*_k|²
///            + ½ λ_prev² |q − q_{t−1}|² + ½ λ_nom² |q − q_nominal|²
///     by projected Levenberg–Marquardt (Gauss–Newton with adaptive damping): at each iteration
///     the variables at a bound whose gradient pushes outward are held fixed, the damped normal
///     equations are solved for the others, the step is clamped to the box and accepted only if
///     it lowers f. Warm start from frame t−1 (frame 0: the nominal pose). Jacobians are
///     analytic: ∂p/∂q_j = a_j × (p − o_j) for the hinge axes a_j (world) at link origins o_j,
///     ∂d/∂q_j = a_j × d for a link axis, (I − d dᵀ)/|v| · ∂v/∂q_j for a bone v;
///  6. grounding (two passes): where the scaled root is too high for the stance soles to reach the
///     floor, the root target (and the root-relative hand/head targets) is lowered by the stance
///     sole's height, interpolated across frames without stance, and the clip is solved again;
///     then the per-frame vertical offset that puts the stance soles on z = 0, and a lift of any
///     frame whose lowest geom point is below z = 0 (no frame penetrates).
///
/// The parts live in their own headers, all included here:
///  - g1/clip.hpp       the G1Clip type and its .npz format (save_g1_clip, load_g1_clip);
///  - g1/ik.hpp         step 5: targets, weights, the G1-side features and solve_ik;
///  - g1/targets.hpp    steps 2–3: humanoid_points, the scale ratios, g1_targets;
///  - g1/foot_lock.hpp  step 4: detail::lock_feet;
///  - this header       g1_lowest_point, step 6 and the whole-clip retarget_to_g1.
/// Joint limits hold exactly by construction (every iterate is clamped to the box).
/// Quality figures of the result: g1/retarget_quality.hpp.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/g1/clip.hpp>
#include <maskadapt/g1/description.hpp>
#include <maskadapt/g1/foot_lock.hpp>
#include <maskadapt/g1/ik.hpp>
#include <maskadapt/g1/targets.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/skeleton.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace maskadapt::g1 {

/// Lowest world z of link i's geoms (boxes exact, capsules and spheres exact); all links if i < 0.
inline double g1_lowest_point(const G1Description& d, const LinkPoses& p, int i = -1) {
  double low = std::numeric_limits<double>::infinity();
  const int first = i < 0 ? 0 : i, last = i < 0 ? d.num_bodies() - 1 : i;
  for (int k = first; k <= last; ++k) {
    const auto u = static_cast<std::size_t>(k);
    const Mat3 R = p.rot[u].toRotationMatrix();
    for (const Geom& g : d.links[u].geoms) {
      const Vec3 a = p.pos[u] + R * g.a;
      switch (g.type) {
        case Geom::Type::Sphere: low = std::min(low, a.z() - g.radius); break;
        case Geom::Type::Capsule: low = std::min(low, std::min(a.z(), (p.pos[u] + R * g.b).z()) - g.radius); break;
        case Geom::Type::Box:
          low = std::min(low, a.z() - (R.row(2).cwiseAbs().transpose().cwiseProduct(g.b)).sum());
          break;
      }
    }
  }
  return low;
}

// ---------------------------------------------------------------------------------------------
// Whole clips
// ---------------------------------------------------------------------------------------------

struct G1RetargetOptions {
  IkWeights weights;
  double root_scale = 0;      ///< root translation and feet; 0: leg-length ratio (pelvis heights)
  double effector_scale = 0;  ///< hands relative to the root; 0: height ratio (g1_height_ratio)
  double head_scale = 0;      ///< head relative to the root; 0: head ratio (g1_head_ratio)
  bool ground = true;         ///< lift a frame whose lowest geom point is below z = 0
  /// Foot contact cleanup (detail::lock_feet): in stance phases of the source a sole is held
  /// flat on the floor at the phase's mean position, blended in and out over `lock_blend` frames.
  bool lock_feet = true;
  double lock_height = 0.03;  ///< m above the foot's low level (5th percentile of its height)
  double lock_speed = 0.5;    ///< m/s, horizontal sole target speed (central difference)
  int lock_blend = 3;         ///< frames
};

struct G1RetargetReport {
  double root_scale = 0, effector_scale = 0, head_scale = 0;
  double mean_iterations = 0;
  int max_iterations = 0;
  int unconverged_frames = 0;   ///< frames that hit IkWeights::max_iterations
  double max_offset = 0;        ///< m, largest root lowering of pass 2 (stance soles onto z = 0)
  int lifted_frames = 0;        ///< frames lifted because a geom was below z = 0
  double max_lift = 0;          ///< m
  double stance_fraction = 0;   ///< fraction of (frame, foot) in stance (held by lock_feet)
};

/// Retargets a whole humanoid clip onto the G1 (see the file comment). Throws maskadapt::Error
/// on an empty clip, a non-finite frame or a clip of another skeleton.
inline G1Clip retarget_to_g1(const MotionClip& src, const G1RetargetOptions& opt = {}, G1RetargetReport* report = nullptr,
                             const G1Description& d = g1_description(),
                             const HumanoidDescription& h = humanoid_description()) {
  detail::check_g1_source(src, h);
  const HumanoidPoints hp = humanoid_points(h);
  const IkModel m = make_ik_model(d);
  G1RetargetReport rep;
  rep.root_scale = opt.root_scale > 0 ? opt.root_scale : g1_leg_ratio(d, h);
  rep.effector_scale = opt.effector_scale > 0 ? opt.effector_scale : g1_height_ratio(d, h);
  rep.head_scale = opt.head_scale > 0 ? opt.head_scale : g1_head_ratio(d, h);
  const int T = src.num_frames();
  G1Clip out;
  out.name = src.name;
  out.description = "G1 retargeting of " + (src.name.empty() ? std::string("a humanoid clip") : src.name) +
                    (src.description.empty() ? std::string() : " (" + src.description + ")");
  out.fps = src.fps;
  out.loop = src.loop;
  out.resize(T);
  const Vec3 origin(src.root_pos(0, 0), src.root_pos(1, 0), 0.0);
  std::vector<IkTargets> targets(static_cast<std::size_t>(T));
  BodyStates bs;
  for (int t = 0; t < T; ++t) {
    forward_kinematics(h.skeleton, src.frame(t), bs);
    targets[static_cast<std::size_t>(t)] = g1_targets(hp, bs, origin, rep.root_scale, rep.effector_scale, rep.head_scale);
  }
  std::vector<std::array<char, 2>> stance;
  if (opt.lock_feet) {
    const long long held = detail::lock_feet(targets, src.fps, opt.lock_height, opt.lock_speed, opt.lock_blend, stance,
                                             rep.root_scale * hp.sole);
    rep.stance_fraction = double(held) / (2.0 * T);
  }
  long long iters = 0;
  const std::array<int, 2> feet = {d.link_index("left_ankle_roll_link"), d.link_index("right_ankle_roll_link")};
  // one IK pass over the clip, warm-started frame to frame (from `init` where given)
  auto solve_all = [&](const MatrixXd* init) {
    VectorXd q_prev = m.nominal;
    for (int t = 0; t < T; ++t) {
      const IkTargets& tg = targets[static_cast<std::size_t>(t)];
      const VectorXd start = init ? VectorXd(init->col(t)) : q_prev;
      const IkResult r = solve_ik(m, tg, opt.weights, start, t > 0 ? &q_prev : nullptr);
      iters += r.iterations;
      rep.max_iterations = std::max(rep.max_iterations, r.iterations);
      if (!r.converged) ++rep.unconverged_frames;
      out.root_pos.col(t) = tg.root_pos;
      out.set_rot(t, tg.root_rot);
      out.q.col(t) = r.q;
      q_prev = r.q;
    }
  };
  // per-frame height of the lowest stance sole, interpolated linearly across frames without a
  // stance foot (held at the ends); empty if the clip has no stance at all
  auto stance_height = [&]() {
    std::vector<double> z(static_cast<std::size_t>(T), std::numeric_limits<double>::quiet_NaN());
    std::vector<int> known;
    for (int t = 0; t < T && !stance.empty(); ++t) {
      const LinkPoses p = out.poses(d, t);
      for (int f = 0; f < 2; ++f)
        if (stance[static_cast<std::size_t>(t)][static_cast<std::size_t>(f)]) {
          const double lz = g1_lowest_point(d, p, feet[static_cast<std::size_t>(f)]);
          auto& zt = z[static_cast<std::size_t>(t)];
          zt = std::isnan(zt) ? lz : std::min(zt, lz);
        }
      if (!std::isnan(z[static_cast<std::size_t>(t)])) known.push_back(t);
    }
    if (known.empty()) return std::vector<double>();
    for (int t = 0; t < T; ++t) {
      const auto it = std::lower_bound(known.begin(), known.end(), t);
      if (it == known.end()) z[static_cast<std::size_t>(t)] = z[static_cast<std::size_t>(known.back())];
      else if (*it == t || it == known.begin()) z[static_cast<std::size_t>(t)] = z[static_cast<std::size_t>(*it)];
      else {
        const int b = *it, a = *(it - 1);
        const double u = double(t - a) / (b - a);
        z[static_cast<std::size_t>(t)] = (1 - u) * z[static_cast<std::size_t>(a)] + u * z[static_cast<std::size_t>(b)];
      }
    }
    return z;
  };
  solve_all(nullptr);
  if (opt.lock_feet && opt.ground) {
    // Pass 2: where the scaled root is too high for the stance soles to reach the floor (the G1's
    // proportions, the source's tilted feet), lower the root target — and the root-relative hand
    // and head targets with it — by the stance sole's height, and solve again.
    const std::vector<double> z = stance_height();
    if (!z.empty()) {
      for (int t = 0; t < T; ++t) {
        IkTargets& tg = targets[static_cast<std::size_t>(t)];
        const double off = z[static_cast<std::size_t>(t)];
        tg.root_pos.z() -= off;
        for (int e : {int(kLeftHand), int(kRightHand), int(kHead)}) tg.pos[static_cast<std::size_t>(e)].z() -= off;
        rep.max_offset = std::max(rep.max_offset, std::abs(off));
      }
      solve_all(nullptr);
    }
  }
  if (opt.ground) {
    // per-frame vertical offset: the stance soles exactly onto z = 0; then no geom below z = 0
    if (opt.lock_feet) {
      const std::vector<double> z = stance_height();
      for (int t = 0; t < T && !z.empty(); ++t) out.root_pos(2, t) -= z[static_cast<std::size_t>(t)];
    }
    for (int t = 0; t < T; ++t) {
      const double low = g1_lowest_point(d, out.poses(d, t));
      if (low < 0) {
        out.root_pos(2, t) -= low;
        ++rep.lifted_frames;
        rep.max_lift = std::max(rep.max_lift, -low);
      }
    }
  }
  rep.mean_iterations = double(iters) / T;
  if (report) *report = rep;
  return out;
}


}  // namespace maskadapt::g1
