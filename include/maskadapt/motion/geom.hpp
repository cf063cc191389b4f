#pragma once
/// \file geom.hpp
/// `Geom`: a collision/inertia primitive attached to a body, in that body's frame — the shape
/// vocabulary a character description (humanoid/description.hpp, g1/description.hpp) hands to the
/// motion code (geometry.hpp, quality.hpp) and to its MJCF writer.
#include <maskadapt/core/types.hpp>

namespace maskadapt {

/// A collision/inertia primitive attached to a body, in that body's frame (metres, kg).
struct Geom {
  enum class Type { Capsule, Box, Sphere };
  Type type = Type::Sphere;
  Vec3 a = Vec3::Zero();  ///< capsule: segment start; box/sphere: centre
  Vec3 b = Vec3::Zero();  ///< capsule: segment end; box: half sizes; sphere: unused
  double radius = 0.0;    ///< capsule/sphere radius (m); box: unused
  double mass = 0.0;      ///< kg (MuJoCo derives the inertia from the shape and this mass)
};

}  // namespace maskadapt
