#pragma once
/// \file retarget.hpp
/// Retargeting BVH and AMASS motion onto the reference humanoid.
///
/// Pipeline (all rotations as quaternions; source Euler angles are never differenced):
///  1. source world rotations R_s(t) and positions by the source's own kinematics (bvh.hpp);
///  2. axis change W (Y-up, facing +Z  →  Z-up, facing +x) and unit scale;
///  3. rest-pose alignment at a calibration pose t₀ (CMU frame 0 is a T-pose; or the source's
///     zero-rotation rest pose): the humanoid root at t₀ gets the frame M = [forward left up]
///     built from the source hips, and every mapped body b the alignment
///        A_b = Rmin(M·d_h → d_s) · M,
///     where d_h is the humanoid's zero-pose bone direction (body → its first mapped child) and
///     d_s the source bone direction at t₀; then
///        R_h(b, t) = W R_s(b, t) R_s(b, t₀)⁻¹ Wᵀ · A_b,
///     so every humanoid bone points where the source bone points, at every frame;
///  4. local rotations L_b = R_h(parent)ᵀ R_h(b) (unmapped bodies follow their parent);
///  5. resampling to the control rate (30 Hz) with slerp (roots: lerp + slerp);
///  6. conversion to the 3-hinge angles, continuous in time, clamped to the joint limits;
///  7. root translation scaled by the leg-length ratio, then the clip grounded: a low quantile
///     (default 2 %) of the per-frame lowest foot point is put on z = 0.
#include <maskadapt/core/error.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/motion/bvh.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/geometry.hpp>
#include <maskadapt/motion/npz.hpp>
#include <maskadapt/motion/rotation.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace maskadapt {

/// How a source skeleton maps onto the humanoid.
struct JointMap {
  std::string name;                                          ///< e.g. "cmu"
  std::vector<std::pair<std::string, std::string>> joints;   ///< (humanoid body, source joint)
  std::map<std::string, std::string> tips;                   ///< humanoid body → source joint marking the end of its bone, for bodies without a mapped child
  double unit_scale = 1.0;        ///< source length unit → metres
  char up_axis = 'y';             ///< source world up axis: 'y' (forward +z) or 'z' (forward +x)
  int calibration_frame = 0;      ///< frame used as the rest pose; −1: the zero-rotation pose
  bool drop_first_frame = false;  ///< drop frame 0 (a synthetic T-pose in the CMU releases)
};

/// CMU cgspeed MotionBuilder-friendly release (31 joints, ×0.056444 m, Y-up, frame 0 = T-pose).
inline JointMap cmu_joint_map() {
  JointMap m;
  m.name = "cmu";
  m.joints = {{"Pelvis", "Hips"},          {"L_Hip", "LeftUpLeg"},      {"R_Hip", "RightUpLeg"},
              {"Torso", "LowerBack"},      {"L_Knee", "LeftLeg"},       {"R_Knee", "RightLeg"},
              {"Spine", "Spine"},          {"L_Ankle", "LeftFoot"},     {"R_Ankle", "RightFoot"},
              {"Chest", "Spine1"},         {"L_Toe", "LeftToeBase"},    {"R_Toe", "RightToeBase"},
              {"Neck", "Neck"},            {"L_Thorax", "LeftShoulder"}, {"R_Thorax", "RightShoulder"},
              {"Head", "Head"},            {"L_Shoulder", "LeftArm"},   {"R_Shoulder", "RightArm"},
              {"L_Elbow", "LeftForeArm"},  {"R_Elbow", "RightForeArm"}, {"L_Wrist", "LeftHand"},
              {"R_Wrist", "RightHand"}};
  m.tips = {{"L_Toe", "LeftToeBase_End"}, {"R_Toe", "RightToeBase_End"}, {"Head", "Head_End"},
            {"L_Wrist", "LeftFingerBase"}, {"R_Wrist", "RightFingerBase"}};
  m.unit_scale = 0.056444;
  m.up_axis = 'y';
  m.calibration_frame = 0;
  m.drop_first_frame = true;
  return m;
}

