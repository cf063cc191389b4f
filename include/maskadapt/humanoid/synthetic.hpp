#pragma once
/// \file synthetic.hpp
/// Built-in clips generated procedurally for the reference humanoid, so that a machine without
/// any motion files can run every example: a walk cycle, arm circles, alternating front kicks and
/// a jump in place. Feet are placed by inverse kinematics: a stance foot is planted flat on the
/// floor (no skating by construction), swing feet follow smooth arcs; every clip is grounded.
///
/// `builtin_motion_set(name)` gathers clips for a purpose (real sets such as "bandai-locomotion":
/// motion_set_specs): "locomotion" (the CMU walks/runs when
/// MASKADAPT_DATA_DIR has them, else the synthetic walk), "synthetic" (all four), or one of
/// "walk", "arms", "kick", "jump".
#include <maskadapt/core/error.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/geometry.hpp>
#include <maskadapt/humanoid/retarget.hpp>
#include <maskadapt/motion/rotation.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

namespace maskadapt {
namespace synth_detail {

constexpr double kPi = std::numbers::pi;

/// Smooth 0 → 1 on [0, 1] (C¹), clamped outside.
inline double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

/// Sets body b's joint so that its world rotation is `desired` (given the parents' current
/// rotations), within limits, continuous with its current angles.
inline void set_world_rotation(const Skeleton& s, KinematicState& st, int b, const Quat& desired) {
  const BodyStates bs = forward_kinematics(s, st);
  const Quat local = bs.rot[s.parents[b]].conjugate() * desired;
  s.require_xyz_hinges(b, "set_world_rotation");
  const int k = s.dof_offset(b);
  st.q.segment<3>(k) =
      joint_angles_within(local, st.q.segment<3>(k), s.lower_limits().segment<3>(k), s.upper_limits().segment<3>(k));
}

/// Leg IK: hip roll/pitch and knee pitch placing the ankle joint at `target` (world), Newton
/// iterations with a finite-difference Jacobian, warm-started from the current angles.
inline void leg_ik(const Skeleton& s, KinematicState& st, int hip, int knee, int ankle, const Vec3& target) {
  s.require_xyz_hinges(hip, "leg_ik");
  s.require_xyz_hinges(knee, "leg_ik");
  const int kh = s.dof_offset(hip), kk = s.dof_offset(knee);
  int idx[3] = {kh, kh + 1, kk + 1};
  auto clamp_limits = [&] {
    for (int i = 0; i < 3; ++i) st.q[idx[i]] = std::clamp(st.q[idx[i]], s.dof_lower(idx[i]), s.dof_upper(idx[i]));
    st.q[kk + 1] = std::max(st.q[kk + 1], 0.02);  // keep the knee on its forward-bending branch
  };
  BodyStates bs;
  for (int it = 0; it < 30; ++it) {
    forward_kinematics(s, st, bs);
    const Vec3 err = target - bs.pos.col(ankle);
    if (err.norm() < 1e-7) break;
    Mat3 J;
    for (int i = 0; i < 3; ++i) {
      KinematicState p = st;
      p.q[idx[i]] += 1e-6;
      BodyStates pb;
      forward_kinematics(s, p, pb);
      J.col(i) = (pb.pos.col(ankle) - bs.pos.col(ankle)) / 1e-6;
    }
    const Vec3 dq = (J.transpose() * J + 1e-6 * Mat3::Identity()).ldlt().solve(J.transpose() * err);
    for (int i = 0; i < 3; ++i) st.q[idx[i]] += std::clamp(dq[i], -0.3, 0.3);
    clamp_limits();
  }
}

/// Arms hanging (slightly abducted), swung by `swing` (rad, + = forward for the left arm).
inline void arms_down(const Skeleton& s, KinematicState& st, const Quat& heading, double swing_left,
                      double swing_right, double elbow) {
  set_world_rotation(s, st, hb::LShoulder,
                     heading * Quat(Eigen::AngleAxisd(-swing_left, Vec3::UnitY())) * Quat(Eigen::AngleAxisd(-1.4, Vec3::UnitX())));
  set_world_rotation(s, st, hb::RShoulder,
                     heading * Quat(Eigen::AngleAxisd(-swing_right, Vec3::UnitY())) * Quat(Eigen::AngleAxisd(1.4, Vec3::UnitX())));
  st.q[s.dof_offset(hb::LElbow) + 2] = -elbow;
  st.q[s.dof_offset(hb::RElbow) + 2] = elbow;
}

/// Feet flat (world rotation = heading) unless `pitch` tilts them (rad, + = toes down).
inline void feet_flat(const Skeleton& s, KinematicState& st, const Quat& heading, double pitch_l = 0, double pitch_r = 0) {
  set_world_rotation(s, st, hb::LAnkle, heading * Quat(Eigen::AngleAxisd(pitch_l, Vec3::UnitY())));
  set_world_rotation(s, st, hb::RAnkle, heading * Quat(Eigen::AngleAxisd(pitch_r, Vec3::UnitY())));
}

/// Puts the lowest foot point of the whole clip on z = 0.
inline void ground(MotionClip& c) {
  const auto& d = humanoid_description();
  BodyStates bs;
  double zmin = 1e300;
  for (int t = 0; t < c.num_frames(); ++t) {
    forward_kinematics(d.skeleton, c.frame(t), bs);
    for (int f : d.foot_bodies()) zmin = std::min(zmin, geometry::lowest_point(d, bs, f));
  }
  c.root_pos.row(2).array() -= zmin;
}

/// Ankle-joint height above the floor when the foot is flat.
inline double ankle_height() {
  const Geom& sole = humanoid_description().bodies[hb::LAnkle].geoms.at(0);
  return sole.b.z() - sole.a.z();  // box: centre below the joint, half height
}

}  // namespace synth_detail

/// Walk cycle along +x: 0.9 m/s, one 1 s stride cycle (31 frames at 30 Hz, looping), 60 % stance.
inline MotionClip synthetic_walk(double speed = 0.9, double period = 1.0) {
  using namespace synth_detail;
  const Skeleton& s = humanoid_skeleton();
  const double fps = 30.0;
  const int T = static_cast<int>(std::lround(period * fps)) + 1;
  MotionClip c;
  c.name = "synthetic_walk";
  c.labels = {"walk forward", "walk"};
  c.description = "procedural walk cycle (maskadapt synthetic.hpp)";
  c.fps = fps;
  c.loop = true;
  c.resize(T, s.num_dofs());
  const double stride = speed * period, duty = 0.6, ah = ankle_height();
  const BodyStates zero = forward_kinematics(s, KinematicState::zero(s));
  KinematicState st = KinematicState::zero(s);
  for (int b : {hb::LKnee, hb::RKnee}) st.q[s.dof_offset(b) + 1] = 0.2;
  for (int pass = 0; pass < 2; ++pass)  // pass 0 warms the IK up so that frame 0 equals the last
    for (int t = 0; t < T; ++t) {
      const double time = t / fps, ph = time / period;
      const double yaw = 0.06 * std::sin(2 * kPi * ph);
      const Quat heading = Quat::Identity();
      st.root_pos = Vec3(speed * time, 0.02 * std::sin(2 * kPi * (ph - 0.3)), 0.868 + 0.012 * std::cos(4 * kPi * (ph - 0.3)));
      st.root_rot = Quat(Eigen::AngleAxisd(yaw, Vec3::UnitZ()));
      for (int side = 0; side < 2; ++side) {
        const int hip = side == 0 ? hb::LHip : hb::RHip, knee = side == 0 ? hb::LKnee : hb::RKnee;
        const int ankle = side == 0 ? hb::LAnkle : hb::RAnkle;
        const double phase = ph + (side == 0 ? 0.0 : 0.5);
        const double cyc = std::floor(phase), f = phase - cyc;
        const Vec3 rest = zero.pos.col(ankle);  // (x, ±y) of the ankle under the hip
        // footprint of the stance that contains mid-stance at f = duty / 2
        double x, z = ah;
        if (f < duty) {
          x = speed * period * (cyc + duty / 2 - (side == 0 ? 0.0 : 0.5)) + rest.x();
        } else {
          const double sw = (f - duty) / (1 - duty);
          const double x0 = speed * period * (cyc + duty / 2 - (side == 0 ? 0.0 : 0.5)) + rest.x();
          x = x0 + stride * (0.5 - 0.5 * std::cos(kPi * sw));
          z = ah + 0.07 * std::sin(kPi * sw);
        }
        leg_ik(s, st, hip, knee, ankle, Vec3(x, rest.y(), z));
      }
      feet_flat(s, st, heading);
      const double swing = 0.35 * std::sin(2 * kPi * ph);  // left arm forward when the right leg is
      arms_down(s, st, heading, -swing, swing, 0.3);
      if (pass == 1) c.set_frame(t, st);
    }
  ground(c);
  return c;
}

/// Arm circles while standing: both arms out to the side, hands drawing circles (1.5 s period,
/// two circles, looping).
inline MotionClip synthetic_arm_circles(double period = 1.5, double cone = 0.5) {
  using namespace synth_detail;
  const Skeleton& s = humanoid_skeleton();
  const double fps = 30.0;
  const int T = static_cast<int>(std::lround(2 * period * fps)) + 1;
  MotionClip c;
  c.name = "synthetic_arm_circles";
  c.labels = {"rotate arms", "arm circles"};
  c.description = "procedural arm circles (maskadapt synthetic.hpp)";
  c.fps = fps;
  c.loop = true;
  c.resize(T, s.num_dofs());
  KinematicState st = KinematicState::zero(s);
  for (int t = 0; t < T; ++t) {
    const double w = 2 * kPi * t / fps / period;
    st.root_pos = Vec3(0, 0, humanoid_description().root_height);
    const Vec3 dl = (Vec3::UnitY() + cone * Vec3(std::cos(w), 0, std::sin(w))).normalized();
    const Vec3 dr = (-Vec3::UnitY() + cone * Vec3(std::cos(w), 0, std::sin(w))).normalized();
    set_world_rotation(s, st, hb::LShoulder, Quat::FromTwoVectors(Vec3::UnitY(), dl));
    set_world_rotation(s, st, hb::RShoulder, Quat::FromTwoVectors(-Vec3::UnitY(), dr));
    c.set_frame(t, st);
  }
  ground(c);
  return c;
}

/// Alternating front kicks, right then left (1.2 s each, looping), stance foot planted.
inline MotionClip synthetic_kick(double kick_time = 1.2) {
  using namespace synth_detail;
  const Skeleton& s = humanoid_skeleton();
  const double fps = 30.0;
  const int T = static_cast<int>(std::lround(2 * kick_time * fps)) + 1;
  MotionClip c;
  c.name = "synthetic_kick";
  c.labels = {"kick", "front kick"};
  c.description = "procedural alternating front kicks (maskadapt synthetic.hpp)";
  c.fps = fps;
  c.loop = true;
  c.resize(T, s.num_dofs());
  KinematicState st = KinematicState::zero(s);
  const BodyStates zero = forward_kinematics(s, KinematicState::zero(s));
  const double stand = humanoid_description().root_height - 0.01;  // knees soft
  for (int t = 0; t < T; ++t) {
    const double time = t / fps;
    const int which = time < kick_time ? 0 : 1;  // 0: right leg kicks, 1: left
    const double u = std::min((time - which * kick_time) / kick_time, 1.0);
    // kick between u = 0.15 and 0.85
    const double k = std::clamp((u - 0.15) / 0.7, 0.0, 1.0);
    const double lift = std::pow(std::sin(kPi * k), 2);
    const double ext = std::exp(-std::pow((k - 0.5) / 0.12, 2));
    st.q.setZero();
    st.root_pos = Vec3(0, 0, stand);
    st.root_rot = Quat(Eigen::AngleAxisd(-0.15 * lift, Vec3::UnitY()));  // lean back a little
    const int hip = which == 0 ? hb::RHip : hb::LHip, knee = which == 0 ? hb::RKnee : hb::LKnee;
    // both legs planted by IK, then the kicking leg's hip and knee add the kick on top
    for (int side = 0; side < 2; ++side) {
      const int h = side == 0 ? hb::LHip : hb::RHip, kn = side == 0 ? hb::LKnee : hb::RKnee;
      const int an = side == 0 ? hb::LAnkle : hb::RAnkle;
      st.q[s.dof_offset(kn) + 1] = 0.2;
      st.q[s.dof_offset(h) + 1] = 0.0;
      leg_ik(s, st, h, kn, an, Vec3(zero.pos.col(an)) + Vec3(0, 0, stand));
    }
    const double chamber = std::sin(kPi * k);  // the knee bends quickly so the foot leaves the floor
    st.q[s.dof_offset(hip) + 1] += -1.35 * lift;
    st.q[s.dof_offset(knee) + 1] += 1.5 * chamber * (1 - 0.85 * ext);
    for (int b : {hb::Torso, hb::Spine}) st.q[s.dof_offset(b) + 1] = 0.08 * lift;
    arms_down(s, st, Quat::Identity(), 0.2 * lift * (which == 0 ? 1 : -1), -0.2 * lift * (which == 0 ? 1 : -1), 1.2);
    // the stance foot stays planted where it stood in the zero pose (IK), and flat
    {
      const int ship = which == 0 ? hb::LHip : hb::RHip, sknee = which == 0 ? hb::LKnee : hb::RKnee;
      const int sankle = which == 0 ? hb::LAnkle : hb::RAnkle;
      st.q[s.dof_offset(sknee) + 1] = 0.2;
      leg_ik(s, st, ship, sknee, sankle, Vec3(zero.pos.col(sankle)) + Vec3(0, 0, stand));
    }
    feet_flat(s, st, Quat::Identity(), 0, 0);
    // the kicking foot points its toes (+ pitch) with the extension
    {
      const int ankle = which == 0 ? hb::RAnkle : hb::LAnkle;
      const int k2 = s.dof_offset(ankle) + 1;
      st.q[k2] = std::min(st.q[k2] + 0.5 * lift, s.dof_upper(k2));
    }
    c.set_frame(t, st);
  }
  ground(c);
  return c;
}

/// A jump in place: crouch, push, 0.2 m flight, landing, recovery (2 s, not looping).
inline MotionClip synthetic_jump(double apex = 0.2) {
  using namespace synth_detail;
  const Skeleton& s = humanoid_skeleton();
  const double fps = 30.0, g = 9.81;
  const double stand = 0.90, low = 0.74, takeoff_h = 0.925;
  const double v0 = std::sqrt(2 * g * apex);
  const double t_crouch0 = 0.3, t_crouch1 = 0.75, t_push1 = 0.95;
  const double t_land = t_push1 + 2 * v0 / g, t_absorb = t_land + 0.3, t_end = t_absorb + 0.6;
  const int T = static_cast<int>(std::lround(t_end * fps)) + 1;
  MotionClip c;
  c.name = "synthetic_jump";
  c.labels = {"jump", "jump in place"};
  c.description = "procedural vertical jump (maskadapt synthetic.hpp)";
  c.fps = fps;
  c.loop = false;
  c.resize(T, s.num_dofs());
  const double ah = ankle_height();
  const BodyStates zero = forward_kinematics(s, KinematicState::zero(s));
  KinematicState st = KinematicState::zero(s);
  for (int b : {hb::LKnee, hb::RKnee}) st.q[s.dof_offset(b) + 1] = 0.2;
  for (int t = 0; t < T; ++t) {
    const double time = t / fps;
    double z, lean, arms;
    if (time < t_crouch0) {
      z = stand, lean = 0, arms = 0;
    } else if (time < t_crouch1) {
      const double a = smoothstep((time - t_crouch0) / (t_crouch1 - t_crouch0));
      z = stand + (low - stand) * a, lean = 0.35 * a, arms = -0.6 * a;
    } else if (time < t_push1) {
      const double a = smoothstep((time - t_crouch1) / (t_push1 - t_crouch1));
      z = low + (takeoff_h - low) * a, lean = 0.35 * (1 - a), arms = -0.6 + 1.4 * a;
    } else if (time < t_land) {
      const double tau = time - t_push1;
      z = takeoff_h + v0 * tau - 0.5 * g * tau * tau, lean = 0, arms = 0.8;
    } else if (time < t_absorb) {
      const double a = std::sin(0.5 * kPi * (time - t_land) / (t_absorb - t_land));
      z = takeoff_h + (low + 0.04 - takeoff_h) * a, lean = 0.3 * a, arms = 0.8 * (1 - a);
    } else {
      const double a = smoothstep((time - t_absorb) / (t_end - t_absorb));
      z = low + 0.04 + (stand - low - 0.04) * a, lean = 0.3 * (1 - a), arms = 0;
    }
    st.root_pos = Vec3(0, 0, z);
    st.root_rot = Quat(Eigen::AngleAxisd(lean, Vec3::UnitY()));
    for (int side = 0; side < 2; ++side) {
      const int hip = side == 0 ? hb::LHip : hb::RHip, knee = side == 0 ? hb::LKnee : hb::RKnee;
      const int ankle = side == 0 ? hb::LAnkle : hb::RAnkle;
      const Vec3 rest = zero.pos.col(ankle);
      // feet stay on the floor until the hips are too high for bent legs, then hang below
      const double az = std::max(ah, z - takeoff_h + ah);
      leg_ik(s, st, hip, knee, ankle, Vec3(rest.x() + 0.02, rest.y(), az));
    }
    feet_flat(s, st, Quat::Identity());
    arms_down(s, st, Quat::Identity(), arms, arms, 0.3);
    c.set_frame(t, st);
  }
  ground(c);
  return c;
}

/// A built-in clip by name: "walk", "arms", "kick", "jump" (also accepted with "synthetic:").
inline MotionClip synthetic_clip(std::string name) {
  if (name.rfind("synthetic:", 0) == 0) name = name.substr(10);
  if (name == "walk") return synthetic_walk();
  if (name == "arms" || name == "arm_circles" || name == "rotate_arms") return synthetic_arm_circles();
  if (name == "kick") return synthetic_kick();
  if (name == "jump") return synthetic_jump();
  throw Error("unknown synthetic clip '" + name + "' (expected walk, arms, kick, jump)", {{}, {}, "clip"});
}

/// The data directory: $MASKADAPT_DATA_DIR, else `fallback` (may be empty).
inline std::string motion_data_dir(const std::string& fallback = {}) {
  if (const char* e = std::getenv("MASKADAPT_DATA_DIR"); e && *e) return e;
  return fallback;
}

/// A named set of real clips in the shared data directory: every .bvh in `<data_dir>/<folder>`
/// whose file name contains one of `include` (all if empty) and none of `exclude`, sorted by name.
struct MotionSetSpec {
  std::string name;
  std::string folder;                ///< relative to the data directory
  std::vector<std::string> include;  ///< file-name substrings (any)
  std::vector<std::string> exclude;  ///< file-name substrings (none)
  std::string what;                  ///< one line for error messages and docs
};

/// The named sets of real motion capture (docs/motion.md). Bandai: "Bandai-Namco-Research-
/// Motiondataset (c) 2022 Bandai Namco Research Inc., licensed under CC BY-NC 4.0".
inline const std::vector<MotionSetSpec>& motion_set_specs() {
  static const std::vector<MotionSetSpec> specs = {
      {"bandai-locomotion", "motions/bandai/locomotion", {}, {}, "Bandai walks, runs and 90-degree turns (140 clips, 691 s)"},
      {"bandai-walk", "motions/bandai/locomotion", {"_walk"}, {}, "Bandai walks and walking turns, no runs (89 clips)"},
      {"bandai-walk-straight", "motions/bandai/locomotion", {"_walk_normal"}, {}, "Bandai straight walks (24 clips)"},
      {"bandai-turn", "motions/bandai/locomotion", {"_walk-turn-"}, {}, "Bandai walking turns left and right (65 clips)"},
      {"bandai-run", "motions/bandai/locomotion", {"_run_"}, {}, "Bandai runs (51 clips)"},
      {"bandai-gestures", "motions/bandai/gestures", {}, {}, "Bandai waving while standing (20 clips)"},
      {"bandai-actions", "motions/bandai/actions", {}, {}, "Bandai kicks and punches (3 clips)"},
      {"styles", "motions/styles", {}, {}, "boxing, jumping jacks, hops, a kick, walks, swim and wipe (12 clips)"},
      {"cmu-131", "motions/cmu-131", {}, {}, "CMU subject 131: start-walk-stop, start-hop-stop (3 clips)"},
  };
  return specs;
}

inline const MotionSetSpec* find_motion_set(const std::string& name) {
  for (const auto& s : motion_set_specs())
    if (s.name == name) return &s;
  return nullptr;
}

/// Text labels from a clip's file name (Bandai: "walk forward", "run forward", "walk and turn left", …).
inline std::vector<std::string> labels_from_file_name(const std::string& stem) {
  if (stem.find("walk-turn-left") != std::string::npos) return {"walk and turn left", "turn left", "walk"};
  if (stem.find("walk-turn-right") != std::string::npos) return {"walk and turn right", "turn right", "walk"};
  if (stem.find("run") != std::string::npos) return {"run forward", "run"};
  if (stem.find("walk") != std::string::npos) return {"walk forward", "walk"};
  if (stem.find("wave") != std::string::npos || stem.find("bye") != std::string::npos) return {"wave", "wave hand"};
  if (stem.find("kick") != std::string::npos) return {"kick"};
  if (stem.find("punch") != std::string::npos || stem.find("box") != std::string::npos) return {"punch", "box"};
  if (stem.find("hop") != std::string::npos) return {"hop", "jump in place"};
  if (stem.find("jump") != std::string::npos) return {"jump"};
  return {stem};
}

/// Loads a named set: throws naming the directory when it is missing or holds no matching clip.
inline std::vector<MotionClip> load_motion_set(const MotionSetSpec& spec, const std::string& data_dir) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(data_dir) / spec.folder;
  require(!data_dir.empty() && fs::is_directory(dir),
          "motion set '" + spec.name + "' (" + spec.what + ") needs the directory " + dir.string() +
              ": set MASKADAPT_DATA_DIR to the folder holding motions/",
          {dir.string(), std::nullopt, "motions"});
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() != ".bvh") continue;
    const std::string f = e.path().filename().string();
    bool in = spec.include.empty();
    for (const auto& s : spec.include) in = in || f.find(s) != std::string::npos;
    for (const auto& s : spec.exclude) in = in && f.find(s) == std::string::npos;
    if (in) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  require(!files.empty(), "motion set '" + spec.name + "': no matching .bvh files", {dir.string(), std::nullopt, "motions"});
  std::vector<MotionClip> out;
  out.reserve(files.size());
  for (const auto& f : files) {
    MotionClip c = import_motion(f.string());
    c.labels = labels_from_file_name(c.name);
    out.push_back(std::move(c));
  }
  return out;
}

