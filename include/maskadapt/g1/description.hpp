#pragma once
/// \file description.hpp
/// A Unitree-G1-like humanoid robot (29-DoF variant), described once: kinematic tree, one
/// single-axis hinge per link, joint limits, torque limits, masses, collision primitives, PD
/// gains, body-part groups, a nominal standing pose and physics settings. The MuJoCo model
/// (g1/mjcf.hpp, assets/g1.xml) is generated from this description. docs/characters.md lists the
/// source of every figure; the comments here say the same next to each figure.
///
/// Frames and conventions (metres, radians, kg, N·m):
///  - world z-up; at the zero pose the robot faces +x, its left is +y, legs straight, arms down,
///    forearms pointing forward (the G1's elbow zero is a right angle);
///  - links are Unitree's (names as in the public unitree_ros g1_29dof URDF) and each carries
///    exactly one hinge, so an anatomical joint is a chain of links (hip pitch → roll → yaw);
///  - every link frame is world-aligned at the zero pose. The URDF tilts some link frames (hip
///    roll/yaw links by −0.1749 rad about y, shoulder pitch links by ±0.27931 rad about x); we
///    fold those tilts into the joint *axes* and the offsets (detail::urdf_chain), so the hinge
///    axes are arbitrary unit vectors (e.g. the hip roll axis is (0.985, 0, 0.174));
///  - joint j (0..28) is the hinge of link j+1; the order is Unitree's motor order: left leg
///    (0–5), right leg (6–11), waist (12–14), left arm (15–21), right arm (22–28);
///  - the geoms are our own primitives (the URDF has meshes); their masses are the URDF link
///    masses, inertia follows from the shapes (MuJoCo's inertiafromgeom), hence "estimated".
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/humanoid/description.hpp>  // Geom, PhysicsOptions, detail::capsule/box/sphere
#include <maskadapt/mask/parts.hpp>

#include <cmath>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace maskadapt::g1 {

using maskadapt::Geom;
using maskadapt::PhysicsOptions;

inline constexpr int kNumJoints = 29;  ///< 29-DoF variant (G1 EDU): 3-DoF waist, 3-DoF wrists
inline constexpr int kNumBodies = 30;  ///< pelvis (floating root) + one link per hinge

/// One link of the tree and the hinge it hangs from.
struct Link {
  std::string name;              ///< MuJoCo body name (Unitree link name), e.g. "left_knee_link"
  std::string joint;             ///< hinge name, e.g. "left_knee_joint"; empty for the root
  int parent = -1;               ///< parent link index (parents come before children); −1: root
  Vec3 offset = Vec3::Zero();    ///< origin in the parent's frame at the zero pose (m)
  Vec3 axis = Vec3::Zero();      ///< unit hinge axis in this link's frame; zero for the root
  double lower = 0, upper = 0;   ///< joint range (rad)
  double effort = 0;             ///< peak joint torque (N·m), the actuator's force range
  double kp = 0;                 ///< PD stiffness (N·m/rad)
  double kd = 0;                 ///< PD damping (N·m·s/rad), simulated as joint damping
  double armature = 0;           ///< reflected rotor inertia (kg·m²)
  BodyPart part = BodyPart::Trunk;
  std::vector<Geom> geoms;       ///< collision/inertia primitives in this link's frame
  double mass() const {
    double m = 0;
    for (const auto& g : geoms) m += g.mass;
    return m;
  }
};

/// Everything needed to build the simulated G1.
struct G1Description {
  std::vector<Link> links;         ///< (kNumBodies) index 0 = pelvis
  double root_height = 0.0;        ///< pelvis height (m) that puts the zero pose's soles on z = 0
  VectorXd nominal_q;              ///< (kNumJoints) standing pose, slightly bent knees (rad)
  double nominal_root_height = 0;  ///< pelvis height (m) of the nominal pose with soles on z = 0
  int head_link = -1;              ///< link carrying the head sphere (the torso)
  Vec3 head_centre = Vec3::Zero(); ///< head sphere centre in that link's frame (m)
  double head_radius = 0;          ///< head sphere radius (m); its top is the robot's height
  /// Physics step (s), semi-implicit Euler. Ours: 1/240 s stands open-loop and survives random
  /// targets with margin (1/60, 1/150, 1/180, 1/300, 1/480 s did too; 1/120 s toppled forward
  /// while settling — see docs/characters.md), and keeps the floor's solref 0.02 s unclamped.
  double physics_dt = 1.0 / 240.0;
  int substeps = 8;                ///< physics steps per control step (30 Hz control, DESIGN §4)
  double friction = 1.0;           ///< sliding friction geom–floor
  int nconmax = 100;               ///< MuJoCo contact buffer (per mjData)
  int njmax = 400;                 ///< MuJoCo constraint rows
  PhysicsOptions physics;          ///< solver, integrator, cone, Jacobian, contact solref