/// CMU cgspeed Daz-friendly release (135_04_front_kick.bvh: 43 joints, centimetres, Y-up,
/// frame 0 = T-pose, no toe joint).
inline JointMap daz_joint_map() {
  JointMap m;
  m.name = "daz";
  m.joints = {{"Pelvis", "hip"},      {"L_Hip", "lThigh"},     {"R_Hip", "rThigh"},     {"Torso", "abdomen"},
              {"L_Knee", "lShin"},    {"R_Knee", "rShin"},     {"L_Ankle", "lFoot"},    {"R_Ankle", "rFoot"},
              {"Chest", "chest"},     {"Neck", "neck"},        {"L_Thorax", "lCollar"}, {"R_Thorax", "rCollar"},
              {"Head", "head"},       {"L_Shoulder", "lShldr"}, {"R_Shoulder", "rShldr"}, {"L_Elbow", "lForeArm"},
              {"R_Elbow", "rForeArm"}, {"L_Wrist", "lHand"},    {"R_Wrist", "rHand"}};
  m.tips = {{"L_Ankle", "lFoot_End"}, {"R_Ankle", "rFoot_End"}, {"L_Wrist", "lMid1"}, {"R_Wrist", "rMid1"}};
  m.unit_scale = 0.01;
  m.up_axis = 'y';
  m.calibration_frame = 0;
  m.drop_first_frame = true;
  return m;
}

/// LAFAN1 (Ubisoft La Forge): 22 joints, centimetres, Y-up, positions on every joint; no T-pose
/// frame, so the zero-rotation rest pose calibrates.
inline JointMap lafan_joint_map() {
  JointMap m;
  m.name = "lafan";
  m.joints = {{"Pelvis", "Hips"},          {"L_Hip", "LeftUpLeg"},      {"R_Hip", "RightUpLeg"},
              {"Torso", "Spine"},          {"L_Knee", "LeftLeg"},       {"R_Knee", "RightLeg"},
              {"Spine", "Spine1"},         {"L_Ankle", "LeftFoot"},     {"R_Ankle", "RightFoot"},
              {"Chest", "Spine2"},         {"L_Toe", "LeftToe"},        {"R_Toe", "RightToe"},
              {"Neck", "Neck"},            {"L_Thorax", "LeftShoulder"}, {"R_Thorax", "RightShoulder"},
              {"Head", "Head"},            {"L_Shoulder", "LeftArm"},   {"R_Shoulder", "RightArm"},
              {"L_Elbow", "LeftForeArm"},  {"R_Elbow", "RightForeArm"}, {"L_Wrist", "LeftHand"},
              {"R_Wrist", "RightHand"}};
  m.unit_scale = 0.01;
  m.up_axis = 'y';
  m.calibration_frame = -1;
  return m;
}

/// The humanoid's own skeleton written as BVH (see clip_to_bvh): names are the body names.
inline JointMap humanoid_joint_map(char up_axis = 'y') {
  JointMap m;
  m.name = "humanoid";
  for (int i = 0; i < humanoid_skeleton().num_bodies(); ++i)
    m.joints.emplace_back(humanoid_skeleton().names[i], humanoid_skeleton().names[i]);
  m.unit_scale = 1.0;
  m.up_axis = up_axis;
  m.calibration_frame = -1;
  return m;
}

/// A joint map from JSON:
///   {"name": "mine", "unit_scale": 0.01, "up_axis": "y", "calibration_frame": 0,
///    "drop_first_frame": true, "joints": {"Pelvis": "Hips", "L_Hip": "LeftUpLeg", …},
///    "tips": {"L_Toe": "LeftToe_End"}}
inline JointMap joint_map_from_json(const nlohmann::json& j, const std::string& file = {}) {
  JointMap m;
  try {
    m.name = j.value("name", std::string("custom"));
    m.unit_scale = j.value("unit_scale", 1.0);
    const std::string up = j.value("up_axis", std::string("y"));
    require(up == "y" || up == "z", "up_axis must be \"y\" or \"z\"", {file, std::nullopt, "up_axis"});
    m.up_axis = up[0];
    m.calibration_frame = j.value("calibration_frame", 0);
    m.drop_first_frame = j.value("drop_first_frame", false);
    require(j.contains("joints") && j.at("joints").is_object(), "expected an object {humanoid body: source joint}",
            {file, std::nullopt, "joints"});
    for (auto& [k, v] : j.at("joints").items()) m.joints.emplace_back(k, v.get<std::string>());
    if (j.contains("tips"))
      for (auto& [k, v] : j.at("tips").items()) m.tips[k] = v.get<std::string>();
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("bad joint map: ") + e.what(), {file, std::nullopt, "joint_map"});
  }
  require(m.unit_scale > 0 && std::isfinite(m.unit_scale), "unit_scale must be positive", {file, std::nullopt, "unit_scale"});
  return m;
}

