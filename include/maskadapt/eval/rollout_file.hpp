#pragma once
/// \file rollout_file.hpp
/// Rollout files for the web viewer (tools/viewer): what a policy did, frame by frame.
///
/// A `Rollout` holds the skeleton (names, parents, parts, rest offsets, drawable geoms), and per
/// frame the world position and orientation of every body, the active part mask, ground-contact
/// flags, plus optional text commands over time, goal trajectories (tracking) and scene goals
/// (goal tasks: location targets, heading arrows, rigid boxes such as the strike box). It is written
/// as one JSON document, schema "maskadapt-rollout" version 1, documented field by field in
/// docs/viewer.md. Typical use:
///
///   eval::Rollout r = eval::make_rollout(humanoid_description());   // geoms from the description
///   r.metadata.command = "maskadapt play ...";
///   for (...) eval::add_frame(r, sim.body_states(0), mask, sim.contacts(0));
///   eval::write_rollout(r, "out/rollout.json");
///
/// Goal tasks add a scene (one entry per frame, pushed next to add_frame):
///
///   r.scene.emplace();
///   r.scene->objects.push_back({"strike_box", Vec3(0.2, 0.2, 0.6), {}, {}});
///   for (...) {
///     eval::add_frame(r, ...);
///     r.scene->targets.push_back({{target_pos, 0.5}});                       // location
///     r.scene->arrows.push_back({eval::heading_arrow(root_pos, dir, speed)});  // heading
///     r.scene->objects[0].positions.push_back(box.pos);                      // strike
///     r.scene->objects[0].rotations.push_back(box.rot);
///   }
///
/// Every writer input is validated: non-finite positions/rotations raise maskadapt::Error naming
/// the frame and the body; the reader reports the file and the JSON field at fault.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/motion/geometry.hpp>
#include <maskadapt/motion/skeleton.hpp>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace maskadapt::eval {

inline constexpr const char* kRolloutFormat = "maskadapt-rollout";
inline constexpr int kRolloutVersion = 1;

/// A drawable primitive attached to a body, in that body's frame (metres).
struct RolloutGeom {
  enum class Type { Capsule, Sphere, Box };
  Type type = Type::Capsule;
  Vec3 from = Vec3::Zero();  ///< capsule: segment start; sphere/box: centre
  Vec3 to = Vec3::Zero();    ///< capsule: segment end; box: half sizes; sphere: unused
  double radius = 0.0;       ///< capsule/sphere radius (m); box: unused
};

/// The skeleton as the viewer needs it.
struct RolloutSkeleton {
  std::vector<std::string> names;               ///< (num_bodies)
  std::vector<int> parents;                     ///< (num_bodies), −1 for the root
  std::vector<BodyPart> parts;                  ///< (num_bodies)
  Matrix3X offsets;                             ///< (3 × num_bodies) rest offsets in the parent frame (m)
  std::vector<std::vector<RolloutGeom>> geoms;  ///< (num_bodies) drawable geoms per body
  int num_bodies() const { return static_cast<int>(names.size()); }
};

/// A text command that becomes active at time t (seconds from the first frame).
struct RolloutText {
  double t = 0.0;
  std::string text;
};

/// Goal trajectory for tracking: fixed designated bodies, per-frame target positions.
struct RolloutGoals {
  std::vector<int> bodies;         ///< (k) designated body indices
  std::vector<Matrix3X> targets;   ///< (num_frames) each (3 × k) world targets (m), or 3 × 0 = no goal that frame
};

/// A location target (goal task "location"): a point the character should reach, drawn as a flat
/// disc/ring of `radius` on the floor below `position`.
struct RolloutTarget {
  Vec3 position = Vec3::Zero();  ///< world position (m); usually on the floor (z = 0)
  double radius = 0.5;           ///< reach radius (m), > 0
};

/// A heading arrow (goal task "heading"): the target direction on the ground and target speed,
/// drawn from `origin` (the root projected on the floor) with a length of `speed` metres (the
/// distance covered in 1 s at that speed).
struct RolloutArrow {
  Vec3 origin = Vec3::Zero();        ///< world position (m) the arrow starts at
  Vec3 direction = Vec3::UnitX();    ///< horizontal unit vector (world; z = 0)
  double speed = 0.0;                ///< target speed (m/s), ≥ 0
};

/// A rigid box in the scene (goal task "strike": the 0.4 × 0.4 × 1.2 m box), with its world pose
/// at every frame.
struct RolloutObject {
  std::string name;                    ///< e.g. "strike_box" (shown by the viewer)
  Vec3 half_size = Vec3::Constant(0.1);  ///< box half sizes along its local x, y, z (m), each > 0
  std::vector<Vec3> positions;         ///< (num_frames) world position of the box centre (m)
  std::vector<Quat> rotations;         ///< (num_frames) world orientation, unit quaternions
};

/// Scene goals of the goal-driven tasks, drawn by the viewer. Every per-frame vector is either
/// empty (that kind of goal is absent from the whole rollout) or has one entry per frame, which
/// may itself be empty (no target / arrow on that frame).
struct RolloutScene {
  std::vector<RolloutObject> objects;                ///< rigid boxes (each with num_frames poses)
  std::vector<std::vector<RolloutTarget>> targets;   ///< (num_frames or 0) location targets per frame
  std::vector<std::vector<RolloutArrow>> arrows;     ///< (num_frames or 0) heading arrows per frame
};

