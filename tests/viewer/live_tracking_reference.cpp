// The native reference for the live page's text-driven partial tracking (tools/viewer/src/live/
// rng.js, textFeatures.js, kinematics.js, generator.js, tracking.js; policy.js for the tracking
// residual): what the page needs besides the model files, and recorded inputs/outputs of the C++
// that the page's JavaScript must reproduce (tools/viewer/tests/tracking.test.js).
//
//   maskadapt_viewer_live_tracking_reference MODELS_DIR OUT_DIR [--no-native]
//
// writes
//   OUT_DIR/tracking_humanoid.json — the reference skeleton the generator works in (parents,
//       joint offsets, hinge layout) and, for every start pose the page offers
//       (live_reference.cpp's start_poses), the H = 5 history frames that end at it (the synthetic
//       walk from t − 4/30 s to t; five copies of the standing pose);
//   OUT_DIR/fixture_tracking_generator.json — models/text_generator.bin natively:
//       * hashed text features (tracking/text_encoder.hpp) of several prompts (case, punctuation,
//         non-ASCII bytes, the empty prompt);
//       * generate() for fixed prompts from the history of the first start: the canonical
//         history, its frame features, the normalised history, the text features and embedding,
//         the initial latent noise and, per diffusion step t = T−1 … 0, x_t, the conditional and
//         unconditional x̂₀, the guided x̂₀, the noise added and x_{t−1}; the latent, the decoded
//         features and the decoded trajectory. The recording loop below is checked to give
//         exactly what BuiltinGenerator::generate gives from the same Rng (else it throws);
//       * an autoregressive tracking::rollout over 4 primitives with a prompt switch, the normal
//         variates it drew (in order: the page may replay them) and goals extracted from it;
//   OUT_DIR/fixture_tracking_ours_s1.json — recorded steps of play-residual's loop for
//       models/table4/tracking_ours_s1.bin from the first start (seed 1, "0:wave right hand,1:punch"):
//       body states, observation, goals, residual input, normalised input, residual mean,
//       composite mean, PD targets, the tracking error after the step;
//   OUT_DIR/native_tracking_ours_s1.json (unless --no-native) — the same loop for 10 s from the
//       first start for three prompts: mean tracking error, falls, distance (what the page is
//       compared with, docs/viewer.md).
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/humanoid/synthetic.hpp>
#include <maskadapt/mask/apply.hpp>
#include <maskadapt/motion/library.hpp>
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>
#include <maskadapt/tracking/builtin_generator.hpp>
#include <maskadapt/tracking/goals.hpp>
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

/// A trajectory as flat column-major arrays (root_pos 3×N, root_rot_xyzw 4×N, q nd×N, body_pos 3nb×N).
json trajectory_json(const tracking::Trajectory& t) {
  json rot = json::array();
  for (const Quat& q : t.root_rot)
    for (double c : {q.x(), q.y(), q.z(), q.w()}) rot.push_back(c);
  return {{"frames", t.num_frames()}, {"root_pos", vec(t.root_pos)}, {"root_rot_xyzw", rot}, {"q", vec(t.q)}, {"body_pos", vec(t.body_pos)}};
}

void write_json(const std::filesystem::path& p, const json& j, int indent = -1) {
  live_reference::write_json_file("live_tracking_reference", p, j, indent);
}

/// The start poses of live_reference.cpp with the H frames of history that end at each.
struct Start {
  std::string label;
  KinematicState pose;
  tracking::Trajectory history;  ///< world frame, H frames, the last one = pose
};

std::vector<Start> starts(const MujocoCharacter& ch, Index H) {
  std::vector<Start> out;
  MotionLibrary walk(ch.skeleton);
  walk.add(synthetic_walk());
  for (double t : {0.1, 0.3, 0.5, 0.7, 0.9}) {
    char label[64];
    std::snprintf(label, sizeof label, "synthetic walk, t = %.1f s", t);
    out.push_back({label, walk.state(0, t), tracking::trajectory_from_library(walk, 0, t - static_cast<double>(H - 1) / 30.0, H)});
  }
  tracking::Trajectory still = tracking::Trajectory::zeros(ch.skeleton, H);
  for (Index i = 0; i < H; ++i) {
    still.root_pos.col(i) = ch.standing.root_pos;
    still.root_rot[static_cast<std::size_t>(i)] = ch.standing.root_rot;
    still.q.col(i) = ch.standing.q;
  }
  tracking::compute_body_positions(ch.skeleton, still);
  out.push_back({"standing", ch.standing, still});
  return out;
}