inline JointMap read_joint_map(const std::string& path) {
  std::ifstream in(path);
  require(static_cast<bool>(in), "cannot open joint map", {path, std::nullopt, {}});
  nlohmann::json j;
  try {
    in >> j;
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("invalid JSON: ") + e.what(), {path, std::nullopt, {}});
  }
  return joint_map_from_json(j, path);
}

/// Picks a built-in map from the joint names of a BVH file; throws listing them if none fits.
inline JointMap detect_joint_map(const bvh::Motion& m, const std::string& file = {}) {
  if (m.find("Hips") >= 0 && m.find("LeftUpLeg") >= 0 && m.find("LowerBack") >= 0 && m.find("Spine1") >= 0)
    return cmu_joint_map();
  if (m.find("hip") >= 0 && m.find("lThigh") >= 0 && m.find("abdomen") >= 0) return daz_joint_map();
  if (m.find("Hips") >= 0 && m.find("Spine2") >= 0 && m.find("LeftToe") >= 0) return lafan_joint_map();
  if (m.find("Pelvis") >= 0 && m.find("L_Hip") >= 0 && m.find("R_Wrist") >= 0) return humanoid_joint_map();
  throw Error("unknown skeleton (root '" + (m.joints.empty() ? std::string() : m.joints[0].name) +
                  "'): pass a joint map (JSON) for it",
              {file, std::nullopt, "joint_map"});
}

struct RetargetOptions {
  double target_fps = 30.0;  ///< output frame rate
  bool ground = true;        ///< shift the clip vertically so that its feet touch z = 0
  /// Grounding puts this quantile of the per-frame lowest foot point on z = 0: 0 = the clip's
  /// minimum (nothing below the floor); the default 0.02 ignores a few outlier frames of raw
  /// mocap (the Daz kick's first frame dips 3 cm below the rest) at the price of them
  /// penetrating a little (motion_quality reports it).
  double ground_quantile = 0.02;
  bool scale_root = true;    ///< scale the root translation by the humanoid/source leg-length ratio
};

/// What retargeting did (for `maskadapt motion info`).
struct RetargetReport {
  int source_frames = 0;
  double source_fps = 0;
  double root_scale = 1.0;           ///< leg-length ratio applied to the root translation
  double ground_shift = 0.0;         ///< metres added to the root height by grounding
  double clamped_fraction = 0.0;     ///< fraction of (frame, DoF) clamped to a joint limit
  double max_limit_excess = 0.0;     ///< largest clamp (rad)
  std::vector<std::string> unmapped; ///< humanoid bodies without a source joint (follow their parent)
};

/// A motion in the humanoid's terms at the source frame rate, before resampling: root
/// position/rotation and each body's local rotation.
struct HumanoidSequence {
  double fps = 30;
  Matrix3X root_pos;                      ///< (3 × T) metres, world z-up
  std::vector<Quat> root_rot;             ///< (T)
  std::vector<std::vector<Quat>> local;   ///< (T) × (num_bodies) local joint rotations (index 0 unused)
  int num_frames() const { return static_cast<int>(root_rot.size()); }
};

