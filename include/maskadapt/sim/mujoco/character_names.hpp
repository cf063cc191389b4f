#pragma once
/// \file character_names.hpp
/// The names of the bundled characters (the values of env.character and --character), apart
/// from character.hpp so that configs can check a name without pulling in every description.
#include <string>
#include <vector>

namespace maskadapt {

/// Names `mujoco_character(name)` (character.hpp) knows; a new character adds its name here.
inline const std::vector<std::string>& character_names() {
  static const std::vector<std::string> names = {"humanoid", "g1"};
  return names;
}

}  // namespace maskadapt
