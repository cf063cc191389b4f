#pragma once
// Measurements that tell a correct retarget from a wrong one without looking at it: the humanoid's
// bone directions against the source's world bone directions, hip height, the facing direction
// against the root velocity, knees bending forward, feet pointing forward. Used by
// test_mocap_sets.cpp on the real Bandai, styles and CMU-131 clips.
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/motion/bvh.hpp>
#include <maskadapt/humanoid/retarget.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace maskadapt::test {

struct MocapCheck {
  // humanoid bone (body → child, forward kinematics of the clip) vs the source's world bone at
  // the same time, degrees, over every frame and mapped bone
  double bone_mean_deg = 0, bone_p95_deg = 0, bone_max_deg = 0;
  std::string worst_bone;          ///< humanoid body with the largest mean bone error
  double worst_bone_mean_deg = 0;
  double hip_height = 0;           ///< mean root height (m)
  double heading_cos = 0;          ///< mean cos(root forward, horizontal root velocity) while moving
  int moving_frames = 0;           ///< frames with horizontal root speed > 0.3 m/s
  double speed = 0;                ///< mean horizontal root speed (m/s) over the whole clip
  double knee_forward = 0;         ///< of frames with a knee bent > 15°: fraction with the knee in front of the hip–ankle line
  int bent_knee_frames = 0;
  double knee_flexion_mean = 0;    ///< mean knee pitch (rad, + = flexion) of both knees
  double knee_off_axis = 0;        ///< mean |roll| + |yaw| of the knees (rad): small if knees are hinges
  double toe_forward = 0;          ///< fraction of (frame, foot) with the toe in front of the ankle
  double min_sole = 0;             ///< 2 % quantile over frames of the lowest foot point (m)
};

/// Bones compared: (humanoid body, humanoid body at the bone's end, source joint, source joint at
/// the bone's end), chosen as retargeting chooses them.
struct BonePair {
  int body, body_end, joint, joint_end;
};

inline std::vector<BonePair> bone_pairs(const bvh::Motion& m, const JointMap& map, const Skeleton& skel) {
  const int nb = skel.num_bodies();
  std::vector<int> src(nb, -1);
  for (const auto& [b, j] : map.joints) src[skel.index_of(b)] = m.find(j);
  std::vector<BonePair> out;
  for (int b = 1; b < nb; ++b) {
    if (src[b] < 0) continue;
    // trunk bodies are fitted by orientation, not by bone (retarget.hpp, fit_attachments): their
    // bones keep the humanoid's own spine shape
    if (map.calibration_frame == JointMap::kCalibrateHeading &&
        (b == hb::Torso || b == hb::Spine || b == hb::Chest || b == hb::Neck || b == hb::Head))
      continue;
    int found = -1, end = -1;
    for (int c = b + 1; c < nb && found < 0; ++c)
      if (skel.parents[c] == b && src[c] >= 0 && src[c] != src[b]) found = c, end = src[c];
    if (found < 0) {
      auto it = map.tips.find(skel.names[b]);
      if (it != map.tips.end() && m.find(it->second) >= 0)
        for (int c = b + 1; c < nb; ++c)
          if (skel.parents[c] == b) {
            found = c, end = m.find(it->second);
            break;
          }
    }
    if (found >= 0) out.push_back({b, found, src[b], end});
  }
  return out;
}