  int num_bodies() const { return static_cast<int>(links.size()); }
  int num_joints() const { return num_bodies() - 1; }
  double control_dt() const { return physics_dt * substeps; }
  double total_mass() const {
    double m = 0;
    for (const auto& l : links) m += l.mass();
    return m;
  }
  /// Per-joint figure, (num_joints): e.g. `joint_vector(&Link::lower)`.
  VectorXd joint_vector(double Link::*field) const {
    VectorXd v(num_joints());
    for (int j = 0; j < num_joints(); ++j) v[j] = links[static_cast<std::size_t>(j + 1)].*field;
    return v;
  }
  int link_index(const std::string& name) const {
    for (int i = 0; i < num_bodies(); ++i)
      if (links[static_cast<std::size_t>(i)].name == name) return i;
    throw Error("no such G1 link: " + name, {{}, {}, "name"});
  }
  /// Throws unless the tree, axes, limits and gains are consistent.
  void validate() const {
    require(!links.empty() && links[0].parent == -1, "G1: link 0 must be the root", {{}, {}, "links"});
    require(nominal_q.size() == num_joints(), "G1: nominal_q needs one entry per joint", {{}, {}, "nominal_q"});
    for (int i = 1; i < num_bodies(); ++i) {
      const Link& l = links[static_cast<std::size_t>(i)];
      require(l.parent >= 0 && l.parent < i, "G1: parents must precede children", {{}, {}, l.name});
      require(std::abs(l.axis.norm() - 1.0) < 1e-9, "G1: hinge axis must be a unit vector", {{}, {}, l.name});
      require(l.lower < l.upper && l.effort > 0 && l.kp > 0 && l.kd >= 0 && l.armature >= 0,
              "G1: joint range, effort or gains out of range", {{}, {}, l.name});
      require(nominal_q[i - 1] >= l.lower && nominal_q[i - 1] <= l.upper, "G1: nominal pose outside the joint range",
              {{}, {}, l.name});
    }
    for (const auto& l : links) require(l.mass() > 0, "G1: every link needs mass", {{}, {}, l.name});
  }
};

/// World poses of every link, (kNumBodies) each.
struct LinkPoses {
  std::vector<Vec3> pos;  ///< link origins (m)
  std::vector<Quat> rot;  ///< link orientations
};

/// Forward kinematics: pelvis at `root_pos`/`root_rot`, joint angles `q` (num_joints, rad).
inline LinkPoses forward_kinematics(const G1Description& d, const Vec3& root_pos, const Quat& root_rot,
                                    const Eigen::Ref<const VectorXd>& q) {
  require(q.size() == d.num_joints(), "G1 forward_kinematics: q needs one entry per joint", {{}, {}, "q"});
  LinkPoses p;
  p.pos.resize(static_cast<std::size_t>(d.num_bodies()));
  p.rot.resize(static_cast<std::size_t>(d.num_bodies()));
  p.pos[0] = root_pos;
  p.rot[0] = root_rot.normalized();
  for (int i = 1; i < d.num_bodies(); ++i) {
    const auto u = static_cast<std::size_t>(i);
    const Link& l = d.links[u];
    const auto par = static_cast<std::size_t>(l.parent);
    p.pos[u] = p.pos[par] + p.rot[par] * l.offset;
    p.rot[u] = p.rot[par] * Quat(Eigen::AngleAxisd(q[i - 1], l.axis));
  }
  return p;
}

/// Height (m) of the top of the head: the robot's standing height at the nominal pose.
inline double head_top_height(const G1Description& d, const LinkPoses& p) {
  const auto h = static_cast<std::size_t>(d.head_link);
  return (p.pos[h] + p.rot[h] * d.head_centre).z() + d.head_radius;
}

