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
///     skeletons with no T-pose at all (Bandai, styles, CMU 3dsMax) fit the attachments
///     C_b = R_s(b, t₀)⁻¹ A_b over the frames instead (kCalibrateHeading, detail::fit_attachments)
///     or carry fixed ones (JointMap::attachments, calibrate_joint_map);
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

#include <Eigen/Eigenvalues>
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
  /// Rest pose: a frame index ≥ 0 (a T-pose frame), kCalibrateZeroPose (−1: the zero-rotation
  /// pose, for skeletons whose zero pose is a T-pose), or kCalibrateHeading (−2: no T-pose at all;
  /// every body's attachment is fitted over the file's frames, see detail::fit_attachments).
  int calibration_frame = 0;
  bool drop_first_frame = false;  ///< drop frame 0 (a synthetic T-pose in the CMU releases)
  /// Fixed attachments, humanoid body → C_b with R_h(b, t) = W R_s(b, t) Wᵀ · C_b (W: the axis
  /// change, R_s the source joint's world rotation): where given they replace the calibration, so
  /// every file of a skeleton is retargeted alike (see calibrate_joint_map).
  std::map<std::string, Quat> attachments;

  static constexpr int kCalibrateZeroPose = -1;
  static constexpr int kCalibrateHeading = -2;
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

/// Bandai Namco Research Motion Dataset (1 and 2): 22 joints under a static dummy `joint_Root`,
/// 6 channels on every joint (only `Hips` moves its position), centimetres, Y-up, 30 fps.
/// Maya-style local axes (every bone along a local ±x): neither the zero-rotation pose nor any
/// frame is a T-pose (zero-pose calibration puts the bones 62° off on average), so the map carries
/// fixed attachments fitted by the heading calibration (kCalibrateHeading) on one walk.
/// No third spine joint: the humanoid's `Spine` follows `Torso` (= Bandai `Spine`, whose bone
/// runs to `Chest`).
inline JointMap bandai_joint_map() {
  JointMap m;
  m.name = "bandai";
  m.joints = {{"Pelvis", "Hips"},           {"L_Hip", "UpperLeg_L"},     {"R_Hip", "UpperLeg_R"},
              {"Torso", "Spine"},           {"L_Knee", "LowerLeg_L"},    {"R_Knee", "LowerLeg_R"},
              {"L_Ankle", "Foot_L"},        {"R_Ankle", "Foot_R"},       {"Chest", "Chest"},
              {"L_Toe", "Toes_L"},          {"R_Toe", "Toes_R"},         {"Neck", "Neck"},
              {"L_Thorax", "Shoulder_L"},   {"R_Thorax", "Shoulder_R"},  {"Head", "Head"},
              {"L_Shoulder", "UpperArm_L"}, {"R_Shoulder", "UpperArm_R"}, {"L_Elbow", "LowerArm_L"},
              {"R_Elbow", "LowerArm_R"},    {"L_Wrist", "Hand_L"},       {"R_Wrist", "Hand_R"}};
  m.tips = {{"Torso", "Chest"},        {"L_Toe", "Toes_L_End"}, {"R_Toe", "Toes_R_End"},
            {"Head", "Head_End"},      {"L_Wrist", "Hand_L_End"}, {"R_Wrist", "Hand_R_End"}};
  m.unit_scale = 0.01;
  m.up_axis = 'y';
  m.calibration_frame = JointMap::kCalibrateHeading;
  // Fitted once: calibrate_joint_map(dataset-2_walk_normal_001.bvh) (Quat(w, x, y, z)); every
  // Bandai file is retargeted with these, so clips agree with each other (a fit per file moves the
  // arms' twists with each clip's mean posture). Test MocapSets.BandaiAttachmentsMatchAFreshFit.
  m.attachments = {
      {"Pelvis", Quat(0.7133054, -0.7002771, 0.0199062, -0.0202765)},
      {"L_Hip", Quat(0.7383258, 0.6744131, -0.0047856, -0.0043641)},
      {"R_Hip", Quat(0.0049482, 0.0049121, 0.7383048, 0.6744312)},
      {"Torso", Quat(-0.4911229, 0.5041727, 0.5131597, 0.4911979)},
      {"L_Knee", Quat(0.6933338, 0.7187771, -0.0361646, -0.0366029)},
      {"R_Knee", Quat(0.0356917, 0.0370933, 0.6933584, 0.7187519)},
      {"L_Ankle", Quat(0.6663744, 0.5152015, 0.3938832, 0.3679248)},
      {"R_Ankle", Quat(0.3997900, 0.3633313, -0.6628473, -0.5184513)},
      {"Chest", Quat(-0.4692386, 0.5163691, 0.5242885, 0.4881595)},
      {"L_Toe", Quat(0.5872903, 0.4365330, 0.4820618, 0.4818148)},
      {"R_Toe", Quat(0.4980459, 0.4893454, -0.5742119, -0.4275185)},
      {"Neck", Quat(-0.4599073, 0.5408351, 0.5101911, 0.4854768)},
      {"L_Thorax", Quat(0.9798842, -0.1898620, -0.0426946, -0.0442327)},
      {"R_Thorax", Quat(0.0331009, 0.0423726, 0.9802553, -0.1902851)},
      {"Head", Quat(-0.4608141, 0.5407030, 0.5401245, 0.4511719)},
      {"L_Shoulder", Quat(0.9938072, 0.0353140, -0.0952407, -0.0450479)},
      {"R_Shoulder", Quat(0.1123659, 0.0444315, 0.9920172, 0.0360787)},
      {"L_Elbow", Quat(0.9982424, -0.0237873, -0.0532265, -0.0106355)},
      {"R_Elbow", Quat(0.0780823, 0.0112250, 0.9966064, -0.0235124)},
      {"L_Wrist", Quat(0.9903542, -0.0828190, -0.1055590, 0.0345945)},
      {"R_Wrist", Quat(0.1273355, -0.0082245, 0.9852393, -0.1141124)},
  };
  return m;
}

