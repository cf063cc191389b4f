#pragma once
/// \file geometry.hpp
/// A character's collision shapes seen from the motion code: every geom approximated by a
/// capsule (segment + radius) in world coordinates for a pose, the lowest point of a body, and
/// segment–segment distances. Used for grounding, foot contacts and self-collision checks.
///
/// The character is any description satisfying `CharacterGeometry` — a `skeleton`, per-body
/// `bodies[i].geoms` (motion/geom.hpp) and `foot_bodies()` — such as the reference humanoid's
/// `HumanoidDescription` (humanoid/description.hpp). The motion layer includes no character.
#include <maskadapt/core/types.hpp>
#include <maskadapt/motion/geom.hpp>
#include <maskadapt/motion/skeleton.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <ranges>
#include <vector>

namespace maskadapt {

/// What the motion code needs of a character's shape: its skeleton, the geoms of every body
/// (in the body's frame) and the bodies that carry the feet.
template <class D>
concept CharacterGeometry = requires(const D& d, std::size_t i) {
  { d.skeleton } -> std::convertible_to<const Skeleton&>;
  { d.bodies.size() } -> std::convertible_to<std::size_t>;
  { d.bodies[i].geoms } -> std::ranges::range;
  requires std::same_as<std::ranges::range_value_t<decltype(d.bodies[i].geoms)>, Geom>;
  { d.foot_bodies() } -> std::ranges::range;
};

}  // namespace maskadapt

namespace maskadapt::geometry {

/// A capsule in world coordinates.
struct Capsule {
  Vec3 a = Vec3::Zero(), b = Vec3::Zero();  ///< segment end points (m)
  double radius = 0.0;                      ///< (m)
  int body = 0;                             ///< owning body
};

/// Capsule approximation of a geom in its body frame: capsules as they are, spheres as a
/// zero-length capsule, boxes as a capsule along their longest axis with the radius of the larger
/// remaining half size (so a flat foot stays a foot-sized sausage).
inline Capsule local_capsule(const Geom& g, int body) {
  Capsule c;
  c.body = body;
  switch (g.type) {
    case Geom::Type::Capsule: c.a = g.a; c.b = g.b; c.radius = g.radius; break;
    case Geom::Type::Sphere: c.a = c.b = g.a; c.radius = g.radius; break;
    case Geom::Type::Box: {
      int k;
      g.b.maxCoeff(&k);
      const double r = std::max(g.b[(k + 1) % 3], g.b[(k + 2) % 3]);
      const double half = std::max(0.0, g.b[k] - r);
      c.a = g.a - half * Vec3::Unit(k);
      c.b = g.a + half * Vec3::Unit(k);
      c.radius = r;
      break;
    }
  }
  return c;
}

/// World capsules of every geom for given body states.
template <CharacterGeometry D>
void world_capsules(const D& d, const BodyStates& bs, std::vector<Capsule>& out) {
  out.clear();
  for (int i = 0; i < static_cast<int>(d.bodies.size()); ++i)
    for (const Geom& g : d.bodies[i].geoms) {
      Capsule c = local_capsule(g, i);
      c.a = bs.pos.col(i) + bs.rot[i] * c.a;
      c.b = bs.pos.col(i) + bs.rot[i] * c.b;
      out.push_back(c);
    }
}

/// Lowest world z of body i's geoms (exact for boxes: the lowest of the 8 corners).
template <CharacterGeometry D>
double lowest_point(const D& d, const BodyStates& bs, int i, Vec3* where = nullptr) {
  double zmin = 1e300;
  Vec3 best = bs.pos.col(i);
  const Quat& R = bs.rot[i];
  for (const Geom& g : d.bodies[i].geoms) {
    if (g.type == Geom::Type::Box) {
      for (int c = 0; c < 8; ++c) {
        const Vec3 corner = g.a + Vec3((c & 1) ? g.b.x() : -g.b.x(), (c & 2) ? g.b.y() : -g.b.y(),
                                       (c & 4) ? g.b.z() : -g.b.z());
        const Vec3 w = bs.pos.col(i) + R * corner;
        if (w.z() < zmin) zmin = w.z(), best = w;
      }
    } else {
      const Capsule c = local_capsule(g, i);
      for (const Vec3& p : {c.a, c.b}) {
        const Vec3 w = bs.pos.col(i) + R * p;
        if (w.z() - c.radius < zmin) zmin = w.z() - c.radius, best = w - Vec3(0, 0, c.radius);
      }
    }
  }
  if (where) *where = best;
  return zmin;
}

/// Lowest world z of the whole body.
template <CharacterGeometry D>
double lowest_point(const D& d, const BodyStates& bs) {
  double z = 1e300;
  for (int i = 0; i < bs.num_bodies(); ++i)
    if (!d.bodies[i].geoms.empty()) z = std::min(z, lowest_point(d, bs, i));
  return z;
}

/// Distance between segments [p1, q1] and [p2, q2] (closest points, clamped to both segments).
inline double segment_distance(const Vec3& p1, const Vec3& q1, const Vec3& p2, const Vec3& q2) {
  const Vec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  double s = 0, t = 0;
  constexpr double eps = 1e-12;
  if (a <= eps && e <= eps) return r.norm();
  if (a <= eps) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= eps) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2), denom = a * e - b * b;
      s = denom > eps ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1) {
        t = 1;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return ((p1 + s * d1) - (p2 + t * d2)).norm();
}

/// Penetration depth of two capsules (> 0 when they overlap), metres.
inline double penetration(const Capsule& x, const Capsule& y) {
  return x.radius + y.radius - segment_distance(x.a, x.b, y.a, y.b);
}

}  // namespace maskadapt::geometry