json tracking_character_json(const MujocoCharacter& ch, const tracking::BuiltinGenerator& g) {
  const Skeleton& s = ch.skeleton;
  s.require_xyz_layout("live tracking reference");
  json offsets = json::array(), dof = json::array();
  for (int i = 0; i < s.num_bodies(); ++i) {
    offsets.push_back(json::array({s.offsets(0, i), s.offsets(1, i), s.offsets(2, i)}));
    dof.push_back(i == 0 ? -1 : s.dof_offset(i));
  }
  json st = json::array();
  for (const auto& x : starts(ch, g.history_frames()))
    st.push_back({{"label", x.label}, {"history", trajectory_json(x.history)}});
  return {{"format", "maskadapt-live-tracking"},
          {"version", 1},
          {"character", ch.name},
          {"skeleton", {{"names", s.names}, {"parents", s.parents}, {"offsets", offsets}, {"dof_offset", dof}, {"hinges", "xyz"}}},
          {"history_frames", g.history_frames()},
          {"future_frames", g.future_frames()},
          {"starts", st},
          {"note", "written by tests/viewer/live_tracking_reference.cpp"}};
}

/// generate() step by step, recording every intermediate; returns the trajectory (canonical frame).
tracking::Trajectory recorded_generate(const tracking::BuiltinGenerator& g, const std::string& text,
                                       const tracking::Trajectory& history_canonical, std::uint64_t seed, json& rec) {
  const Skeleton& skel = g.skeleton();
  tracking::Trajectory h = history_canonical;
  tracking::compute_body_positions(skel, h);
  const MatrixXf hf = tracking::encode_frames<float>(skel, h);
  const MatrixXf hn = g.vae().history_stats.normalize(Eigen::Map<const MatrixXf>(hf.data(), hf.size(), 1));
  const VectorXf tf = g.text_features(tracking::TextCondition(text));
  const MatrixXf e = g.denoiser().embed(tf);
  const MatrixXf zero = MatrixXf::Zero(e.rows(), 1);
  const bool unconditional = tf.cwiseAbs().maxCoeff() == 0.0f;
  const double w = g.config().guidance;
  const auto& s = g.schedule();
  const Index L = g.vae().latent_dim();
  Rng rng(seed);
  MatrixXf x(L, 1);
  for (Index i = 0; i < L; ++i) x(i, 0) = static_cast<float>(rng.normal());
  rec = {{"text", text}, {"seed", seed}, {"history", trajectory_json(h)}, {"history_features", vec(hf)}, {"history_normalised", vec(hn)},
         {"text_features", vec(tf)}, {"embedding", vec(e)}, {"unconditional", unconditional}, {"initial_noise", vec(x)}};
  json steps = json::array();
  for (int t = s.num_steps() - 1; t >= 0; --t) {
    const MatrixXf cond = g.denoiser().predict(x, t, unconditional ? zero : e, hn);
    const MatrixXf uncond = g.denoiser().predict(x, t, zero, hn);
    const MatrixXf x0 = unconditional ? cond : tracking::guided_prediction<float>(cond, uncond, w);
    MatrixXf next = tracking::posterior_mean<float>(s, t, x0, x);
    MatrixXf noise = MatrixXf::Zero(L, 1);
    if (t > 0) {
      const float sigma = static_cast<float>(std::sqrt(s.posterior_variance[t]));
      for (Index i = 0; i < L; ++i) {
        noise(i, 0) = static_cast<float>(rng.normal());
        next(i, 0) += sigma * noise(i, 0);
      }
    }
    steps.push_back({{"t", t}, {"x_t", vec(x)}, {"x0_cond", vec(cond)}, {"x0_uncond", vec(uncond)}, {"x0_hat", vec(x0)},
                     {"noise", t > 0 ? vec(noise) : json(nullptr)}, {"x_next", vec(next)}});
    x = std::move(next);
  }
  const MatrixXf z = g.latent_scale() * x;
  const MatrixXf dec = g.vae().decode(hn, z);
  const MatrixXf fut = g.vae().future_stats.denormalize(dec);
  const tracking::Trajectory out =
      tracking::decode_frames<float>(skel, Eigen::Map<const MatrixXf>(fut.data(), g.vae().frame_dim(), g.future_frames()), h.fps);
  rec["steps"] = steps;
  rec["latent"] = vec(z);
  rec["decoded_normalised"] = vec(dec);
  rec["future_features"] = vec(fut);
  rec["future"] = trajectory_json(out);
  // The recording loop must be the generator's own computation.
  Rng again(seed);
  const tracking::Trajectory ref = g.generate(tracking::TextCondition(text), history_canonical, again);
  require(ref.q == out.q && ref.root_pos == out.root_pos, "the recording loop differs from BuiltinGenerator::generate for '" + text + "'",
          {{}, {}, "recorded_generate"});
  return out;
}

