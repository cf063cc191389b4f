#pragma once
/// \file description.hpp
/// The bundled reference humanoid, described once: kinematic tree, body parts, joint limits,
/// collision geoms, masses, PD gains and simulation settings. The MuJoCo model
/// (humanoid/mjcf.hpp, assets/humanoid.xml) is generated from this description, so the library's
/// own kinematics and the simulator cannot disagree.
///
/// Frames (see docs/humanoid.md):
///  - world z-up; at the zero pose the character faces +x, its left is +y (a T-pose, arms along
///    ±y, palms down) and every body frame is aligned with the world frame;
///  - 22 bodies in SMPL joint order (AMASS joints 0..21 map 1:1). A body is named after the
///    joint it hangs from: "L_Hip" is the left thigh, "L_Knee" the left shank, "L_Ankle" the
///    foot, "L_Toe" the toes, "L_Shoulder" the upper arm, "L_Wrist" the hand;
///  - each non-root joint is three hinges about the body's local x (roll, forward axis),
///    y (pitch, left axis) and z (yaw, up axis), applied x then y then z (see skeleton.hpp);
///  - body offsets are the SMPL neutral model's mean-shape joint locations, converted from
///    SMPL's (x left, y up, z forward) to ours and made left/right symmetric.
#include <maskadapt/core/types.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/motion/geom.hpp>
#include <maskadapt/motion/skeleton.hpp>

#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace maskadapt {

inline constexpr int kHumanoidNumBodies = 22;
inline constexpr int kHumanoidNumDofs = 63;  ///< 21 joints × 3 hinges

/// Body indices of the reference humanoid (SMPL joint order).
namespace hb {
enum : int {
  Pelvis = 0, LHip, RHip, Torso, LKnee, RKnee, Spine, LAnkle, RAnkle, Chest, LToe, RToe,
  Neck, LThorax, RThorax, Head, LShoulder, RShoulder, LElbow, RElbow, LWrist, RWrist
};
}  // namespace hb

inline constexpr std::array<std::string_view, kHumanoidNumBodies> kHumanoidBodyNames = {
    "Pelvis", "L_Hip",   "R_Hip",      "Torso",      "L_Knee",  "R_Knee",  "Spine",   "L_Ankle",
    "R_Ankle", "Chest",  "L_Toe",      "R_Toe",      "Neck",    "L_Thorax", "R_Thorax", "Head",
    "L_Shoulder", "R_Shoulder", "L_Elbow", "R_Elbow", "L_Wrist", "R_Wrist"};

/// Per-body physical properties and PD gains of the joint the body hangs from.
struct BodyDescription {
  std::vector<Geom> geoms;
  double kp = 0.0;        ///< PD stiffness of each of the 3 hinges (N·m/rad); 0 for the root
  double kd = 0.0;        ///< PD damping (N·m·s/rad), simulated as joint damping
  double armature = 0.0;  ///< rotor inertia added to each hinge (kg·m²)
  double mass() const {
    double m = 0;
    for (const auto& g : geoms) m += g.mass;
    return m;
  }
};

/// MuJoCo solver/integrator options of the simulated humanoid (MJCF `<option>` and contact
/// parameters). The defaults are MuJoCo 2.2.2's own except where docs/humanoid.md says why.
struct PhysicsOptions {
  enum class Integrator { Euler, Implicit };  ///< RK4 blows up with these gains (docs/humanoid.md)
  enum class Solver { PGS, CG, Newton };
  enum class Cone { Pyramidal, Elliptic };
  enum class Jacobian { Dense, Sparse, Auto };  ///< Auto: dense if nv < 60 (ours: nv = 69 → sparse)
  Integrator integrator = Integrator::Euler;
  Solver solver = Solver::Newton;
  int iterations = 100;     ///< maximum main-solver iterations
  double tolerance = 1e-8;  ///< main-solver tolerance (relative cost improvement)
  Cone cone = Cone::Pyramidal;
  Jacobian jacobian = Jacobian::Auto;
  /// Contact `solref` (time constant s, damping ratio) of the floor and all body geoms. MuJoCo
  /// clamps the time constant to ≥ 2 × physics_dt unless refsafe is disabled.
  double contact_timeconst = 0.02;
  double contact_dampratio = 1.0;
};

