// The native reference for the live viewer (tools/viewer/src/live/): what the page needs to run a
// shipped base policy in the browser, and recorded inputs/outputs of the C++ that the page's
// JavaScript must reproduce.
//
//   maskadapt_viewer_live_reference MODELS_DIR OUT_DIR
//
// writes
//   OUT_DIR/character_humanoid.json, OUT_DIR/character_g1.json — what the page needs of each
//       character besides its MJCF (assets/<name>.xml): MuJoCo body and joint names, the body
//       part of every body, physics step and substeps, the bodies that may touch the ground, the
//       head, and the start poses the page offers (KinematicState: root position, root rotation
//       x,y,z,w, joint angles, world root velocities, joint rates);
//   OUT_DIR/fixture_<model>.json — recorded steps of the native loop (examples/usage/
//       readme_example.cpp's loop, the one `maskadapt play --deterministic` runs): the body
//       states read out of MuJoCo 2.2.2, the mask, the observation s, the policy input [s̄ ; m],
//       the normalised input, the mean action and the PD targets, each as the C++ computed them;
//   OUT_DIR/native_<model>.json — `train::play_base_policy` (what `maskadapt play` runs) from
//       each start pose the page offers, 10 s, deterministic, per mask: distance walked in the
//       ground plane and falls. The browser's figures are compared with these (docs/viewer.md).
//
//   OUT_DIR/fixture_<stage-2 model>.json, OUT_DIR/native_<stage-2 model>.json — the same for the
//       stage-2 composition policies (adapt/residual_policy.hpp: base input, base mean, residual
//       input, normalised residual input, residual mean, composite mean, targets); the native
//       figures come from the same loop run for 10 s (what `maskadapt play-residual
//       --deterministic` computes per step).
//
// Models: mask_mi_walk_bandai, amp_walk_bandai (humanoid), g1_mask_mi_walk_bandai,
// g1_amp_walk_bandai (G1); stage 2: table2/swim_ours_s1, table2/kick_cut_ours_s1 (humanoid).
// Everything is deterministic (mean actions, fixed starts).
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/humanoid/synthetic.hpp>
#include <maskadapt/mask/apply.hpp>
#include <maskadapt/motion/library.hpp>
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/play.hpp>
#include <maskadapt/train/residual_config.hpp>

#include <nlohmann/json.hpp>

#include "live_reference_io.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

using namespace maskadapt;
using nlohmann::json;

using live_reference::body_states_json;
using live_reference::vec;