/// The heading arrow of a root at `root_pos` (world, m): starts at the root projected on the floor,
/// points along `dir` projected on the ground and normalised (throws when it is vertical or not
/// finite), with length `speed` (m/s).
inline RolloutArrow heading_arrow(const Vec3& root_pos, const Vec3& dir, double speed) {
  const Vec3 d(dir.x(), dir.y(), 0.0);
  require(d.allFinite() && d.norm() > 1e-9, "heading direction must be finite and not vertical", {{}, {}, "scene.arrows.direction"});
  return {Vec3(root_pos.x(), root_pos.y(), 0.0), d.normalized(), speed};
}

struct RolloutMetadata {
  std::string command;                       ///< command line that produced the rollout
  std::string checkpoint;                    ///< checkpoint path, if any
  std::optional<std::int64_t> seed;          ///< seed, if any
  std::map<std::string, std::string> extra;  ///< free-form key/value pairs (e.g. "lambda_mi": "1.0")
};

struct Rollout {
  RolloutSkeleton skeleton;
  double fps = 30.0;                                  ///< frames per second
  std::vector<Matrix3X> positions;                    ///< (num_frames) each (3 × num_bodies) world positions (m)
  std::vector<std::vector<Quat>> rotations;           ///< (num_frames) each (num_bodies) world orientations
  std::vector<PartMask> masks;                        ///< (num_frames) active (adapted) parts
  std::vector<std::vector<std::uint8_t>> contacts;    ///< (num_frames) each (num_bodies) 0/1, or empty = unknown
  std::vector<RolloutText> texts;                     ///< sorted by t
  std::optional<RolloutGoals> goals;
  std::optional<RolloutScene> scene;                  ///< goal-task scene (targets, arrows, boxes), if any
  RolloutMetadata metadata;

  int num_frames() const { return static_cast<int>(positions.size()); }
};

// ---- building ---------------------------------------------------------------------------------

/// Skeleton part of a rollout with default geoms: a capsule from every body's origin to each
/// child's joint (radius `radius`), and a sphere for bodies without children.
inline RolloutSkeleton rollout_skeleton(const Skeleton& skel, double radius = 0.04) {
  skel.validate();
  RolloutSkeleton s;
  s.names = skel.names;
  s.parents = skel.parents;
  s.parts = skel.parts;
  s.offsets = skel.offsets;
  s.geoms.resize(static_cast<std::size_t>(skel.num_bodies()));
  for (int i = 1; i < skel.num_bodies(); ++i)
    s.geoms[static_cast<std::size_t>(skel.parents[i])].push_back(
        {RolloutGeom::Type::Capsule, Vec3::Zero(), skel.offsets.col(i), radius});
  for (auto& g : s.geoms)
    if (g.empty()) g.push_back({RolloutGeom::Type::Sphere, Vec3::Zero(), Vec3::Zero(), radius});
  return s;
}

/// Skeleton part of a rollout with a character's own collision geoms (a HumanoidDescription, a
/// MujocoCharacter: any CharacterGeometry).
template <CharacterGeometry D>
RolloutSkeleton rollout_skeleton(const D& d) {
  RolloutSkeleton s = rollout_skeleton(d.skeleton);
  require(d.bodies.size() == s.geoms.size(), "description has the wrong number of bodies", {{}, {}, "bodies"});
  for (std::size_t i = 0; i < d.bodies.size(); ++i) {
    if (d.bodies[i].geoms.empty()) continue;  // keep the default capsule
    s.geoms[i].clear();
    for (const Geom& g : d.bodies[i].geoms) {
      RolloutGeom r;
      r.from = g.a;
      r.to = g.b;
      r.radius = g.radius;
      r.type = g.type == Geom::Type::Capsule ? RolloutGeom::Type::Capsule
               : g.type == Geom::Type::Box   ? RolloutGeom::Type::Box
                                             : RolloutGeom::Type::Sphere;
      s.geoms[i].push_back(r);
    }
  }
  return s;
}

inline Rollout make_rollout(const Skeleton& skel, double fps = 30.0) {
  Rollout r;
  r.skeleton = rollout_skeleton(skel);
  r.fps = fps;
  return r;
}
template <CharacterGeometry D>
Rollout make_rollout(const D& d, double fps = 30.0) {
  Rollout r;
  r.skeleton = rollout_skeleton(d);
  r.fps = fps;
  return r;
}