namespace detail {

/// Source (Y-up, facing +Z) → humanoid (Z-up, facing +x): x_h = z_s, y_h = x_s, z_h = y_s.
inline Mat3 y_up_to_z_up() {
  Mat3 C;
  C << 0, 0, 1, 1, 0, 0, 0, 1, 0;
  return C;
}

/// Rotation taking unit direction a to unit direction b by the smallest angle.
inline Quat min_rotation(const Vec3& a, const Vec3& b) { return Quat::FromTwoVectors(a, b).normalized(); }

/// Steps 5–7: resample, angles with limits, scale, ground.
inline MotionClip finish(const HumanoidSequence& seq, const HumanoidDescription& desc, const RetargetOptions& opt,
                         RetargetReport& rep, const std::string& file) {
  const Skeleton& skel = desc.skeleton;
  const int nb = skel.num_bodies();
  const int T = seq.num_frames();
  require(T >= 1, "no frames to retarget", {file, std::nullopt, "frames"});
  require(opt.target_fps > 0, "target fps must be positive", {file, std::nullopt, "target_fps"});
  const double duration = (T - 1) / seq.fps;
  const int Tout = static_cast<int>(std::floor(duration * opt.target_fps + 1e-3)) + 1;
  MotionClip clip;
  clip.fps = opt.target_fps;
  clip.resize(Tout, skel.num_dofs());
  long long clamped = 0;
  Vec3 hint[64];
  require(nb <= 64, "skeleton too large", {file, std::nullopt, "bodies"});
  for (int b = 0; b < nb; ++b) hint[b].setZero();
  for (int k = 0; k < Tout; ++k) {
    const double u = std::min(k / opt.target_fps * seq.fps, double(T - 1));
    const int i0 = std::min(static_cast<int>(std::floor(u)), T - 1);
    const int i1 = std::min(i0 + 1, T - 1);
    const double w = u - i0;
    clip.root_pos.col(k) = (1 - w) * seq.root_pos.col(i0) + w * seq.root_pos.col(i1);
    clip.set_rot(k, slerp(seq.root_rot[i0], seq.root_rot[i1], w));
    for (int b = 1; b < nb; ++b) {
      const Quat L = slerp(seq.local[i0][b], seq.local[i1][b], w);
      double viol = 0;
      const Vec3 a = joint_angles_within(L, hint[b], skel.joint_lower.col(b), skel.joint_upper.col(b), &viol);
      if (viol > 1e-9) {
        ++clamped;
        rep.max_limit_excess = std::max(rep.max_limit_excess, viol);
      }
      hint[b] = a;
      clip.q.col(k).segment<3>(Skeleton::dof_offset(b)) = a;
    }
  }
  rep.clamped_fraction = double(clamped) / (double(Tout) * (nb - 1));
  if (opt.ground) {
    BodyStates bs;
    std::vector<double> low(static_cast<std::size_t>(Tout), 1e300);
    for (int k = 0; k < Tout; ++k) {
      forward_kinematics(skel, clip.frame(k), bs);
      for (int f : geometry::foot_bodies())
        low[static_cast<std::size_t>(k)] = std::min(low[static_cast<std::size_t>(k)], geometry::lowest_point(desc, bs, f));
    }
    const auto nth = static_cast<std::size_t>(std::clamp(opt.ground_quantile, 0.0, 1.0) * (Tout - 1));
    std::nth_element(low.begin(), low.begin() + static_cast<std::ptrdiff_t>(nth), low.end());
    const double zmin = low[nth];
    rep.ground_shift = -zmin;
    clip.root_pos.row(2).array() -= zmin;
  }
  return clip;
}

}  // namespace detail

