#pragma once
/// \file clip.hpp
/// `MotionClip`: a motion in the humanoid's skeleton, stored as contiguous arrays (frames are
/// columns), and its save/load in the library's own format (.npz, see below).
///
/// Looping clips: the last frame is the first frame of the next cycle (same pose, root moved by
/// one cycle), so a looping clip's period is duration() = (num_frames − 1) / fps.
///
/// File format (`.npz`, stored members; NumPy's np.load reads it):
///   format       text  "maskadapt.clip.v1"
///   name         text
///   labels       text  one label per line ("walk forward\nwalk")
///   description  text
///   fps          ()    frames per second
///   loop         ()    0 or 1
///   root_pos     (T, 3)         metres, world z-up
///   root_rot     (T, 4)         quaternion x, y, z, w
///   q            (T, num_dofs)  3-hinge joint angles (rad)
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/motion/npz.hpp>
#include <maskadapt/motion/rotation.hpp>
#include <maskadapt/motion/skeleton.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace maskadapt {

struct MotionClip {
  std::string name;                 ///< short identifier, e.g. "cmu_02_01_walk"
  std::vector<std::string> labels;  ///< text labels, e.g. {"walk forward", "walk"}
  std::string description;          ///< free text (source, licence, notes)
  double fps = 30.0;                ///< frames per second
  bool loop = false;                ///< cyclic clip (see file comment)
  Matrix3X root_pos;                ///< (3 × T) root position (m)
  Eigen::Matrix<double, 4, Eigen::Dynamic> root_rot;  ///< (4 × T) root quaternion coefficients (x, y, z, w)
  MatrixXd q;                       ///< (num_dofs × T) joint angles (rad)

  int num_frames() const { return static_cast<int>(q.cols()); }
  int num_dofs() const { return static_cast<int>(q.rows()); }
  double dt() const { return 1.0 / fps; }
  /// Time of the last frame (s); the period of a looping clip.
  double duration() const { return num_frames() > 0 ? (num_frames() - 1) / fps : 0.0; }

  /// Allocates T frames for a skeleton with `num_dofs` DoF (identity roots, zero angles).
  void resize(int num_frames, int num_dofs) {
    root_pos.setZero(3, num_frames);
    root_rot.setZero(4, num_frames);
    root_rot.row(3).setOnes();
    q.setZero(num_dofs, num_frames);
  }
  Quat rot(int t) const { return Quat(root_rot(3, t), root_rot(0, t), root_rot(1, t), root_rot(2, t)); }
  void set_rot(int t, const Quat& r) { root_rot.col(t) = r.normalized().coeffs(); }

  /// Pose of frame t (velocities zero; MotionLibrary supplies velocities).
  KinematicState frame(int t) const {
    require(t >= 0 && t < num_frames(), "frame index out of range", {{}, {}, name});
    KinematicState s;
    s.root_pos = root_pos.col(t);
    s.root_rot = rot(t);
    s.q = q.col(t);
    s.qd = VectorXd::Zero(q.rows());
    return s;
  }
  void set_frame(int t, const KinematicState& s) {
    root_pos.col(t) = s.root_pos;
    set_rot(t, s.root_rot);
    q.col(t) = s.q;
  }