namespace detail {
inline std::string body_label(const RolloutSkeleton& s, int b) {
  return "body " + std::to_string(b) + (b < s.num_bodies() ? " ('" + s.names[static_cast<std::size_t>(b)] + "')" : "");
}
inline void check_frame(const RolloutSkeleton& s, int frame, const Matrix3X& pos, const std::vector<Quat>& rot) {
  const int nb = s.num_bodies();
  require(pos.cols() == nb, "frame " + std::to_string(frame) + ": " + std::to_string(pos.cols()) +
                                " body positions for " + std::to_string(nb) + " bodies",
          {{}, {}, "positions"});
  require(static_cast<int>(rot.size()) == nb, "frame " + std::to_string(frame) + ": " + std::to_string(rot.size()) +
                                                  " body rotations for " + std::to_string(nb) + " bodies",
          {{}, {}, "rotations"});
  for (int b = 0; b < nb; ++b) {
    require(pos.col(b).allFinite(), "frame " + std::to_string(frame) + ", " + body_label(s, b) + ": non-finite position",
            {{}, {}, "positions"});
    const auto& q = rot[static_cast<std::size_t>(b)];
    require(q.coeffs().allFinite() && q.coeffs().norm() > 1e-9,
            "frame " + std::to_string(frame) + ", " + body_label(s, b) + ": non-finite or zero rotation",
            {{}, {}, "rotations"});
  }
}
}  // namespace detail

/// Appends one frame from a simulator's / FK's body states.
/// \param contacts per-body ground contact flags (any range of bool-convertible values with
///                 size() == num_bodies), or an empty range when unknown.
/// Throws (naming frame and body) for non-finite states or wrong sizes; the rollout is unchanged then.
template <class Contacts = std::vector<std::uint8_t>>
void add_frame(Rollout& r, const BodyStates& states, PartMask mask, const Contacts& contacts = {}) {
  const int frame = r.num_frames();
  detail::check_frame(r.skeleton, frame, states.pos, states.rot);
  std::vector<std::uint8_t> c;
  if (std::size(contacts) > 0) {
    require(static_cast<int>(std::size(contacts)) == r.skeleton.num_bodies(),
            "frame " + std::to_string(frame) + ": " + std::to_string(std::size(contacts)) + " contact flags for " +
                std::to_string(r.skeleton.num_bodies()) + " bodies",
            {{}, {}, "contacts"});
    for (const auto& v : contacts) c.push_back(static_cast<bool>(v) ? 1 : 0);
  }
  r.positions.push_back(states.pos);
  r.rotations.push_back(states.rot);
  r.masks.push_back(mask);
  r.contacts.push_back(std::move(c));
}

namespace detail {
/// Tolerance on the norm of unit vectors and quaternions (files store 6 decimals).
inline constexpr double kUnitTolerance = 1e-3;

/// Checks the scene goals against `nf` frames; fields are named as in the JSON document
/// ("scene.targets[3][0].radius"), messages name the frame.
inline void validate_scene(const RolloutScene& sc, int nf) {
  const auto fr = [](std::size_t f) { return "frame " + std::to_string(f) + ": "; };
  const auto ix = [](std::size_t i) { return "[" + std::to_string(i) + "]"; };
  const auto unf = static_cast<std::size_t>(nf);
  for (std::size_t i = 0; i < sc.objects.size(); ++i) {
    const auto& o = sc.objects[i];
    const std::string f = "scene.objects" + ix(i);
    const std::string label = "object " + std::to_string(i) + " ('" + o.name + "')";
    require(o.half_size.allFinite() && (o.half_size.array() > 0.0).all(),
            label + ": half sizes must be positive and finite", {{}, {}, f + ".half_size"});
    require(o.positions.size() == unf, label + ": " + std::to_string(o.positions.size()) + " positions for " +
                                           std::to_string(nf) + " frames", {{}, {}, f + ".positions"});
    require(o.rotations.size() == unf, label + ": " + std::to_string(o.rotations.size()) + " rotations for " +
                                           std::to_string(nf) + " frames", {{}, {}, f + ".rotations"});
    for (std::size_t t = 0; t < unf; ++t) {
      require(o.positions[t].allFinite(), fr(t) + label + ": non-finite position", {{}, {}, f + ".positions" + ix(t)});
      const auto& q = o.rotations[t];
      require(q.coeffs().allFinite() && std::abs(q.coeffs().norm() - 1.0) <= kUnitTolerance,
              fr(t) + label + ": rotation is not a unit quaternion (norm " + std::to_string(q.coeffs().norm()) + ")",
              {{}, {}, f + ".rotations" + ix(t)});
    }
  }
  require(sc.targets.empty() || sc.targets.size() == unf,
          "scene targets: " + std::to_string(sc.targets.size()) + " entries for " + std::to_string(nf) +
              " frames (need one per frame, or none)", {{}, {}, "scene.targets"});
  for (std::size_t t = 0; t < sc.targets.size(); ++t)
    for (std::size_t k = 0; k < sc.targets[t].size(); ++k) {
      const auto& g = sc.targets[t][k];
      const std::string f = "scene.targets" + ix(t) + ix(k);
      require(g.position.allFinite(), fr(t) + "target " + std::to_string(k) + ": non-finite position", {{}, {}, f + ".position"});
      require(std::isfinite(g.radius) && g.radius > 0.0,
              fr(t) + "target " + std::to_string(k) + ": radius must be positive and finite, got " + std::to_string(g.radius),
              {{}, {}, f + ".radius"});
    }
  require(sc.arrows.empty() || sc.arrows.size() == unf,
          "scene arrows: " + std::to_string(sc.arrows.size()) + " entries for " + std::to_string(nf) +
              " frames (need one per frame, or none)", {{}, {}, "scene.arrows"});
  for (std::size_t t = 0; t < sc.arrows.size(); ++t)
    for (std::size_t k = 0; k < sc.arrows[t].size(); ++k) {
      const auto& a = sc.arrows[t][k];
      const std::string f = "scene.arrows" + ix(t) + ix(k);
      const std::string label = fr(t) + "arrow " + std::to_string(k) + ": ";
      require(a.origin.allFinite(), label + "non-finite origin", {{}, {}, f + ".origin"});
      require(a.direction.allFinite() && std::abs(a.direction.norm() - 1.0) <= kUnitTolerance &&
                  std::abs(a.direction.z()) <= kUnitTolerance,
              label + "direction must be a horizontal unit vector", {{}, {}, f + ".direction"});
      require(std::isfinite(a.speed) && a.speed >= 0.0, label + "speed must be >= 0 and finite, got " + std::to_string(a.speed),
              {{}, {}, f + ".speed"});
    }
}
}  // namespace detail

