#pragma once
/// \file observation.hpp
/// The state feature s of any skeleton, observation_dim(skel) = 1 + 3·(nb−1) + 6·nb + 3·nb + 3·nb
/// (R^328 for the reference 22-body humanoid, humanoid/observation.hpp), all in the root's heading frame.
///
/// Heading frame: origin below the root, rotated by the root's yaw h about world z, where
/// h = atan2(R₀·x̂ |y, R₀·x̂ |x) is the direction of the root's forward (x) axis projected on the
/// ground. Let H = R_z(h). Layout of s (element ranges, body i = 0..nb−1):
///
///   [0]                      root height p₀.z (m, world)
///   [1 + 3(i−1), +3)         Hᵀ (p_i − p₀), non-root bodies i = 1..nb−1 (m)
///   [o_rot + 6i, +6)         rotation of body i in the heading frame, 6-D form: the first two
///                            columns of Hᵀ R_i (its x and y axes), column 0 first
///   [o_lin + 3i, +3)         Hᵀ v_i, linear velocity of body i's origin (m/s)
///   [o_ang + 3i, +3)         Hᵀ ω_i, angular velocity (rad/s)
///
/// with o_rot = 3·nb − 2, o_lin = o_rot + 6·nb, o_ang = o_lin + 3·nb. Every element belongs to
/// the part of the body it describes; the root height belongs to the root's part (Trunk).
/// Features are invariant to the root's heading and horizontal position by construction.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/motion/skeleton.hpp>

#include <cmath>
#include <vector>

namespace maskadapt {

/// Observation size for any skeleton with nb bodies: 1 + 3(nb−1) + 12·nb.
inline Index observation_dim(const Skeleton& skel) {
  const Index nb = skel.num_bodies();
  return 1 + 3 * (nb - 1) + 12 * nb;
}

/// Offsets of the blocks of s (see the file comment).
struct ObservationLayout {
  Index root_height = 0;
  Index rel_pos = 1;   ///< 3·(nb−1)
  Index rot6d = 0;     ///< 6·nb
  Index lin_vel = 0;   ///< 3·nb
  Index ang_vel = 0;   ///< 3·nb
  Index dim = 0;
  static ObservationLayout of(const Skeleton& skel) {
    const Index nb = skel.num_bodies();
    ObservationLayout l;
    l.rot6d = 1 + 3 * (nb - 1);
    l.lin_vel = l.rot6d + 6 * nb;
    l.ang_vel = l.lin_vel + 3 * nb;
    l.dim = l.ang_vel + 3 * nb;
    return l;
  }
};

/// Yaw of a rotation: the angle of its x axis projected on the ground plane (rad, (−π, π]).
inline double heading_angle(const Quat& q) {
  const Vec3 x = q * Vec3::UnitX();
  return std::atan2(x.y(), x.x());
}

/// The heading rotation H = R_z(heading_angle(q)).
inline Quat heading_rotation(const Quat& q) {
  return Quat(Eigen::AngleAxisd(heading_angle(q), Vec3::UnitZ()));
}

/// Writes s (observation_dim(skel)) for one set of body states into `out`.
/// Throws Error on a size mismatch; non-finite body states are reported too (never propagated).
template <class Scalar>
void compute_observation(const Skeleton& skel, const BodyStates& b,
                         Eigen::Ref<Eigen::Matrix<Scalar, Eigen::Dynamic, 1>> out) {
  const int nb = skel.num_bodies();
  const ObservationLayout L = ObservationLayout::of(skel);
  require(b.num_bodies() == nb && static_cast<int>(b.rot.size()) == nb && b.lin_vel.cols() == nb &&
              b.ang_vel.cols() == nb,
          "body states have " + std::to_string(b.num_bodies()) + " bodies, the skeleton " + std::to_string(nb),
          {{}, {}, "body_states"});
  require(out.size() == L.dim,
          "observation output has " + std::to_string(out.size()) + " rows, expected " + std::to_string(L.dim),
          {{}, {}, "observation"});
  require_finite(b.pos, "body_states.pos");
  require_finite(b.lin_vel, "body_states.lin_vel");
  require_finite(b.ang_vel, "body_states.ang_vel");

  const Mat3 Ht = heading_rotation(b.rot[0]).toRotationMatrix().transpose();
  const Vec3 p0 = b.pos.col(0);
  out[L.root_height] = static_cast<Scalar>(p0.z());
  for (int i = 1; i < nb; ++i)
    out.template segment<3>(L.rel_pos + 3 * (i - 1)) = (Ht * (b.pos.col(i) - p0)).template cast<Scalar>();
  for (int i = 0; i < nb; ++i) {
    const Mat3 R = Ht * b.rot[i].normalized().toRotationMatrix();
    out.template segment<3>(L.rot6d + 6 * i) = R.col(0).template cast<Scalar>();
    out.template segment<3>(L.rot6d + 6 * i + 3) = R.col(1).template cast<Scalar>();
    out.template segment<3>(L.lin_vel + 3 * i) = (Ht * b.lin_vel.col(i)).template cast<Scalar>();
    out.template segment<3>(L.ang_vel + 3 * i) = (Ht * b.ang_vel.col(i)).template cast<Scalar>();
  }
}

/// Float overload with the canonical signature (out: 328 rows for the reference humanoid).
inline void compute_observation(const Skeleton& skel, const BodyStates& b, Eigen::Ref<Eigen::VectorXf> out) {
  compute_observation<float>(skel, b, out);
}

/// Convenience: returns s as a new vector.
inline VectorXf compute_observation(const Skeleton& skel, const BodyStates& b) {
  VectorXf s(observation_dim(skel));
  compute_observation<float>(skel, b, s);
  return s;
}

/// Part of every element of s, (observation_dim(skel)): the part of the body it describes;
/// the root height belongs to the root's part.
inline std::vector<BodyPart> observation_parts(const Skeleton& skel) {
  const int nb = skel.num_bodies();
  const ObservationLayout L = ObservationLayout::of(skel);
  std::vector<BodyPart> parts(static_cast<std::size_t>(L.dim));
  auto fill = [&](Index start, Index count, BodyPart p) {
    for (Index k = 0; k < count; ++k) parts[static_cast<std::size_t>(start + k)] = p;
  };
  fill(L.root_height, 1, skel.parts[0]);
  for (int i = 1; i < nb; ++i) fill(L.rel_pos + 3 * (i - 1), 3, skel.parts[i]);
  for (int i = 0; i < nb; ++i) {
    fill(L.rot6d + 6 * i, 6, skel.parts[i]);
    fill(L.lin_vel + 3 * i, 3, skel.parts[i]);
    fill(L.ang_vel + 3 * i, 3, skel.parts[i]);
  }
  return parts;
}

}  // namespace maskadapt
