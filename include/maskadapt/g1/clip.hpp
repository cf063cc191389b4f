#pragma once
/// \file clip.hpp
/// A motion of the G1-like robot (`G1Clip`: root pose and 29 joint angles per frame) and its
/// `.npz` file format. g1/retarget.hpp makes these from humanoid clips.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/g1/description.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/npz.hpp>

#include <cmath>
#include <optional>
#include <string>

namespace maskadapt::g1 {

/// A motion of the G1: root pose and 29 joint angles per frame (frames are columns).
///
/// File format (`.npz`, like MotionClip's): format "maskadapt.g1clip.v1", name, description,
/// fps (), loop (), root_pos (T, 3) m, root_rot (T, 4) quaternion x y z w, q (T, 29) rad in
/// Unitree's motor order (joint j = hinge of link j + 1).
struct G1Clip {
  std::string name;
  std::string description;
  double fps = 30.0;
  bool loop = false;
  Matrix3X root_pos;                                  ///< (3 × T) pelvis position (m), world z-up
  Eigen::Matrix<double, 4, Eigen::Dynamic> root_rot;  ///< (4 × T) pelvis quaternion (x, y, z, w)
  MatrixXd q;                                         ///< (29 × T) joint angles (rad)

  int num_frames() const { return static_cast<int>(q.cols()); }
  double dt() const { return 1.0 / fps; }
  double duration() const { return num_frames() > 0 ? (num_frames() - 1) / fps : 0.0; }
  void resize(int frames) {
    root_pos.setZero(3, frames);
    root_rot.setZero(4, frames);
    root_rot.row(3).setOnes();
    q.setZero(kNumJoints, frames);
  }
  Quat rot(int t) const { return Quat(root_rot(3, t), root_rot(0, t), root_rot(1, t), root_rot(2, t)); }
  void set_rot(int t, const Quat& r) { root_rot.col(t) = r.normalized().coeffs(); }
  /// Link poses of frame t.
  LinkPoses poses(const G1Description& d, int t) const {
    require(t >= 0 && t < num_frames(), "G1 clip frame index out of range", {{}, {}, name});
    return forward_kinematics(d, root_pos.col(t), rot(t), q.col(t));
  }
  /// Sizes, finiteness, unit quaternions (joint limits are a quality figure, not checked here).
  void validate(const std::string& file = {}) const {
    require(fps > 0 && std::isfinite(fps), "fps must be positive", {file, std::nullopt, "fps"});
    require(num_frames() >= 1, "G1 clip has no frames", {file, std::nullopt, "q"});
    require(q.rows() == kNumJoints, "G1 clip needs 29 joint angles per frame, has " + std::to_string(q.rows()),
            {file, std::nullopt, "q"});
    require(root_pos.cols() == num_frames() && root_rot.cols() == num_frames(),
            "root arrays and q have different frame counts", {file, std::nullopt, "root_pos"});
    require_finite(root_pos, "root_pos", file);
    require_finite(root_rot, "root_rot", file);
    require_finite(q, "q", file);
    for (int t = 0; t < num_frames(); ++t)
      require(std::abs(root_rot.col(t).norm() - 1.0) < 1e-3,
              "root quaternion of frame " + std::to_string(t) + " is not unit length", {file, std::nullopt, "root_rot"});
  }
};

inline npz::Archive g1_clip_to_archive(const G1Clip& c) {
  npz::Archive a;
  a["format"] = npz::text("maskadapt.g1clip.v1");
  a["name"] = npz::text(c.name);
  a["description"] = npz::text(c.description);
  a["fps"] = npz::scalar(c.fps);
  a["loop"] = npz::scalar(c.loop ? 1.0 : 0.0);
  a["root_pos"] = npz::matrix(c.root_pos.transpose());
  a["root_rot"] = npz::matrix(c.root_rot.transpose());
  a["q"] = npz::matrix(c.q.transpose());
  return a;
}

inline G1Clip g1_clip_from_archive(const npz::Archive& a, const std::string& file = {}) {
  const auto& fmt = npz::member(a, "format", file);
  require(!fmt.numeric && fmt.text == "maskadapt.g1clip.v1",
          "not a G1 clip (format '" + fmt.text + "', expected 'maskadapt.g1clip.v1')", {file, std::nullopt, "format"});
  G1Clip c;
  auto text_of = [&](const char* k) {
    auto it = a.find(k);
    return it != a.end() && !it->second.numeric ? it->second.text : std::string();
  };
  c.name = text_of("name");
  c.description = text_of("description");
  c.fps = npz::as_scalar(npz::member(a, "fps", file), "fps", file);
  c.loop = npz::as_scalar(npz::member(a, "loop", file), "loop", file) != 0.0;
  const MatrixXd rp = npz::as_matrix(npz::member(a, "root_pos", file), "root_pos", file);
  const MatrixXd rr = npz::as_matrix(npz::member(a, "root_rot", file), "root_rot", file);
  const MatrixXd q = npz::as_matrix(npz::member(a, "q", file), "q", file);
  require(rp.cols() == 3, "expected shape (frames, 3)", {file, std::nullopt, "root_pos"});
  require(rr.cols() == 4, "expected shape (frames, 4)", {file, std::nullopt, "root_rot"});
  require(q.cols() == kNumJoints, "expected shape (frames, 29)", {file, std::nullopt, "q"});
  require(rp.rows() == q.rows() && rr.rows() == q.rows(), "members have different frame counts",
          {file, std::nullopt, "q"});
  c.root_pos = rp.transpose();
  c.root_rot = rr.transpose();
  c.q = q.transpose();
  c.validate(file);
  return c;
}

inline void save_g1_clip(const std::string& path, const G1Clip& c) { npz::write(path, g1_clip_to_archive(c)); }
inline G1Clip load_g1_clip(const std::string& path) { return g1_clip_from_archive(npz::read(path), path); }

/// Whether `path` is a G1 clip file (an .npz whose `format` is maskadapt.g1clip.v1); false for
/// any other file, readable or not.
inline bool is_g1_clip_archive(const npz::Archive& a) {
  const auto it = a.find("format");
  return it != a.end() && !it->second.numeric && it->second.text == "maskadapt.g1clip.v1";
}
inline bool is_g1_clip_file(const std::string& path) {
  try {
    return is_g1_clip_archive(npz::read(path));
  } catch (const Error&) {
    return false;
  }
}

/// The same motion as a `MotionClip` on `g1_skeleton()` (g1/skeleton.hpp: DoF k is joint k), so
/// that `MotionLibrary`, AMP windows and the trainers take it like any other clip.
inline MotionClip to_motion_clip(const G1Clip& c) {
  c.validate(c.name);
  MotionClip m;
  m.name = c.name;
  m.description = c.description;
  m.fps = c.fps;
  m.loop = c.loop;
  m.root_pos = c.root_pos;
  m.root_rot = c.root_rot;
  m.q = c.q;
  return m;
}

}  // namespace maskadapt::g1
