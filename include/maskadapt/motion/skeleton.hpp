#pragma once
/// \file skeleton.hpp
/// The kinematic model shared by the motion code, the features and every simulator.
///
/// A `Skeleton` is a tree of rigid bodies. Body 0 is the root (6-DoF free joint); every other
/// body hangs from its parent through a 3-DoF joint made of three hinges about the body's own
/// local x, y and z axes, applied in that order (exactly how MuJoCo composes the three hinges
/// declared x, y, z inside one <body>):
///
///   R_world(i) = R_world(parent) · R_x(q[3k]) · R_y(q[3k+1]) · R_z(q[3k+2]),   k = i − 1
///   p_world(i) = p_world(parent) + R_world(parent) · offset(i)
///
/// so the generalised coordinates are (root position, root quaternion, q ∈ R^{3·(nb−1)}).
/// Units: metres, radians, seconds; world z-up.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/mask/parts.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace maskadapt {

struct Skeleton {
  std::vector<std::string> names;  ///< (num_bodies) body names; names[0] is the root
  std::vector<int> parents;        ///< (num_bodies) parent index, −1 for the root; parents[i] < i
  Matrix3X offsets;                ///< (3 × num_bodies) joint position in the parent frame at q = 0 (m)
  std::vector<BodyPart> parts;     ///< (num_bodies) body-part group of each body
  Matrix3X joint_lower;            ///< (3 × num_bodies) hinge lower limits (rad); column 0 unused
  Matrix3X joint_upper;            ///< (3 × num_bodies) hinge upper limits (rad); column 0 unused

  int num_bodies() const { return static_cast<int>(names.size()); }
  /// Actuated DoF: three hinges per non-root body.
  int num_dofs() const { return 3 * (num_bodies() - 1); }
  /// First DoF index of body i's joint (i ≥ 1).
  static int dof_offset(int body) { return 3 * (body - 1); }

  /// Index of a body by name; throws Error naming the body if absent.
  int index_of(const std::string& name) const {
    for (int i = 0; i < num_bodies(); ++i)
      if (names[i] == name) return i;
    throw Error("no body named '" + name + "' in the skeleton", {{}, {}, "body"});
  }

  /// Checks sizes, topological order and limits; throws on the first inconsistency.
  void validate() const {
    const auto nb = static_cast<Index>(names.size());
    require(nb >= 1, "skeleton has no bodies", {{}, {}, "names"});
    require(static_cast<Index>(parents.size()) == nb, "parents has the wrong size", {{}, {}, "parents"});
    require(offsets.cols() == nb, "offsets has the wrong size", {{}, {}, "offsets"});
    require(static_cast<Index>(parts.size()) == nb, "parts has the wrong size", {{}, {}, "parts"});
    require(joint_lower.cols() == nb && joint_upper.cols() == nb, "joint limits have the wrong size",
            {{}, {}, "joint_lower"});
    require(parents[0] == -1, "body 0 must be the root (parent −1)", {{}, {}, "parents"});
    for (Index i = 1; i < nb; ++i) {
      require(parents[i] >= 0 && parents[i] < i, "parent of '" + names[i] + "' must precede it",
              {{}, {}, "parents"});
      require((joint_lower.col(i).array() <= joint_upper.col(i).array()).all(),
              "joint limits of '" + names[i] + "' have lower > upper", {{}, {}, "joint_lower"});
    }
    require(offsets.allFinite(), "offsets contain non-finite values", {{}, {}, "offsets"});
  }
};

/// Generalised position + velocity of a skeleton (what a simulator is reset to).
struct KinematicState {
  Vec3 root_pos = Vec3::Zero();      ///< world position of the root (m)
  Quat root_rot = Quat::Identity();  ///< world orientation of the root
  VectorXd q;                        ///< (num_dofs) joint angles (rad)
  Vec3 root_lin_vel = Vec3::Zero();  ///< world linear velocity of the root (m/s)
  Vec3 root_ang_vel = Vec3::Zero();  ///< world angular velocity of the root (rad/s)
  VectorXd qd;                       ///< (num_dofs) joint angle rates (rad/s)

  static KinematicState zero(const Skeleton& skel) {
    KinematicState s;
    s.q = VectorXd::Zero(skel.num_dofs());
    s.qd = VectorXd::Zero(skel.num_dofs());
    return s;
  }
};

