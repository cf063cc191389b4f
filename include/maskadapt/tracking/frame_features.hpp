#pragma once
/// \file frame_features.hpp
/// The per-frame representation the motion VAE works in, for one motion primitive canonicalised
/// to its first frame (see generator.hpp: root of frame 0 above the origin, heading 0, z-up).
///
/// Layout of one frame's feature vector (dim = 13 + 9·(nb − 1), 202 for the 22-body humanoid):
///
///   [0, 3)             root position p₀ in the canonical frame (m)
///   [3, 9)             root orientation, 6-D form (first two columns of R₀, column 0 first)
///   [9, 12)            root delta p₀(i) − p₀(i−1) in the canonical frame (m; zero for frame 0
///                      of the window)
///   [12]               heading delta h(i) − h(i−1) wrapped to (−π, π] (rad; zero for frame 0)
///   [13 + 6(k−1), +6)  local rotation of joint k = 1..nb−1 (R_x R_y R_z of its 3 hinges), 6-D
///   [13 + 6(nb−1) + 3(k−1), +3)  position of body k = 1..nb−1 in the canonical frame (m)
///
/// Decoding uses the root position, root 6-D and joint 6-D blocks (Gram–Schmidt back to rotations,
/// joint rotations back to the 3 hinge angles); body positions are then recomputed by FK so a
/// decoded trajectory is always self-consistent. The position and delta blocks are redundant
/// training signals that make the networks learn the kinematics.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/motion/rotation.hpp>
#include <maskadapt/motion/skeleton.hpp>
#include <maskadapt/tracking/generator.hpp>

#include <cmath>
#include <numbers>

namespace maskadapt::tracking {

/// 6-D rotation form: the first two columns of R (x axis then y axis).
inline Eigen::Matrix<double, 6, 1> rotation_to_6d(const Quat& q) {
  const Mat3 R = q.normalized().toRotationMatrix();
  Eigen::Matrix<double, 6, 1> v;
  v << R.col(0), R.col(1);
  return v;
}

/// Inverse of rotation_to_6d for any (non-degenerate) 6-vector: Gram–Schmidt (Zhou et al. 2019).
inline Quat rotation_from_6d(const Eigen::Ref<const Eigen::Matrix<double, 6, 1>>& v) {
  Vec3 a = v.head<3>(), b = v.tail<3>();
  const double na = a.norm();
  if (!(na > 1e-9)) a = Vec3::UnitX(); else a /= na;
  b -= a.dot(b) * a;
  const double nb = b.norm();
  if (!(nb > 1e-9)) b = a.unitOrthogonal(); else b /= nb;
  Mat3 R;
  R.col(0) = a;
  R.col(1) = b;
  R.col(2) = a.cross(b);
  return Quat(R).normalized();
}

/// Offsets of the feature blocks for a skeleton.
struct FrameLayout {
  Index root_pos = 0, root_rot = 3, root_delta = 9, yaw_delta = 12, joint_rot = 13, body_pos = 0, dim = 0;
  int num_bodies = 0;
  static FrameLayout of(const Skeleton& skel) {
    FrameLayout l;
    l.num_bodies = skel.num_bodies();
    const Index nj = skel.num_bodies() - 1;
    l.body_pos = l.joint_rot + 6 * nj;
    l.dim = l.body_pos + 3 * nj;
    return l;
  }
};

inline Index frame_feature_dim(const Skeleton& skel) { return FrameLayout::of(skel).dim; }

/// Features (dim × N) of a trajectory already expressed in its canonical frame; `body_pos` must
/// be filled (see compute_body_positions).
template <class T = float>
MatrixX<T> encode_frames(const Skeleton& skel, const Trajectory& t) {
  const FrameLayout L = FrameLayout::of(skel);
  const Index N = t.num_frames();
  require(t.q.rows() == skel.num_dofs() && t.q.cols() == N, "trajectory q does not match the skeleton", {{}, {}, "q"});
  require(t.body_pos.rows() == 3 * skel.num_bodies() && t.body_pos.cols() == N,
          "trajectory body_pos is missing or has the wrong shape", {{}, {}, "body_pos"});
  MatrixX<T> f(L.dim, N);
  for (Index i = 0; i < N; ++i) {
    const auto iu = static_cast<std::size_t>(i);
    f.template block<3, 1>(L.root_pos, i) = t.root_pos.col(i).cast<T>();
    f.template block<6, 1>(L.root_rot, i) = rotation_to_6d(t.root_rot[iu]).cast<T>();
    if (i == 0) {
      f.template block<4, 1>(L.root_delta, i).setZero();
    } else {
      f.template block<3, 1>(L.root_delta, i) = (t.root_pos.col(i) - t.root_pos.col(i - 1)).cast<T>();
      f(L.yaw_delta, i) = static_cast<T>(wrap_angle(heading_angle(t.root_rot[iu]) - heading_angle(t.root_rot[iu - 1])));
    }
    for (int k = 1; k < L.num_bodies; ++k) {
      f.template block<6, 1>(L.joint_rot + 6 * (k - 1), i) = rotation_to_6d(joint_rotation(skel, k, t.q.col(i))).cast<T>();
      f.template block<3, 1>(L.body_pos + 3 * (k - 1), i) = t.body_pos.block<3, 1>(3 * k, i).cast<T>();
    }
  }
  require_finite(f, "frame_features");
  return f;
}

/// Trajectory (canonical frame) from features (dim × N); see the file comment.
template <class T>
Trajectory decode_frames(const Skeleton& skel, const Eigen::Ref<const MatrixX<T>>& f, double fps = 30.0) {
  const FrameLayout L = FrameLayout::of(skel);
  require(f.rows() == L.dim, "frame features have " + std::to_string(f.rows()) + " rows, expected " +
                                 std::to_string(L.dim), {{}, {}, "frame_features"});
  require_finite(f, "frame_features");
  skel.require_xyz_layout("decode_frames (joint angles from rotations)");
  const Index N = f.cols();
  Trajectory t = Trajectory::zeros(skel, N, fps);
  for (Index i = 0; i < N; ++i) {
    const Eigen::VectorXd c = f.col(i).template cast<double>();
    t.root_pos.col(i) = c.segment<3>(L.root_pos);
    t.root_rot[static_cast<std::size_t>(i)] = rotation_from_6d(c.segment<6>(L.root_rot));
    for (int k = 1; k < L.num_bodies; ++k)
      t.q.block<3, 1>(skel.dof_offset(k), i) =
          joint_angles_from_rotation(rotation_from_6d(c.segment<6>(L.joint_rot + 6 * (k - 1))));
  }
  compute_body_positions(skel, t);
  return t;
}

}  // namespace maskadapt::tracking
