// Writes real rollout files for the viewer's end-to-end test (and the docs screenshots) with the
// library's own writer: the reference humanoid's forward kinematics of an animated walk-like pose
// (not a trained policy), with the adapted parts switching halfway, ground contacts from the
// feet's height, text commands and wrist goal trajectories.
//
//   maskadapt_viewer_make_rollout OUT_DIR [SECONDS]
// writes OUT_DIR/rollout_a.json (legs adapted, then arms), OUT_DIR/rollout_b.json (the same
// walk with a different arm motion and no masks: the "other" side of a side-by-side comparison)
// and OUT_DIR/rollout_goals.json (rollout A with a goal-task scene: location target, heading
// arrow, strike box).
#include <maskadapt/eval/rollout_file.hpp>
#include <maskadapt/humanoid/description.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <numbers>
#include <stdexcept>

using namespace maskadapt;

namespace {

void set_joint(KinematicState& s, int body, double x, double y, double z) {
  s.q.segment<3>(humanoid_skeleton().dof_offset(body)) = Vec3(x, y, z);
}

// A stylised walk at ~1 m/s: hips and knees swing in antiphase, arms swing (variant 0) or wave
// above the head (variant 1). Angles in radians; pitch is about each body's left (+y) axis.
KinematicState walk_pose(double t, int variant) {
  KinematicState s = humanoid_standing_pose();
  const double w = 2.0 * std::numbers::pi * 0.9;  // stride frequency (Hz → rad/s)
  const double ph = w * t;
  s.root_pos.x() = 1.0 * t;
  s.root_pos.z() -= 0.03 + 0.015 * std::cos(2 * ph);
  s.root_rot = Quat(Eigen::AngleAxisd(0.15 * std::sin(0.3 * t), Vec3::UnitZ()));
  set_joint(s, hb::LHip, 0, -0.45 * std::sin(ph), 0);
  set_joint(s, hb::RHip, 0, 0.45 * std::sin(ph), 0);
  set_joint(s, hb::LKnee, 0, 0.35 + 0.35 * std::cos(ph), 0);
  set_joint(s, hb::RKnee, 0, 0.35 - 0.35 * std::cos(ph), 0);
  set_joint(s, hb::LAnkle, 0, -0.15 * std::cos(ph), 0);
  set_joint(s, hb::RAnkle, 0, 0.15 * std::cos(ph), 0);
  if (variant == 0) {  // arms down (rotate about the forward axis) and swinging
    set_joint(s, hb::LShoulder, -1.25, 0.4 * std::sin(ph), 0);
    set_joint(s, hb::RShoulder, 1.25, -0.4 * std::sin(ph), 0);
    set_joint(s, hb::LElbow, 0, 0, 0.3);
    set_joint(s, hb::RElbow, 0, 0, -0.3);
  } else {  // waving both hands above the head
    set_joint(s, hb::LShoulder, 1.1 + 0.3 * std::sin(3 * t), 0, 0);
    set_joint(s, hb::RShoulder, -1.1 - 0.3 * std::sin(3 * t), 0, 0);
    set_joint(s, hb::LElbow, 0.6 * std::sin(4 * t), 0, 0);
    set_joint(s, hb::RElbow, -0.6 * std::sin(4 * t), 0, 0);
  }
  return s;
}

eval::Rollout make(double seconds, int variant) {
  const Skeleton& skel = humanoid_skeleton();
  eval::Rollout r = eval::make_rollout(humanoid_description(), 30.0);
  r.metadata.command = "maskadapt_viewer_make_rollout (kinematic test animation, variant " + std::to_string(variant) + ")";
  r.metadata.seed = variant;
  r.metadata.extra["source"] = "forward kinematics of a scripted pose, not a trained policy";
  const int frames = static_cast<int>(std::lround(seconds * r.fps));
  eval::RolloutGoals goals;
  goals.bodies = {hb::LWrist, hb::RWrist};
  for (int f = 0; f < frames; ++f) {
    const double t = f / r.fps;
    const BodyStates bs = forward_kinematics(skel, walk_pose(t, variant));
    std::vector<std::uint8_t> contacts(static_cast<std::size_t>(skel.num_bodies()), 0);
    for (int b : {hb::LAnkle, hb::RAnkle, hb::LToe, hb::RToe}) contacts[static_cast<std::size_t>(b)] = bs.pos(2, b) < 0.09;
    const PartMask mask = variant == 1 ? PartMask::none() : (f < frames / 2 ? PartMask::parse("legs") : PartMask::parse("arms"));
    eval::add_frame(r, bs, mask, contacts);
    // Goals for the wrists: where the other variant's wrists are, 0.5 s ahead (a tracking target).
    const BodyStates target = forward_kinematics(skel, walk_pose(t + 0.5, 1 - variant));
    Matrix3X g(3, 2);
    g.col(0) = target.pos.col(hb::LWrist) - target.pos.col(0) + bs.pos.col(0);
    g.col(1) = target.pos.col(hb::RWrist) - target.pos.col(0) + bs.pos.col(0);
    goals.targets.push_back(g);
  }
  r.goals = goals;
  r.texts = {{0.0, variant == 0 ? "walk (legs adapted)" : "wave hands"}, {seconds / 2, variant == 0 ? "swing arms (arms adapted)" : "raise arms"}};
  return r;
}

// The walk of variant 0 with a goal-task scene (what play-residual writes for the location,
// heading and strike tasks): a location target (radius 0.5 m) ahead on the floor that jumps
// further on halfway, a heading arrow from the root (target speed 1 m/s, direction turning
// slowly) and the strike box (0.4 × 0.4 × 1.2 m) beside the path, tipping over after 2 s.
eval::Rollout make_goal_scene(double seconds) {
  eval::Rollout r = make(seconds, 0);
  r.metadata.command = "maskadapt_viewer_make_rollout (kinematic test animation with a goal-task scene)";
  eval::RolloutScene sc;
  eval::RolloutObject box{"strike_box", Vec3(0.2, 0.2, 0.6), {}, {}};
  for (int f = 0; f < r.num_frames(); ++f) {
    const double t = f / r.fps;
    const Vec3 root = r.positions[static_cast<std::size_t>(f)].col(0);
    sc.targets.push_back({{Vec3(f < r.num_frames() / 2 ? 2.0 : 4.5, -0.8, 0.0), 0.5}});
    sc.arrows.push_back({eval::heading_arrow(root, Vec3(std::cos(0.2 * t), std::sin(0.2 * t), 0.0), 1.0)});
    const double tilt = std::clamp((t - 2.0) * 1.5, 0.0, std::numbers::pi / 2);  // falls over in ~1 s
    // Tipping away from the path about its bottom edge at y = 1.4 (the box stands centred at
    // y = 1.2, 0.6 m high; a rotation about −x tilts its top towards +y).
    const Quat q(Eigen::AngleAxisd(-tilt, Vec3::UnitX()));
    box.positions.push_back(Vec3(2.5, 1.4, 0.0) + q * Vec3(0.0, -0.2, 0.6));
    box.rotations.push_back(q);
  }
  sc.objects.push_back(box);
  r.scene = sc;
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: " << argv[0] << " OUT_DIR [SECONDS]\n";
    return 2;
  }
  const std::string dir = argv[1];
  const double seconds = argc > 2 ? std::atof(argv[2]) : 4.0;
  try {
    eval::write_rollout(make(seconds, 0), dir + "/rollout_a.json");
    eval::write_rollout(make(seconds, 1), dir + "/rollout_b.json");
    eval::write_rollout(make_goal_scene(seconds), dir + "/rollout_goals.json");
    const eval::Rollout goals = eval::read_rollout(dir + "/rollout_goals.json");
    if (!goals.scene || goals.scene->objects.size() != 1 || static_cast<int>(goals.scene->targets.size()) != goals.num_frames())
      throw std::runtime_error("rollout_goals.json: scene did not survive the round trip");
    // Read back with the library's reader: what the viewer gets is what the library accepts.
    const eval::Rollout back = eval::read_rollout(dir + "/rollout_a.json");
    std::cout << "wrote " << dir << "/rollout_a.json, rollout_b.json and rollout_goals.json (" << back.num_frames() << " frames, "
              << back.skeleton.num_bodies() << " bodies)\n";
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
