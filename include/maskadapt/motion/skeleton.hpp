#pragma once
/// \file skeleton.hpp
/// The kinematic model shared by the motion code, the features and every simulator.
///
/// A `Skeleton` is a tree of rigid bodies. Body 0 is the root (6-DoF free joint); every other
/// body hangs from its parent through one to three hinges with unit axes given in the body's own
/// frame, applied in their order (exactly how MuJoCo composes several hinges declared inside
/// one <body>). With body i's hinges k = dof_offset(i) … dof_offset(i) + n_i − 1:
///
///   R_world(i) = R_world(parent) · R(axis_k, q[k]) · R(axis_{k+1}, q[k+1]) · …
///   p_world(i) = p_world(parent) + R_world(parent) · offset(i)
///
/// so the generalised coordinates are (root position, root quaternion, q ∈ R^{num_dofs}), the
/// hinges numbered body by body in body order. The reference humanoid gives every non-root body
/// three hinges about its local x, y, z (`add_xyz_hinges`; joint_rotation below is that joint's
/// rotation); the G1 robot one hinge per link about an arbitrary axis (g1/skeleton.hpp).
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

  int num_bodies() const { return static_cast<int>(names.size()); }
  /// Actuated DoF: the total number of hinges.
  int num_dofs() const { return static_cast<int>(dof_body_.size()); }
  /// First DoF index of body i's joint (precomputed; num_dofs() for a body without hinges).
  int dof_offset(int body) const {
    return body >= 0 && body < static_cast<int>(first_dof_.size()) ? first_dof_[static_cast<std::size_t>(body)]
                                                                     : num_dofs();
  }
  /// Number of hinges of body i's joint (0 for the root).
  int num_dofs_of(int body) const {
    return body >= 0 && body + 1 < static_cast<int>(first_dof_.size())
               ? first_dof_[static_cast<std::size_t>(body) + 1] - first_dof_[static_cast<std::size_t>(body)]
               : 0;
  }
  /// Body whose joint hinge k belongs to.
  int dof_body(int k) const { return dof_body_[static_cast<std::size_t>(k)]; }
  /// Unit axis of hinge k in its body's frame.
  auto dof_axis(int k) const { return dof_axes_.col(k); }
  double dof_lower(int k) const { return lower_[k]; }  ///< lower limit of hinge k (rad)
  double dof_upper(int k) const { return upper_[k]; }  ///< upper limit of hinge k (rad)
  const Matrix3X& dof_axes() const { return dof_axes_; }     ///< (3 × num_dofs) hinge axes
  const VectorXd& lower_limits() const { return lower_; }    ///< (num_dofs) lower limits (rad)
  const VectorXd& upper_limits() const { return upper_; }    ///< (num_dofs) upper limits (rad)

  /// Appends a hinge to `body`'s joint (after the ones it has). Bodies get their hinges in body
  /// order: a hinge for body i may not follow one for a body after i.
  void add_hinge(int body, const Vec3& axis, double lower, double upper) {
    require(body >= 1, "hinge for body " + std::to_string(body) + ": only non-root bodies have hinges",
            {{}, {}, "dof_body"});
    if (!dof_body_.empty() && body < dof_body_.back())
      throw Error("hinge for body " + std::to_string(body) + " added after one for body " +
                      std::to_string(dof_body_.back()) + ": hinges go in body order",
                  {{}, {}, "dof_body"});
    const int n = num_dofs();
    if (first_dof_.empty()) first_dof_.push_back(0);  // the root has none
    while (static_cast<int>(first_dof_.size()) <= body + 1) first_dof_.push_back(n);
    first_dof_[static_cast<std::size_t>(body) + 1] = n + 1;
    dof_axes_.conservativeResize(3, n + 1);
    dof_axes_.col(n) = axis;
    lower_.conservativeResize(n + 1);
    upper_.conservativeResize(n + 1);
    lower_[n] = lower;
    upper_[n] = upper;
    dof_body_.push_back(body);
  }
  /// Appends the humanoid's joint: three hinges about the body's x, y, z with limits (rad).
  void add_xyz_hinges(int body, const Vec3& lower, const Vec3& upper) {
    for (int a = 0; a < 3; ++a) add_hinge(body, Vec3::Unit(a), lower[a], upper[a]);
  }
  /// Replaces every hinge by x, y, z hinges on each non-root body; `lower`/`upper` are
  /// (3 × num_bodies), column 0 unused (rad).
  void set_xyz_hinges(const Matrix3X& lower, const Matrix3X& upper) {
    require(lower.cols() == num_bodies() && upper.cols() == num_bodies(), "joint limits need one column per body",
            {{}, {}, "dof_lower"});
    clear_hinges();
    for (int i = 1; i < num_bodies(); ++i) add_xyz_hinges(i, lower.col(i), upper.col(i));
  }
  void clear_hinges() {
    dof_axes_.resize(3, 0);
    lower_.resize(0);
    upper_.resize(0);
    dof_body_.clear();
    first_dof_.clear();
  }

  /// Whether body i's joint is the humanoid's: exactly three hinges about x, y, z, in that order.
  bool has_xyz_hinges(int body) const {
    if (num_dofs_of(body) != 3) return false;
    const int k = dof_offset(body);
    for (int a = 0; a < 3; ++a)
      if (dof_axes_.col(k + a) != Vec3::Unit(a)) return false;
    return true;
  }
  /// Throws unless body i has x, y, z hinges; `who` names the caller that needs them.
  void require_xyz_hinges(int body, const std::string& who) const {
    require(has_xyz_hinges(body),
            who + " needs three hinges about x, y, z on body '" +
                (body >= 0 && body < num_bodies() ? names[static_cast<std::size_t>(body)] : std::to_string(body)) +
                "', which has " + std::to_string(num_dofs_of(body)) + " hinge(s) of other axes",
            {{}, {}, "dof_axes"});
  }
  /// Throws unless every non-root body has x, y, z hinges (the humanoid's layout).
  void require_xyz_layout(const std::string& who) const {
    for (int i = 1; i < num_bodies(); ++i) require_xyz_hinges(i, who);
  }
  /// Whether every non-root body has x, y, z hinges.
  bool has_xyz_layout() const {
    for (int i = 1; i < num_bodies(); ++i)
      if (!has_xyz_hinges(i)) return false;
    return true;
  }

  /// Index of a body by name; throws Error naming the body if absent.
  int index_of(const std::string& name) const {
    for (int i = 0; i < num_bodies(); ++i)
      if (names[i] == name) return i;
    throw Error("no body named '" + name + "' in the skeleton", {{}, {}, "body"});
  }

  /// Checks sizes, topological order, hinges and limits; throws on the first inconsistency.
  void validate() const {
    const auto nb = static_cast<Index>(names.size());
    require(nb >= 1, "skeleton has no bodies", {{}, {}, "names"});
    require(static_cast<Index>(parents.size()) == nb, "parents has the wrong size", {{}, {}, "parents"});
    require(offsets.cols() == nb, "offsets has the wrong size", {{}, {}, "offsets"});
    require(static_cast<Index>(parts.size()) == nb, "parts has the wrong size", {{}, {}, "parts"});
    require(parents[0] == -1, "body 0 must be the root (parent −1)", {{}, {}, "parents"});
    if (num_dofs() > 0 && dof_body_.back() >= nb)
      throw Error("hinge " + std::to_string(num_dofs() - 1) + " belongs to body " + std::to_string(dof_body_.back()) +
                      ", beyond the " + std::to_string(nb) + " bodies",
                  {{}, {}, "dof_body"});
    for (Index i = 1; i < nb; ++i) {
      require(parents[i] >= 0 && parents[i] < i, "parent of '" + names[i] + "' must precede it",
              {{}, {}, "parents"});
      const int n = num_dofs_of(static_cast<int>(i));
      require(n >= 1 && n <= 3,
              "body '" + names[i] + "' has " + std::to_string(n) + " hinges; every non-root body needs 1 to 3",
              {{}, {}, "dof_body"});
      for (int k = dof_offset(static_cast<int>(i)); k < dof_offset(static_cast<int>(i)) + n; ++k) {
        require(dof_axes_.col(k).allFinite() && std::abs(dof_axes_.col(k).norm() - 1.0) < 1e-9,
                "hinge " + std::to_string(k) + " of '" + names[i] + "' needs a unit axis", {{}, {}, "dof_axes"});
        require(lower_[k] <= upper_[k], "joint limits of '" + names[i] + "' (hinge " + std::to_string(k) +
                                            ") have lower > upper", {{}, {}, "dof_lower"});
      }
    }
    require(offsets.allFinite(), "offsets contain non-finite values", {{}, {}, "offsets"});
  }

 private:
  Matrix3X dof_axes_;             // (3 × num_dofs) unit hinge axes, each in its body's frame
  VectorXd lower_, upper_;        // (num_dofs) hinge limits (rad)
  std::vector<int> dof_body_;     // (num_dofs) owning body, non-decreasing, ≥ 1
  std::vector<int> first_dof_;    // (last hinged body + 2) first DoF of each body; last entry = num_dofs
};

