#pragma once
/// \file skeleton.hpp
/// The G1 robot as a generic `Skeleton`: one body per link (pelvis = root), each non-root link
/// with the one hinge it hangs from (its axis in the link frame, its range), the link's offset
/// and body part. DoF k is joint k (Unitree's motor order), so q is the G1's joint vector and
/// maskadapt::forward_kinematics(g1_skeleton(d), …) gives the same link poses as
/// g1::forward_kinematics(d, …) (tests/g1/test_mujoco.cpp checks both against MuJoCo).
#include <maskadapt/g1/description.hpp>
#include <maskadapt/motion/skeleton.hpp>

namespace maskadapt::g1 {

/// Skeleton of a G1 description: num_bodies = d.num_bodies(), num_dofs = d.num_joints().
inline Skeleton g1_skeleton(const G1Description& d) {
  Skeleton s;
  const int nb = d.num_bodies();
  s.offsets.setZero(3, nb);
  for (int i = 0; i < nb; ++i) {
    const Link& l = d.links[static_cast<std::size_t>(i)];
    s.names.push_back(l.name);
    s.parents.push_back(l.parent);
    s.parts.push_back(l.part);
    if (i > 0) {
      s.offsets.col(i) = l.offset;
      s.add_hinge(i, l.axis, l.lower, l.upper);
    }
  }
  s.validate();
  return s;
}

/// The G1's skeleton (built once from g1_description()).
inline const Skeleton& g1_skeleton() {
  static const Skeleton s = g1_skeleton(g1_description());
  return s;
}

}  // namespace maskadapt::g1
