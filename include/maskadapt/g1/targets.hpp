#pragma once
/// \file targets.hpp
/// The G1 IK targets (g1/ik.hpp) of one frame of reference-humanoid motion, and the scale ratios
/// between the two characters (docs/characters.md, "Retargeting onto the G1").
///
/// The G1 root (pelvis) is placed at the humanoid root, its translation scaled by the
/// *leg-length ratio* s_leg = (G1 pelvis height) / (humanoid pelvis height) at the zero poses
/// (0.838), about the first frame's ground point; the root orientation is copied (both characters
/// face +x with z up at their zero pose, so the frames agree). Targets, world frame:
///     end-effectors  p*_e = root_G1 + s_e · (p_e^hum − root_hum)      (5 points)
/// for the two soles (the point of the sole under the ankle), the two hand centres and the head
/// centre. s_e is the *height ratio* s_h = 1.3199 / 1.7510 (0.754, head tops) for the hands; the
/// feet use s_leg, the root's ratio, so that the sole targets are s_leg × the humanoid's soles
/// about a fixed point (a foot planted in the source stays planted, a straight humanoid leg gives
/// a straight G1 leg; with s_h the feet would float 10 cm under a straight-legged pelvis); the head
/// uses the ratio of the head-centre heights above the pelvis, 0.649 (the G1 has no neck and a
/// short trunk: with s_h an upright G1's head would miss by 7.7 cm in every frame);
///     directions     d*_k = unit humanoid direction                  (18 unit vectors)
/// upper arms, forearms, thighs, shanks (bone vectors between joint centres), hands (wrist → hand
/// centre, and the back-of-hand normal), the chest's up and forward axes against the G1 torso
/// link's, each foot's forward and up axes against the ankle-roll link's.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/g1/description.hpp>
#include <maskadapt/g1/ik.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/skeleton.hpp>

#include <array>
#include <cmath>
#include <string>