json generator_fixture_json(const tracking::BuiltinGenerator& g, const MujocoCharacter& ch) {
  json texts = json::array();
  for (const char* t : {"wave right hand", "Wave, RIGHT hand!", "punch", "", "  ", "jumping jack arms", "swim", "na\xc3\xafve wave 2 hands",
                        "arms high", "wash self", "raise both arms and wave"})
    texts.push_back({{"text", t}, {"features", vec(g.text_features(tracking::TextCondition(t)))}});
  const auto st = starts(ch, g.history_frames());
  const auto [local, frame] = tracking::canonicalize(st.front().history, 0);
  json gens = json::array();
  std::uint64_t seed = 7;
  for (const char* t : {"wave right hand", "punch", ""}) {
    json rec;
    recorded_generate(g, t, local, seed++, rec);
    gens.push_back(rec);
  }
  // An autoregressive rollout with a prompt switch (4 primitives), the normals it drew, goals.
  const std::string schedule_text = "0:wave right hand,0.9:arms high";
  const auto schedule = tracking::parse_text_schedule(schedule_text);
  const Index frames = 4 * g.future_frames();
  Rng rng(3);
  const tracking::Trajectory roll = tracking::rollout(g, schedule, st.front().history, frames, rng);
  Rng replay(3);  // (generate draws L normals, then L per step t > 0, and nothing else)
  const Index draws = 4 * g.vae().latent_dim() * g.schedule().num_steps();
  json normals = json::array();
  for (Index i = 0; i < draws; ++i) normals.push_back(replay.normal());
  const PartMask designated = PartMask::parse("arms", "designated");
  const std::vector<int> bodies = tracking::designated_bodies(g.skeleton(), designated);
  json goals = json::array();
  for (Index f : {0, 7, 14, 29, 44, 58}) {
    VectorXf gv(tracking::goal_dim(g.skeleton(), designated, 2));
    tracking::extract_goals(g.skeleton(), bodies, roll, f, 2, gv);
    goals.push_back({{"frame", f}, {"goals", vec(gv)}});
  }
  return {{"format", "maskadapt-live-tracking-fixture"},
          {"generator", "models/text_generator.bin"},
          {"note", "written by tests/viewer/live_tracking_reference.cpp from the C++ of include/maskadapt"},
          {"latent_scale", g.latent_scale()},
          {"guidance", g.config().guidance},
          {"texts", texts},
          {"generate", gens},
          {"rollout",
           {{"schedule", schedule_text}, {"seed", 3}, {"frames", frames}, {"start", st.front().label}, {"normals", normals},
            {"trajectory", trajectory_json(roll)}, {"designated", "arms"}, {"bodies", bodies}, {"goal_steps", 2}, {"goals", goals}}}};
}

struct TrackingRun {
  double mean_error = 0, distance = 0;
  std::vector<double> fall_times;
  json steps = json::array();
};