namespace {

json quat_xyzw(const Quat& q) { return json::array({q.x(), q.y(), q.z(), q.w()}); }

json pose_json(const KinematicState& s, const std::string& label) {
  return {{"label", label},
          {"root_pos", vec(s.root_pos)},
          {"root_rot_xyzw", quat_xyzw(s.root_rot)},
          {"q", vec(s.q)},
          {"root_lin_vel", vec(s.root_lin_vel)},
          {"root_ang_vel", vec(s.root_ang_vel)},
          {"qd", vec(s.qd)}};
}

void write_json(const std::filesystem::path& p, const json& j, int indent = 1) {
  live_reference::write_json_file("live_reference", p, j, indent);
}

/// Start poses the page offers for a character (label, pose).
std::vector<std::pair<std::string, KinematicState>> start_poses(const MujocoCharacter& ch) {
  std::vector<std::pair<std::string, KinematicState>> out;
  MotionLibrary walk(ch.skeleton);
  MotionClip clip = synthetic_walk();
  if (ch.from_humanoid) clip = ch.from_humanoid(clip);
  walk.add(clip);
  for (double t : {0.1, 0.3, 0.5, 0.7, 0.9}) {
    char label[64];
    std::snprintf(label, sizeof label, "synthetic walk, t = %.1f s", t);
    out.emplace_back(label, walk.state(0, t));
  }
  out.emplace_back("standing", ch.standing);
  return out;
}

json character_json(const MujocoCharacter& ch, const std::string& mjcf_file, double termination_height) {
  // The drawing: a one-frame viewer rollout (eval/rollout_file.hpp) of the first start pose; the
  // page moves its bodies to the simulated poses.
  eval::Rollout drawing = eval::make_rollout(ch);
  {
    MujocoHumanoidSim sim(1, 1, ch);
    sim.reset(0, start_poses(ch).front().second);
    eval::add_frame(drawing, sim.body_states(0), PartMask::none(), sim.contacts(0));
  }
  drawing.metadata.command = "live simulation";
  json bodies = json::array();
  for (int i = 0; i < ch.skeleton.num_bodies(); ++i)
    bodies.push_back({{"name", ch.skeleton.names[static_cast<std::size_t>(i)]},
                      {"part", std::string(part_name(ch.skeleton.parts[static_cast<std::size_t>(i)]))},
                      {"parent", ch.skeleton.parents[static_cast<std::size_t>(i)]}});
  json starts = json::array();
  for (const auto& [label, pose] : start_poses(ch)) starts.push_back(pose_json(pose, label));
  return {{"format", "maskadapt-live-character"},
          {"version", 1},
          {"name", ch.name},
          {"mjcf", mjcf_file},
          {"bodies", bodies},
          {"joint_names", ch.joint_names},
          {"physics_dt", ch.physics_dt},
          {"substeps", ch.substeps},
          {"ground_contacts", ch.ground_contacts},
          {"head", ch.head},
          {"termination_height", termination_height},
          {"part_names", json::array({"trunk", "left_arm", "right_arm", "left_leg", "right_leg"})},
          {"starts", starts},
          {"drawing", eval::to_json(drawing)}};
}

train::LoadedBasePolicy load(const std::string& path, const MujocoCharacter& ch) {
  const Index obs_dim = observation_dim(ch.skeleton);
  return train::load_base_policy(load_checkpoint(path),
                                 {obs_dim, policy_input_dim(obs_dim), ch.skeleton.num_dofs(), obs_dim * kAmpWindowFrames}, path);
}

/// Recorded steps of the native loop: 60 control steps from the first start, the mask changing
/// every 10 steps; steps 0, 7, 15, 26, 38, 52 recorded.
json fixture_json(const std::string& model_path, const std::string& model_name, const MujocoCharacter& ch) {
  const train::LoadedBasePolicy base = load(model_path, ch);
  const auto& actor = base.policy.ac.actor;
  MujocoHumanoidSim sim(1, 1, ch);
  const Skeleton& skel = sim.skeleton();
  const Index obs_dim = observation_dim(skel);
  const auto starts = start_poses(ch);
  sim.reset(0, starts.front().second);
  const PartElements parts(observation_parts(skel));
  const std::vector<PartMask> schedule = {PartMask::none(),
                                          PartMask::parse("left_leg,right_leg"),
                                          PartMask::parse("arms"),
                                          PartMask::parse("trunk,left_arm"),
                                          PartMask::parse("right_leg"),
                                          PartMask::parse("trunk,left_arm,right_leg")};
  const std::vector<int> recorded = {0, 7, 15, 26, 38, 52};
  MatrixXf obs(obs_dim, 1), input(policy_input_dim(obs_dim), 1), mean(skel.num_dofs(), 1), targets(skel.num_dofs(), 1),
      normalised;
  nn::InferenceWorkspace<float> ws;
  json steps = json::array();
  for (int step = 0; step < 60; ++step) {
    const std::vector<PartMask> masks = {schedule[static_cast<std::size_t>(step / 10)]};
    compute_observation(skel, sim.body_states(0), obs.col(0));
    build_policy_input<float>(parts, obs, masks, input);
    actor.mean(input, mean, ws, normalised);
    base.policy.actions.to_targets(mean, targets);
    if (std::find(recorded.begin(), recorded.end(), step) != recorded.end())
      steps.push_back({{"step", step},
                       {"mask_bits", masks[0].bits},
                       {"mask", masks[0].to_string()},
                       {"body_states", body_states_json(sim.body_states(0))},
                       {"observation", vec(obs.col(0))},
                       {"policy_input", vec(input.col(0))},
                       {"normalised_input", vec(normalised.col(0))},
                       {"mean_action", vec(mean.col(0))},
                       {"targets", vec(targets.col(0))}});
    sim.step(targets);
  }
  return {{"format", "maskadapt-live-fixture"},
          {"model", model_name},
          {"character", ch.name},
          {"start", starts.front().first},
          {"note", "written by tests/viewer/live_reference.cpp from the C++ of include/maskadapt on MuJoCo " +
                       std::string(mj_versionString())},
          {"steps", steps}};
}

/// play_base_policy (what `maskadapt play --deterministic` runs) from every start, per mask.
json native_json(const std::string& model_path, const std::string& model_name, const MujocoCharacter& ch) {
  const train::LoadedBasePolicy base = load(model_path, ch);
  json runs = json::array();
  for (const auto& [label, pose] : start_poses(ch)) {
    for (const char* mask_text : {"none", "left_leg,right_leg", "arms", "left_leg", "trunk"}) {
      MujocoHumanoidSim sim(1, 1, ch);
      train::PlayOptions opt;
      opt.seconds = 10.0;
      opt.seed = 1;
      opt.deterministic = true;
      opt.masks = MaskSampler::fixed(PartMask::parse(mask_text, "mask"));
      const KinematicState start = pose;
      tasks::ResetSampler reset = [start](Rng&) { return tasks::ResetSample{start, {}}; };
      const train::PlayResult r =
          train::play_base_policy(sim, base.policy, reset, opt, eval::make_rollout(sim.character()),
                                  ch.fall_criteria(base.config.env.termination_height), base.config.env.termination_height);
      const Vec3 d = r.root.col(r.root.cols() - 1) - r.root.col(0);
      const double distance = std::hypot(d.x(), d.y());
      json run = {{"start", label}, {"mask", mask_text}, {"distance_m", distance}, {"falls", r.fall_times.size()},
                  {"first_fall_s", r.fall_times.empty() ? json(nullptr) : json(r.fall_times.front())}};
      std::cout << "native " << model_name << " | " << label << " | mask " << mask_text << ": " << distance << " m, "
                << r.fall_times.size() << " fall(s)"
                << (r.fall_times.empty() ? std::string() : ", first at " + std::to_string(r.fall_times.front()) + " s")
                << "\n";
      runs.push_back(run);
    }
  }
  return {{"format", "maskadapt-live-native"},
          {"model", model_name},
          {"character", ch.name},
          {"mujoco", mj_versionString()},
          {"seconds", 10.0},
          {"actions", "mean (deterministic)"},
          {"runs", runs}};
}

/// Composite PD targets of a stage-2 policy for one set of body states (the per-step computation
/// of play-residual with mean actions); the intermediate values go into `rec` when given.
MatrixXf residual_targets(const adapt::ResidualPolicy<float>& pol, const PartElements& parts, const Skeleton& skel,
                          const BodyStates& b, PartMask mask, json* rec) {
  const Index obs_dim = observation_dim(skel);
  MatrixXf obs(obs_dim, 1), x, mu, targets;
  compute_observation(skel, b, obs.col(0));
  const std::vector<PartMask> masks = {mask};
  adapt::ResidualWorkspace<float> w;
  pol.build_input(parts, obs, masks, MatrixXf(0, 1), x, w);
  pol.mean(x, masks, mu, w);
  pol.to_targets(mu, targets);
  if (rec) {
    MatrixXf res_norm;
    pol.residual().normalize(x, res_norm);
    *rec = {{"mask_bits", mask.bits},
            {"mask", mask.to_string()},
            {"body_states", body_states_json(b)},
            {"observation", vec(obs.col(0))},
            {"base_input", vec(w.base_in.col(0))},
            {"base_mean", vec(w.base_mu.col(0))},
            {"residual_input", vec(x.col(0))},
            {"residual_normalised_input", vec(res_norm.col(0))},
            {"residual_mean", vec(w.res_mu.col(0))},
            {"mean_action", vec(mu.col(0))},
            {"targets", vec(targets.col(0))}};
  }
  return targets;
}

json residual_fixture_json(const std::string& model_path, const std::string& model_name, const MujocoCharacter& ch) {
  train::ResidualTrainConfig cfg;
  const adapt::ResidualPolicy<float> pol = train::residual_policy_from_checkpoint(load_checkpoint(model_path), ch.skeleton, &cfg);
  MujocoHumanoidSim sim(1, 1, ch);
  const auto starts = start_poses(ch);
  sim.reset(0, starts.front().second);
  const PartElements parts(observation_parts(ch.skeleton));
  const PartMask trained = PartMask::parse(cfg.masks.front(), "masks");
  const std::vector<PartMask> schedule = {trained, PartMask::none(), trained | PartMask::parse("trunk"), PartMask::parse("left_arm,left_leg")};
  const std::vector<int> recorded = {0, 9, 17, 26, 33};
  json steps = json::array();
  for (int step = 0; step < 40; ++step) {
    json rec;
    const bool keep = std::find(recorded.begin(), recorded.end(), step) != recorded.end();
    const MatrixXf targets = residual_targets(pol, parts, ch.skeleton, sim.body_states(0), schedule[static_cast<std::size_t>(step / 10)],
                                              keep ? &rec : nullptr);
    if (keep) {
      rec["step"] = step;
      steps.push_back(rec);
    }
    sim.step(targets);
  }
  return {{"format", "maskadapt-live-fixture"},
          {"model", model_name},
          {"character", ch.name},
          {"kind", "maskadapt.residual_policy"},
          {"task", cfg.task},
          {"method", cfg.method},
          {"trained_mask", trained.to_string()},
          {"start", starts.front().first},
          {"note", "written by tests/viewer/live_reference.cpp from the C++ of include/maskadapt on MuJoCo " +
                       std::string(mj_versionString())},
          {"steps", steps}};
}

json residual_native_json(const std::string& model_path, const std::string& model_name, const MujocoCharacter& ch) {
  train::ResidualTrainConfig cfg;
  const adapt::ResidualPolicy<float> pol = train::residual_policy_from_checkpoint(load_checkpoint(model_path), ch.skeleton, &cfg);
  const PartElements parts(observation_parts(ch.skeleton));
  const FallCriteria fall = ch.fall_criteria(cfg.rl.env.termination_height);
  json runs = json::array();
  for (const auto& [label, pose] : start_poses(ch)) {
    for (const std::string& mask_text : {cfg.masks.front(), std::string("none")}) {
      MujocoHumanoidSim sim(1, 1, ch);
      sim.reset(0, pose);
      const PartMask mask = PartMask::parse(mask_text, "mask");
      const Vec3 from = sim.body_states(0).pos.col(0);
      bool was_fallen = has_fallen(fall, sim.body_states(0), sim.contacts(0));
      std::vector<double> fall_times;
      for (int step = 1; step <= 300; ++step) {
        sim.step(residual_targets(pol, parts, ch.skeleton, sim.body_states(0), mask, nullptr));
        const bool fallen = has_fallen(fall, sim.body_states(0), sim.contacts(0));
        if (fallen && !was_fallen) fall_times.push_back(step * sim.control_dt());
        was_fallen = fallen;
      }
      const Vec3 d = sim.body_states(0).pos.col(0) - from;
      const double distance = std::hypot(d.x(), d.y());
      std::cout << "native " << model_name << " | " << label << " | mask " << mask.to_string() << ": " << distance << " m, "
                << fall_times.size() << " fall(s)\n";
      runs.push_back({{"start", label}, {"mask", mask.to_string()}, {"distance_m", distance}, {"falls", fall_times.size()},
                      {"first_fall_s", fall_times.empty() ? json(nullptr) : json(fall_times.front())}});
    }
  }
  return {{"format", "maskadapt-live-native"}, {"model", model_name}, {"character", ch.name}, {"mujoco", mj_versionString()},
          {"seconds", 10.0}, {"actions", "mean (deterministic)"}, {"runs", runs}};
}

}  // namespace