namespace detail {

using maskadapt::detail::box, maskadapt::detail::capsule, maskadapt::detail::sphere, maskadapt::detail::round_um;

/// A link as the URDF gives it: joint origin `xyz` in the parent's URDF frame, the joint frame's
/// rotation `rpy` (roll, pitch, yaw; R = Rz·Ry·Rx) and the hinge axis in that joint frame.
struct UrdfJoint {
  std::string link;
  std::string joint;
  int parent;
  Vec3 xyz, rpy, axis;
};

inline Mat3 rpy_matrix(const Vec3& rpy) {
  return (Eigen::AngleAxisd(rpy.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(rpy.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

/// Re-expresses URDF joints in world-aligned link frames: offset = R_parent·xyz, axis =
/// R_link·axis with R the URDF frame orientation at the zero pose (rounded to µm / 1e-9).
inline void urdf_chain(const std::vector<UrdfJoint>& js, std::vector<Link>& links) {
  std::vector<Mat3> R(js.size() + 1, Mat3::Identity());
  for (std::size_t k = 0; k < js.size(); ++k) {
    const UrdfJoint& u = js[k];
    const Mat3& Rp = R[static_cast<std::size_t>(u.parent)];
    R[k + 1] = Rp * rpy_matrix(u.rpy);
    Link l;
    l.name = u.link;
    l.joint = u.joint;
    l.parent = u.parent;
    l.offset = round_um(Rp * u.xyz);
    l.axis = ((R[k + 1] * u.axis) * 1e9).array().round().matrix().normalized();
    links.push_back(std::move(l));
  }
}

inline G1Description make_g1_description() {
  G1Description d;
  d.links.resize(1);
  d.links[0].name = "pelvis";
  d.links[0].part = BodyPart::Trunk;

  // Kinematics (m, rad): joint origins, frame tilts and axes of the public unitree_ros
  // robots/g1_description g1_29dof URDF (figures recalled, not copied from the file; our
  // world-aligned offsets are rounded to 1 µm). Tilts that the URDF undoes one link later are
  // folded into the axes; the shoulder roll link's URDF
  // un-tilt, −0.27925, is taken as −0.27931 and its ~1e-4 rad y/z residuals dropped, so every
  // link frame is world-aligned at the zero pose).
  const Vec3 X = Vec3::UnitX(), Y = Vec3::UnitY(), Z = Vec3::UnitZ(), O = Vec3::Zero();
  constexpr double kHipTilt = 0.1749;       // hip roll/yaw link tilt about y (rad), URDF
  constexpr double kShoulderTilt = 0.27931; // shoulder pitch link tilt about x (rad), URDF
  std::vector<UrdfJoint> js;
  for (int side = 0; side < 2; ++side) {  // legs: links 1–6 (left), 7–12 (right)
    const double s = side == 0 ? 1.0 : -1.0;  // right side mirrors y
    const std::string n = side == 0 ? "left_" : "right_";
    const int b = 1 + 6 * side;
    auto add = [&](const std::string& what, int parent, Vec3 xyz, Vec3 rpy, Vec3 axis) {
      js.push_back({n + what + "_link", n + what + "_joint", parent, xyz, rpy, axis});
    };
    add("hip_pitch", 0, {0, s * 0.064452, -0.1027}, O, Y);
    add("hip_roll", b, {0, s * 0.052, -0.030465}, {0, -kHipTilt, 0}, X);
    add("hip_yaw", b + 1, {0.025001, 0, -0.12412}, O, Z);
    add("knee", b + 2, {-0.078273, s * 0.0021489, -0.17734}, {0, kHipTilt, 0}, Y);
    add("ankle_pitch", b + 3, {0, -s * 0.000094445, -0.30001}, O, Y);
    add("ankle_roll", b + 4, {0, 0, -0.017558}, O, X);
  }
  // Waist: links 13 (yaw), 14 (roll), 15 (torso, hangs from the pitch hinge).
  js.push_back({"waist_yaw_link", "waist_yaw_joint", 0, O, O, Z});
  js.push_back({"waist_roll_link", "waist_roll_joint", 13, {-0.0039635, 0, 0.035}, O, X});
  js.push_back({"torso_link", "waist_pitch_joint", 14, {0, 0, 0.019}, O, Y});
  for (int side = 0; side < 2; ++side) {  // arms: links 16–22 (left), 23–29 (right)
    const double s = side == 0 ? 1.0 : -1.0;
    const std::string n = side == 0 ? "left_" : "right_";
    const int b = 16 + 7 * side;
    auto add = [&](const std::string& what, int parent, Vec3 xyz, Vec3 rpy, Vec3 axis) {
      js.push_back({n + what + "_link", n + what + "_joint", parent, xyz, rpy, axis});
    };
    add("shoulder_pitch", 15, {0.0039563, s * 0.10022, 0.24778}, {s * kShoulderTilt, 0, 0}, Y);
    add("shoulder_roll", b, {0, s * 0.038, -0.013831}, {-s * kShoulderTilt, 0, 0}, X);
    add("shoulder_yaw", b + 1, {0, s * 0.00624, -0.1032}, O, Z);
    add("elbow", b + 2, {0.015783, 0, -0.080518}, O, Y);
    add("wrist_roll", b + 3, {0.1, s * 0.00188791, -0.01}, O, X);
    add("wrist_pitch", b + 4, {0.038, 0, 0}, O, Y);
    add("wrist_yaw", b + 5, {0.046, 0, 0}, O, Z);
  }
  urdf_chain(js, d.links);
  auto& Lk = d.links;
  auto off = [&](int child) { return Vec3(Lk[static_cast<std::size_t>(child)].offset); };

  // Joint ranges (rad) and peak torques (N·m): the URDF's <limit lower upper effort>, which
  // match Unitree's G1 developer documentation (joint motor sequence and limits).
  auto limits = [&](int i, double lo, double hi, double effort) {
    Lk[static_cast<std::size_t>(i)].lower = lo;
    Lk[static_cast<std::size_t>(i)].upper = hi;
    Lk[static_cast<std::size_t>(i)].effort = effort;
  };
  // Armature (kg·m²): reflected rotor inertia of Unitree's actuators as used by public G1
  // training code (BeyondMimic's G1 config, recalled): 7520-14 0.010177520, 7520-22 0.025101925,
  // 5020 0.003609725, two 5020 in parallel (ankle, waist roll/pitch) 0.00721945, 4010 0.00425.
  // PD gains (kp N·m/rad, kd N·m·s/rad): the published ones are in published_gains() below.
  // Legs and waist are stiffened to kp 500 (kd = kp/50, the published kd/kp ratio of 0.02 s)
  // because a fixed PD target must hold the robot up without a balance policy: open-loop
  // standing needs 2·kp_ankle > m·g·h_CoM ≈ 35·9.81·0.67 ≈ 230 plus margin for the compliance of
  // knees, hips and waist in series (estimated by simulation: legs at 300 topple within 3 s,
  // 400 stand with 4 cm of forward sway, 500 with 2 cm; docs/characters.md). Arms keep the
  // published 40 / 1.
  constexpr double a7520_14 = 0.010177520, a7520_22 = 0.025101925, a5020 = 0.003609725, a2x5020 = 0.00721945,
                   a4010 = 0.00425;
  auto gains = [&](int i, double kp, double kd, double armature) {
    Lk[static_cast<std::size_t>(i)].kp = kp;
    Lk[static_cast<std::size_t>(i)].kd = kd;
    Lk[static_cast<std::size_t>(i)].armature = armature;
  };
  for (int side = 0; side < 2; ++side) {
    const int b = 1 + 6 * side;
    limits(b + 0, -2.5307, 2.8798, 88);        // hip pitch
    if (side == 0) limits(b + 1, -0.5236, 2.9671, 139);  // hip roll (left abducts positive)
    else limits(b + 1, -2.9671, 0.5236, 139);
    limits(b + 2, -2.7576, 2.7576, 88);        // hip yaw
    limits(b + 3, -0.087267, 2.8798, 139);     // knee
    limits(b + 4, -0.87267, 0.5236, 50);       // ankle pitch
    limits(b + 5, -0.2618, 0.2618, 50);        // ankle roll
    gains(b + 0, 500, 10, a7520_14);
    gains(b + 1, 500, 10, a7520_22);
    gains(b + 2, 500, 10, a7520_14);
    gains(b + 3, 500, 10, a7520_22);
    gains(b + 4, 500, 10, a2x5020);
    gains(b + 5, 500, 10, a2x5020);
  }
  limits(13, -2.618, 2.618, 88);  // waist yaw
  limits(14, -0.52, 0.52, 50);    // waist roll
  limits(15, -0.52, 0.52, 50);    // waist pitch
  gains(13, 500, 10, a7520_14);
  gains(14, 500, 10, a2x5020);
  gains(15, 500, 10, a2x5020);
  for (int side = 0; side < 2; ++side) {
    const int b = 16 + 7 * side;
    limits(b + 0, -3.0892, 2.6704, 25);  // shoulder pitch
    if (side == 0) limits(b + 1, -1.5882, 2.2515, 25);  // shoulder roll (left abducts positive)
    else limits(b + 1, -2.2515, 1.5882, 25);
    limits(b + 2, -2.618, 2.618, 25);       // shoulder yaw
    limits(b + 3, -1.0472, 2.0944, 25);     // elbow
    limits(b + 4, -1.972222, 1.972222, 25); // wrist roll
    limits(b + 5, -1.614430, 1.614430, 5);  // wrist pitch
    limits(b + 6, -1.614430, 1.614430, 5);  // wrist yaw
    for (int k = 0; k < 5; ++k) gains(b + k, 40, 1, a5020);
    gains(b + 5, 40, 1, a4010);
    gains(b + 6, 40, 1, a4010);
  }

  // Body parts (mask/parts.hpp): pelvis and waist → trunk; each leg and arm chain → its part.
  for (int i = 1; i <= 6; ++i) Lk[static_cast<std::size_t>(i)].part = BodyPart::LeftLeg;
  for (int i = 7; i <= 12; ++i) Lk[static_cast<std::size_t>(i)].part = BodyPart::RightLeg;
  for (int i = 13; i <= 15; ++i) Lk[static_cast<std::size_t>(i)].part = BodyPart::Trunk;
  for (int i = 16; i <= 22; ++i) Lk[static_cast<std::size_t>(i)].part = BodyPart::LeftArm;
  for (int i = 23; i <= 29; ++i) Lk[static_cast<std::size_t>(i)].part = BodyPart::RightArm;

  // Geoms: shapes estimated (our primitives spanning joint to joint, sized to the G1's outline);
  // masses are the URDF link masses (recalled, ±5 %), except where marked "estimated".
  auto G = [&](int i) -> std::vector<Geom>& { return Lk[static_cast<std::size_t>(i)].geoms; };
  G(0) = {capsule({0, -0.06, -0.07}, {0, 0.06, -0.07}, 0.06, 3.813)};  // pelvis 3.813 kg
  for (int side = 0; side < 2; ++side) {
    const int b = 1 + 6 * side;
    G(b + 0) = {capsule(Vec3::Zero(), off(b + 1), 0.04, 1.35)};               // hip pitch link 1.35 kg
    G(b + 1) = {capsule(Vec3::Zero(), off(b + 2), 0.045, 1.52)};              // hip roll link 1.52 kg
    G(b + 2) = {capsule(0.1 * off(b + 3), 0.9 * off(b + 3), 0.05, 1.702)};    // thigh (hip yaw link) 1.702 kg
    G(b + 3) = {capsule(0.08 * off(b + 4), 0.9 * off(b + 4), 0.045, 1.932)};  // shank (knee link) 1.932 kg
    G(b + 4) = {sphere(Vec3::Zero(), 0.02, 0.074)};                           // ankle pitch link 0.074 kg
    // Foot 0.608 kg: sole 0.035 m below the ankle roll axis, heel −0.055 m, toe +0.125 m, 0.07 m
    // wide (the URDF's four contact points at x −0.05/0.12, y ±0.025/±0.03, z −0.03, r 0.005).
    G(b + 5) = {box({0.035, 0, -0.0225}, {0.09, 0.035, 0.0125}, 0.608)};
  }
  G(13) = {sphere({0, 0, 0.015}, 0.03, 0.214)};  // waist yaw link 0.214 kg
  G(14) = {sphere({0, 0, 0.01}, 0.02, 0.086)};   // waist roll link 0.086 kg
  // Torso 7.818 kg (URDF torso_link) as a chest box; head estimated 1.0 kg (URDF head_link,
  // recalled) as a sphere whose top is 1.32 m above the floor at the zero pose (Unitree's
  // published standing height 1320 mm; the centre height is chosen to match it).
  d.head_link = 15;
  d.head_radius = 0.07;
  d.head_centre = {0.0, 0.0, 0.404};
  G(15) = {box({0.0, 0, 0.19}, {0.07, 0.09, 0.14}, 7.818), sphere(d.head_centre, d.head_radius, 1.0)};
  for (int side = 0; side < 2; ++side) {
    const int b = 16 + 7 * side;
    const double s = side == 0 ? 1.0 : -1.0;
    G(b + 0) = {capsule(Vec3::Zero(), off(b + 1), 0.035, 0.718)};            // shoulder pitch link 0.718 kg
    G(b + 1) = {capsule(Vec3::Zero(), 0.6 * off(b + 2), 0.035, 0.643)};      // shoulder roll link 0.643 kg
    G(b + 2) = {capsule(Vec3::Zero(), 0.85 * off(b + 3), 0.032, 0.734)};     // upper arm (shoulder yaw) 0.734 kg
    G(b + 3) = {capsule(0.1 * off(b + 4), 0.95 * off(b + 4), 0.03, 0.6)};    // forearm (elbow link) 0.6 kg
    G(b + 4) = {capsule(Vec3::Zero(), off(b + 5), 0.025, 0.085445)};         // wrist roll link 0.085 kg
    G(b + 5) = {capsule(Vec3::Zero(), off(b + 6), 0.025, 0.48405)};          // wrist pitch link 0.484 kg
    // Wrist yaw link 0.2546 kg + rubber hand, estimated 0.17 kg (fixed at x +0.0415 in the URDF).
    G(b + 6) = {capsule(Vec3::Zero(), {0.03, 0, 0}, 0.025, 0.254576), sphere({0.08, s * 0.003, 0}, 0.035, 0.17)};
  }

  // Zero pose: soles (ankle roll origin − 0.035 m) on z = 0.
  const VectorXd zero = VectorXd::Zero(kNumJoints);
  const LinkPoses p0 = forward_kinematics(d, Vec3::Zero(), Quat::Identity(), zero);
  d.root_height = std::round((0.035 - p0.pos[6].z()) * 1e6) / 1e6;

  // Nominal standing pose (rad): legs from unitree_rl_gym's G1 default_joint_angles (hip
  // pitch −0.1, knee 0.3, ankle pitch −0.2: the feet stay flat, the trunk upright); arms ours
  // (estimated): shoulder roll ±0.15 to clear the thighs, elbow 0.6 (hands forward-down).
  d.nominal_q = zero;
  for (int side = 0; side < 2; ++side) {
    d.nominal_q[6 * side + 0] = -0.1;
    d.nominal_q[6 * side + 3] = 0.3;
    d.nominal_q[6 * side + 4] = -0.2;
    d.nominal_q[15 + 7 * side + 1] = side == 0 ? 0.15 : -0.15;
    d.nominal_q[15 + 7 * side + 3] = 0.6;
  }
  const LinkPoses pn = forward_kinematics(d, Vec3::Zero(), Quat::Identity(), d.nominal_q);
  d.nominal_root_height = std::round((0.035 - pn.pos[6].z()) * 1e6) / 1e6;
  d.validate();
  return d;
}

}  // namespace detail

/// The published PD gains (kp N·m/rad, kd N·m·s/rad) of joint j (Unitree motor order). Legs:
/// unitree_rl_gym's G1 config (hip 100 / 2, knee 150 / 4, ankle 40 / 2); waist and arms:
/// unitree_sdk2's G1 low-level examples (waist yaw 60, roll/pitch 40, arms 40, all kd 1)
/// (figures recalled). Those gains serve feedback policies at 50 Hz; held open-loop the robot
/// topples with them, hence the stiffer legs and waist of g1_description().
inline std::pair<double, double> published_gains(int j) {
  require(j >= 0 && j < kNumJoints, "G1 published_gains: no such joint", {{}, {}, "joint"});
  if (j < 12) {
    constexpr double kp[6] = {100, 100, 100, 150, 40, 40}, kd[6] = {2, 2, 2, 4, 2, 2};
    return {kp[j % 6], kd[j % 6]};
  }
  if (j == 12) return {60, 1};
  return {40, 1};
}

/// The G1-like robot (built once, immutable).
inline const G1Description& g1_description() {
  static const G1Description d = detail::make_g1_description();
  return d;
}

/// The G1 with the published PD gains instead of the stiffened legs and waist (for policies
/// that balance actively; it does not stand open-loop).
inline G1Description g1_description_published_gains() {
  G1Description d = g1_description();
  for (int j = 0; j < kNumJoints; ++j) {
    Link& l = d.links[static_cast<std::size_t>(j + 1)];
    std::tie(l.kp, l.kd) = published_gains(j);
  }
  return d;
}

}  // namespace maskadapt::g1