/// Part of every action DoF, (num_dofs): the part of the body the hinge moves (the residual's
/// masked DoFs, adapt/residual_policy.hpp).
inline std::vector<BodyPart> action_parts(const Skeleton& skel) {
  std::vector<BodyPart> parts(static_cast<std::size_t>(skel.num_dofs()));
  for (int k = 0; k < skel.num_dofs(); ++k) parts[static_cast<std::size_t>(k)] = skel.parts[static_cast<std::size_t>(skel.dof_body(k))];
  return parts;
}

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

/// Rotation of an x-y-z joint (the humanoid's, Skeleton::has_xyz_hinges): R_x(a.x) · R_y(a.y) · R_z(a.z).
inline Quat joint_rotation(const Eigen::Ref<const Vec3>& a) {
  return Quat(Eigen::AngleAxisd(a.x(), Vec3::UnitX())) * Quat(Eigen::AngleAxisd(a.y(), Vec3::UnitY())) *
         Quat(Eigen::AngleAxisd(a.z(), Vec3::UnitZ()));
}

/// Inverse of joint_rotation for an x-y-z joint: angles (x, y, z) with R = R_x·R_y·R_z, y ∈ [−π/2, π/2].
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

/// Rotation of body i's joint (i ≥ 1) in its parent's frame: the product of its hinge
/// rotations, from the full joint-angle vector q (num_dofs, rad).
inline Quat joint_rotation(const Skeleton& skel, int body, const Eigen::Ref<const VectorXd>& q) {
  const int k0 = skel.dof_offset(body), k1 = k0 + skel.num_dofs_of(body);
  if (k1 == k0) return Quat::Identity();
  Quat r(Eigen::AngleAxisd(q[k0], skel.dof_axis(k0)));  // (for x-y-z joints: bit for bit joint_rotation(a))
  for (int k = k0 + 1; k < k1; ++k) r = r * Quat(Eigen::AngleAxisd(q[k], skel.dof_axis(k)));
  return r;
}

