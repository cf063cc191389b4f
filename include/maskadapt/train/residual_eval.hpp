#pragma once
/// \file residual_eval.hpp
/// Evaluation of a stage-2 residual policy (`maskadapt eval-residual`).
///
/// Composition (the paper's metric): `envs` envs run `frames` control steps each with a fixed
/// adapted-part mask m (policy mean by default); fallen envs are reset by RSI from the base
/// motion set A and keep running. Every simulated frame contributes two visitation features
/// (root-relative body positions in the heading frame, motion/library.hpp):
///   - the bodies of the ADAPTED parts (m), compared with the same rows of every frame of the
///     new-motion set B → H_norm(adapted | B);
///   - the bodies of the REST (¬m), compared with every frame of the base set A → H_norm(rest | A).
/// The distance threshold is per body: threshold = threshold_per_body · √(bodies in the subset),
/// so subsets of different sizes are judged with the same per-body tolerance (0.1 m per body ≈ the
/// 0.5 m over all 23 non-root bodies that eval-base uses).
///
/// Tracking: for each prompt and repeat, one episode of `seconds`: the env starts at a random
/// frame of the reference walk (base set A), the generator continues that frame's history with
/// the prompt, and the policy tracks it. Per episode:
///   - tracking error (m): mean over frames and designated bodies of the distance between the
///     simulated and the target root-relative heading-frame positions (tracking::position_error
///     layout; drift-invariant), eval::TrackingEpisode;
///   - success: no frame's mean deviation above 0.5 m and no fall;
///   - pose error of the rest (m): DTW (eval/dtw.hpp) between the simulated rest-body features
///     and the reference walk's features over the same span, mean cost per aligned pair divided
///     by the number of rest bodies (metres per body).
///   - rotation error (rad): mean over frames and designated bodies of the angle between the
///     simulated local joint rotation and the target's (what the training reward exp(−k·Σ angle²)
///     sees, tracking::rotation_error_sq); it separates the arms' own error from what the trunk and
///     the root's heading add to the position error.
/// With `oracle_targets` the designated DoFs' PD targets are the target trajectory's hinge angles
/// at the frame being tracked, whatever the policy commands there (the rest stays the policy's):
/// the best a residual that outputs PD targets could do for those joints with this PD controller,
/// if it knew the target exactly — a floor for the tracking error that no training can beat.
///
/// Both send the policy's composite actions â (the base's units) to the simulator as the PD
/// targets offset + scale ⊙ â of the base's action space (ResidualPolicy::actions(); identity: â).
#include <maskadapt/adapt/residual_policy.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/eval/dtw.hpp>
#include <maskadapt/eval/tracking_metrics.hpp>
#include <maskadapt/eval/visitation_entropy.hpp>
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/motion/library.hpp>
#include <maskadapt/sim/termination.hpp>
#include <maskadapt/tasks/imitation.hpp>
#include <maskadapt/tracking/generator.hpp>
#include <maskadapt/tracking/goals.hpp>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