/// Steps 1–4 for a BVH file: the motion as humanoid local rotations at the source frame rate.
inline HumanoidSequence bvh_to_humanoid_sequence(const bvh::Motion& m, const JointMap& map,
                                                 const HumanoidDescription& desc, RetargetReport& rep,
                                                 const std::string& file = {}) {
  const Skeleton& skel = desc.skeleton;
  const int nb = skel.num_bodies();
  require(m.num_frames() >= 1, "BVH has no frames", {file, std::nullopt, "MOTION"});
  // humanoid body → source joint index
  std::vector<int> src(nb, -1);
  for (const auto& [body, joint] : map.joints) {
    const int b = skel.index_of(body);
    const int j = m.find(joint);
    require(j >= 0, "joint map '" + map.name + "' names source joint '" + joint + "', which the file lacks",
            {file, std::nullopt, body});
    src[b] = j;
  }
  require(src[0] >= 0, "the joint map must map the root body '" + skel.names[0] + "'", {file, std::nullopt, "joint_map"});
  std::vector<int> tip(nb, -1);
  for (const auto& [body, joint] : map.tips) {
    const int b = skel.index_of(body);
    tip[b] = m.find(joint);  // optional: ignore missing tips
  }
  rep.unmapped.clear();
  for (int b = 0; b < nb; ++b)
    if (src[b] < 0) rep.unmapped.push_back(skel.names[b]);

  const Mat3 W = map.up_axis == 'y' ? detail::y_up_to_z_up() : Mat3::Identity();
  const Quat Wq(W);
  // ---- calibration pose ----
  bvh::Motion calib_m;
  const bvh::Motion* cm = &m;
  int cf = map.calibration_frame;
  if (cf < 0) {  // zero-rotation rest pose: keep positions, zero rotations
    calib_m.joints = m.joints;
    calib_m.frames = m.frames.col(0);
    for (const auto& jt : m.joints)
      for (std::size_t c = 0; c < jt.channels.size(); ++c)
        if (bvh::is_rotation(jt.channels[c])) calib_m.frames(jt.first_channel + static_cast<int>(c), 0) = 0.0;
    cm = &calib_m;
    cf = 0;
  }
  require(cf < m.num_frames(), "calibration frame out of range", {file, std::nullopt, "calibration_frame"});
  Matrix3X cpos;
  std::vector<Quat> crot;
  bvh::forward_kinematics(*cm, cf, cpos, crot);
  cpos = W * (cpos * map.unit_scale);
  // root frame M from the hips (left = L_Hip − R_Hip projected on the ground; up = z)
  Quat M = Quat::Identity();
  {
    const int lh = src[skel.index_of("L_Hip")], rh = src[skel.index_of("R_Hip")];
    if (lh >= 0 && rh >= 0) {
      Vec3 left = cpos.col(lh) - cpos.col(rh);
      left.z() = 0;
      if (left.norm() > 1e-6) {
        left.normalize();
        const Vec3 up = Vec3::UnitZ();
        const Vec3 fwd = left.cross(up);
        Mat3 F;
        F.col(0) = fwd;
        F.col(1) = left;
        F.col(2) = up;
        M = Quat(F);
      }
    }
  }
  // zero-pose humanoid joint positions (for bone directions)
  const BodyStates zero = forward_kinematics(skel, KinematicState::zero(skel));
  std::vector<Quat> align(nb, M), calib_inv(nb, Quat::Identity());
  for (int b = 0; b < nb; ++b) {
    if (src[b] < 0) continue;
    calib_inv[b] = (Wq * crot[src[b]] * Wq.conjugate()).conjugate();
    // first child (index order) with a distinct mapped source joint, else the tip
    int child_src = -1;
    Vec3 dh = Vec3::Zero();
    for (int c = b + 1; c < nb && child_src < 0; ++c)
      if (skel.parents[c] == b && src[c] >= 0 && src[c] != src[b]) {
        child_src = src[c];
        dh = zero.pos.col(c) - zero.pos.col(b);
      }
    if (child_src < 0 && tip[b] >= 0) {
      child_src = tip[b];
      for (int c = b + 1; c < nb; ++c)
        if (skel.parents[c] == b) {
          dh = zero.pos.col(c) - zero.pos.col(b);
          break;
        }
      if (dh.norm() < 1e-9) child_src = -1;
    }
    if (b == 0 || child_src < 0) continue;
    const Vec3 ds = cpos.col(child_src) - cpos.col(src[b]);
    if (ds.norm() < 1e-9 || dh.norm() < 1e-9) continue;
    align[b] = detail::min_rotation((M * dh).normalized(), ds.normalized()) * M;
  }
  // leg-length ratio for the root translation
  rep.root_scale = 1.0;
  {
    const int hb_ = skel.index_of("L_Hip"), kb = skel.index_of("L_Knee"), ab = skel.index_of("L_Ankle");
    if (src[hb_] >= 0 && src[kb] >= 0 && src[ab] >= 0) {
      const double ls = (cpos.col(src[kb]) - cpos.col(src[hb_])).norm() + (cpos.col(src[ab]) - cpos.col(src[kb])).norm();
      const double lh = (zero.pos.col(kb) - zero.pos.col(hb_)).norm() + (zero.pos.col(ab) - zero.pos.col(kb)).norm();
      if (ls > 1e-6) rep.root_scale = lh / ls;
    }
  }

  // ---- every frame ----
  const int first = map.drop_first_frame && m.num_frames() > 1 ? 1 : 0;
  HumanoidSequence seq;
  seq.fps = m.fps();
  const int T = m.num_frames() - first;
  seq.root_pos.resize(3, T);
  seq.root_rot.resize(T);
  seq.local.assign(T, std::vector<Quat>(nb, Quat::Identity()));
  Matrix3X pos;
  std::vector<Quat> rot;
  std::vector<Quat> world(nb);
  for (int t = 0; t < T; ++t) {
    bvh::forward_kinematics(m, t + first, pos, rot);
    for (int b = 0; b < nb; ++b) {
      if (src[b] >= 0) {
        world[b] = (Wq * rot[src[b]] * Wq.conjugate() * calib_inv[b] * align[b]).normalized();
      } else {
        world[b] = world[skel.parents[b]];
      }
    }
    seq.root_pos.col(t) = W * (pos.col(src[0]) * map.unit_scale);
    seq.root_rot[t] = world[0];
    for (int b = 1; b < nb; ++b) seq.local[t][b] = (world[skel.parents[b]].conjugate() * world[b]).normalized();
  }
  if (map.drop_first_frame && m.num_frames() == 1) {
    // nothing dropped: a single frame stays
  }
  return seq;
}