/// play-residual's loop (examples/maskadapt/cmd_train_residual.cpp run_play, tracking task) from a
/// start of this file; steps in `record` are recorded.
TrackingRun run_tracking(const std::string& model_path, const tracking::BuiltinGenerator& g, const MujocoCharacter& ch,
                         const Start& start, const std::string& schedule_text, double seconds, std::uint64_t seed,
                         const std::vector<int>& record) {
  train::ResidualTrainConfig cfg;
  const adapt::ResidualPolicy<float> pol = train::residual_policy_from_checkpoint(load_checkpoint(model_path), ch.skeleton, &cfg);
  require(cfg.task == "tracking", "not a tracking policy", {model_path, {}, "task"});
  MujocoHumanoidSim sim(1, 1, ch);
  const Skeleton& skel = sim.skeleton();
  sim.reset(0, start.pose);
  const PartMask designated = PartMask::parse(cfg.designated, "designated");
  const std::vector<int> bodies = tracking::designated_bodies(skel, designated);
  const Index steps = std::max<Index>(1, std::llround(seconds / sim.control_dt()));
  Rng rng(seed);
  const auto schedule = tracking::parse_text_schedule(schedule_text);
  const tracking::Trajectory targets = tracking::rollout(g, schedule, start.history, steps + cfg.goal_steps + 1, rng);
  const PartElements pe(observation_parts(skel));
  const FallCriteria fall = ch.fall_criteria(cfg.rl.env.termination_height);
  const std::vector<PartMask> m{designated};
  MatrixXf obs(observation_dim(skel), 1), x, mu, pd, goals(pol.goal_dim(), 1);
  adapt::ResidualWorkspace<float> ws;
  TrackingRun run;
  const Vec3 from = sim.body_states(0).pos.col(0);
  bool was_fallen = has_fallen(fall, sim.body_states(0), sim.contacts(0));
  double err_sum = 0;
  for (Index t = 0; t < steps; ++t) {
    const BodyStates before = sim.body_states(0);
    compute_observation(skel, before, obs.col(0));
    tracking::extract_goals(skel, bodies, targets, t, cfg.goal_steps, goals.col(0));
    pol.build_input(pe, obs, m, goals, x, ws);
    pol.mean(x, m, mu, ws);
    pol.to_targets(mu, pd);
    sim.step(pd);
    const BodyStates& b = sim.body_states(0);
    const double err = tracking::position_error(bodies, targets, t + 1, b);
    err_sum += err;
    const bool fallen = has_fallen(fall, b, sim.contacts(0));
    if (fallen && !was_fallen) run.fall_times.push_back(static_cast<double>(t + 1) * sim.control_dt());
    was_fallen = fallen;
    if (std::find(record.begin(), record.end(), static_cast<int>(t)) != record.end()) {
      MatrixXf res_norm;
      pol.residual().normalize(x, res_norm);
      run.steps.push_back({{"step", t},
                           {"text", tracking::text_at(schedule, static_cast<double>(t) / 30.0)},
                           {"mask_bits", designated.bits},
                           {"body_states", body_states_json(before)},
                           {"observation", vec(obs)},
                           {"goals", vec(goals)},
                           {"residual_input", vec(x)},
                           {"residual_normalised_input", vec(res_norm)},
                           {"residual_mean", vec(ws.res_mu)},
                           {"mean_action", vec(mu)},
                           {"targets", vec(pd)},
                           {"body_states_after", body_states_json(b)},
                           {"tracking_error_after", err}});
    }
  }
  run.mean_error = err_sum / static_cast<double>(steps);
  const Vec3 d = sim.body_states(0).pos.col(0) - from;
  run.distance = std::hypot(d.x(), d.y());
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  return live_reference::reference_main(argc, argv, "live_tracking_reference", [](const std::filesystem::path& models, const std::filesystem::path& out, bool native) {
    const MujocoCharacter& humanoid = mujoco_character("humanoid");
    const auto g = tracking::BuiltinGenerator::load(models / "text_generator.bin", humanoid.skeleton);
    write_json(out / "tracking_humanoid.json", tracking_character_json(humanoid, g), 1);
    write_json(out / "fixture_tracking_generator.json", generator_fixture_json(g, humanoid));
    const std::string model = (models / "table4" / "tracking_ours_s1.bin").string();
    const auto st = starts(humanoid, g.history_frames());
    const std::string fixture_schedule = "0:wave right hand,1:punch";
    const TrackingRun rec = run_tracking(model, g, humanoid, st.front(), fixture_schedule, 2.0, 1, {0, 13, 29, 31, 47, 59});
    write_json(out / "fixture_tracking_ours_s1.json",
               {{"format", "maskadapt-live-fixture"}, {"model", "tracking_ours_s1"}, {"character", "humanoid"},
                {"kind", "maskadapt.residual_policy"}, {"task", "tracking"}, {"start", st.front().label}, {"seed", 1},
                {"schedule", fixture_schedule}, {"mean_tracking_error_2s", rec.mean_error},
                {"note", "written by tests/viewer/live_tracking_reference.cpp from the C++ of include/maskadapt on MuJoCo " +
                             std::string(mj_versionString())},
                {"steps", rec.steps}});
    if (native) {
      json runs = json::array();
      for (const std::string prompt : {"wave right hand", "punch", "arms high"}) {
        const TrackingRun r = run_tracking(model, g, humanoid, st.front(), "0:" + prompt, 10.0, 1, {});
        std::cout << "native tracking_ours_s1 | " << st.front().label << " | \"" << prompt << "\": mean tracking error " << r.mean_error
                  << " m, " << r.fall_times.size() << " fall(s), " << r.distance << " m\n";
        runs.push_back({{"prompt", prompt}, {"start", st.front().label}, {"seed", 1}, {"mean_tracking_error_m", r.mean_error},
                        {"falls", r.fall_times.size()}, {"first_fall_s", r.fall_times.empty() ? json(nullptr) : json(r.fall_times.front())},
                        {"distance_m", r.distance}});
      }
      write_json(out / "native_tracking_ours_s1.json",
                 {{"format", "maskadapt-live-native"}, {"model", "tracking_ours_s1"}, {"character", "humanoid"},
                  {"mujoco", mj_versionString()}, {"seconds", 10.0}, {"actions", "mean (deterministic)"}, {"runs", runs}},
                 1);
    }
  });
}