/// Checks sizes and values of a whole rollout; throws the first problem (naming frame/body/field).
inline void validate(const Rollout& r) {
  const auto& s = r.skeleton;
  const int nb = s.num_bodies(), nf = r.num_frames();
  require(nb >= 1, "skeleton has no bodies", {{}, {}, "skeleton.bodies"});
  require(static_cast<int>(s.parents.size()) == nb && static_cast<int>(s.parts.size()) == nb &&
              s.offsets.cols() == nb && static_cast<int>(s.geoms.size()) == nb,
          "skeleton arrays disagree on the number of bodies", {{}, {}, "skeleton.bodies"});
  for (int b = 0; b < nb; ++b) {
    const int p = s.parents[static_cast<std::size_t>(b)];
    require(b == 0 ? p == -1 : (p >= 0 && p < b), detail::body_label(s, b) + ": parent must precede it (root: -1)",
            {{}, {}, "skeleton.bodies.parent"});
  }
  require(s.offsets.allFinite(), "non-finite rest offset", {{}, {}, "skeleton.bodies.offset"});
  require(std::isfinite(r.fps) && r.fps > 0.0, "fps must be positive and finite", {{}, {}, "fps"});
  require(static_cast<int>(r.rotations.size()) == nf && static_cast<int>(r.masks.size()) == nf &&
              static_cast<int>(r.contacts.size()) == nf,
          "per-frame arrays disagree on the number of frames", {{}, {}, "frames"});
  for (int f = 0; f < nf; ++f) {
    detail::check_frame(s, f, r.positions[static_cast<std::size_t>(f)], r.rotations[static_cast<std::size_t>(f)]);
    require(r.masks[static_cast<std::size_t>(f)].bits <= PartMask::all().bits,
            "frame " + std::to_string(f) + ": mask has bits beyond the 5 parts", {{}, {}, "masks"});
    const auto& c = r.contacts[static_cast<std::size_t>(f)];
    require(c.empty() || static_cast<int>(c.size()) == nb,
            "frame " + std::to_string(f) + ": contact flags must be empty or one per body", {{}, {}, "contacts"});
  }
  for (std::size_t k = 0; k < r.texts.size(); ++k) {
    require(std::isfinite(r.texts[k].t) && r.texts[k].t >= 0.0, "text " + std::to_string(k) + ": t must be >= 0",
            {{}, {}, "texts"});
    require(k == 0 || r.texts[k].t >= r.texts[k - 1].t, "texts must be sorted by t", {{}, {}, "texts"});
  }
  if (r.goals) {
    const auto& g = *r.goals;
    for (int b : g.bodies) require(b >= 0 && b < nb, "goal body index " + std::to_string(b) + " out of range", {{}, {}, "goals.bodies"});
    require(static_cast<int>(g.targets.size()) == nf, "goal targets need one entry per frame", {{}, {}, "goals.targets"});
    for (int f = 0; f < nf; ++f) {
      const auto& t = g.targets[static_cast<std::size_t>(f)];
      require(t.cols() == 0 || t.cols() == static_cast<Index>(g.bodies.size()),
              "frame " + std::to_string(f) + ": goal targets need one column per goal body", {{}, {}, "goals.targets"});
      require(t.allFinite(), "frame " + std::to_string(f) + ": non-finite goal target", {{}, {}, "goals.targets"});
    }
  }
  if (r.scene) detail::validate_scene(*r.scene, nf);
}

// ---- JSON -------------------------------------------------------------------------------------

namespace detail {
inline double rounded(double x, double scale) { return std::round(x * scale) / scale; }
inline nlohmann::json vec3_json(const Vec3& v, double scale) {
  return nlohmann::json::array({rounded(v.x(), scale), rounded(v.y(), scale), rounded(v.z(), scale)});
}
inline const char* geom_type_name(RolloutGeom::Type t) {
  switch (t) {
    case RolloutGeom::Type::Capsule: return "capsule";
    case RolloutGeom::Type::Sphere: return "sphere";
    default: return "box";
  }
}
}  // namespace detail