  /// Checks sizes against a skeleton, finiteness and unit quaternions; throws naming the field.
  void validate(const Skeleton& skel, const std::string& file = {}) const {
    require(fps > 0 && std::isfinite(fps), "fps must be positive", {file, std::nullopt, "fps"});
    require(num_frames() >= 1, "clip has no frames", {file, std::nullopt, "q"});
    require(q.rows() == skel.num_dofs(),
            "clip has " + std::to_string(q.rows()) + " DoF, the skeleton " + std::to_string(skel.num_dofs()),
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

/// Frames [first, first + count) of a clip as a new clip.
inline MotionClip slice(const MotionClip& c, int first, int count) {
  require(first >= 0 && count >= 1 && first + count <= c.num_frames(), "slice out of range", {{}, {}, c.name});
  MotionClip out = c;
  out.root_pos = c.root_pos.middleCols(first, count);
  out.root_rot = c.root_rot.middleCols(first, count);
  out.q = c.q.middleCols(first, count);
  return out;
}

/// The frames of a clip from time `from_s` to `to_s` (seconds from its first frame, both
/// inclusive, each rounded to the nearest frame) as a new, non-looping clip — e.g. the kick out of
/// a clip that stands, steps, kicks and stands again. to_s < 0 means the last frame. Throws naming
/// `from_field` / `to_field` when from_s is negative or past the end, or the range holds fewer
/// than 2 frames.
inline MotionClip slice_seconds(const MotionClip& c, double from_s, double to_s, const std::string& from_field = "from",
                                const std::string& to_field = "to") {
  const double end = c.duration();
  require(std::isfinite(from_s) && from_s >= 0 && from_s <= end,
          "start " + std::to_string(from_s) + " s is not within the clip (0 to " + std::to_string(end) + " s)",
          {{}, std::nullopt, from_field});
  if (to_s < 0) to_s = end;
  require(std::isfinite(to_s) && to_s <= end + 0.5 / c.fps,
          "end " + std::to_string(to_s) + " s is past the clip's last frame (" + std::to_string(end) + " s)",
          {{}, std::nullopt, to_field});
  const int first = static_cast<int>(std::lround(from_s * c.fps));
  const int last = std::min(c.num_frames() - 1, static_cast<int>(std::lround(to_s * c.fps)));
  require(last - first + 1 >= 2,
          "the range " + std::to_string(from_s) + "–" + std::to_string(to_s) + " s holds fewer than 2 frames",
          {{}, std::nullopt, to_field});
  MotionClip out = slice(c, first, last - first + 1);
  out.loop = false;
  return out;
}

/// The clip as an npz archive (see file comment).
inline npz::Archive clip_to_archive(const MotionClip& c) {
  npz::Archive a;
  a["format"] = npz::text("maskadapt.clip.v1");
  a["name"] = npz::text(c.name);
  std::string labels;
  for (std::size_t i = 0; i < c.labels.size(); ++i) labels += (i ? "\n" : "") + c.labels[i];
  a["labels"] = npz::text(labels);
  a["description"] = npz::text(c.description);
  a["fps"] = npz::scalar(c.fps);
  a["loop"] = npz::scalar(c.loop ? 1.0 : 0.0);
  a["root_pos"] = npz::matrix(c.root_pos.transpose());
  a["root_rot"] = npz::matrix(c.root_rot.transpose());
  a["q"] = npz::matrix(c.q.transpose());
  return a;
}

/// Reads a clip from an archive written by clip_to_archive; checks every member.
inline MotionClip clip_from_archive(const npz::Archive& a, const std::string& file = {}) {
  const auto& fmt = npz::member(a, "format", file);
  require(!fmt.numeric && fmt.text == "maskadapt.clip.v1",
          "not a maskadapt clip (format '" + fmt.text + "', expected 'maskadapt.clip.v1')", {file, std::nullopt, "format"});
  MotionClip c;
  auto text_of = [&](const char* k) {
    auto it = a.find(k);
    return it != a.end() && !it->second.numeric ? it->second.text : std::string();
  };
  c.name = text_of("name");
  c.description = text_of("description");
  const std::string labels = text_of("labels");
  std::size_t s = 0;
  while (s < labels.size()) {
    std::size_t e = labels.find('\n', s);
    if (e == std::string::npos) e = labels.size();
    if (e > s) c.labels.push_back(labels.substr(s, e - s));
    s = e + 1;
  }
  c.fps = npz::as_scalar(npz::member(a, "fps", file), "fps", file);
  c.loop = npz::as_scalar(npz::member(a, "loop", file), "loop", file) != 0.0;
  const MatrixXd rp = npz::as_matrix(npz::member(a, "root_pos", file), "root_pos", file);
  const MatrixXd rr = npz::as_matrix(npz::member(a, "root_rot", file), "root_rot", file);
  const MatrixXd q = npz::as_matrix(npz::member(a, "q", file), "q", file);
  require(rp.cols() == 3, "expected shape (frames, 3)", {file, std::nullopt, "root_pos"});
  require(rr.cols() == 4, "expected shape (frames, 4)", {file, std::nullopt, "root_rot"});
  require(rp.rows() == q.rows() && rr.rows() == q.rows(), "members have different frame counts",
          {file, std::nullopt, "q"});
  c.root_pos = rp.transpose();
  c.root_rot = rr.transpose();
  c.q = q.transpose();
  require(c.fps > 0 && std::isfinite(c.fps), "fps must be positive", {file, std::nullopt, "fps"});
  require(c.num_frames() >= 1, "clip has no frames", {file, std::nullopt, "q"});
  require_finite(c.root_pos, "root_pos", file);
  require_finite(c.root_rot, "root_rot", file);
  require_finite(c.q, "q", file);
  for (int t = 0; t < c.num_frames(); ++t)
    require(std::abs(c.root_rot.col(t).norm() - 1.0) < 1e-3, "non-unit quaternion in frame " + std::to_string(t),
            {file, std::nullopt, "root_rot"});
  return c;
}

inline void save_clip(const std::string& path, const MotionClip& c) { npz::write(path, clip_to_archive(c)); }
inline MotionClip load_clip(const std::string& path) { return clip_from_archive(npz::read(path), path); }

}  // namespace maskadapt