/// Forward kinematics: world positions, orientations and velocities of every body.
/// `out` is resized as needed (no allocation when it already has the right size).
/// Hinge k of body i turns about R_world(parent) · R(hinges before k) · axis_k, so
/// ω_i = ω_parent + Σ_k q̇_k · (that world axis), v_i = v_parent + ω_parent × (p_i − p_parent).
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
    const int k0 = skel.dof_offset(i), k1 = k0 + skel.num_dofs_of(i);
    const Quat& Rp = out.rot[p];
    out.pos.col(i) = out.pos.col(p) + Rp * skel.offsets.col(i);
    Quat r = Rp;  // parent rotation times the hinges applied so far
    if (with_vel) {
      out.lin_vel.col(i) = out.lin_vel.col(p) + out.ang_vel.col(p).cross(out.pos.col(i) - out.pos.col(p));
      Vec3 w = out.ang_vel.col(p);
      for (int k = k0; k < k1; ++k) {
        const Vec3 axis = skel.dof_axis(k);
        w += s.qd[k] * (r * axis);
        r = r * Quat(Eigen::AngleAxisd(s.q[k], axis));
      }
      out.ang_vel.col(i) = w;
    } else {
      for (int k = k0; k < k1; ++k) r = r * Quat(Eigen::AngleAxisd(s.q[k], skel.dof_axis(k)));
      out.lin_vel.col(i).setZero();
      out.ang_vel.col(i).setZero();
    }
    out.rot[i] = r;
  }
}

inline BodyStates forward_kinematics(const Skeleton& skel, const KinematicState& s) {
  BodyStates out;
  forward_kinematics(skel, s, out);
  return out;
}

}  // namespace maskadapt