/// The 21-joint skeleton of `motions/styles/` (Semi-Motion-Style-Transfer's m21 data: CMU, BFA,
/// Xia et al.): `Hips`, `LeftUpLeg`…`LeftToeBase`, `Spine`, `Spine1`, `Neck1`, `Head`,
/// `LeftShoulder`…`LeftHand`; all rotations `Zrotation Yrotation Xrotation`; 60 fps; centimetres
/// (`unit_scale` 0.01) except files in CMU units (SNEAKY.bvh: ×0.056444, chosen by
/// detect_joint_map from the leg length). No T-pose frame, zero-length End Sites; heading
/// calibration. The humanoid's `Spine` follows `Torso`.
inline JointMap styles_joint_map(double unit_scale = 0.01) {
  JointMap m;
  m.name = "styles";
  m.joints = {{"Pelvis", "Hips"},         {"L_Hip", "LeftUpLeg"},      {"R_Hip", "RightUpLeg"},
              {"Torso", "Spine"},         {"L_Knee", "LeftLeg"},       {"R_Knee", "RightLeg"},
              {"L_Ankle", "LeftFoot"},    {"R_Ankle", "RightFoot"},    {"Chest", "Spine1"},
              {"L_Toe", "LeftToeBase"},   {"R_Toe", "RightToeBase"},   {"Neck", "Neck1"},
              {"L_Thorax", "LeftShoulder"}, {"R_Thorax", "RightShoulder"}, {"Head", "Head"},
              {"L_Shoulder", "LeftArm"},  {"R_Shoulder", "RightArm"},  {"L_Elbow", "LeftForeArm"},
              {"R_Elbow", "RightForeArm"}, {"L_Wrist", "LeftHand"},    {"R_Wrist", "RightHand"}};
  m.tips = {{"Torso", "Spine1"}};
  m.unit_scale = unit_scale;
  m.up_axis = 'y';
  m.calibration_frame = JointMap::kCalibrateHeading;
  return m;
}