/// Everything needed to build the simulated humanoid.
struct HumanoidDescription {
  Skeleton skeleton;                    ///< kinematics, parts and joint limits (rad)
  std::vector<BodyDescription> bodies;  ///< (num_bodies) geoms, masses, gains
  double root_height = 0.0;             ///< pelvis height (m) that puts the zero pose's soles on z = 0
  double physics_dt = 1.0 / 60.0;       ///< physics time step (s), semi-implicit Euler (the paper's rate)
  int substeps = 2;                     ///< physics steps per control step (30 Hz control)
  double friction = 1.0;                ///< sliding friction between geoms and the floor
  int nconmax = 100;                    ///< MuJoCo contact buffer (per mjData)
  int njmax = 500;                      ///< MuJoCo constraint rows (memory grows with its square)
  PhysicsOptions physics;               ///< solver, integrator, cone, Jacobian, contact solref

  double control_dt() const { return physics_dt * substeps; }
  /// The bodies that carry the feet, {L_Ankle, L_Toe, R_Ankle, R_Toe} (motion/quality.hpp's
  /// contacts and skating; `CharacterGeometry`).
  std::array<int, 4> foot_bodies() const { return {hb::LAnkle, hb::LToe, hb::RAnkle, hb::RToe}; }
  double total_mass() const {
    double m = 0;
    for (const auto& b : bodies) m += b.mass();
    return m;
  }
  /// PD stiffness of every DoF, (num_dofs).
  VectorXd dof_kp() const {
    VectorXd k(skeleton.num_dofs());
    for (int i = 1; i < skeleton.num_bodies(); ++i) k.segment(skeleton.dof_offset(i), skeleton.num_dofs_of(i)).setConstant(bodies[i].kp);
    return k;
  }
  /// PD damping of every DoF, (num_dofs).
  VectorXd dof_kd() const {
    VectorXd k(skeleton.num_dofs());
    for (int i = 1; i < skeleton.num_bodies(); ++i) k.segment(skeleton.dof_offset(i), skeleton.num_dofs_of(i)).setConstant(bodies[i].kd);
    return k;
  }
};

/// The reference humanoid's fall criteria (sim/termination.hpp): the bodies that may touch the
/// ground without a fall — feet, toes, hands — and the head whose height is checked. The
/// imitation task's default and the humanoid's MuJoCo character both read them from here.
inline std::vector<std::string> humanoid_ground_contacts() { return {"L_Ankle", "R_Ankle", "L_Toe", "R_Toe", "L_Wrist", "R_Wrist"}; }
inline std::string humanoid_head() { return "Head"; }
/// The bodies that strike (tasks/strike.hpp): the hands.
inline std::vector<std::string> humanoid_hands() { return {"L_Wrist", "R_Wrist"}; }