/// Retargets a BVH motion onto the humanoid.
inline MotionClip retarget_bvh(const bvh::Motion& m, const JointMap& map, const RetargetOptions& opt = {},
                               RetargetReport* report = nullptr, const HumanoidDescription& desc = humanoid_description(),
                               const std::string& file = {}) {
  RetargetReport rep;
  rep.source_frames = m.num_frames();
  rep.source_fps = m.fps();
  HumanoidSequence seq = bvh_to_humanoid_sequence(m, map, desc, rep, file);
  if (opt.scale_root) {
    // scale about the first frame's ground point so the clip stays where it was horizontally
    const Vec3 o(seq.root_pos(0, 0), seq.root_pos(1, 0), 0.0);
    seq.root_pos = ((seq.root_pos.colwise() - o) * rep.root_scale).colwise() + o;
  }
  MotionClip clip = detail::finish(seq, desc, opt, rep, file);
  clip.description = "retargeted from " + (file.empty() ? std::string("BVH") : file) + " with the '" + map.name +
                     "' joint map";
  if (report) *report = rep;
  return clip;
}

/// Retargets AMASS SMPL parameters. SMPL joints 0..21 are the humanoid's bodies 0..21 (same
/// order, same parents); SMPL body axes (x left, y up, z forward) become ours (x forward, y left,
/// z up). AMASS worlds are z-up (`world_up = 'z'`); pass 'y' for y-up SMPL data. The pelvis is
/// placed at `trans` (the shape-dependent pelvis offset is absorbed by grounding).
inline MotionClip retarget_amass(const npz::AmassMotion& a, char world_up = 'z', const RetargetOptions& opt = {},
                                 RetargetReport* report = nullptr,
                                 const HumanoidDescription& desc = humanoid_description(), const std::string& file = {}) {
  const Skeleton& skel = desc.skeleton;
  require(skel.num_bodies() == 22, "AMASS retargeting needs the 22-body humanoid", {file, std::nullopt, "skeleton"});
  require(a.num_joints() >= 22, "poses must have at least 22 joints", {file, std::nullopt, "poses"});
  RetargetReport rep;
  rep.source_frames = a.num_frames();
  rep.source_fps = a.fps;
  const Mat3 C = detail::y_up_to_z_up();  // SMPL body axes → ours
  const Quat Cq(C);
  const Mat3 Wm = world_up == 'y' ? C : Mat3::Identity();
  const Quat Wq(Wm);
  HumanoidSequence seq;
  seq.fps = a.fps;
  const int T = a.num_frames();
  seq.root_pos.resize(3, T);
  seq.root_rot.resize(T);
  seq.local.assign(T, std::vector<Quat>(22, Quat::Identity()));
  for (int t = 0; t < T; ++t) {
    const Quat root = quat_exp(a.poses.col(t).segment<3>(0));
    seq.root_rot[t] = (Wq * root * Cq.conjugate()).normalized();
    seq.root_pos.col(t) = Wm * a.trans.col(t);
    for (int b = 1; b < 22; ++b)
      seq.local[t][b] = (Cq * quat_exp(a.poses.col(t).segment<3>(3 * b)) * Cq.conjugate()).normalized();
  }
  MotionClip clip = detail::finish(seq, desc, opt, rep, file);
  clip.description = "retargeted from AMASS " + (file.empty() ? std::string("npz") : file);
  if (report) *report = rep;
  return clip;
}

