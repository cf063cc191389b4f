#pragma once
/// \file character.hpp
/// `MujocoCharacter`: everything the MuJoCo adapter (humanoid_sim.hpp) and the trainers need to
/// know of a character, whatever its shape — its skeleton, its MJCF, which MuJoCo joint drives
/// each DoF, the physics step, the pose it stands in, what counts as a fall, and the geoms the
/// viewer draws. Built from a character's own description:
///
///   mujoco_character(humanoid_description())   // the 22-body, 63-DoF reference humanoid
///   mujoco_character(g1::g1_description())      // the 30-link, 29-DoF G1-like robot
///   mujoco_character("g1", "--character")       // by name, for command lines and configs
///
/// A third character needs one more `mujoco_character(const ItsDescription&)` (docs/characters.md,
/// "Adding a character"). The MJCF must follow the scheme of humanoid/mjcf.hpp: a plane geom
/// named `floor`, a free joint named `root` on body 0, the skeleton's bodies under their names,
/// `joint_names[k]` the hinge of DoF k, and one position actuator per DoF in DoF order
/// (MujocoHumanoidSim checks every one of these when it loads the model).
///
/// This header does not include MuJoCo itself.
#include <maskadapt/core/error.hpp>
#include <maskadapt/g1/clip.hpp>
#include <maskadapt/g1/description.hpp>
#include <maskadapt/g1/mjcf.hpp>
#include <maskadapt/g1/retarget.hpp>
#include <maskadapt/g1/skeleton.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/humanoid/mjcf.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/geom.hpp>
#include <maskadapt/motion/skeleton.hpp>
#include <maskadapt/sim/mujoco/character_names.hpp>
#include <maskadapt/sim/termination.hpp>

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace maskadapt {

/// The shapes of one body (body frame), for the viewer and motion-quality checks.
struct CharacterBody {
  std::vector<Geom> geoms;
};

struct MujocoCharacter {
  std::string name;                        ///< "humanoid", "g1": what configs and checkpoints record
  Skeleton skeleton;                       ///< kinematics, parts, joint limits (rad)
  std::vector<CharacterBody> bodies;       ///< (num_bodies) geoms in each body's frame
  std::vector<int> feet;                   ///< bodies that carry the soles
  std::string mjcf;                        ///< the model (scheme in the file comment)
  std::vector<std::string> joint_names;    ///< (num_dofs) MuJoCo hinge of DoF k
  double physics_dt = 0.0;                 ///< physics step (s)
  int substeps = 0;                        ///< physics steps per control step
  KinematicState standing;                 ///< the pose every env starts in (soles on z = 0)
  std::vector<std::string> ground_contacts;  ///< bodies that may touch the ground without a fall
  std::string head;                        ///< body whose height ends an episode when too low
  std::vector<std::string> hands;          ///< bodies that strike (tasks/strike.hpp) and carry the hands
  /// How a clip of the reference humanoid (what BVH, AMASS and the built-in sets import as) becomes
  /// this character's clip; empty for the humanoid itself. The G1: g1::retarget_to_g1.
  std::function<MotionClip(const MotionClip&)> from_humanoid;
  /// Reads a clip file in the character's own format, or returns nothing when `path` is not one
  /// (then the file is imported as a humanoid clip and converted by `from_humanoid`).
  std::function<std::optional<MotionClip>(const std::string& path)> read_own_clip;

  double control_dt() const { return physics_dt * substeps; }
  /// `CharacterGeometry` (motion/geometry.hpp).
  const std::vector<int>& foot_bodies() const { return feet; }
  /// Fall criteria: a ground contact of any body not in `ground_contacts`, or the head body's
  /// origin below `min_head_height` (m; the trainers pass env.termination_height).
  FallCriteria fall_criteria(double min_head_height) const {
    return FallCriteria::for_skeleton(skeleton, ground_contacts, head, min_head_height);
  }
  /// Throws unless the parts agree with each other (sizes, names, physics step).
  void validate() const {
    skeleton.validate();
    require(!name.empty(), "a character needs a name", {{}, {}, "character"});
    require(bodies.size() == static_cast<std::size_t>(skeleton.num_bodies()),
            "character '" + name + "': one geom list per body", {{}, {}, "bodies"});
    require(joint_names.size() == static_cast<std::size_t>(skeleton.num_dofs()),
            "character '" + name + "': one MuJoCo joint name per DoF", {{}, {}, "joint_names"});
    require(physics_dt > 0 && substeps >= 1, "character '" + name + "': physics_dt and substeps must be positive",
            {{}, {}, "substeps"});
    require(standing.q.size() == skeleton.num_dofs(), "character '" + name + "': standing pose has the wrong size",
            {{}, {}, "standing"});
    require(!mjcf.empty(), "character '" + name + "' has no MJCF", {{}, {}, "mjcf"});
    for (const auto& b : ground_contacts) (void)skeleton.index_of(b);
    for (int f : feet)
      require(f >= 0 && f < skeleton.num_bodies(), "character '" + name + "': foot body out of range", {{}, {}, "feet"});
    if (!head.empty()) (void)skeleton.index_of(head);
    for (const auto& b : hands) (void)skeleton.index_of(b);
  }
};

/// The reference humanoid (humanoid/description.hpp): joints `<body>_x/_y/_z`, the zero pose,
/// feet, toes and hands may touch the ground, "Head" is the head.
inline MujocoCharacter mujoco_character(const HumanoidDescription& d) {
  MujocoCharacter c;
  c.name = "humanoid";
  c.skeleton = d.skeleton;
  for (const auto& b : d.bodies) c.bodies.push_back({b.geoms});
  const auto f = d.foot_bodies();
  c.feet.assign(f.begin(), f.end());
  c.mjcf = humanoid_mjcf(d);
  for (int i = 1; i < d.skeleton.num_bodies(); ++i)
    for (const char* axis : {"_x", "_y", "_z"}) c.joint_names.push_back(d.skeleton.names[static_cast<std::size_t>(i)] + axis);
  c.physics_dt = d.physics_dt;
  c.substeps = d.substeps;
  c.standing = KinematicState::zero(d.skeleton);
  c.standing.root_pos = Vec3(0, 0, d.root_height);
  c.ground_contacts = humanoid_ground_contacts();
  c.head = humanoid_head();
  c.hands = humanoid_hands();
  c.validate();
  return c;
}

/// The G1-like robot (g1/description.hpp): its hinges as named there, the nominal standing pose
/// (knees slightly bent), the ankle-roll links (soles) and the wrist-yaw links (hands) may touch
/// the ground, the torso link is the "head" (the G1 has no neck: its head sphere sits on it).
inline MujocoCharacter mujoco_character(const g1::G1Description& d) {
  MujocoCharacter c;
  c.name = "g1";
  c.skeleton = g1::g1_skeleton(d);
  for (const auto& l : d.links) c.bodies.push_back({l.geoms});
  c.feet = {d.link_index("left_ankle_roll_link"), d.link_index("right_ankle_roll_link")};
  c.mjcf = g1::g1_mjcf(d);
  for (int i = 1; i < d.num_bodies(); ++i) c.joint_names.push_back(d.links[static_cast<std::size_t>(i)].joint);
  c.physics_dt = d.physics_dt;
  c.substeps = d.substeps;
  c.standing = KinematicState::zero(c.skeleton);
  c.standing.q = d.nominal_q;
  c.standing.root_pos = Vec3(0, 0, d.nominal_root_height);
  c.ground_contacts = {"left_ankle_roll_link", "right_ankle_roll_link", "left_wrist_yaw_link", "right_wrist_yaw_link"};
  c.head = d.links[static_cast<std::size_t>(d.head_link)].name;
  c.hands = {"left_wrist_yaw_link", "right_wrist_yaw_link"};
  c.from_humanoid = [d](const MotionClip& humanoid_clip) {
    MotionClip r = g1::to_motion_clip(g1::retarget_to_g1(humanoid_clip, {}, nullptr, d));
    r.labels = humanoid_clip.labels;  // (what the clip shows does not change with the character)
    return r;
  };
  c.read_own_clip = [](const std::string& path) -> std::optional<MotionClip> {
    // (one read: an .npz that is not a G1 clip goes on to import_motion, which reports its errors)
    if (std::filesystem::path(path).extension() != ".npz") return std::nullopt;
    npz::Archive a;
    try {
      a = npz::read(path);
    } catch (const Error&) {
      return std::nullopt;
    }
    if (!g1::is_g1_clip_archive(a)) return std::nullopt;
    return g1::to_motion_clip(g1::g1_clip_from_archive(a, path));
  };
  c.validate();
  return c;
}

/// A bundled character by name; `field` names where the name came from (a flag, a config field)
/// in the error for an unknown one. A new character adds its name here and in character_names.hpp.
inline const MujocoCharacter& mujoco_character(std::string_view name, const std::string& field = "character") {
  if (name == "humanoid") {
    static const MujocoCharacter c = mujoco_character(humanoid_description());
    return c;
  }
  if (name == "g1") {
    static const MujocoCharacter c = mujoco_character(g1::g1_description());
    return c;
  }
  std::string known;
  for (const auto& n : character_names()) known += (known.empty() ? "" : ", ") + n;
  throw Error(field + ": must be one of " + known + ", got '" + std::string(name) + "'", {{}, {}, field});
}

}  // namespace maskadapt