/// The rollout as a JSON document (schema in docs/viewer.md). Positions are rounded to
/// `decimals` decimals (default 10 µm), quaternion coefficients to decimals + 1.
inline nlohmann::json to_json(const Rollout& r, int decimals = 5) {
  validate(r);
  using nlohmann::json;
  const double ps = std::pow(10.0, decimals), qs = std::pow(10.0, decimals + 1);
  const auto& s = r.skeleton;
  json j;
  j["format"] = kRolloutFormat;
  j["version"] = kRolloutVersion;
  j["fps"] = r.fps;
  j["num_frames"] = r.num_frames();
  j["part_names"] = json::array();
  for (auto n : kPartNames) j["part_names"].push_back(std::string(n));

  json meta = json::object();
  meta["command"] = r.metadata.command;
  meta["checkpoint"] = r.metadata.checkpoint;
  meta["seed"] = r.metadata.seed ? json(*r.metadata.seed) : json(nullptr);
  for (const auto& [k, v] : r.metadata.extra) meta[k] = v;
  j["metadata"] = meta;

  json bodies = json::array();
  for (int b = 0; b < s.num_bodies(); ++b) {
    const auto bi = static_cast<std::size_t>(b);
    json body;
    body["name"] = s.names[bi];
    body["parent"] = s.parents[bi];
    body["part"] = std::string(part_name(s.parts[bi]));
    body["offset"] = detail::vec3_json(s.offsets.col(b), ps);
    json geoms = json::array();
    for (const auto& g : s.geoms[bi]) {
      json gj;
      gj["type"] = detail::geom_type_name(g.type);
      if (g.type == RolloutGeom::Type::Capsule) {
        gj["from"] = detail::vec3_json(g.from, ps);
        gj["to"] = detail::vec3_json(g.to, ps);
        gj["radius"] = detail::rounded(g.radius, ps);
      } else if (g.type == RolloutGeom::Type::Sphere) {
        gj["center"] = detail::vec3_json(g.from, ps);
        gj["radius"] = detail::rounded(g.radius, ps);
      } else {
        gj["center"] = detail::vec3_json(g.from, ps);
        gj["half_size"] = detail::vec3_json(g.to, ps);
      }
      geoms.push_back(gj);
    }
    body["geoms"] = geoms;
    bodies.push_back(body);
  }
  j["skeleton"] = {{"bodies", bodies}};

  json positions = json::array(), rotations = json::array(), masks = json::array(), contacts = json::array();
  for (int f = 0; f < r.num_frames(); ++f) {
    const auto fi = static_cast<std::size_t>(f);
    json p = json::array(), q = json::array();
    for (int b = 0; b < s.num_bodies(); ++b) {
      for (int k = 0; k < 3; ++k) p.push_back(detail::rounded(r.positions[fi](k, b), ps));
      Quat qb = r.rotations[fi][static_cast<std::size_t>(b)].normalized();
      if (qb.w() < 0) qb.coeffs() = -qb.coeffs();  // canonical hemisphere: w ≥ 0
      for (int k = 0; k < 4; ++k) q.push_back(detail::rounded(qb.coeffs()[k], qs));  // x, y, z, w
    }
    positions.push_back(std::move(p));
    rotations.push_back(std::move(q));
    masks.push_back(static_cast<int>(r.masks[fi].bits));
    contacts.push_back(r.contacts[fi].empty() ? json(nullptr) : json(r.contacts[fi]));
  }
  j["frames"] = {{"positions", positions}, {"rotations", rotations}, {"masks", masks}, {"contacts", contacts}};

  json texts = json::array();
  for (const auto& t : r.texts) texts.push_back({{"t", t.t}, {"text", t.text}});
  j["texts"] = texts;
  if (r.goals) {
    json targets = json::array();
    for (const auto& t : r.goals->targets) {
      if (t.cols() == 0) {
        targets.push_back(nullptr);
        continue;
      }
      json row = json::array();
      for (Index c = 0; c < t.cols(); ++c)
        for (int k = 0; k < 3; ++k) row.push_back(detail::rounded(t(k, c), ps));
      targets.push_back(std::move(row));
    }
    j["goals"] = {{"bodies", r.goals->bodies}, {"targets", targets}};
  } else {
    j["goals"] = nullptr;
  }
  if (r.scene) {
    const auto& sc = *r.scene;
    const auto quat_json = [qs](const Quat& q0) {
      Quat q = q0.normalized();
      if (q.w() < 0) q.coeffs() = -q.coeffs();  // canonical hemisphere: w ≥ 0
      return json::array({detail::rounded(q.x(), qs), detail::rounded(q.y(), qs), detail::rounded(q.z(), qs),
                          detail::rounded(q.w(), qs)});
    };
    json objects = json::array();
    for (const auto& o : sc.objects) {
      json pj = json::array(), qj = json::array();
      for (const auto& p : o.positions) pj.push_back(detail::vec3_json(p, ps));
      for (const auto& q : o.rotations) qj.push_back(quat_json(q));
      objects.push_back({{"name", o.name}, {"type", "box"}, {"half_size", detail::vec3_json(o.half_size, ps)},
                         {"positions", std::move(pj)}, {"rotations", std::move(qj)}});
    }
    json targets = nullptr, arrows = nullptr;
    if (!sc.targets.empty()) {
      targets = json::array();
      for (const auto& frame : sc.targets) {
        json row = json::array();
        for (const auto& t : frame)
          row.push_back({{"position", detail::vec3_json(t.position, ps)}, {"radius", detail::rounded(t.radius, ps)}});
        targets.push_back(std::move(row));
      }
    }
    if (!sc.arrows.empty()) {
      arrows = json::array();
      for (const auto& frame : sc.arrows) {
        json row = json::array();
        for (const auto& a : frame)
          row.push_back({{"origin", detail::vec3_json(a.origin, ps)},
                         {"direction", detail::vec3_json(a.direction, qs)},
                         {"speed", detail::rounded(a.speed, ps)}});
        arrows.push_back(std::move(row));
      }
    }
    j["scene"] = {{"objects", std::move(objects)}, {"targets", std::move(targets)}, {"arrows", std::move(arrows)}};
  } else {
    j["scene"] = nullptr;
  }
  return j;
}