inline MocapCheck check_retarget(const bvh::Motion& m, const JointMap& map, const MotionClip& clip,
                                 const HumanoidDescription& desc = humanoid_description()) {
  const Skeleton& skel = desc.skeleton;
  MocapCheck r;
  const auto pairs = bone_pairs(m, map, skel);
  const Mat3 W = map.up_axis == 'y' ? detail::y_up_to_z_up() : Mat3::Identity();
  const int first = map.drop_first_frame && m.num_frames() > 1 ? 1 : 0;
  std::vector<double> errs;
  std::vector<double> per_bone(skel.num_bodies(), 0.0);
  std::vector<int> per_bone_n(skel.num_bodies(), 0);
  Matrix3X spos;
  std::vector<Quat> srot;
  BodyStates bs;
  const int T = clip.num_frames();
  std::vector<double> sole;
  int toe_n = 0, toe_fwd = 0, knee_fwd = 0;
  double flex = 0, off = 0;
  for (int k = 0; k < T; ++k) {
    forward_kinematics(skel, clip.frame(k), bs);
    const int sf = std::min(first + static_cast<int>(std::lround(k / clip.fps * m.fps())), m.num_frames() - 1);
    bvh::forward_kinematics(m, sf, spos, srot);
    for (const auto& p : pairs) {
      const Vec3 dh = bs.pos.col(p.body_end) - bs.pos.col(p.body);
      const Vec3 ds = W * (spos.col(p.joint_end) - spos.col(p.joint));
      if (dh.norm() < 1e-9 || ds.norm() < 1e-9) continue;
      const double e = std::acos(std::clamp(dh.normalized().dot(ds.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
      errs.push_back(e);
      per_bone[p.body] += e;
      ++per_bone_n[p.body];
    }
    r.hip_height += bs.pos(2, 0);
    Vec3 fwd = bs.rot[0] * Vec3::UnitX();
    fwd.z() = 0;
    fwd.normalize();
    for (int side = 0; side < 2; ++side) {
      const int hip = side ? hb::RHip : hb::LHip, knee = side ? hb::RKnee : hb::LKnee;
      const int ankle = side ? hb::RAnkle : hb::LAnkle, toe = side ? hb::RToe : hb::LToe;
      const Vec3 a = bs.pos.col(hip), kn = bs.pos.col(knee), an = bs.pos.col(ankle);
      const Vec3 u = (an - a).normalized();
      const double bend = std::acos(std::clamp((kn - a).normalized().dot((an - kn).normalized()), -1.0, 1.0));
      if (bend > 15.0 * M_PI / 180.0) {
        const Vec3 perp = (kn - a) - u * u.dot(kn - a);
        knee_fwd += perp.dot(fwd) > 0;
        ++r.bent_knee_frames;
      }
      const Vec3 q = clip.q.col(k).segment<3>(humanoid_skeleton().dof_offset(knee));
      flex += q.y();
      off += std::abs(q.x()) + std::abs(q.z());
      toe_fwd += (bs.pos.col(toe) - an).dot(fwd) > 0;
      ++toe_n;
    }
    double low = 1e300;
    for (int f : desc.foot_bodies()) low = std::min(low, geometry::lowest_point(desc, bs, f));
    sole.push_back(low);
  }
  r.hip_height /= T;
  r.knee_forward = r.bent_knee_frames ? double(knee_fwd) / r.bent_knee_frames : 1.0;
  r.knee_flexion_mean = flex / (2.0 * T);
  r.knee_off_axis = off / (2.0 * T);
  r.toe_forward = toe_n ? double(toe_fwd) / toe_n : 0.0;
  std::sort(sole.begin(), sole.end());
  r.min_sole = sole[static_cast<std::size_t>(0.02 * (sole.size() - 1))];
  if (!errs.empty()) {
    double s = 0;
    for (double e : errs) s += e;
    r.bone_mean_deg = s / errs.size();
    std::sort(errs.begin(), errs.end());
    r.bone_p95_deg = errs[static_cast<std::size_t>(0.95 * (errs.size() - 1))];
    r.bone_max_deg = errs.back();
  }
  for (int b = 0; b < skel.num_bodies(); ++b)
    if (per_bone_n[b] && per_bone[b] / per_bone_n[b] > r.worst_bone_mean_deg) {
      r.worst_bone_mean_deg = per_bone[b] / per_bone_n[b];
      r.worst_bone = skel.names[b];
    }
  // facing vs velocity: root velocity by central differences over ±0.2 s
  const int h = std::max(1, static_cast<int>(std::lround(0.2 * clip.fps)));
  double cs = 0;
  for (int k = 0; k < T; ++k) {
    const int a = std::max(0, k - h), b = std::min(T - 1, k + h);
    if (b == a) continue;
    Vec3 v = (clip.root_pos.col(b) - clip.root_pos.col(a)) / ((b - a) / clip.fps);
    v.z() = 0;
    r.speed += v.norm() / T;
    if (v.norm() < 0.3) continue;
    Vec3 fwd = clip.rot(k) * Vec3::UnitX();
    fwd.z() = 0;
    cs += fwd.normalized().dot(v.normalized());
    ++r.moving_frames;
  }
  r.heading_cos = r.moving_frames ? cs / r.moving_frames : 0.0;
  return r;
}

}  // namespace maskadapt::test
