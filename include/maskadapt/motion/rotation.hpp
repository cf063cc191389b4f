#pragma once
/// \file rotation.hpp
/// Quaternion helpers for motion data: continuous 3-hinge angles, slerp, log/exp, finite-difference
/// angular velocity, yaw. Euler angles are never differenced or interpolated directly.
#include <maskadapt/core/types.hpp>
#include <maskadapt/motion/skeleton.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace maskadapt {

/// Wraps an angle to (−π, π].
inline double wrap_angle(double a) {
  // (−π, π] already: what std::remainder returns there (the nearest multiple of 2π is 0), without its cost
  if (a > -std::numbers::pi && a <= std::numbers::pi) return a;
  a = std::remainder(a, 2.0 * std::numbers::pi);
  return a <= -std::numbers::pi ? a + 2.0 * std::numbers::pi : a;
}

/// Angle of a rotation vector: log map, |result| ≤ π (rad, axis·angle).
inline Vec3 quat_log(const Quat& q_in) {
  Quat q = q_in.normalized();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  const double s = q.vec().norm();
  if (s < 1e-12) return 2.0 * q.vec();
  return (2.0 * std::atan2(s, q.w()) / s) * q.vec();
}

/// Exponential map of a rotation vector (rad).
inline Quat quat_exp(const Vec3& v) {
  const double a = v.norm();
  if (a < 1e-12) return Quat(1.0, 0.5 * v.x(), 0.5 * v.y(), 0.5 * v.z()).normalized();
  return Quat(Eigen::AngleAxisd(a, v / a));
}

/// Shortest-path slerp from a (u = 0) to b (u = 1).
inline Quat slerp(const Quat& a, const Quat& b, double u) { return a.slerp(u, b).normalized(); }

/// World angular velocity that turns `from` into `to` in `dt` seconds: log(to·from⁻¹)/dt (rad/s).
inline Vec3 angular_velocity(const Quat& from, const Quat& to, double dt) {
  return quat_log(to * from.conjugate()) / dt;
}

/// Yaw about world z of a rotation's x (forward) axis (rad, (−π, π]).
inline double yaw_of(const Quat& q) {
  const Vec3 x = q * Vec3::UnitX();
  return std::atan2(x.y(), x.x());
}

/// 3-hinge angles (x, y, z) with R_x·R_y·R_z = q that are nearest to `hint` (e.g. the previous
/// frame), choosing between the two Euler solutions and their 2π-shifts; then, if `lower`/`upper`
/// are given, clamped to the limits. Keeps angle sequences continuous (a knee bent past 90° stays
/// a pure y rotation instead of flipping x and z by π).
inline Vec3 joint_angles_near(const Quat& q, const Vec3& hint) {
  const Vec3 a = joint_angles_from_rotation(q);
  // second solution: (a + π, π − b, c + π)
  const Vec3 b(a.x() + std::numbers::pi, std::numbers::pi - a.y(), a.z() + std::numbers::pi);
  auto nearest = [&](Vec3 s) {
    for (int k = 0; k < 3; ++k) s[k] = hint[k] + wrap_angle(s[k] - hint[k]);
    return s;
  };
  const Vec3 sa = nearest(a), sb = nearest(b);
  return (sa - hint).squaredNorm() <= (sb - hint).squaredNorm() ? sa : sb;
}

/// As joint_angles_near, preferring the solution that violates the limits least, then clamping.
inline Vec3 joint_angles_within(const Quat& q, const Vec3& hint, const Vec3& lower, const Vec3& upper,
                                double* violation = nullptr) {
  const Vec3 a = joint_angles_from_rotation(q);
  const Vec3 b(a.x() + std::numbers::pi, std::numbers::pi - a.y(), a.z() + std::numbers::pi);
  Vec3 best = Vec3::Zero();
  double best_cost = 1e300, best_viol = 0;
  for (const Vec3& s0 : {a, b}) {
    Vec3 s;
    for (int k = 0; k < 3; ++k) {
      // the 2π-shift of this angle that is inside the limits or nearest to them / to the hint
      const double centre = std::clamp(hint[k], lower[k], upper[k]);
      s[k] = centre + wrap_angle(s0[k] - centre);
    }
    const Vec3 excess = (s - s.cwiseMax(lower).cwiseMin(upper)).cwiseAbs();
    const double viol = excess.sum();
    const double cost = 10.0 * viol + (s - hint).squaredNorm() * 1e-3;
    if (cost < best_cost) {
      best_cost = cost;
      best = s;
      best_viol = excess.maxCoeff();
    }
  }
  if (violation) *violation = best_viol;
  return best.cwiseMax(lower).cwiseMin(upper);
}

}  // namespace maskadapt