/// Canonical rigid-body states of every body, all in the world frame.
/// This is what a Simulator reports and what every feature is computed from.
struct BodyStates {
  Matrix3X pos;            ///< (3 × num_bodies) body origin positions (m)
  std::vector<Quat> rot;   ///< (num_bodies) body orientations
  Matrix3X lin_vel;        ///< (3 × num_bodies) linear velocity of each body origin (m/s)
  Matrix3X ang_vel;        ///< (3 × num_bodies) angular velocity (rad/s)

  void resize(int num_bodies) {
    pos.setZero(3, num_bodies);
    rot.assign(num_bodies, Quat::Identity());
    lin_vel.setZero(3, num_bodies);
    ang_vel.setZero(3, num_bodies);
  }
  int num_bodies() const { return static_cast<int>(pos.cols()); }
};

/// Rotation of a 3-hinge joint: R_x(a.x) · R_y(a.y) · R_z(a.z).
inline Quat joint_rotation(const Eigen::Ref<const Vec3>& a) {
  return Quat(Eigen::AngleAxisd(a.x(), Vec3::UnitX())) * Quat(Eigen::AngleAxisd(a.y(), Vec3::UnitY())) *
         Quat(Eigen::AngleAxisd(a.z(), Vec3::UnitZ()));
}

/// Inverse of joint_rotation: angles (x, y, z) with R = R_x·R_y·R_z, y ∈ [−π/2, π/2].
inline Vec3 joint_angles_from_rotation(const Quat& q) {
  const Mat3 R = q.normalized().toRotationMatrix();
  // R = Rx(a)Ry(b)Rz(c):  R(0,2) = sin b,  R(1,2) = −sin a cos b,  R(2,2) = cos a cos b,
  //                       R(0,0) = cos b cos c,  R(0,1) = −cos b sin c.
  const double sb = std::clamp(R(0, 2), -1.0, 1.0);
  const double b = std::asin(sb);
  double a, c;
  if (std::abs(sb) < 1.0 - 1e-12) {
    a = std::atan2(-R(1, 2), R(2, 2));
    c = std::atan2(-R(0, 1), R(0, 0));
  } else {  // gimbal lock: put everything into a
    a = std::atan2(R(2, 1), R(1, 1));
    c = 0.0;
  }
  return {a, b, c};
}

/// Forward kinematics: world positions, orientations and velocities of every body.
/// `out` is resized as needed (no allocation when it already has the right size).
inline void forward_kinematics(const Skeleton& skel, const KinematicState& s, BodyStates& out) {
  const int nb = skel.num_bodies();
  require(s.q.size() == skel.num_dofs(), "joint angle vector has the wrong size", {{}, {}, "q"});
  const bool with_vel = s.qd.size() == skel.num_dofs();
  if (out.num_bodies() != nb || static_cast<int>(out.rot.size()) != nb) out.resize(nb);
  out.pos.col(0) = s.root_pos;
  out.rot[0] = s.root_rot.normalized();
  out.lin_vel.col(0) = s.root_lin_vel;
  out.ang_vel.col(0) = s.root_ang_vel;
  for (int i = 1; i < nb; ++i) {
    const int p = skel.parents[i];
    const int k = Skeleton::dof_offset(i);
    const Quat& Rp = out.rot[p];
    out.pos.col(i) = out.pos.col(p) + Rp * skel.offsets.col(i);
    const Quat rx(Eigen::AngleAxisd(s.q[k], Vec3::UnitX()));
    const Quat ry(Eigen::AngleAxisd(s.q[k + 1], Vec3::UnitY()));
    const Quat rz(Eigen::AngleAxisd(s.q[k + 2], Vec3::UnitZ()));
    const Quat r_x = Rp * rx, r_xy = r_x * ry;
    out.rot[i] = r_xy * rz;
    if (with_vel) {
      out.lin_vel.col(i) = out.lin_vel.col(p) + out.ang_vel.col(p).cross(out.pos.col(i) - out.pos.col(p));
      out.ang_vel.col(i) = out.ang_vel.col(p) + s.qd[k] * (Rp * Vec3::UnitX()) +
                           s.qd[k + 1] * (r_x * Vec3::UnitY()) + s.qd[k + 2] * (r_xy * Vec3::UnitZ());
    } else {
      out.lin_vel.col(i).setZero();
      out.ang_vel.col(i).setZero();
    }
  }
}

inline BodyStates forward_kinematics(const Skeleton& skel, const KinematicState& s) {
  BodyStates out;
  forward_kinematics(skel, s, out);
  return out;
}

}  // namespace maskadapt