namespace maskadapt::g1 {

/// The humanoid's sole point under the ankle (ankle frame), hand centre (hand frame) and head
/// centre (head frame), from its geoms.
struct HumanoidPoints {
  Vec3 sole = Vec3::Zero();
  std::array<Vec3, 2> hand{};  ///< left, right
  Vec3 head = Vec3::Zero();
};
inline HumanoidPoints humanoid_points(const HumanoidDescription& h) {
  require(h.skeleton.num_bodies() == kHumanoidNumBodies && h.bodies.size() == std::size_t(kHumanoidNumBodies),
          "G1 retargeting needs the 22-body reference humanoid", {{}, {}, "skeleton"});
  HumanoidPoints pts;
  const Geom& foot = h.bodies[hb::LAnkle].geoms.at(0);
  pts.sole = Vec3(0, 0, foot.a.z() - foot.b.z());
  pts.hand[0] = h.bodies[hb::LWrist].geoms.at(0).a;
  pts.hand[1] = h.bodies[hb::RWrist].geoms.at(0).a;
  pts.head = h.bodies[hb::Head].geoms.at(0).a;
  return pts;
}

/// Leg-length ratio (pelvis height above the soles at the zero poses, G1 / humanoid).
inline double g1_leg_ratio(const G1Description& d = g1_description(), const HumanoidDescription& h = humanoid_description()) {
  return d.root_height / h.root_height;
}
/// Height ratio (head top at the zero poses, G1 / humanoid).
inline double g1_height_ratio(const G1Description& d = g1_description(), const HumanoidDescription& h = humanoid_description()) {
  const LinkPoses p = forward_kinematics(d, Vec3(0, 0, d.root_height), Quat::Identity(), VectorXd::Zero(d.num_joints()));
  KinematicState zero = KinematicState::zero(h.skeleton);
  zero.root_pos = Vec3(0, 0, h.root_height);
  const BodyStates bs = forward_kinematics(h.skeleton, zero);
  const Geom& head = h.bodies[hb::Head].geoms.at(0);
  const double h_top = (bs.pos.col(hb::Head) + bs.rot[hb::Head] * head.a).z() + head.radius;
  return head_top_height(d, p) / h_top;
}

/// Head ratio: height of the head centre above the pelvis at the zero poses, G1 / humanoid
/// (0.649). The G1 has no neck and a short trunk, so with the height ratio an upright G1's head
/// would miss its target by 7.7 cm in every frame, and a forward lean would ask it to lean further.
inline double g1_head_ratio(const G1Description& d = g1_description(), const HumanoidDescription& h = humanoid_description()) {
  const LinkPoses p = forward_kinematics(d, Vec3::Zero(), Quat::Identity(), VectorXd::Zero(d.num_joints()));
  const auto hl = static_cast<std::size_t>(d.head_link);
  const double g1_head = (p.pos[hl] + p.rot[hl] * d.head_centre).z();
  const BodyStates bs = forward_kinematics(h.skeleton, KinematicState::zero(h.skeleton));
  const double hum_head = (bs.pos.col(hb::Head) + bs.rot[hb::Head] * h.bodies[hb::Head].geoms.at(0).a).z();
  return g1_head / hum_head;
}

/// The humanoid's effector points and directions for body states `bs` (world; same order as
/// IkTargets), unscaled.
inline void humanoid_features(const HumanoidPoints& hp, const BodyStates& bs, std::array<Vec3, kNumEffectors>& pos,
                              std::array<Vec3, kNumDirections>& dir) {
  auto P = [&](int b) { return Vec3(bs.pos.col(b)); };
  auto at = [&](int b, const Vec3& local) { return Vec3(bs.pos.col(b) + bs.rot[static_cast<std::size_t>(b)] * local); };
  auto axis = [&](int b, const Vec3& u) { return Vec3(bs.rot[static_cast<std::size_t>(b)] * u); };
  for (int side = 0; side < 2; ++side) {
    const auto s = static_cast<std::size_t>(side);
    const int ankle = side == 0 ? hb::LAnkle : hb::RAnkle, wrist = side == 0 ? hb::LWrist : hb::RWrist;
    const int sh = side == 0 ? hb::LShoulder : hb::RShoulder, el = side == 0 ? hb::LElbow : hb::RElbow;
    const int hip = side == 0 ? hb::LHip : hb::RHip, knee = side == 0 ? hb::LKnee : hb::RKnee;
    pos[kLeftFoot + s] = at(ankle, hp.sole);
    pos[kLeftHand + s] = at(wrist, hp.hand[s]);
    dir[kLeftUpperArm + s] = (P(el) - P(sh)).normalized();
    dir[kLeftForearm + s] = (P(wrist) - P(el)).normalized();
    dir[kLeftHandDir + s] = axis(wrist, hp.hand[s].normalized());
    dir[kLeftHandBack + s] = axis(wrist, Vec3::UnitZ());
    dir[kLeftThigh + s] = (P(knee) - P(hip)).normalized();
    dir[kLeftShank + s] = (P(ankle) - P(knee)).normalized();
    dir[kLeftFootForward + s] = axis(ankle, Vec3::UnitX());
    dir[kLeftFootUp + s] = axis(ankle, Vec3::UnitZ());
  }
  pos[kHead] = at(hb::Head, hp.head);
  dir[kTorsoUp] = axis(hb::Chest, Vec3::UnitZ());
  dir[kTorsoForward] = axis(hb::Chest, Vec3::UnitX());
}

/// IK targets of one source frame: `bs` the humanoid's body states, `origin` the ground point
/// about which the root translation is scaled (retarget_to_g1: the first frame's root on z = 0).
inline IkTargets g1_targets(const HumanoidPoints& hp, const BodyStates& bs, const Vec3& origin, double root_scale,
                            double effector_scale, double head_scale) {
  IkTargets tg;
  std::array<Vec3, kNumEffectors> pos;
  humanoid_features(hp, bs, pos, tg.dir);
  const Vec3 root = bs.pos.col(0);
  tg.root_pos = origin + root_scale * (root - origin);
  tg.root_rot = bs.rot[0].normalized();
  for (int e = 0; e < kNumEffectors; ++e) {
    const double s = (e == kLeftFoot || e == kRightFoot) ? root_scale : e == kHead ? head_scale : effector_scale;
    tg.pos[static_cast<std::size_t>(e)] = tg.root_pos + s * (pos[static_cast<std::size_t>(e)] - root);
  }
  return tg;
}

namespace detail {
/// Checks that `src` is a usable clip on the reference humanoid; clear messages for each failure.
inline void check_g1_source(const MotionClip& src, const HumanoidDescription& h) {
  const std::string who = "G1 retargeting of clip '" + src.name + "'";
  require(src.num_frames() >= 1, who + ": the source clip has no frames", {{}, {}, "q"});
  require(src.num_dofs() == h.skeleton.num_dofs(),
          who + ": expected a clip on the reference humanoid skeleton (" + std::to_string(h.skeleton.num_dofs()) +
              " joint angles per frame), got " + std::to_string(src.num_dofs()),
          {{}, {}, "q"});
  require(src.root_pos.cols() == src.num_frames() && src.root_rot.cols() == src.num_frames() &&
              src.root_pos.rows() == 3 && src.root_rot.rows() == 4,
          who + ": root arrays and joint angles have different frame counts", {{}, {}, "root_pos"});
  require(src.fps > 0 && std::isfinite(src.fps), who + ": fps must be positive", {{}, {}, "fps"});
  for (int t = 0; t < src.num_frames(); ++t) {
    const char* bad = !src.root_pos.col(t).allFinite() ? "root_pos"
                      : !src.root_rot.col(t).allFinite() ? "root_rot"
                      : !src.q.col(t).allFinite()        ? "q"
                                                         : nullptr;
    require(bad == nullptr, who + ": frame " + std::to_string(t) + " has a non-finite value in " + (bad ? bad : ""),
            {{}, {}, bad ? bad : ""});
    require(std::abs(src.root_rot.col(t).norm() - 1.0) < 1e-3,
            who + ": root quaternion of frame " + std::to_string(t) + " is not unit length", {{}, {}, "root_rot"});
  }
}
}  // namespace detail

}  // namespace maskadapt::g1