namespace detail {
struct JsonReader {
  std::string file;
  [[noreturn]] void fail(const std::string& field, const std::string& msg) const {
    throw Error(msg, {file, std::nullopt, field});
  }
  const nlohmann::json& at(const nlohmann::json& j, const std::string& key, const std::string& field) const {
    if (!j.is_object()) fail(field, "expected an object");
    auto it = j.find(key);
    if (it == j.end()) fail(field.empty() ? key : field + "." + key, "missing field");
    return *it;
  }
  double number(const nlohmann::json& v, const std::string& field) const {
    if (!v.is_number()) fail(field, "expected a number, got " + std::string(v.type_name()));
    const double x = v.get<double>();
    if (!std::isfinite(x)) fail(field, "expected a finite number");
    return x;
  }
  long long integer(const nlohmann::json& v, const std::string& field) const {
    if (!v.is_number_integer()) fail(field, "expected an integer, got " + std::string(v.type_name()));
    return v.get<long long>();
  }
  std::string string(const nlohmann::json& v, const std::string& field) const {
    if (!v.is_string()) fail(field, "expected a string, got " + std::string(v.type_name()));
    return v.get<std::string>();
  }
  const nlohmann::json& array(const nlohmann::json& v, const std::string& field, std::optional<std::size_t> size = {}) const {
    if (!v.is_array()) fail(field, "expected an array, got " + std::string(v.type_name()));
    if (size && v.size() != *size)
      fail(field, "expected " + std::to_string(*size) + " elements, got " + std::to_string(v.size()));
    return v;
  }
  Vec3 vec3(const nlohmann::json& v, const std::string& field) const {
    array(v, field, 3);
    return {number(v[0], field + "[0]"), number(v[1], field + "[1]"), number(v[2], field + "[2]")};
  }
};
}  // namespace detail