/// CMU in cgspeed's 3dsMax-friendly release (`motions/cmu-131/`): the 31-joint CMU hierarchy
/// under other names (`LHipJoint`, `LeftHip`, `LeftKnee`, `LeftAnkle`, `LeftToe`, `lowerback`,
/// `Chest`, `Chest2`, `lowerneck`, `Neck`, `Head`, `LeftCollar`, `LeftShoulder`, `LeftElbow`,
/// `LeftWrist`, …), CMU length units (×0.056444 m), 120 fps, no T-pose frame; heading calibration.
inline JointMap cmu_3dsmax_joint_map() {
  JointMap m;
  m.name = "cmu-3dsmax";
  m.joints = {{"Pelvis", "Hips"},          {"L_Hip", "LeftHip"},        {"R_Hip", "RightHip"},
              {"Torso", "lowerback"},      {"L_Knee", "LeftKnee"},      {"R_Knee", "RightKnee"},
              {"Spine", "Chest"},          {"L_Ankle", "LeftAnkle"},    {"R_Ankle", "RightAnkle"},
              {"Chest", "Chest2"},         {"L_Toe", "LeftToe"},        {"R_Toe", "RightToe"},
              {"Neck", "Neck"},            {"L_Thorax", "LeftCollar"},  {"R_Thorax", "RightCollar"},
              {"Head", "Head"},            {"L_Shoulder", "LeftShoulder"}, {"R_Shoulder", "RightShoulder"},
              {"L_Elbow", "LeftElbow"},    {"R_Elbow", "RightElbow"},   {"L_Wrist", "LeftWrist"},
              {"R_Wrist", "RightWrist"}};
  m.tips = {{"L_Toe", "LeftToe_End"}, {"R_Toe", "RightToe_End"}, {"Head", "Head_End"},
            {"L_Wrist", "LFingers"},  {"R_Wrist", "RFingers"}};
  m.unit_scale = 0.056444;
  m.up_axis = 'y';
  m.calibration_frame = JointMap::kCalibrateHeading;
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
  if (m.find("joint_Root") >= 0 && m.find("UpperLeg_L") >= 0 && m.find("Toes_R") >= 0) return bandai_joint_map();
  if (m.find("Hips") >= 0 && m.find("LHipJoint") >= 0 && m.find("lowerback") >= 0 && m.find("Chest2") >= 0)
    return cmu_3dsmax_joint_map();
  if (m.find("Hips") >= 0 && m.find("LeftUpLeg") >= 0 && m.find("Spine1") >= 0 && m.find("Neck1") >= 0 &&
      m.find("LeftToeBase") >= 0) {
    // centimetres or CMU units: the leg (thigh + shank) is ≈ 80 cm, ≈ 14.5 CMU units
    const int k = m.find("LeftLeg"), a = m.find("LeftFoot");
    const double leg = k >= 0 && a >= 0 ? m.joints[k].offset.norm() + m.joints[a].offset.norm() : 80.0;
    return styles_joint_map(leg < 40.0 ? 0.056444 : 0.01);
  }
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
  skel.require_xyz_layout("retargeting (joint angles from x-y-z rotations)");
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
      const int kb = skel.dof_offset(b);
      const Vec3 a = joint_angles_within(L, hint[b], skel.lower_limits().segment<3>(kb), skel.upper_limits().segment<3>(kb), &viol);
      if (viol > 1e-9) {
        ++clamped;
        rep.max_limit_excess = std::max(rep.max_limit_excess, viol);
      }
      hint[b] = a;
      clip.q.col(k).segment<3>(kb) = a;
    }
  }
  rep.clamped_fraction = double(clamped) / (double(Tout) * (nb - 1));
  if (opt.ground) {
    BodyStates bs;
    std::vector<double> low(static_cast<std::size_t>(Tout), 1e300);
    for (int k = 0; k < Tout; ++k) {
      forward_kinematics(skel, clip.frame(k), bs);
      for (int f : desc.foot_bodies())
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

/// Heading calibration (JointMap::kCalibrateHeading), for skeletons without a T-pose frame whose
/// zero-rotation pose is not a T-pose either (Bandai: Maya-style local axes, every bone along a
/// local ±x). Each mapped body's attachment C_b (R_h(b, t) = W R_s(b, t) Wᵀ · C_b, in the
/// axis-changed source joint frame) is fitted over all frames:
///  - the root: the rotation that on average puts the humanoid's x axis on the character's
///    heading and z up (Kabsch, SVD of H = Σ_t Σ_a b_a(t) aᵀ); heading per frame from the hips:
///    left = L_Hip − R_Hip on the ground, forward = left × up;
///  - a body with a bone (`bone_src[b] ≥ 0`, humanoid zero-pose direction `bone_h[b]`): the bone is
///    matched exactly, C_b·d_h = ℓ (ℓ the source bone in the joint frame), and only the twist θ
///    about ℓ is fitted, C_b = R_ℓ(θ)·Rmin(d_h → ℓ):
///      · thighs, shanks, upper arms and forearms: so that the measured flexion axis of the knee
///        (elbow) — the principal axis of the joint's frame-to-frame rotation increments, in the
///        parent's and in the child's frame — is the humanoid's knee hinge y (elbow hinge z); then
///        a source knee that is a hinge is a pure y rotation on the humanoid, whatever the stance;
///      · the others (spine, chest, neck, collars, feet): so that on average the body's x axis
///        points along the heading and its z axis up, as in the humanoid's zero pose and, up to
///        rotations about the bone, in any upright stance;
///    (a knee or elbow that hardly bends — < 0.5 rad of summed increments, or no axis carrying
///    4× the variance of the next — falls back to the heading);
///  - a body without one (hands, toes and heads, whose humanoid body has no child): the rotation
///    that makes its joint zero on average relative to its nearest mapped ancestor.
/// Frames where the hips are vertically aligned (no heading) are skipped; a file where every
/// frame is such throws.
inline std::vector<Quat> fit_attachments(const bvh::Motion& m, const Mat3& W, double unit_scale,
                                         const std::vector<int>& src, const std::vector<int>& bone_src,
                                         const std::vector<Vec3>& bone_h, const Skeleton& skel,
                                         const std::string& file) {
  const int nb = skel.num_bodies();
  const Quat Wq(W);
  const int lh = src[skel.index_of("L_Hip")], rh = src[skel.index_of("R_Hip")];
  require(lh >= 0 && rh >= 0, "heading calibration needs L_Hip and R_Hip mapped", {file, std::nullopt, "joint_map"});
  // nearest mapped ancestor of every body
  std::vector<int> anc(nb, -1);
  for (int b = 1; b < nb; ++b) {
    int p = skel.parents[b];
    while (p >= 0 && src[p] < 0) p = skel.parents[p];
    anc[b] = p;
  }
  // hinge joints: (child body, humanoid hinge axis); the child's parent must be mapped
  // hinge joints: the child body and the humanoid axis that flexes it (knee +y, left elbow −z,
  // right elbow +z: the sides of the joint limits that allow 2.7–2.8 rad)
  struct Hinge {
    int child;
    Vec3 flex;
  };
  std::vector<Hinge> hinges;
  for (const auto& [name, flex] : {std::pair<const char*, Vec3>{"L_Knee", Vec3::UnitY()}, {"R_Knee", Vec3::UnitY()},
                                   {"L_Elbow", -Vec3::UnitZ()}, {"R_Elbow", Vec3::UnitZ()}}) {
    const int c = skel.index_of(name);
    if (src[c] >= 0 && anc[c] == skel.parents[c] && bone_src[c] >= 0 && bone_src[skel.parents[c]] >= 0)
      hinges.push_back({c, flex});
  }
  std::vector<Mat3> H(nb, Mat3::Zero());      // Σ_t Σ_a b_a(t) aᵀ, joint frame × body frame
  std::vector<Mat3> rel(nb, Mat3::Zero());    // Σ_t Q_b⁻¹ Q_anc (bone-less bodies)
  std::vector<Vec3> ell(nb, Vec3::Zero());    // Σ_t source bone in the joint frame
  std::vector<Mat3> axp(hinges.size(), Mat3::Zero());  // Σ ω ωᵀ of the increments, parent frame
  std::vector<double> turned(hinges.size(), 0.0);
  std::vector<std::vector<Quat>> rel_hist(hinges.size());  // (T) child relative to parent
  std::vector<std::vector<double>> bend(hinges.size());    // (T) angle between the two bones (rad)
  Matrix3X pos;
  std::vector<Quat> rot;
  std::vector<Quat> Q(nb);
  int used = 0;
  const Vec3 up = Vec3::UnitZ();
  for (int t = 0; t < m.num_frames(); ++t) {
    bvh::forward_kinematics(m, t, pos, rot);
    for (int b = 0; b < nb; ++b)
      if (src[b] >= 0) Q[b] = Wq * rot[src[b]] * Wq.conjugate();
    for (std::size_t h = 0; h < hinges.size(); ++h) {
      const int c = hinges[h].child, p = skel.parents[c];
      const Quat S = (Q[p].conjugate() * Q[c]).normalized();
      if (t > 0) {
        const Vec3 wp = quat_log(S * rel_hist[h].back().conjugate());  // increment in the parent's frame
        axp[h] += wp * wp.transpose();
        turned[h] += wp.norm();
      }
      rel_hist[h].push_back(S);
      const Vec3 u = pos.col(src[c]) - pos.col(src[p]), v = pos.col(bone_src[c]) - pos.col(src[c]);
      bend[h].push_back(std::acos(std::clamp(u.normalized().dot(v.normalized()), -1.0, 1.0)));
    }
    Vec3 left = W * (pos.col(lh) - pos.col(rh));
    left.z() = 0;
    if (left.norm() < 1e-9) continue;
    left.normalize();
    const Vec3 fwd = left.cross(up);
    ++used;
    for (int b = 0; b < nb; ++b) {
      if (src[b] < 0) continue;
      const Quat Qinv = Q[b].conjugate();
      H[b] += (Qinv * fwd) * Vec3::UnitX().transpose() + (Qinv * up) * Vec3::UnitZ().transpose();
      if (bone_src[b] >= 0) ell[b] += Qinv * (W * (pos.col(bone_src[b]) - pos.col(src[b])) * unit_scale);
      if (b > 0 && anc[b] >= 0) rel[b] += (Qinv * Q[anc[b]]).toRotationMatrix();
    }
  }
  require(used > 0, "heading calibration: the hips never give a heading", {file, std::nullopt, "calibration_frame"});
  auto so3 = [](const Mat3& A) {  // nearest rotation
    Eigen::JacobiSVD<Mat3> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Mat3 D = Mat3::Identity();
    D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
    return Quat(Mat3(svd.matrixU() * D * svd.matrixV().transpose())).normalized();
  };
  // per body: the flexion axis of its hinge in its own frame (positive rotation about it bends
  // the joint) and the humanoid axis it must become
  std::vector<Vec3> hinge_axis(nb, Vec3::Zero()), hinge_h(nb, Vec3::Zero());
  for (std::size_t h = 0; h < hinges.size(); ++h) {
    if (turned[h] < 0.5) continue;
    Eigen::SelfAdjointEigenSolver<Mat3> ep(axp[h]);
    if (ep.eigenvalues()(2) < 10 * ep.eigenvalues()(1)) continue;  // not a hinge
    Vec3 kp = ep.eigenvectors().col(2);
    // sign: the angle about kp (integrated increments) must grow with the bend between the bones
    const auto& R = rel_hist[h];
    const auto& be = bend[h];
    const std::size_t T = R.size();
    double phi = 0, sp = 0, sb = 0, spb = 0, spp = 0;
    for (std::size_t t = 0; t < T; ++t) {
      if (t > 0) phi += quat_log(R[t] * R[t - 1].conjugate()).dot(kp);
      sp += phi, sb += be[t], spb += phi * be[t], spp += phi * phi;
    }
    const double cov = spb / T - (sp / T) * (sb / T);
    if (std::abs(cov) < 1e-9) continue;
    if (cov < 0) kp = -kp;
    Vec3 kc = Vec3::Zero();  // the same axis in the child's frame: S(t)⁻¹ kp, constant for a hinge
    for (const Quat& S : R) kc += S.conjugate() * kp;
    const int c = hinges[h].child, p = skel.parents[c];
    hinge_axis[p] = kp;
    hinge_axis[c] = kc.normalized();
    hinge_h[p] = hinge_h[c] = hinges[h].flex;
  }
  // trunk bodies take the orientation fit: their bones are short and kinked differently in every
  // skeleton (the humanoid's Chest→Neck leans back 14°, its Neck→Head forward 27°), and matching
  // each bone's direction exactly pitches neighbours by ±30–50° against each other
  std::vector<bool> trunk(nb, false);
  for (const char* n : {"Pelvis", "Torso", "Spine", "Chest", "Neck", "Head"}) trunk[skel.index_of(n)] = true;
  std::vector<Quat> C(nb, Quat::Identity());
  for (int b = 0; b < nb; ++b) {
    if (src[b] < 0) continue;
    if (!trunk[b] && bone_src[b] >= 0 && ell[b].norm() > 1e-9) {
      const Vec3 l = ell[b].normalized();
      const Mat3 C0 = min_rotation(bone_h[b], l).toRotationMatrix();
      const Mat3 N = C0 * H[b].transpose();  // heading: maximise f(θ) = tr(R_l(θ) N)
      Mat3 lx;
      lx << 0, -l.z(), l.y(), l.z(), 0, -l.x(), -l.y(), l.x(), 0;
      double theta = std::atan2((lx * N).trace(), (N - l * (l.transpose() * N)).trace());
      if (hinge_h[b].norm() > 0) {
        // rotate the humanoid flexion axis (after C0) about l onto the measured one, both ⊥ l
        Vec3 a = C0 * hinge_h[b], k = hinge_axis[b];
        a -= l * l.dot(a);
        k -= l * l.dot(k);
        if (a.norm() > 1e-6 && k.norm() > 1e-6) theta = std::atan2(l.dot(a.normalized().cross(k.normalized())), a.normalized().dot(k.normalized()));
      }
      C[b] = (Quat(Eigen::AngleAxisd(theta, l)) * Quat(C0)).normalized();
    } else if (trunk[b] || anc[b] < 0) {
      C[b] = so3(H[b]);
    } else {
      C[b] = (so3(rel[b]) * C[anc[b]]).normalized();
    }
  }
  return C;
}

}  // namespace detail

/// Steps 1–4 for a BVH file: the motion as humanoid local rotations at the source frame rate.
/// `attachments_out` (optional): the attachment C_b used for every body (identity where unmapped).
inline HumanoidSequence bvh_to_humanoid_sequence(const bvh::Motion& m, const JointMap& map,
                                                 const HumanoidDescription& desc, RetargetReport& rep,
                                                 const std::string& file = {},
                                                 std::vector<Quat>* attachments_out = nullptr) {
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
  // ---- calibration pose (kCalibrateHeading: frame 0, used for bone lengths only) ----
  const bool heading = map.calibration_frame == JointMap::kCalibrateHeading;
  require(map.calibration_frame >= JointMap::kCalibrateHeading,
          "calibration_frame must be a frame index, -1 (zero pose) or -2 (heading fit)",
          {file, std::nullopt, "calibration_frame"});
  bvh::Motion calib_m;
  const bvh::Motion* cm = &m;
  int cf = heading ? 0 : map.calibration_frame;
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
  // zero-pose humanoid joint positions (for bone directions)
  const BodyStates zero = forward_kinematics(skel, KinematicState::zero(skel));
  // every mapped body's bone: the source joint at its far end and the humanoid's zero-pose bone
  // (first child in index order with a distinct mapped source joint, else the tip)
  std::vector<int> bone_src(nb, -1);
  std::vector<Vec3> bone_h(nb, Vec3::Zero());
  for (int b = 1; b < nb; ++b) {
    if (src[b] < 0) continue;
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
    if (child_src < 0 || dh.norm() < 1e-9) continue;
    if ((cpos.col(child_src) - cpos.col(src[b])).norm() < 1e-9) continue;  // zero-length source bone
    bone_src[b] = child_src;
    bone_h[b] = dh.normalized();
  }
  // attachment C_b of every mapped body: R_h(b, t) = W R_s(b, t) Wᵀ · C_b
  std::vector<Quat> attach(nb, Quat::Identity());
  if (heading) {
    attach = detail::fit_attachments(m, W, map.unit_scale, src, bone_src, bone_h, skel, file);
  } else {
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
    for (int b = 0; b < nb; ++b) {
      if (src[b] < 0) continue;
      const Quat calib_inv = (Wq * crot[src[b]] * Wq.conjugate()).conjugate();
      Quat align = M;
      if (bone_src[b] >= 0) {
        const Vec3 ds = cpos.col(bone_src[b]) - cpos.col(src[b]);
        align = detail::min_rotation((M * bone_h[b]).normalized(), ds.normalized()) * M;
      }
      attach[b] = calib_inv * align;
    }
  }
  for (const auto& [body, C] : map.attachments) {
    const int b = skel.index_of(body);
    require(std::abs(C.norm() - 1.0) < 1e-3, "attachment is not a unit quaternion", {file, std::nullopt, body});
    attach[b] = C.normalized();
  }
  if (attachments_out) *attachments_out = attach;
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
        world[b] = (Wq * rot[src[b]] * Wq.conjugate() * attach[b]).normalized();
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

/// The map with its attachments fitted once on `reference` (heading calibration, see
/// detail::fit_attachments; or the map's own calibration when `heading` is false), so that other
/// files of the same skeleton are retargeted with exactly the same attachments.
inline JointMap calibrate_joint_map(const bvh::Motion& reference, JointMap map, bool heading = true,
                                    const HumanoidDescription& desc = humanoid_description(),
                                    const std::string& file = {}) {
  map.attachments.clear();
  if (heading) map.calibration_frame = JointMap::kCalibrateHeading;
  RetargetReport rep;
  std::vector<Quat> C;
  bvh_to_humanoid_sequence(reference, map, desc, rep, file, &C);
  const Skeleton& skel = desc.skeleton;
  for (const auto& [body, joint] : map.joints) map.attachments[body] = C[static_cast<std::size_t>(skel.index_of(body))];
  return map;
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
    const Quat root = quat_exp(a.pose(t, 0));
    seq.root_rot[t] = (Wq * root * Cq.conjugate()).normalized();
    seq.root_pos.col(t) = Wm * a.translation(t);
    for (int b = 1; b < 22; ++b) seq.local[t][b] = (Cq * quat_exp(a.pose(t, b)) * Cq.conjugate()).normalized();
  }
  MotionClip clip = detail::finish(seq, desc, opt, rep, file);
  clip.description = "retargeted from AMASS " + (file.empty() ? std::string("npz") : file);
  if (report) *report = rep;
  return clip;
}

/// The humanoid clip as BVH (joints = bodies, channels `Xrotation Yrotation Zrotation` in
/// degrees, the root with positions). `y_up = false`: the humanoid's own Z-up frame, and the
/// channels are exactly the hinge angles of x-y-z joints (other joints, e.g. the G1's single
/// hinges, are written as their rotation's X·Y·Z angles). `y_up = true` (default; what Blender's importer and most
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
  std::vector<bool> xyz(nb);  // joints whose own angles are the BVH's X, Y, Z channels
  for (int b = 1; b < nb; ++b) xyz[b] = skel.has_xyz_hinges(b);
  for (int t = 0; t < c.num_frames(); ++t) {
    m.frames.col(t).segment<3>(0) = Ct * c.root_pos.col(t);
    for (int b = 0; b < nb; ++b) {
      const Quat L = b == 0 ? c.rot(t) : joint_rotation(skel, b, c.q.col(t));
      const Vec3 a = y_up ? joint_angles_near(Cq * L * Cq.conjugate(), prev[b])
                          : (b == 0 || !xyz[b] ? joint_angles_near(L, prev[b]) : Vec3(c.q.col(t).segment<3>(skel.dof_offset(b))));
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