/// Clips for a purpose (see file comment). CMU files are looked up in <data_dir>/motions/cmu;
/// the named real sets (motion_set_specs: `bandai-locomotion`, `bandai-walk`, …) in their folders.
inline std::vector<MotionClip> builtin_motion_set(const std::string& name, const std::string& data_dir = motion_data_dir()) {
  std::vector<MotionClip> out;
  if (name == "locomotion") {
    const std::filesystem::path dir = std::filesystem::path(data_dir) / "motions" / "cmu";
    for (const char* f : {"02_01_walk.bvh", "07_01_walk.bvh", "02_03_run.bvh", "09_11_run.bvh"}) {
      const auto p = dir / f;
      if (!data_dir.empty() && std::filesystem::exists(p)) {
        MotionClip c = import_motion(p.string());
        c.labels = {std::string(f).find("run") != std::string::npos ? "run forward" : "walk forward"};
        out.push_back(std::move(c));
      }
    }
    if (out.empty()) out.push_back(synthetic_walk());
    return out;
  }
  if (name == "synthetic") return {synthetic_walk(), synthetic_arm_circles(), synthetic_kick(), synthetic_jump()};
  if (const MotionSetSpec* spec = find_motion_set(name)) return load_motion_set(*spec, data_dir);
  if (name == "walk" || name == "arms" || name == "arm_circles" || name == "rotate_arms" || name == "kick" ||
      name == "jump" || name.rfind("synthetic:", 0) == 0) {
    out.push_back(synthetic_clip(name));
    return out;
  }
  std::string known = "locomotion, synthetic, walk, arms, kick, jump";
  for (const auto& s : motion_set_specs()) known += ", " + s.name;
  throw Error("unknown motion set '" + name + "' (expected one of: " + known + ")", {{}, std::nullopt, "motions"});
}

}  // namespace maskadapt
