#pragma once
/// \file quality.hpp
/// Plausibility report of a clip on a character (any `CharacterGeometry`, e.g. the reference
/// humanoid's description): foot skating, ground penetration, joint-limit violations and
/// kinematic self-collision.
///
/// Definitions (all from kinematics; the clip's frames are the samples):
///  - a foot body (ankle or toe) is *in contact* in a frame when its lowest point is below
///    `contact_height` (2.5 cm); its *skating speed* is the horizontal speed of that body's origin
///    between consecutive frames where it is in contact in both; `foot_skating` is the mean of
///    those speeds (m/s), `foot_skating_max` the largest;
///  - *penetration*: how far the lowest point of the body (all geoms) is below z = 0 (m),
///    reported as the mean over frames and the maximum;
///  - *joint-limit violations*: fraction of (frame, DoF) outside the limits, and the largest
///    excess (rad);
///  - *self-collision*: every geom as a capsule (geometry.hpp); a frame self-collides when two
///    capsules of bodies that are not within two joints of each other in the tree, and that do
///    not already overlap in the zero pose, interpenetrate by more than `collision_depth` (1 cm).
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/geometry.hpp>

#include <cstdio>
#include <string>
#include <vector>

namespace maskadapt {

struct QualityOptions {
  double contact_height = 0.025;   ///< m
  double collision_depth = 0.01;   ///< m
};

struct QualityReport {
  int frames = 0;
  double duration = 0;               ///< s
  double foot_skating = 0;           ///< mean horizontal foot speed in contact (m/s)
  double foot_skating_max = 0;       ///< m/s
  double contact_fraction = 0;       ///< fraction of (frame, foot body) in contact
  double penetration_mean = 0;       ///< m
  double penetration_max = 0;        ///< m
  double limit_violation_fraction = 0;
  double limit_violation_max = 0;    ///< rad
  double self_collision_fraction = 0;
  double root_height_mean = 0;       ///< m
  double root_height_min = 0, root_height_max = 0;
  double travel = 0;                 ///< horizontal root displacement first → last frame (m)

  std::string to_string() const {
    char buf[1024];
    std::snprintf(buf, sizeof(buf),
                  "frames %d, duration %.2f s, root height %.3f m (%.3f..%.3f), travel %.2f m\n"
                  "foot skating %.3f m/s mean, %.3f m/s max (feet in contact %.0f%% of frames)\n"
                  "ground penetration %.1f mm mean, %.1f mm max\n"
                  "joint-limit violations %.2f%% of DoF-frames, max %.3f rad\n"
                  "self-collision in %.1f%% of frames",
                  frames, duration, root_height_mean, root_height_min, root_height_max, travel, foot_skating,
                  foot_skating_max, 100.0 * contact_fraction, 1000.0 * penetration_mean, 1000.0 * penetration_max,
                  100.0 * limit_violation_fraction, limit_violation_max, 100.0 * self_collision_fraction);
    return buf;
  }
};

namespace detail {
/// Pairs of capsules to test for self-collision (see file comment).
template <CharacterGeometry D>
std::vector<std::pair<int, int>> collision_pairs(const D& d) {
  const Skeleton& s = d.skeleton;
  const int nb = s.num_bodies();
  auto depth = [&](int b) {
    int k = 0;
    while (s.parents[b] >= 0) b = s.parents[b], ++k;
    return k;
  };
  auto tree_distance = [&](int a, int b) {
    int da = depth(a), db = depth(b), n = 0;
    while (da > db) a = s.parents[a], --da, ++n;
    while (db > da) b = s.parents[b], --db, ++n;
    while (a != b) a = s.parents[a], b = s.parents[b], n += 2;
    return n;
  };
  std::vector<geometry::Capsule> caps;
  geometry::world_capsules(d, forward_kinematics(s, KinematicState::zero(s)), caps);
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < static_cast<int>(caps.size()); ++i)
    for (int j = i + 1; j < static_cast<int>(caps.size()); ++j) {
      if (caps[i].body == caps[j].body || tree_distance(caps[i].body, caps[j].body) <= 2) continue;
      if (geometry::penetration(caps[i], caps[j]) > 0) continue;
      pairs.emplace_back(i, j);
    }
  (void)nb;
  return pairs;
}
}  // namespace detail

/// Computes the report of a clip on character `d` (the clip in d's skeleton).
template <CharacterGeometry D>
QualityReport motion_quality(const MotionClip& clip, const D& d, const QualityOptions& opt = {}) {
  const Skeleton& s = d.skeleton;
  clip.validate(s);
  QualityReport r;
  const int T = clip.num_frames();
  r.frames = T;
  r.duration = clip.duration();
  const auto pairs = detail::collision_pairs(d);
  const auto feet_range = d.foot_bodies();
  const std::vector<int> feet(std::ranges::begin(feet_range), std::ranges::end(feet_range));
  BodyStates bs;
  std::vector<geometry::Capsule> caps;
  std::vector<Vec3> prev_pos(feet.size());
  std::vector<bool> prev_contact(feet.size(), false);
  double skate_sum = 0;
  long long skate_n = 0, contact_n = 0, viol_n = 0, collide_n = 0;
  r.root_height_min = 1e300;
  r.root_height_max = -1e300;
  for (int t = 0; t < T; ++t) {
    forward_kinematics(s, clip.frame(t), bs);
    const double z = clip.root_pos(2, t);
    r.root_height_mean += z / T;
    r.root_height_min = std::min(r.root_height_min, z);
    r.root_height_max = std::max(r.root_height_max, z);
    for (std::size_t f = 0; f < feet.size(); ++f) {
      const double low = geometry::lowest_point(d, bs, feet[f]);
      const bool contact = low < opt.contact_height;
      const Vec3 p = bs.pos.col(feet[f]);
      if (contact) ++contact_n;
      if (t > 0 && contact && prev_contact[f]) {
        const double v = (p - prev_pos[f]).head<2>().norm() * clip.fps;
        skate_sum += v;
        ++skate_n;
        r.foot_skating_max = std::max(r.foot_skating_max, v);
      }
      prev_contact[f] = contact;
      prev_pos[f] = p;
    }
    const double pen = std::max(0.0, -geometry::lowest_point(d, bs));
    r.penetration_mean += pen / T;
    r.penetration_max = std::max(r.penetration_max, pen);
    for (int k = 0; k < s.num_dofs(); ++k) {
      const double a = clip.q(k, t);
      const double ex = std::max(a - s.dof_upper(k), s.dof_lower(k) - a);
      if (ex > 1e-9) {
        ++viol_n;
        r.limit_violation_max = std::max(r.limit_violation_max, ex);
      }
    }
    geometry::world_capsules(d, bs, caps);
    for (auto [i, j] : pairs)
      if (geometry::penetration(caps[i], caps[j]) > opt.collision_depth) {
        ++collide_n;
        break;
      }
  }
  r.foot_skating = skate_n ? skate_sum / skate_n : 0.0;
  r.contact_fraction = double(contact_n) / (double(T) * feet.size());
  r.limit_violation_fraction = double(viol_n) / (double(T) * s.num_dofs());
  r.self_collision_fraction = double(collide_n) / T;
  r.travel = (clip.root_pos.col(T - 1) - clip.root_pos.col(0)).head<2>().norm();
  return r;
}

}  // namespace maskadapt
