#pragma once
/// \file termination.hpp
/// Fall detection from canonical body states and contact flags (engine-independent).
///
/// An env has fallen when any body that is not allowed to touch the ground does (by default
/// everything except feet, toes and hands), or when the head is below `min_head_height`.
#include <maskadapt/core/error.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/motion/skeleton.hpp>
#include <maskadapt/sim/simulator.hpp>

#include <string>
#include <vector>

namespace maskadapt {

struct FallCriteria {
  std::vector<std::uint8_t> contact_allowed;  ///< (num_bodies) 1 ⇔ the body may touch the ground
  int head = -1;                              ///< body whose height is checked (−1: none)
  double min_head_height = 0.4;               ///< m; fallen if head z < this

  /// Criteria for a skeleton: contacts allowed for the named bodies, head height for `head_name`
  /// (none when empty). The defaults are the reference humanoid's (humanoid/description.hpp: feet,
  /// toes, hands; "Head"). Unknown names throw naming them.
  static FallCriteria for_skeleton(const Skeleton& skel, const std::vector<std::string>& allowed = humanoid_ground_contacts(),
                                   const std::string& head_name = humanoid_head(), double min_head_height = 0.4) {
    FallCriteria c;
    c.contact_allowed.assign(static_cast<std::size_t>(skel.num_bodies()), 0);
    for (const std::string& name : allowed) c.contact_allowed[static_cast<std::size_t>(skel.index_of(name))] = 1;
    c.head = head_name.empty() ? -1 : skel.index_of(head_name);
    c.min_head_height = min_head_height;
    return c;
  }
};

/// True if the body states/contacts describe a fall under `c`.
inline bool has_fallen(const FallCriteria& c, const BodyStates& b, const ContactFlags& contacts) {
  require(contacts.size() == c.contact_allowed.size() && b.num_bodies() == static_cast<int>(contacts.size()),
          "contact flags, body states and fall criteria disagree on the number of bodies", {{}, {}, "contacts"});
  for (std::size_t i = 0; i < contacts.size(); ++i)
    if (contacts[i] && !c.contact_allowed[i]) return true;
  return c.head >= 0 && b.pos(2, c.head) < c.min_head_height;
}

/// Fall flags of every env of a simulator, (num_envs).
template <Simulator S>
std::vector<std::uint8_t> fallen_envs(const S& sim, const FallCriteria& c) {
  std::vector<std::uint8_t> out(sim.num_envs());
  for (std::size_t e = 0; e < sim.num_envs(); ++e) out[e] = has_fallen(c, sim.body_states(e), sim.contacts(e)) ? 1 : 0;
  return out;
}

}  // namespace maskadapt