namespace detail {

/// Absolute joint positions of the zero pose relative to the pelvis joint, metres, our frame
/// (x forward, y left, z up). From the SMPL neutral mean shape (rounded to mm, symmetrised).
inline Vec3 humanoid_joint_position(int body) {
  switch (body) {
    case hb::Pelvis:    return {0.000, 0.000, 0.000};
    case hb::LHip:      return {-0.005, 0.069, -0.094};
    case hb::RHip:      return {-0.005, -0.069, -0.094};
    case hb::Torso:     return {-0.027, 0.000, 0.114};
    case hb::LKnee:     return {-0.010, 0.104, -0.480};
    case hb::RKnee:     return {-0.010, -0.104, -0.480};
    case hb::Spine:     return {0.003, 0.000, 0.249};
    case hb::LAnkle:    return {-0.050, 0.090, -0.867};
    case hb::RAnkle:    return {-0.050, -0.090, -0.867};
    case hb::Chest:     return {0.007, 0.000, 0.302};
    case hb::LToe:      return {0.081, 0.119, -0.925};
    case hb::RToe:      return {0.081, -0.119, -0.925};
    case hb::Neck:      return {-0.045, 0.000, 0.512};
    case hb::LThorax:   return {-0.036, 0.077, 0.414};
    case hb::RThorax:   return {-0.036, -0.077, 0.414};
    case hb::Head:      return {0.005, 0.000, 0.611};
    case hb::LShoulder: return {-0.045, 0.195, 0.462};
    case hb::RShoulder: return {-0.045, -0.195, 0.462};
    case hb::LElbow:    return {-0.070, 0.453, 0.446};
    case hb::RElbow:    return {-0.070, -0.453, 0.446};
    case hb::LWrist:    return {-0.075, 0.720, 0.459};
    case hb::RWrist:    return {-0.075, -0.720, 0.459};
    default: throw Error("no such humanoid body", {{}, {}, "body"});
  }
}

/// Rounds to whole micrometres, so that derived figures print as short decimals in the MJCF.
inline Vec3 round_um(const Vec3& v) { return (v * 1e6).array().round().matrix() / 1e6; }

inline Geom capsule(Vec3 from, Vec3 to, double radius, double mass) {
  return {Geom::Type::Capsule, round_um(from), round_um(to), radius, mass};
}
inline Geom box(Vec3 centre, Vec3 half, double mass) { return {Geom::Type::Box, centre, half, 0.0, mass}; }
inline Geom sphere(Vec3 centre, double radius, double mass) {
  return {Geom::Type::Sphere, centre, Vec3::Zero(), radius, mass};
}

inline HumanoidDescription make_humanoid_description() {
  HumanoidDescription d;
  Skeleton& s = d.skeleton;
  constexpr int nb = kHumanoidNumBodies;
  s.names.assign(kHumanoidBodyNames.begin(), kHumanoidBodyNames.end());
  s.parents = {-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19};
  s.offsets.setZero(3, nb);
  for (int i = 1; i < nb; ++i)
    s.offsets.col(i) = round_um(humanoid_joint_position(i) - humanoid_joint_position(s.parents[i]));

  using P = BodyPart;
  s.parts = {P::Trunk,   P::LeftLeg,  P::RightLeg, P::Trunk,   P::LeftLeg, P::RightLeg, P::Trunk,   P::LeftLeg,
             P::RightLeg, P::Trunk,   P::LeftLeg,  P::RightLeg, P::Trunk,   P::LeftArm,  P::RightArm, P::Trunk,
             P::LeftArm, P::RightArm, P::LeftArm,  P::RightArm, P::LeftArm, P::RightArm};

  // Joint limits (rad), hinges (x roll, y pitch, z yaw) in the body frame. Sign conventions at
  // the zero pose: +y pitch swings a limb that points down backwards (hip extension, knee
  // flexion) and bends the spine forward; +x roll lifts the left arm / abducts the left leg.
  Matrix3X lower = Matrix3X::Zero(3, nb), upper = Matrix3X::Zero(3, nb);  // (3 × num_bodies), column 0 unused
  auto lim = [&](int b, Vec3 lo, Vec3 hi) {
    lower.col(b) = lo;
    upper.col(b) = hi;
  };
  lim(hb::LHip, {-0.6, -2.2, -1.0}, {1.3, 0.7, 1.0});
  lim(hb::RHip, {-1.3, -2.2, -1.0}, {0.6, 0.7, 1.0});
  for (int b : {hb::LKnee, hb::RKnee}) lim(b, {-0.3, 0.0, -0.4}, {0.3, 2.7, 0.4});
  for (int b : {hb::LAnkle, hb::RAnkle}) lim(b, {-0.6, -0.9, -0.7}, {0.6, 0.9, 0.7});
  for (int b : {hb::LToe, hb::RToe}) lim(b, {-0.4, -1.0, -0.4}, {0.4, 0.7, 0.4});
  for (int b : {hb::Torso, hb::Spine, hb::Chest}) lim(b, {-0.7, -0.7, -0.7}, {0.7, 1.1, 0.7});
  lim(hb::Neck, {-0.7, -0.9, -1.2}, {0.7, 1.0, 1.2});
  lim(hb::Head, {-0.6, -0.7, -0.9}, {0.6, 0.8, 0.9});
  for (int b : {hb::LThorax, hb::RThorax}) lim(b, {-0.6, -0.6, -0.7}, {0.6, 0.6, 0.7});
  lim(hb::LShoulder, {-1.8, -1.7, -2.5}, {1.8, 1.7, 1.2});
  lim(hb::RShoulder, {-1.8, -1.7, -1.2}, {1.8, 1.7, 2.5});
  lim(hb::LElbow, {-0.4, -1.8, -2.8}, {0.4, 1.8, 0.1});
  lim(hb::RElbow, {-0.4, -1.8, -0.1}, {0.4, 1.8, 2.8});
  for (int b : {hb::LWrist, hb::RWrist}) lim(b, {-0.9, -1.2, -1.2}, {0.9, 1.2, 1.2});
  s.set_xyz_hinges(lower, upper);
  s.validate();

  // Geoms and masses (kg; segment fractions after de Leva 1996 for a ~68 kg adult).
  d.bodies.resize(nb);
  auto off = [&](int child) { return Vec3(s.offsets.col(child)); };
  using detail::box, detail::capsule, detail::sphere;
  auto& B = d.bodies;
  B[hb::Pelvis].geoms = {capsule({-0.010, -0.070, -0.035}, {-0.010, 0.070, -0.035}, 0.095, 9.0)};
  B[hb::Torso].geoms = {capsule({0.005, -0.065, 0.065}, {0.005, 0.065, 0.065}, 0.085, 6.0)};
  B[hb::Spine].geoms = {capsule({0.010, -0.070, 0.030}, {0.010, 0.070, 0.030}, 0.090, 6.0)};
  B[hb::Chest].geoms = {capsule({-0.020, -0.085, 0.090}, {-0.020, 0.085, 0.090}, 0.100, 9.5)};
  B[hb::Neck].geoms = {capsule(Vec3::Zero(), 0.8 * off(hb::Head), 0.045, 1.0)};
  B[hb::Head].geoms = {sphere({0.015, 0.0, 0.095}, 0.100, 4.5)};
  for (int side = 0; side < 2; ++side) {
    const double sy = side == 0 ? 1.0 : -1.0;
    const int hip = side == 0 ? hb::LHip : hb::RHip, knee = side == 0 ? hb::LKnee : hb::RKnee;
    const int ankle = side == 0 ? hb::LAnkle : hb::RAnkle, toe = side == 0 ? hb::LToe : hb::RToe;
    const int thorax = side == 0 ? hb::LThorax : hb::RThorax, shoulder = side == 0 ? hb::LShoulder : hb::RShoulder;
    const int elbow = side == 0 ? hb::LElbow : hb::RElbow, wrist = side == 0 ? hb::LWrist : hb::RWrist;
    B[hip].geoms = {capsule(0.05 * off(knee), 0.92 * off(knee), 0.060, 7.3)};
    B[knee].geoms = {capsule(0.05 * off(ankle), 0.85 * off(ankle), 0.048, 3.2)};
    // Foot: sole at the ankle height of 0.078 m below the ankle joint (see root_height).
    B[ankle].geoms = {box({0.040, sy * 0.012, -0.048}, {0.090, 0.045, 0.030}, 0.9)};
    B[toe].geoms = {box({0.025, 0.0, -0.0105}, {0.025, 0.045, 0.0095}, 0.2)};
    B[thorax].geoms = {capsule(0.2 * off(shoulder), 0.85 * off(shoulder), 0.050, 1.5)};
    B[shoulder].geoms = {capsule(0.08 * off(elbow), 0.92 * off(elbow), 0.045, 1.9)};
    B[elbow].geoms = {capsule(0.06 * off(wrist), 0.94 * off(wrist), 0.040, 1.2)};
    B[wrist].geoms = {box({0.0, sy * 0.085, 0.0}, {0.045, 0.085, 0.020}, 0.5)};
  }

  // PD gains (N·m/rad); kd = kp / 10 placed in joint damping (docs/humanoid.md explains why).
  auto gains = [&](int b, double kp, double armature) {
    B[b].kp = kp;
    B[b].kd = kp / 10.0;
    B[b].armature = armature;
  };
  // Armature (kg·m²) 0.08 legs/spine, 0.04 arms/neck/head/toes: what 1/60 s physics needs to
  // stand and survive random targets, with a 2× margin (0.02/0.01 topples at 1/60 s, 0.04/0.02
  // stands but failed 9 times in 10k random-target steps, 0.06/0.03 and 0.08/0.04 never did;
  // docs/humanoid.md). Every joint is overdamped (kd/kp = 0.1 s sets its response), so the
  // added rotor inertia leaves PD tracking no worse (test PdTrackingNoWorseThanThe120HzSettings).
  for (int b : {hb::LHip, hb::RHip, hb::LKnee, hb::RKnee, hb::Torso, hb::Spine, hb::Chest}) gains(b, 500, 0.08);
  for (int b : {hb::LAnkle, hb::RAnkle}) gains(b, 800, 0.08);
  for (int b : {hb::LThorax, hb::RThorax, hb::LShoulder, hb::RShoulder}) gains(b, 300, 0.04);
  for (int b : {hb::LElbow, hb::RElbow}) gains(b, 200, 0.04);
  for (int b : {hb::LWrist, hb::RWrist, hb::Neck, hb::Head, hb::LToe, hb::RToe}) gains(b, 100, 0.04);

  // Soles: ankle joint at z = −0.867 below the pelvis, sole 0.078 m lower.
  d.root_height = 0.867 + 0.078;
  return d;
}

}  // namespace detail