/// Parses a rollout document; `file` only labels errors. Throws maskadapt::Error naming the field.
inline Rollout rollout_from_json(const nlohmann::json& j, const std::string& file = {}) {
  detail::JsonReader rd{file};
  if (!j.is_object()) rd.fail("", "expected a JSON object");
  if (rd.string(rd.at(j, "format", ""), "format") != kRolloutFormat)
    rd.fail("format", std::string("not a rollout file (expected \"") + kRolloutFormat + "\")");
  const long long version = rd.integer(rd.at(j, "version", ""), "version");
  if (version != kRolloutVersion)
    rd.fail("version", "unsupported version " + std::to_string(version) + " (this reader reads " +
                           std::to_string(kRolloutVersion) + ")");
  Rollout r;
  r.fps = rd.number(rd.at(j, "fps", ""), "fps");

  const auto& bodies = rd.array(rd.at(rd.at(j, "skeleton", ""), "bodies", "skeleton"), "skeleton.bodies");
  const int nb = static_cast<int>(bodies.size());
  auto& s = r.skeleton;
  s.offsets.resize(3, nb);
  for (int b = 0; b < nb; ++b) {
    const std::string f = "skeleton.bodies[" + std::to_string(b) + "]";
    const auto& bj = bodies[static_cast<std::size_t>(b)];
    s.names.push_back(rd.string(rd.at(bj, "name", f), f + ".name"));
    s.parents.push_back(static_cast<int>(rd.integer(rd.at(bj, "parent", f), f + ".parent")));
    const std::string part = rd.string(rd.at(bj, "part", f), f + ".part");
    int p = 0;
    while (p < kNumParts && kPartNames[static_cast<std::size_t>(p)] != part) ++p;
    if (p == kNumParts) rd.fail(f + ".part", "unknown body part '" + part + "'");
    s.parts.push_back(static_cast<BodyPart>(p));
    s.offsets.col(b) = rd.vec3(rd.at(bj, "offset", f), f + ".offset");
    std::vector<RolloutGeom> geoms;
    const auto& gs = rd.array(rd.at(bj, "geoms", f), f + ".geoms");
    for (std::size_t k = 0; k < gs.size(); ++k) {
      const std::string gf = f + ".geoms[" + std::to_string(k) + "]";
      const std::string type = rd.string(rd.at(gs[k], "type", gf), gf + ".type");
      RolloutGeom g;
      if (type == "capsule") {
        g.type = RolloutGeom::Type::Capsule;
        g.from = rd.vec3(rd.at(gs[k], "from", gf), gf + ".from");
        g.to = rd.vec3(rd.at(gs[k], "to", gf), gf + ".to");
        g.radius = rd.number(rd.at(gs[k], "radius", gf), gf + ".radius");
      } else if (type == "sphere") {
        g.type = RolloutGeom::Type::Sphere;
        g.from = rd.vec3(rd.at(gs[k], "center", gf), gf + ".center");
        g.radius = rd.number(rd.at(gs[k], "radius", gf), gf + ".radius");
      } else if (type == "box") {
        g.type = RolloutGeom::Type::Box;
        g.from = rd.vec3(rd.at(gs[k], "center", gf), gf + ".center");
        g.to = rd.vec3(rd.at(gs[k], "half_size", gf), gf + ".half_size");
      } else {
        rd.fail(gf + ".type", "unknown geom type '" + type + "' (capsule, sphere, box)");
      }
      geoms.push_back(g);
    }
    s.geoms.push_back(std::move(geoms));
  }

  const auto& frames = rd.at(j, "frames", "");
  const auto& pos = rd.array(rd.at(frames, "positions", "frames"), "frames.positions");
  const std::size_t nf = pos.size();
  const auto& rot = rd.array(rd.at(frames, "rotations", "frames"), "frames.rotations", nf);
  const auto& masks = rd.array(rd.at(frames, "masks", "frames"), "frames.masks", nf);
  const auto& contacts = rd.array(rd.at(frames, "contacts", "frames"), "frames.contacts", nf);
  const auto unb = static_cast<std::size_t>(nb);
  for (std::size_t f = 0; f < nf; ++f) {
    const std::string idx = "[" + std::to_string(f) + "]";
    const auto& pf = rd.array(pos[f], "frames.positions" + idx, 3 * unb);
    const auto& qf = rd.array(rot[f], "frames.rotations" + idx, 4 * unb);
    Matrix3X p(3, nb);
    std::vector<Quat> q(unb);
    for (std::size_t b = 0; b < unb; ++b) {
      for (std::size_t k = 0; k < 3; ++k)
        p(static_cast<Index>(k), static_cast<Index>(b)) = rd.number(pf[3 * b + k], "frames.positions" + idx);
      for (std::size_t k = 0; k < 4; ++k) q[b].coeffs()[static_cast<Index>(k)] = rd.number(qf[4 * b + k], "frames.rotations" + idx);
    }
    r.positions.push_back(std::move(p));
    r.rotations.push_back(std::move(q));
    const long long m = rd.integer(masks[f], "frames.masks" + idx);
    if (m < 0 || m > PartMask::all().bits) rd.fail("frames.masks" + idx, "mask must be in [0, 31], got " + std::to_string(m));
    r.masks.push_back(PartMask{static_cast<std::uint8_t>(m)});
    std::vector<std::uint8_t> c;
    if (!contacts[f].is_null()) {
      const auto& cf = rd.array(contacts[f], "frames.contacts" + idx, unb);
      for (const auto& v : cf) {
        const long long x = rd.integer(v, "frames.contacts" + idx);
        if (x != 0 && x != 1) rd.fail("frames.contacts" + idx, "contact flags must be 0 or 1");
        c.push_back(static_cast<std::uint8_t>(x));
      }
    }
    r.contacts.push_back(std::move(c));
  }

  if (auto it = j.find("texts"); it != j.end() && !it->is_null()) {
    rd.array(*it, "texts");
    for (std::size_t k = 0; k < it->size(); ++k) {
      const std::string f = "texts[" + std::to_string(k) + "]";
      r.texts.push_back({rd.number(rd.at((*it)[k], "t", f), f + ".t"), rd.string(rd.at((*it)[k], "text", f), f + ".text")});
    }
  }
  if (auto it = j.find("goals"); it != j.end() && !it->is_null()) {
    RolloutGoals g;
    const auto& gb = rd.array(rd.at(*it, "bodies", "goals"), "goals.bodies");
    for (const auto& b : gb) g.bodies.push_back(static_cast<int>(rd.integer(b, "goals.bodies")));
    const auto& gt = rd.array(rd.at(*it, "targets", "goals"), "goals.targets", nf);
    const std::size_t k = g.bodies.size();
    for (std::size_t f = 0; f < nf; ++f) {
      const std::string fld = "goals.targets[" + std::to_string(f) + "]";
      if (gt[f].is_null()) {
        g.targets.emplace_back(3, 0);
        continue;
      }
      const auto& row = rd.array(gt[f], fld, 3 * k);
      Matrix3X t(3, static_cast<Index>(k));
      for (std::size_t c = 0; c < 3 * k; ++c) t(static_cast<Index>(c % 3), static_cast<Index>(c / 3)) = rd.number(row[c], fld);
      g.targets.push_back(std::move(t));
    }
    r.goals = std::move(g);
  }
  if (auto it = j.find("scene"); it != j.end() && !it->is_null()) {
    if (!it->is_object()) rd.fail("scene", "expected an object or null, got " + std::string(it->type_name()));
    RolloutScene sc;
    const auto ix = [](std::size_t i) { return "[" + std::to_string(i) + "]"; };
    if (auto o = it->find("objects"); o != it->end() && !o->is_null()) {
      rd.array(*o, "scene.objects");
      for (std::size_t i = 0; i < o->size(); ++i) {
        const std::string f = "scene.objects" + ix(i);
        const auto& oj = (*o)[i];
        RolloutObject ob;
        ob.name = rd.string(rd.at(oj, "name", f), f + ".name");
        if (auto ty = oj.find("type"); ty != oj.end() && rd.string(*ty, f + ".type") != "box")
          rd.fail(f + ".type", "unknown object type '" + ty->get<std::string>() + "' (box)");
        ob.half_size = rd.vec3(rd.at(oj, "half_size", f), f + ".half_size");
        const auto& pj = rd.array(rd.at(oj, "positions", f), f + ".positions", nf);
        const auto& qj = rd.array(rd.at(oj, "rotations", f), f + ".rotations", nf);
        for (std::size_t t = 0; t < nf; ++t) {
          ob.positions.push_back(rd.vec3(pj[t], f + ".positions" + ix(t)));
          const std::string qf = f + ".rotations" + ix(t);
          const auto& q = rd.array(qj[t], qf, 4);
          Quat qq;
          for (std::size_t k = 0; k < 4; ++k) qq.coeffs()[static_cast<Index>(k)] = rd.number(q[k], qf + ix(k));
          ob.rotations.push_back(qq);
        }
        sc.objects.push_back(std::move(ob));
      }
    }
    if (auto tg = it->find("targets"); tg != it->end() && !tg->is_null()) {
      rd.array(*tg, "scene.targets", nf);
      for (std::size_t t = 0; t < nf; ++t) {
        std::vector<RolloutTarget> row;
        if (!(*tg)[t].is_null()) {
          const std::string f = "scene.targets" + ix(t);
          const auto& rj = rd.array((*tg)[t], f);
          for (std::size_t k = 0; k < rj.size(); ++k) {
            const std::string e = f + ix(k);
            row.push_back({rd.vec3(rd.at(rj[k], "position", e), e + ".position"), rd.number(rd.at(rj[k], "radius", e), e + ".radius")});
          }
        }
        sc.targets.push_back(std::move(row));
      }
    }
    if (auto ar = it->find("arrows"); ar != it->end() && !ar->is_null()) {
      rd.array(*ar, "scene.arrows", nf);
      for (std::size_t t = 0; t < nf; ++t) {
        std::vector<RolloutArrow> row;
        if (!(*ar)[t].is_null()) {
          const std::string f = "scene.arrows" + ix(t);
          const auto& rj = rd.array((*ar)[t], f);
          for (std::size_t k = 0; k < rj.size(); ++k) {
            const std::string e = f + ix(k);
            row.push_back({rd.vec3(rd.at(rj[k], "origin", e), e + ".origin"), rd.vec3(rd.at(rj[k], "direction", e), e + ".direction"),
                           rd.number(rd.at(rj[k], "speed", e), e + ".speed")});
          }
        }
        sc.arrows.push_back(std::move(row));
      }
    }
    r.scene = std::move(sc);
  }
  if (auto it = j.find("metadata"); it != j.end() && it->is_object()) {
    for (auto m = it->begin(); m != it->end(); ++m) {
      if (m.key() == "command" && m->is_string()) r.metadata.command = m->get<std::string>();
      else if (m.key() == "checkpoint" && m->is_string()) r.metadata.checkpoint = m->get<std::string>();
      else if (m.key() == "seed" && m->is_number_integer()) r.metadata.seed = m->get<std::int64_t>();
      else if (m->is_string()) r.metadata.extra[m.key()] = m->get<std::string>();
    }
  }
  try {
    validate(r);
  } catch (const Error& e) {
    throw Error(e.message(), {file, std::nullopt, e.context().field});
  }
  return r;
}

/// Writes `r` as JSON to `path` atomically (temporary file + rename). Creates parent directories.
inline void write_rollout(const Rollout& r, const std::string& path, int decimals = 5) {
  const std::string text = to_json(r, decimals).dump();
  const std::filesystem::path p(path);
  if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path());
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    require(static_cast<bool>(out), "cannot open for writing", {tmp, std::nullopt, {}});
    out << text << '\n';
    out.flush();
    require(static_cast<bool>(out), "write failed", {tmp, std::nullopt, {}});
  }
  std::error_code ec;
  std::filesystem::rename(tmp, p, ec);
  if (ec) {
    std::remove(tmp.c_str());
    throw Error("cannot rename temporary file: " + ec.message(), {path, std::nullopt, {}});
  }
}

/// Reads a rollout file written by write_rollout (or any producer following docs/viewer.md).
inline Rollout read_rollout(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  require(static_cast<bool>(in), "cannot open rollout file", {path, std::nullopt, {}});
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw Error(std::string("malformed JSON: ") + e.what(), {path, std::nullopt, {}});
  }
  return rollout_from_json(j, path);
}

}  // namespace maskadapt::eval