/// The humanoid clip as BVH (joints = bodies, channels `Xrotation Yrotation Zrotation` in
/// degrees, the root with positions). `y_up = false`: the humanoid's own Z-up frame, and the
/// channels are exactly the hinge angles. `y_up = true` (default; what Blender's importer and most
/// BVH tools expect): the whole figure is expressed in Y-up axes facing +Z (offsets and every
/// rotation re-expressed, R' = Cᵀ R C), so the zero-rotation pose is an upright T-pose.
inline bvh::Motion clip_to_bvh(const MotionClip& c, const Skeleton& skel = humanoid_skeleton(), bool y_up = true) {
  c.validate(skel);
  bvh::Motion m;
  const int nb = skel.num_bodies();
  const Mat3 Ct = y_up ? Mat3(detail::y_up_to_z_up().transpose()) : Mat3::Identity();  // humanoid → file axes
  const Quat Cq(Ct);
  int ch = 0;
  std::vector<int> first(nb);
  std::vector<bool> has_child(nb, false);
  for (int i = 1; i < nb; ++i) has_child[skel.parents[i]] = true;
  // joints in depth-first order so that the written file is valid BVH
  std::vector<int> order;
  auto dfs = [&](auto&& self, int b) -> void {
    order.push_back(b);
    for (int c2 = b + 1; c2 < nb; ++c2)
      if (skel.parents[c2] == b) self(self, c2);
  };
  dfs(dfs, 0);
  std::vector<int> joint_of(nb, -1);
  using bvh::Channel;
  for (int b : order) {
    bvh::Joint j;
    j.name = skel.names[b];
    j.parent = b == 0 ? -1 : joint_of[skel.parents[b]];
    j.offset = b == 0 ? Vec3::Zero() : Vec3(Ct * skel.offsets.col(b));
    if (b == 0) j.channels = {Channel::Xposition, Channel::Yposition, Channel::Zposition};
    j.channels.insert(j.channels.end(), {Channel::Xrotation, Channel::Yrotation, Channel::Zrotation});
    j.first_channel = ch;
    first[b] = ch;
    ch += static_cast<int>(j.channels.size());
    joint_of[b] = static_cast<int>(m.joints.size());
    m.joints.push_back(j);
    if (!has_child[b]) {
      bvh::Joint e;
      e.name = j.name + "_End";
      e.parent = joint_of[b];
      e.end_site = true;
      e.offset = 0.5 * j.offset;
      if (e.offset.norm() < 1e-6) e.offset = Ct * Vec3(0, 0, 0.05);
      e.first_channel = ch;
      m.joints.push_back(e);
    }
  }
  m.frame_time = 1.0 / c.fps;
  m.frames.resize(ch, c.num_frames());
  constexpr double deg = 180.0 / M_PI;
  std::vector<Vec3> prev(nb, Vec3::Zero());
  for (int t = 0; t < c.num_frames(); ++t) {
    m.frames.col(t).segment<3>(0) = Ct * c.root_pos.col(t);
    for (int b = 0; b < nb; ++b) {
      const Quat L = b == 0 ? c.rot(t) : joint_rotation(c.q.col(t).segment<3>(Skeleton::dof_offset(b)));
      const Vec3 a = y_up ? joint_angles_near(Cq * L * Cq.conjugate(), prev[b])
                          : (b == 0 ? joint_angles_near(L, prev[b]) : Vec3(c.q.col(t).segment<3>(Skeleton::dof_offset(b))));
      prev[b] = a;
      m.frames.col(t).segment<3>(b == 0 ? 3 : first[b]) = a * deg;
    }
  }
  return m;
}

/// Imports any supported file as a humanoid clip: `.bvh` (joint map detected from its names
/// unless given), `.npz` (a maskadapt clip, else AMASS parameters).
inline MotionClip import_motion(const std::string& path, const RetargetOptions& opt = {},
                                RetargetReport* report = nullptr, const JointMap* map = nullptr) {
  const std::string ext = std::filesystem::path(path).extension().string();
  const std::string stem = std::filesystem::path(path).stem().string();
  MotionClip clip;
  if (ext == ".bvh" || ext == ".BVH") {
    const bvh::Motion m = bvh::read(path);
    const JointMap jm = map ? *map : detect_joint_map(m, path);
    clip = retarget_bvh(m, jm, opt, report, humanoid_description(), path);
  } else if (ext == ".npz") {
    const npz::Archive ar = npz::read(path);
    if (ar.count("format")) {
      clip = clip_from_archive(ar, path);
      clip.validate(humanoid_skeleton(), path);
      if (report) {
        *report = RetargetReport{};
        report->source_frames = clip.num_frames();
        report->source_fps = clip.fps;
      }
      return clip;
    }
    clip = retarget_amass(npz::amass_from_archive(ar, path), 'z', opt, report, humanoid_description(), path);
  } else {
    throw Error("unknown motion file type '" + ext + "' (expected .bvh or .npz)", {path, std::nullopt, {}});
  }
  clip.name = stem;
  return clip;
}

}  // namespace maskadapt