/// The reference humanoid (built once, immutable).
inline const HumanoidDescription& humanoid_description() {
  static const HumanoidDescription d = detail::make_humanoid_description();
  return d;
}

/// The reference humanoid with the physics settings used before issue 13: 1/120 s × 4 substeps,
/// armature 0.02 (legs/spine) / 0.01 (arms, neck, head, toes); same bodies, gains, solver.
/// For comparisons (benchmarks/sim, tests/sim) and for running policies trained before the
/// change on the dynamics they were trained on: `MujocoHumanoidSim sim(n, t, legacy_humanoid_description_120hz())`.
inline HumanoidDescription legacy_humanoid_description_120hz() {
  HumanoidDescription d = humanoid_description();
  d.physics_dt = 1.0 / 120.0;
  d.substeps = 4;
  for (auto& b : d.bodies) b.armature /= 4.0;  // 0.08 → 0.02, 0.04 → 0.01 (exact: powers of two)
  d.physics = PhysicsOptions{};
  return d;
}

/// The reference humanoid's skeleton: 22 bodies in SMPL order, 63 DoF.
inline const Skeleton& humanoid_skeleton() { return humanoid_description().skeleton; }

/// The zero (T-) pose standing on the floor: soles at z = 0, facing +x, at rest.
inline KinematicState humanoid_standing_pose() {
  KinematicState s = KinematicState::zero(humanoid_skeleton());
  s.root_pos = Vec3(0, 0, humanoid_description().root_height);
  return s;
}

}  // namespace maskadapt
