#pragma once
/// \file scene.hpp
/// Rigid objects beside the character (the strike task's box): what a simulator plug-in must
/// provide to take part in tasks that need them.
///
/// `SceneSimulator` refines `Simulator`. For `S& s`, `const S& cs`, env `e`, object `k` <
/// num_objects():
///
/// | expression                     | returns                      | meaning |
/// | ------------------------------ | ---------------------------- | ------- |
/// | `cs.num_objects()`             | convertible to `std::size_t` | objects in every env's scene (the same set in each env) |
/// | `cs.object_state(e, k)`        | `const RigidState&`          | world pose and velocities of object k after the last step / placement |
/// | `s.place_object(e, k, state)`  | (any)                        | puts object k of env e at `state` (takes effect from the next step; throws `Error` on a non-finite or non-unit state) |
/// | `cs.object_contacts(e, k)`     | `const ContactFlags&`        | (num_bodies) 1 ⇔ that body of the character touched object k during the last step |
///
/// A character reset (`reset`) does not move the objects; tasks place them for each episode.
/// A simulator with no objects simply is not a `SceneSimulator`; tasks that need one say so in
/// their requires-clause (tasks/strike.hpp).
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/sim/simulator.hpp>

#include <concepts>
#include <cstddef>
#include <string>

namespace maskadapt {

/// World state of a rigid object, at its frame origin (its centre for a box).
struct RigidState {
  Vec3 pos = Vec3::Zero();      ///< m
  Quat rot = Quat::Identity();  ///< world orientation
  Vec3 lin_vel = Vec3::Zero();  ///< m/s
  Vec3 ang_vel = Vec3::Zero();  ///< rad/s, world frame
};

/// A free box in the scene (uniform density).
struct BoxObject {
  std::string name = "box";
  Vec3 half_size = Vec3(0.2, 0.2, 0.6);  ///< m (the strike target: 0.4 × 0.4 × 1.2 m)
  double mass = 5.0;                     ///< kg
  double friction = 1.0;                 ///< sliding friction against floor and body

  void validate() const {
    require(!name.empty() && name.find_first_of("<>\"&' ") == std::string::npos,
            "object name must be non-empty without spaces or XML characters", {{}, {}, "object.name"});
    require(half_size.allFinite() && half_size.minCoeff() > 0, "box half sizes must be finite and > 0",
            {{}, {}, "object.half_size"});
    require(std::isfinite(mass) && mass > 0, "box mass must be finite and > 0", {{}, {}, "object.mass"});
    require(std::isfinite(friction) && friction >= 0, "box friction must be finite and >= 0", {{}, {}, "object.friction"});
  }
};

template <class S>
concept SceneSimulator = Simulator<S> && requires(S& s, const S& cs, std::size_t env, std::size_t k, const RigidState& st) {
  { cs.num_objects() } -> std::convertible_to<std::size_t>;
  { cs.object_state(env, k) } -> std::same_as<const RigidState&>;
  s.place_object(env, k, st);
  { cs.object_contacts(env, k) } -> std::same_as<const ContactFlags&>;
};

/// Checks a placement: finite, unit quaternion (|‖q‖ − 1| ≤ 1e−6). Throws Error naming `field`.
inline void check_rigid_state(const RigidState& s, const std::string& field = "object_state") {
  require(s.pos.allFinite() && s.rot.coeffs().allFinite() && s.lin_vel.allFinite() && s.ang_vel.allFinite(),
          "object state is not finite", {{}, {}, field});
  require(std::abs(s.rot.norm() - 1.0) <= 1e-6, "object orientation is not a unit quaternion", {{}, {}, field});
}

}  // namespace maskadapt