namespace maskadapt::train {

struct CompositionEvalOptions {
  Index frames = 1000;              ///< control steps per env
  double threshold_per_body = 0.1;  ///< m (see file comment)
  double episode_seconds = 10.0;    ///< episode limit (s)
  bool deterministic = true;        ///< policy mean (false: sample)
  std::uint64_t seed = 1;
};

struct CompositionResult {
  PartMask mask;
  double h_adapted = 0;          ///< H_norm of the adapted parts vs B
  double h_rest = 0;             ///< H_norm of the rest vs A
  double matched_adapted = 0;    ///< fraction of generated frames within the threshold of some B frame
  double matched_rest = 0;       ///< … of some A frame
  double fall_rate = NAN;        ///< falls / ended episodes (NaN: none ended)
  long long falls = 0;
  /// (frames of B, clip after clip in library order) the visit counts behind h_adapted: how many
  /// generated frames came within the threshold of each of B's frames — which part of B is met.
  std::vector<std::int64_t> visits_adapted;
};

/// The imitation task an evaluation steps the policy in: RSI resets, falls and the episode limit,
/// no masking of its own (the policy's masks are the evaluation's), and the policy's action space
/// (the task sends offset + scale ⊙ â to the simulator).
template <class Policy>
tasks::ImitationTaskConfig evaluation_task_config(const Policy& policy, std::optional<FallCriteria> fall, double episode_seconds) {
  tasks::ImitationTaskConfig tc;
  tc.fall = std::move(fall);
  tc.episode_seconds = episode_seconds;
  tc.masking = false;
  tc.actions = policy.actions();
  return tc;
}

/// Number of non-root bodies in `parts`.
inline int bodies_in(const Skeleton& skel, PartMask parts) {
  int n = 0;
  for (int i = 1; i < skel.num_bodies(); ++i) n += parts.has(skel.parts[static_cast<std::size_t>(i)]);
  return n;
}

/// All frames of all clips of `lib`, features of the bodies of `parts`: (3·bodies × frames).
inline MatrixXf library_features(const MotionLibrary& lib, PartMask parts) {
  std::vector<MatrixXf> f;
  Index total = 0;
  for (int c = 0; c < lib.num_clips(); ++c) {
    f.push_back(lib.clip_visitation_features(c, parts));
    total += f.back().cols();
  }
  require(total > 0, "the motion set has no frames", {{}, {}, "motions"});
  MatrixXf out(f.front().rows(), total);
  Index k = 0;
  for (const auto& m : f) {
    out.middleCols(k, m.cols()) = m;
    k += m.cols();
  }
  return out;
}

/// Composition metric of `policy` with the fixed mask `mask` (see file comment). `sim` provides
/// the envs; `reset` draws RSI states from A. `policy_mask` (default: `mask`) is the mask the
/// policy is run with — PartMask::all() for a from-scratch policy, whose residual drives every DoF.
template <Simulator Sim>
CompositionResult evaluate_composition(Sim& sim, const adapt::ResidualPolicy<float>& policy, PartMask mask,
                                       const MotionLibrary& base_set, const MotionLibrary& new_set,
                                       tasks::ResetSampler reset, std::optional<FallCriteria> fall,
                                       const CompositionEvalOptions& opt, ThreadPool* pool = nullptr,
                                       std::optional<PartMask> policy_mask = std::nullopt) {
  require(opt.frames >= 1, "frames must be ≥ 1", {{}, {}, "frames"});
  require(!mask.empty() && mask != PartMask::all(), "the adapted mask must be neither empty nor every part",
          {{}, {}, "mask"});
  const Skeleton& skel = sim.skeleton();
  tasks::ImitationTask<Sim> task(sim, std::move(reset), evaluation_task_config(policy, std::move(fall), opt.episode_seconds),
                                 opt.seed, pool);
  require(policy.obs_dim() == task.obs_dim() && policy.action_dim() == task.action_dim() && policy.goal_dim() == 0,
          "the residual policy does not fit this simulator / task (composition needs no goals)", {{}, {}, "checkpoint"});
  const Index N = task.num_envs();
  const MatrixXf ref_b = library_features(new_set, mask), ref_a = library_features(base_set, ~mask);
  MatrixXf gen_b(ref_b.rows(), N * opt.frames), gen_a(ref_a.rows(), N * opt.frames);
  const PartElements pe(task.obs_parts());
  const std::vector<PartMask> masks(static_cast<std::size_t>(N), policy_mask.value_or(mask));
  const MatrixXf goals(0, N);
  MatrixXf x, mu, actions;
  RowVectorX<float> logp;
  adapt::ResidualWorkspace<float> ws;
  Rng rng = Rng::stream(opt.seed, 0xC0E7ULL);
  task.stats().clear();
  for (Index f = 0; f < opt.frames; ++f) {
    policy.build_input(pe, task.observations(), masks, goals, x, ws);
    if (opt.deterministic) policy.mean(x, masks, actions, ws);
    else policy.act(x, masks, rng, actions, logp, mu, ws);
    task.step(actions);
    for (Index e = 0; e < N; ++e) {
      const BodyStates& b = sim.body_states(static_cast<std::size_t>(e));
      gen_b.col(f * N + e) = visitation_features(skel, b, mask);
      gen_a.col(f * N + e) = visitation_features(skel, b, ~mask);
    }
  }
  CompositionResult r;
  r.mask = mask;
  const auto vb = eval::visitation_entropy(ref_b, gen_b, opt.threshold_per_body * std::sqrt(bodies_in(skel, mask)));
  const auto va = eval::visitation_entropy(ref_a, gen_a, opt.threshold_per_body * std::sqrt(bodies_in(skel, ~mask)));
  r.h_adapted = vb.h_norm;
  r.visits_adapted = vb.counts;
  r.h_rest = va.h_norm;
  r.matched_adapted = static_cast<double>(vb.matched_generated) / static_cast<double>(gen_b.cols());
  r.matched_rest = static_cast<double>(va.matched_generated) / static_cast<double>(gen_a.cols());
  r.fall_rate = task.stats().fall_rate();
  r.falls = task.stats().falls;
  return r;
}

struct TrackingEvalOptions {
  std::vector<std::string> prompts;  ///< texts (the default pool's first 10)
  int repeats = 3;
  double seconds = 5.0;
  double threshold = eval::kSuccessThreshold;  ///< m
  bool deterministic = true;
  std::uint64_t seed = 1;
  bool oracle_targets = false;  ///< the designated DoFs' PD targets := the target's angles (see file comment)
};

struct TrackingPromptResult {
  std::string prompt;
  double tracking_error = 0;  ///< m, mean over repeats
  double pose_error = 0;      ///< m per body (DTW), mean over repeats
  double rotation_error = 0;  ///< rad per designated body, mean over repeats
  double success_rate = 0;
  int falls = 0;
};

struct TrackingEvaluation {
  std::vector<TrackingPromptResult> prompts;
  double tracking_error = 0, pose_error = 0, rotation_error = 0, success_rate = 0;  ///< over all episodes
  int episodes = 0, falls = 0;
};

/// Partial-tracking evaluation (see file comment). `sim` must have `opt.repeats` envs (one
/// episode per env per prompt); `walk` is the reference walk set (its clips start the episodes).
/// `policy_mask` (default: `designated`) is the mask the policy runs with (all parts: scratch).
template <Simulator Sim, tracking::TrajectoryGenerator G>
TrackingEvaluation evaluate_tracking(Sim& sim, const adapt::ResidualPolicy<float>& policy, G& gen, PartMask designated,
                                     Index goal_steps, const MotionLibrary& walk, const FallCriteria& fall,
                                     const TrackingEvalOptions& opt, std::optional<PartMask> policy_mask = std::nullopt) {
  const Skeleton& skel = sim.skeleton();
  const Index N = static_cast<Index>(sim.num_envs());
  require(N == opt.repeats && N >= 1, "the simulator needs one env per repeat", {{}, {}, "repeats"});
  require(!opt.prompts.empty(), "no prompts", {{}, {}, "prompts"});
  require(opt.seconds > 0, "seconds must be > 0", {{}, {}, "seconds"});
  const auto bodies = tracking::designated_bodies(skel, designated);
  require(!bodies.empty(), "no designated bodies", {{}, {}, "designated"});
  require(policy.goal_dim() == tracking::goal_dim(skel, designated, goal_steps),
          "the policy's goal size does not match the designated parts", {{}, {}, "checkpoint"});
  const PartMask rest = ~designated;
  const int rest_bodies = std::max(1, bodies_in(skel, rest));
  const Index steps = std::max<Index>(1, std::llround(opt.seconds / sim.control_dt()));
  const Index H = static_cast<Index>(gen.history_frames());
  const PartElements pe(observation_parts(skel));
  const std::vector<PartMask> masks(static_cast<std::size_t>(N), policy_mask.value_or(designated));
  Rng rng = Rng::stream(opt.seed, 0x7EA1ULL);
  MatrixXf obs(observation_dim(skel), N), goals(policy.goal_dim(), N), x, mu, actions, pd_targets;
  RowVectorX<float> logp;
  adapt::ResidualWorkspace<float> ws;
  TrackingEvaluation out;
  double sum_track = 0, sum_pose = 0, sum_rot = 0;
  int successes = 0;
  for (const std::string& prompt : opt.prompts) {
    TrackingPromptResult pr;
    pr.prompt = prompt;
    std::vector<tracking::Trajectory> targets;
    std::vector<ClipTime> starts;
    for (Index e = 0; e < N; ++e) {
      const ClipTime ct = walk.sample(rng, true, static_cast<double>(H) / 30.0);
      starts.push_back(ct);
      sim.reset(static_cast<std::size_t>(e), walk.state(ct.clip, ct.time));
      const auto hist = tracking::trajectory_from_library(walk, ct.clip, ct.time - static_cast<double>(H - 1) / 30.0, H);
      targets.push_back(tracking::rollout(gen, {{0.0, prompt}}, hist, steps + goal_steps + 1, rng));
    }
    std::vector<eval::TrackingEpisode> eps(static_cast<std::size_t>(N), eval::TrackingEpisode(opt.threshold));
    std::vector<MatrixXf> sim_rest(static_cast<std::size_t>(N), MatrixXf(3 * rest_bodies, steps));
    std::vector<Index> alive(static_cast<std::size_t>(N), steps);
    std::vector<bool> fell(static_cast<std::size_t>(N), false);
    std::vector<double> rot_sum(static_cast<std::size_t>(N), 0.0);  // Σ over alive frames of the mean angle (rad)
    for (Index t = 0; t < steps; ++t) {
      for (Index e = 0; e < N; ++e) {
        compute_observation(skel, sim.body_states(static_cast<std::size_t>(e)), obs.col(e));
        tracking::extract_goals(skel, bodies, targets[static_cast<std::size_t>(e)], t, goal_steps, goals.col(e));
      }
      policy.build_input(pe, obs, masks, goals, x, ws);
      if (opt.deterministic) policy.mean(x, masks, actions, ws);
      else policy.act(x, masks, rng, actions, logp, mu, ws);
      policy.to_targets(actions, pd_targets);  // offset + scale ⊙ â
      if (opt.oracle_targets)
        for (Index e = 0; e < N; ++e)
          for (int b : bodies)
            pd_targets.col(e).segment<3>(skel.dof_offset(b)) =
                targets[static_cast<std::size_t>(e)].q.col(t + 1).segment<3>(skel.dof_offset(b)).cast<float>();
      sim.step(pd_targets);
      for (Index e = 0; e < N; ++e) {
        const auto ue = static_cast<std::size_t>(e);
        if (fell[ue]) continue;
        const BodyStates& b = sim.body_states(ue);
        const auto& tr = targets[ue];
        Matrix3X actual(3, static_cast<Index>(bodies.size())), target(3, static_cast<Index>(bodies.size()));
        for (std::size_t j = 0; j < bodies.size(); ++j) {
          const int bi = bodies[j];
          target.col(static_cast<Index>(j)) = tracking::heading_local(tr.body_pos.block<3, 1>(3 * bi, t + 1), tr.root_pos.col(t + 1),
                                                                      tr.root_rot[static_cast<std::size_t>(t + 1)]);
          actual.col(static_cast<Index>(j)) = tracking::heading_local(b.pos.col(bi), b.pos.col(0), b.rot[0]);
        }
        eps[ue].add_frame(actual, target);
        for (int bi : bodies)
          rot_sum[ue] += tracking::rotation_error(skel, bi, tr.q.col(t + 1), b) / static_cast<double>(bodies.size());
        sim_rest[ue].col(t) = visitation_features(skel, b, rest);
        if (has_fallen(fall, b, sim.contacts(ue))) {
          fell[ue] = true;
          alive[ue] = t + 1;
        }
      }
    }
    for (Index e = 0; e < N; ++e) {
      const auto ue = static_cast<std::size_t>(e);
      // the reference walk over the same span (clip frames after the start, looping/clamped by the library)
      MatrixXf ref(3 * rest_bodies, alive[ue]);
      BodyStates bs;
      for (Index t = 0; t < alive[ue]; ++t) {
        forward_kinematics(skel, walk.state(starts[ue].clip, starts[ue].time + static_cast<double>(t + 1) * sim.control_dt()), bs);
        ref.col(t) = visitation_features(skel, bs, rest);
      }
      const auto d = eval::dtw(sim_rest[ue].leftCols(alive[ue]), ref);
      const double pose = d.mean_cost / std::sqrt(static_cast<double>(rest_bodies));
      const bool ok = eps[ue].success() && !fell[ue];
      pr.tracking_error += eps[ue].mean_error() / static_cast<double>(N);
      pr.pose_error += pose / static_cast<double>(N);
      const double rot = rot_sum[ue] / static_cast<double>(eps[ue].frames());
      pr.rotation_error += rot / static_cast<double>(N);
      sum_rot += rot;
      pr.success_rate += (ok ? 1.0 : 0.0) / static_cast<double>(N);
      pr.falls += fell[ue] ? 1 : 0;
      sum_track += eps[ue].mean_error();
      sum_pose += pose;
      successes += ok;
    }
    out.falls += pr.falls;
    out.episodes += static_cast<int>(N);
    out.prompts.push_back(pr);
  }
  out.tracking_error = sum_track / out.episodes;
  out.pose_error = sum_pose / out.episodes;
  out.rotation_error = sum_rot / out.episodes;
  out.success_rate = static_cast<double>(successes) / out.episodes;
  return out;
}

inline nlohmann::json to_json(const CompositionResult& r) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"mask", r.mask.to_string()},         {"h_norm_adapted_vs_new", num(r.h_adapted)},
          {"h_norm_rest_vs_base", num(r.h_rest)}, {"matched_adapted", num(r.matched_adapted)},
          {"matched_rest", num(r.matched_rest)},  {"fall_rate", num(r.fall_rate)},
          {"falls", r.falls},                     {"visits_adapted_vs_new", r.visits_adapted}};
}