int main(int argc, char** argv) {
  return live_reference::reference_main(argc, argv, "live_reference", [](const std::filesystem::path& models, const std::filesystem::path& out, bool native) {
    const MujocoCharacter& humanoid = mujoco_character("humanoid");
    const MujocoCharacter& g1 = mujoco_character("g1");
    const double th_h = load((models / "mask_mi_walk_bandai.bin").string(), humanoid).config.env.termination_height;
    const double th_g = load((models / "g1_mask_mi_walk_bandai.bin").string(), g1).config.env.termination_height;
    write_json(out / "character_humanoid.json", character_json(humanoid, "humanoid.xml", th_h));
    write_json(out / "character_g1.json", character_json(g1, "g1.xml", th_g));
    const std::vector<std::pair<std::string, const MujocoCharacter*>> list = {{"mask_mi_walk_bandai", &humanoid},
                                                                              {"amp_walk_bandai", &humanoid},
                                                                              {"g1_mask_mi_walk_bandai", &g1},
                                                                              {"g1_amp_walk_bandai", &g1}};
    for (const auto& [name, ch] : list) {
      const std::string path = (models / (name + ".bin")).string();
      write_json(out / ("fixture_" + name + ".json"), fixture_json(path, name, *ch), -1);  // (compact: numbers)
      if (native) write_json(out / ("native_" + name + ".json"), native_json(path, name, *ch));
    }
    for (const std::string name : {"swim_ours_s1", "kick_cut_ours_s1"}) {
      const std::string path = (models / "table2" / (name + ".bin")).string();
      write_json(out / ("fixture_" + name + ".json"), residual_fixture_json(path, name, humanoid), -1);
      if (native) write_json(out / ("native_" + name + ".json"), residual_native_json(path, name, humanoid));
    }
  });
}