/// The clips of a motion set as `[{"name", "frames"}, …]`, in library order: the key to the
/// per-frame visit counts of a CompositionResult.
inline nlohmann::json clip_list_json(const MotionLibrary& lib) {
  nlohmann::json out = nlohmann::json::array();
  for (int c = 0; c < lib.num_clips(); ++c) out.push_back({{"name", lib.clip(c).name}, {"frames", lib.clip(c).num_frames()}});
  return out;
}

inline nlohmann::json to_json(const TrackingEvaluation& ev) {
  nlohmann::json j;
  j["tracking_error_m"] = ev.tracking_error;
  j["pose_error_dtw_m"] = ev.pose_error;
  j["rotation_error_rad"] = ev.rotation_error;
  j["success_rate"] = ev.success_rate;
  j["episodes"] = ev.episodes;
  j["falls"] = ev.falls;
  j["prompts"] = nlohmann::json::array();
  for (const auto& p : ev.prompts)
    j["prompts"].push_back({{"prompt", p.prompt}, {"tracking_error_m", p.tracking_error}, {"pose_error_dtw_m", p.pose_error},
                            {"rotation_error_rad", p.rotation_error}, {"success_rate", p.success_rate}, {"falls", p.falls}});
  return j;
}

/// Plain-text table of composition results (one row per mask).
inline std::string format_composition_table(const std::vector<CompositionResult>& rows) {
  std::string s = "mask                 H_norm(adapted|B)  H_norm(rest|A)  matched B  matched A  fall rate\n";
  char line[160];
  for (const auto& r : rows) {
    std::snprintf(line, sizeof line, "%-20s %17.3f %15.3f %10.3f %10.3f %10.3f\n", r.mask.to_string().c_str(), r.h_adapted,
                  r.h_rest, r.matched_adapted, r.matched_rest, r.fall_rate);
    s += line;
  }
  return s;
}

/// Plain-text table of a tracking evaluation (one row per prompt + the total).
inline std::string format_tracking_table(const TrackingEvaluation& ev) {
  std::string s = "prompt                   tracking err (m)  pose err DTW (m)  rotation err (rad)  success  falls\n";
  char line[220];
  for (const auto& p : ev.prompts) {
    std::snprintf(line, sizeof line, "%-24s %16.3f %17.3f %19.3f %8.2f %6d\n", p.prompt.substr(0, 24).c_str(), p.tracking_error,
                  p.pose_error, p.rotation_error, p.success_rate, p.falls);
    s += line;
  }
  std::snprintf(line, sizeof line, "%-24s %16.3f %17.3f %19.3f %8.2f %6d\n", "all", ev.tracking_error, ev.pose_error,
                ev.rotation_error, ev.success_rate, ev.falls);
  s += line;
  return s;
}

}  // namespace maskadapt::train
