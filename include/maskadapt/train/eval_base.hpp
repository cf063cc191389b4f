#pragma once
/// \file eval_base.hpp
/// Evaluation of a base policy (`maskadapt eval-base`): the paper's table of the normalised
/// entropy of frame visitation H_norm (eval/visitation_entropy.hpp) for the null mask and every
/// mask of one or two parts (5 + 10 masks: an upper-triangular table over the 5 parts, singles on
/// the diagonal), each from random reference initial states (RSI) and from one shared initial
/// state, plus the fall rate and mean episode length under each mask.
///
/// Per (mask, start mode): `envs` envs run `frames` control steps each with the fixed mask; an
/// env that falls is reset (RSI, or the shared state) and keeps running; episodes are limited to
/// `episode_seconds`. Every simulated frame contributes its visitation feature (root-relative body
/// positions in the heading frame, motion/library.hpp visitation_features) to the generated set;
/// H_norm is computed against the reference frames' features with `threshold` (Euclidean, m).
/// Every (mask, mode) uses the same seeds (common random numbers), so differences between masks
/// are not sampling noise of the initial states.
///
/// Per starting class (`eval-base --per-class`, evaluate_by_start_class): the clips' frames are
/// classified by their root motion (motion/motion_class.hpp: stand, walk, run, backward, sideways,
/// turn); for each class with frames, episodes start (and restart after a fall) only from frames
/// of that class, and their falls, speed and forward speed are set beside the clips' own mean
/// speed and forward speed over those frames.
///
/// Jumping (`rise_height`, issue 41): each episode is cut into whole seconds from its start; a
/// second *rises* when the root's highest point in it is at least `rise_clearance` (0.1 m) above
/// `rise_height` (the CLI gives the clips' median root height). The share of rising seconds is
/// reported beside the same share of the clips (clips_rise_fraction), so "it jumps like its
/// clips" is one comparison; a walker rises in none.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/eval/visitation_entropy.hpp>
#include <maskadapt/motion/library.hpp>
#include <maskadapt/motion/motion_class.hpp>
#include <maskadapt/tasks/imitation.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/library_reset.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace maskadapt::train {

struct EvalBaseOptions {
  long long frames = 1000;       ///< control steps per env per (mask, mode)
  double threshold = 0.5;        ///< m; Euclidean over the 3·(bodies−1) features (≈ 0.1 m per body on the humanoid)
  /// nearest: a frame visits its nearest reference frame (if within the threshold); all_within:
  /// every reference frame within the threshold (eval/visitation_entropy.hpp says why nearest)
  eval::VisitCounting counting = eval::VisitCounting::nearest;
  double episode_seconds = 10.0; ///< episode limit (s)
  /// The masks evaluated, in this order; empty: the whole table, one_and_two_part_masks(). Each
  /// mask's rows are the same whichever others are evaluated (common random numbers).
  std::vector<PartMask> masks;
  bool deterministic = false;    ///< policy mean instead of samples
  bool entropy = true;           ///< compute H_norm (false: falls and speeds only, h_norm NaN)
  double rise_height = NAN;      ///< m; finite: count the seconds whose highest root point is ≥ rise_height + rise_clearance
  double rise_clearance = 0.1;   ///< m
  std::uint64_t seed = 1;
};

/// Results of one (mask, start mode).
struct VisitationResult {
  double h_norm = 0;              ///< normalised visitation entropy in [0, 1]
  double matched_fraction = 0;    ///< generated frames within the threshold of some reference frame
  double visited_fraction = 0;    ///< reference frames visited at least once
  double fall_rate = NAN;         ///< ended-by-fall / ended episodes (NaN: none ended)
  double mean_episode_length = NAN;  ///< s, over ended episodes (NaN: none ended)
  double mean_speed = NAN;        ///< m/s: horizontal root path length / time, over steps that did not end an episode
  double mean_forward_speed = NAN;  ///< m/s: the same path projected on the root's heading (negative: backwards)
  double rise_fraction = NAN;     ///< whole seconds of episodes in which the root rose (file comment); NaN: not measured or none
  long long episodes = 0;         ///< ended episodes
  long long falls = 0;
};

struct MaskEvaluation {
  PartMask mask;
  VisitationResult rsi;     ///< random reference initial states
  VisitationResult shared;  ///< one shared initial state
};

struct BaseEvaluation {
  std::vector<MaskEvaluation> rows;  ///< null mask, 5 singles, 10 pairs (part order)
  long long reference_frames = 0;
  long long generated_frames_per_mask = 0;
  double reference_speed = NAN;  ///< m/s, the clips' mean horizontal root speed (reference_mean_speed; NaN: not given)
  double reference_rise_fraction = NAN;  ///< the clips' share of rising seconds at options.rise_height (NaN: not given)
  EvalBaseOptions options;
};

/// Mean horizontal root speed of the clips of `lib` (m/s): their summed frame-to-frame root path
/// length in the ground plane over their summed duration — what "it walks" is compared with.
inline double reference_mean_speed(const MotionLibrary& lib) {
  double path = 0, seconds = 0;
  for (int c = 0; c < lib.num_clips(); ++c) {
    const MotionClip& clip = lib.clip(c);
    for (Index f = 1; f < clip.num_frames(); ++f)
      path += (clip.root_pos.col(f).head<2>() - clip.root_pos.col(f - 1).head<2>()).norm();
    seconds += static_cast<double>(clip.num_frames() - 1) / clip.fps;
  }
  require(seconds > 0, "the motion library has no frames", {{}, {}, "reference"});
  return path / seconds;
}

/// Median root height of every frame of the clips (m): what eval-base measures rises from.
inline double clips_median_root_height(const MotionLibrary& lib) {
  std::vector<double> z;
  for (int c = 0; c < lib.num_clips(); ++c)
    for (Index f = 0; f < lib.clip(c).num_frames(); ++f) z.push_back(lib.clip(c).root_pos(2, f));
  require(!z.empty(), "the motion library has no frames", {{}, {}, "reference"});
  std::nth_element(z.begin(), z.begin() + static_cast<std::ptrdiff_t>(z.size() / 2), z.end());
  return z[z.size() / 2];
}

/// The clips' share of rising seconds: each clip cut into whole seconds from its first frame (the
/// last, partial second left out), a second rising when its highest root point is ≥ height +
/// clearance. NaN when no clip lasts a second.
inline double clips_rise_fraction(const MotionLibrary& lib, double height, double clearance = 0.1) {
  long long counted = 0, risen = 0;
  for (int c = 0; c < lib.num_clips(); ++c) {
    const MotionClip& clip = lib.clip(c);
    const int per = std::max(1, static_cast<int>(std::lround(clip.fps)));
    for (int start = 0; start + per <= clip.num_frames(); start += per) {
      ++counted;
      risen += clip.root_pos.row(2).segment(start, per).maxCoeff() >= height + clearance;
    }
  }
  return counted > 0 ? static_cast<double>(risen) / static_cast<double>(counted) : NAN;
}

/// The masks of the table: none, then {p} for each part, then {p, q} for p < q.
inline std::vector<PartMask> one_and_two_part_masks() {
  std::vector<PartMask> m{PartMask::none()};
  for (int p = 0; p < kNumParts; ++p) m.push_back(PartMask::of(static_cast<BodyPart>(p)));
  for (int p = 0; p < kNumParts; ++p)
    for (int q = p + 1; q < kNumParts; ++q) m.push_back(PartMask::of(static_cast<BodyPart>(p)) | PartMask::of(static_cast<BodyPart>(q)));
  return m;
}

/// Reference visitation features of every frame of every clip of `lib`: (3·(bodies−1) × total frames).
inline MatrixXf reference_visitation_features(const MotionLibrary& lib) {
  std::vector<MatrixXf> parts;
  Index cols = 0;
  for (int c = 0; c < lib.num_clips(); ++c) {
    parts.push_back(lib.clip_visitation_features(c));
    cols += parts.back().cols();
  }
  require(!parts.empty() && cols > 0, "the motion library has no frames", {{}, {}, "reference"});
  MatrixXf r(parts.front().rows(), cols);
  Index at = 0;
  for (const auto& p : parts) {
    r.middleCols(at, p.cols()) = p;
    at += p.cols();
  }
  return r;
}

/// Runs `policy` on all envs of `sim` with the fixed `mask` for opt.frames steps, starting from
/// `reset` samples, and returns H_norm against `reference` plus episode statistics.
template <Simulator Sim>
VisitationResult evaluate_visitation(Sim& sim, const BasePolicy& policy, const tasks::ResetSampler& reset, PartMask mask,
                                     const Eigen::Ref<const MatrixXf>& reference, const EvalBaseOptions& opt,
                                     std::optional<FallCriteria> fall = std::nullopt, double min_head_height = 0.3,
                                     ThreadPool* pool = nullptr) {
  require(opt.frames >= 1, "frames must be >= 1", {{}, {}, "frames"});
  tasks::ImitationTaskConfig tc;
  tc.fall = std::move(fall);
  tc.min_head_height = min_head_height;
  tc.episode_seconds = opt.episode_seconds;
  tc.early_termination = true;
  tc.masking = false;
  tc.fixed_mask = mask;
  tc.actions = policy.actions;  // the policy's actions → PD targets
  tasks::ImitationTask<Sim> task(sim, reset, tc, opt.seed, pool);
  require(policy.ac.actor.input_dim() == task.policy_input_dim() && policy.ac.actor.action_dim() == task.action_dim(),
          "the policy does not fit this simulator", {{}, {}, "checkpoint"});
  const Skeleton& skel = sim.skeleton();
  const Index N = task.num_envs();
  const Index d = reference.rows();
  MatrixXf generated(d, opt.entropy ? N * static_cast<Index>(opt.frames) : 0);  // (without H_norm: no frames kept)
  Rng act_rng = Rng::stream(opt.seed, 0xE7A1ULL);
  nn::InferenceWorkspace<float> ws;
  MatrixXf actions(task.action_dim(), N), mu(task.action_dim(), N), scratch;
  RowVectorX<float> logp;
  task.stats().clear();
  auto root_xy = [&](Index e) -> Eigen::Vector2d { return sim.body_states(static_cast<std::size_t>(e)).pos.col(0).template head<2>().template cast<double>(); };
  std::vector<Eigen::Vector2d> last_xy(static_cast<std::size_t>(N));
  for (Index e = 0; e < N; ++e) last_xy[static_cast<std::size_t>(e)] = root_xy(e);
  double path = 0, forward_path = 0, moving_seconds = 0;
  // rising seconds: per env, the highest root point of the current second of its episode
  const long long steps_per_second = std::max(1LL, std::llround(1.0 / sim.control_dt()));
  std::vector<double> second_top(static_cast<std::size_t>(N), -INFINITY);
  std::vector<long long> second_steps(static_cast<std::size_t>(N), 0);
  long long seconds_counted = 0, seconds_risen = 0;
  for (long long f = 0; f < opt.frames; ++f) {
    if (opt.deterministic) {
      policy.ac.actor.mean(task.policy_inputs(), mu, ws, scratch);
      actions = mu;
    } else {
      policy.ac.actor.act(task.policy_inputs(), act_rng, actions, logp, mu, ws, scratch);
    }
    task.step(actions);
    for (Index e = 0; e < N; ++e) {  // an env whose episode ended was reset: its step is no motion
      const auto ue = static_cast<std::size_t>(e);
      const Eigen::Vector2d xy = root_xy(e);
      if (!task.terminated()[ue] && !task.truncated()[ue]) {
        const double h = heading_angle(sim.body_states(ue).rot[0]);
        path += (xy - last_xy[ue]).norm();
        forward_path += (xy - last_xy[ue]).dot(Eigen::Vector2d(std::cos(h), std::sin(h)));
        moving_seconds += sim.control_dt();
        second_top[ue] = std::max(second_top[ue], static_cast<double>(sim.body_states(ue).pos(2, 0)));
        if (++second_steps[ue] == steps_per_second) {
          ++seconds_counted;
          seconds_risen += second_top[ue] >= opt.rise_height + opt.rise_clearance;
          second_steps[ue] = 0;
          second_top[ue] = -INFINITY;
        }
      } else {  // a new episode: its first second starts now
        second_steps[ue] = 0;
        second_top[ue] = -INFINITY;
      }
      last_xy[ue] = xy;
    }
    // the frame after this step (for an env whose episode just ended: the new episode's first frame)
    for (Index e = 0; opt.entropy && e < N; ++e) {
      const VectorXf v = visitation_features(skel, sim.body_states(static_cast<std::size_t>(e)));
      require(v.size() == d, "visitation features have " + std::to_string(v.size()) + " rows, reference has " +
                                 std::to_string(d), {{}, {}, "reference"});
      generated.col(static_cast<Index>(f) * N + e) = v;
    }
  }
  const auto& es = task.stats();
  VisitationResult r;
  if (opt.entropy) {
    const eval::VisitationEntropy ve = eval::visitation_entropy(reference, generated, opt.threshold, opt.counting);
    r.h_norm = ve.h_norm;
    r.matched_fraction = static_cast<double>(ve.matched_generated) / static_cast<double>(generated.cols());
    r.visited_fraction = static_cast<double>(ve.visited_reference) / static_cast<double>(reference.cols());
  } else {
    r.h_norm = r.matched_fraction = r.visited_fraction = NAN;
  }
  r.fall_rate = es.fall_rate();
  r.mean_episode_length = es.mean_length();
  r.mean_speed = moving_seconds > 0 ? path / moving_seconds : NAN;
  r.mean_forward_speed = moving_seconds > 0 ? forward_path / moving_seconds : NAN;
  r.rise_fraction = std::isfinite(opt.rise_height) && seconds_counted > 0
                        ? static_cast<double>(seconds_risen) / static_cast<double>(seconds_counted)
                        : NAN;
  r.episodes = es.episodes;
  r.falls = es.falls;
  return r;
}

/// The whole table: every mask of one_and_two_part_masks() (or of opt.masks), from RSI (`reset`)
/// and from one shared initial state (the first sample of `reset` with Rng::stream(seed, 0x5A4ED)).
template <Simulator Sim>
BaseEvaluation evaluate_base_policy(Sim& sim, const BasePolicy& policy, const tasks::ResetSampler& reset,
                                    const Eigen::Ref<const MatrixXf>& reference, const EvalBaseOptions& opt,
                                    std::optional<FallCriteria> fall = std::nullopt, double min_head_height = 0.3,
                                    ThreadPool* pool = nullptr, std::ostream* progress = nullptr) {
  BaseEvaluation out;
  out.options = opt;
  out.reference_frames = reference.cols();
  out.generated_frames_per_mask = static_cast<long long>(sim.num_envs()) * opt.frames;
  Rng shared_rng = Rng::stream(opt.seed, 0x5A4EDULL);
  const tasks::ResetSample shared_sample = reset(shared_rng);
  const tasks::ResetSampler shared = [shared_sample](Rng&) { return shared_sample; };
  for (PartMask m : opt.masks.empty() ? one_and_two_part_masks() : opt.masks) {
    MaskEvaluation row;
    row.mask = m;
    row.rsi = evaluate_visitation(sim, policy, reset, m, reference, opt, fall, min_head_height, pool);
    row.shared = evaluate_visitation(sim, policy, shared, m, reference, opt, fall, min_head_height, pool);
    if (progress)
      *progress << "eval-base: " << m.to_string() << ": H_norm RSI " << row.rsi.h_norm << ", shared " << row.shared.h_norm
                << ", fall rate " << row.rsi.fall_rate << ", speed " << row.rsi.mean_speed << " m/s" << std::endl;
    out.rows.push_back(row);
  }
  return out;
}

/// The reference frames of one motion class, as episode starts.
struct ClassStarts {
  MotionClass motion_class = MotionClass::walk;
  std::vector<ClipTime> starts;  ///< frames of the class at time ≥ kEarliestResetTime
  std::vector<double> weights;   ///< each frame's duration (1/fps), so clips of any frame rate count by time
  double seconds = 0;            ///< s of reference motion of this class (the sum of the weights)
  double mean_speed = NAN;       ///< m/s, the clips' RootMotion::speed averaged over these frames (by time)
  double mean_forward = NAN;     ///< m/s, their forward speed likewise
};

/// The classes that have frames in `lib` (in MotionClass order), with their starts and the clips'
/// mean speeds there.
inline std::vector<ClassStarts> class_starts(const MotionLibrary& lib, const MotionClassThresholds& t = {}) {
  std::vector<ClassStarts> by(kNumMotionClasses);
  std::vector<double> speed(kNumMotionClasses, 0), forward(kNumMotionClasses, 0);
  for (int c = 0; c < lib.num_clips(); ++c) {
    const MotionClip& clip = lib.clip(c);
    if (clip.num_frames() < 2) continue;
    for (int f = 0; f < clip.num_frames(); ++f) {
      const double time = f / clip.fps;
      if (time < kEarliestResetTime - 1e-9) continue;  // (the first 4 frames are its history)
      const RootMotion m = root_motion_at(clip, f, t.window_s);
      const auto k = static_cast<std::size_t>(classify_root_motion(m, t));
      by[k].starts.push_back({c, time});
      by[k].weights.push_back(1.0 / clip.fps);
      by[k].seconds += 1.0 / clip.fps;
      speed[k] += m.speed / clip.fps;
      forward[k] += m.forward / clip.fps;
    }
  }
  std::vector<ClassStarts> out;
  for (int k = 0; k < kNumMotionClasses; ++k) {
    auto& cs = by[static_cast<std::size_t>(k)];
    if (cs.starts.empty()) continue;
    cs.motion_class = static_cast<MotionClass>(k);
    cs.mean_speed = speed[static_cast<std::size_t>(k)] / cs.seconds;
    cs.mean_forward = forward[static_cast<std::size_t>(k)] / cs.seconds;
    out.push_back(std::move(cs));
  }
  return out;
}

/// Resets drawn (by time) from the frames of one class only.
inline tasks::ResetSampler class_reset_sampler(std::shared_ptr<const MotionLibrary> lib, std::shared_ptr<const ClassStarts> cs) {
  require(cs && !cs->starts.empty(), "no frames of this class to start from", {{}, {}, "motion class"});
  return [lib, cs](Rng& rng) { return reset_sample_at(*lib, cs->starts[draw_weighted(cs->weights, rng)]); };
}

/// Falls and speeds of one (mask, starting class).
struct ClassEvaluation {
  PartMask mask;
  MotionClass motion_class = MotionClass::walk;
  double reference_seconds = 0;        ///< s of the clips in this class
  double reference_speed = NAN;        ///< m/s, the clips' mean speed in this class
  double reference_forward = NAN;      ///< m/s, their mean forward speed
  VisitationResult result;             ///< H_norm not computed (NaN)
  /// the policy's mean speed over the clips' (NaN without motion)
  double speed_ratio() const { return result.mean_speed / reference_speed; }
};

/// Every mask of opt.masks (empty: the null mask and both legs) × every class with frames in
/// `lib`: episodes start only from that class's frames (class_reset_sampler); the same seed for
/// every cell. H_norm is not computed.
template <Simulator Sim>
std::vector<ClassEvaluation> evaluate_by_start_class(Sim& sim, const BasePolicy& policy, std::shared_ptr<const MotionLibrary> lib,
                                                     EvalBaseOptions opt, std::optional<FallCriteria> fall = std::nullopt,
                                                     double min_head_height = 0.3, ThreadPool* pool = nullptr,
                                                     std::ostream* progress = nullptr, const MotionClassThresholds& t = {}) {
  opt.entropy = false;
  const std::vector<PartMask> masks = opt.masks.empty() ? std::vector<PartMask>{PartMask::none(), PartMask::parse("legs", "masks")} : opt.masks;
  const MatrixXf no_reference(3 * (sim.skeleton().num_bodies() - 1), 0);  // (visitation feature rows × 0): no H_norm
  std::vector<ClassEvaluation> out;
  for (ClassStarts& cs : class_starts(*lib, t)) {
    auto shared = std::make_shared<const ClassStarts>(std::move(cs));
    const tasks::ResetSampler reset = class_reset_sampler(lib, shared);
    for (PartMask m : masks) {
      ClassEvaluation e;
      e.mask = m;
      e.motion_class = shared->motion_class;
      e.reference_seconds = shared->seconds;
      e.reference_speed = shared->mean_speed;
      e.reference_forward = shared->mean_forward;
      e.result = evaluate_visitation(sim, policy, reset, m, no_reference, opt, fall, min_head_height, pool);
      if (progress)
        *progress << "eval-base: " << m.to_string() << " from " << to_string(e.motion_class) << ": fall rate "
                  << e.result.fall_rate << ", speed " << e.result.mean_speed << " m/s (clips " << e.reference_speed << ")"
                  << std::endl;
      out.push_back(e);
    }
  }
  return out;
}

/// The upper-triangular table of one start mode as text: rows and columns are the 5 parts; cell
/// (p, p) masks part p alone, cell (p, q), p < q, masks both; the null mask is printed above.
inline std::string format_hnorm_table(const BaseEvaluation& ev, bool shared) {
  auto value = [&](PartMask m) {
    for (const auto& r : ev.rows)
      if (r.mask == m) return shared ? r.shared.h_norm : r.rsi.h_norm;
    return static_cast<double>(NAN);
  };
  std::ostringstream s;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.4f", value(PartMask::none()));
  s << "H_norm, " << (shared ? "shared initial state" : "random initial states (RSI)") << "; null mask: " << buf << "\n";
  s << std::string(11, ' ');
  for (int q = 0; q < kNumParts; ++q) {
    std::snprintf(buf, sizeof buf, "%10s", std::string(kPartNames[q]).c_str());
    s << buf;
  }
  s << "\n";
  for (int p = 0; p < kNumParts; ++p) {
    std::snprintf(buf, sizeof buf, "%-11s", std::string(kPartNames[p]).c_str());
    s << buf;
    for (int q = 0; q < kNumParts; ++q) {
      if (q < p) {
        s << std::string(10, ' ');
        continue;
      }
      const PartMask m = PartMask::of(static_cast<BodyPart>(p)) | PartMask::of(static_cast<BodyPart>(q));
      std::snprintf(buf, sizeof buf, "%10.4f", value(m));
      s << buf;
    }
    s << "\n";
  }
  return s.str();
}

/// Fall rate, mean episode length and mean speed per mask, one line each (with the clips' speed
/// when known).
inline std::string format_episode_table(const BaseEvaluation& ev) {
  std::ostringstream s;
  char buf[200];
  const bool rise = std::isfinite(ev.options.rise_height);
  std::snprintf(buf, sizeof buf, "%-22s %10s %11s %12s %12s %14s %14s", "mask", "fall(RSI)", "len(RSI) s",
                "speed(RSI)", "fall(shared)", "len(shared) s", "speed(shared)");
  s << buf << (rise ? "   rise(RSI) rise(shared)\n" : "\n");
  for (const auto& r : ev.rows) {
    std::snprintf(buf, sizeof buf, "%-22s %10.3f %11.2f %12.2f %12.3f %14.2f %14.2f", r.mask.to_string().c_str(),
                  r.rsi.fall_rate, r.rsi.mean_episode_length, r.rsi.mean_speed, r.shared.fall_rate,
                  r.shared.mean_episode_length, r.shared.mean_speed);
    s << buf;
    if (rise) {
      std::snprintf(buf, sizeof buf, " %11.3f %12.3f", r.rsi.rise_fraction, r.shared.rise_fraction);
      s << buf;
    }
    s << "\n";
  }
  if (rise) {
    std::snprintf(buf, sizeof buf,
                  "rise: share of whole seconds in which the root rose >= %.2f m above %.3f m (the clips' median root "
                  "height); the clips: %.3f\n",
                  ev.options.rise_clearance, ev.options.rise_height, ev.reference_rise_fraction);
    s << buf;
  }
  if (std::isfinite(ev.reference_speed)) {
    std::snprintf(buf, sizeof buf, "speed in m/s; the clips' mean speed is %.2f m/s\n", ev.reference_speed);
    s << buf;
  }
  return s.str();
}

/// One line per (mask, starting class): seconds of the clips there, episodes, falls, the
/// policy's speed and forward speed beside the clips', and the speed ratio.
inline std::string format_class_table(const std::vector<ClassEvaluation>& rows) {
  std::ostringstream s;
  char buf[240];
  std::snprintf(buf, sizeof buf, "%-22s %-9s %8s %9s %6s %9s %8s %8s %8s %8s %7s\n", "mask", "class", "clips s", "episodes",
                "falls", "fall rate", "speed", "clips'", "forward", "clips'", "ratio");
  s << buf;
  for (const auto& r : rows) {
    std::snprintf(buf, sizeof buf, "%-22s %-9s %8.1f %9lld %6lld %9.3f %8.2f %8.2f %8.2f %8.2f %7.2f\n", r.mask.to_string().c_str(),
                  to_string(r.motion_class).c_str(), r.reference_seconds, r.result.episodes, r.result.falls, r.result.fall_rate,
                  r.result.mean_speed, r.reference_speed, r.result.mean_forward_speed, r.reference_forward, r.speed_ratio());
    s << buf;
  }
  s << "speeds in m/s (forward: along the root's heading, negative backwards); ratio = speed / clips' speed\n";
  return s.str();
}

inline nlohmann::json to_json(const VisitationResult& r) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"h_norm", num(r.h_norm)},
          {"matched_fraction", num(r.matched_fraction)},
          {"visited_fraction", num(r.visited_fraction)},
          {"fall_rate", num(r.fall_rate)},
          {"mean_episode_length", num(r.mean_episode_length)},
          {"mean_speed", num(r.mean_speed)},
          {"mean_forward_speed", num(r.mean_forward_speed)},
          {"rise_fraction", num(r.rise_fraction)},
          {"episodes", r.episodes},
          {"falls", r.falls}};
}

/// JSON document: options, sizes, one object per mask, and the two 5×5 upper-triangular tables
/// (`table_rsi`, `table_shared`; null below the diagonal and for masks not evaluated).
inline nlohmann::json to_json(const BaseEvaluation& ev) {
  nlohmann::json j;
  j["format"] = "maskadapt-eval-base";
  j["version"] = 1;
  j["parts"] = std::vector<std::string>(kPartNames.begin(), kPartNames.end());
  j["frames"] = ev.options.frames;
  j["threshold"] = ev.options.threshold;
  j["counting"] = eval::to_string(ev.options.counting);
  j["episode_seconds"] = ev.options.episode_seconds;
  j["deterministic"] = ev.options.deterministic;
  j["seed"] = ev.options.seed;
  j["reference_frames"] = ev.reference_frames;
  j["generated_frames_per_mask"] = ev.generated_frames_per_mask;
  j["reference_speed"] = std::isfinite(ev.reference_speed) ? nlohmann::json(ev.reference_speed) : nlohmann::json(nullptr);
  j["rise_height"] = std::isfinite(ev.options.rise_height) ? nlohmann::json(ev.options.rise_height) : nlohmann::json(nullptr);
  j["rise_clearance"] = ev.options.rise_clearance;
  j["reference_rise_fraction"] =
      std::isfinite(ev.reference_rise_fraction) ? nlohmann::json(ev.reference_rise_fraction) : nlohmann::json(nullptr);
  j["masks"] = nlohmann::json::array();
  for (const auto& r : ev.rows)
    j["masks"].push_back({{"mask", r.mask.to_string()}, {"bits", r.mask.bits}, {"rsi", to_json(r.rsi)}, {"shared", to_json(r.shared)}});
  for (int shared = 0; shared < 2; ++shared) {
    nlohmann::json t = nlohmann::json::array();
    for (int p = 0; p < kNumParts; ++p) {
      nlohmann::json row = nlohmann::json::array();
      for (int q = 0; q < kNumParts; ++q) {
        if (q < p) {
          row.push_back(nullptr);
          continue;
        }
        const PartMask m = PartMask::of(static_cast<BodyPart>(p)) | PartMask::of(static_cast<BodyPart>(q));
        nlohmann::json cell = nullptr;  // (a mask not evaluated: null)
        for (const auto& r : ev.rows)
          if (r.mask == m) cell = shared ? r.shared.h_norm : r.rsi.h_norm;
        row.push_back(cell);
      }
      t.push_back(row);
    }
    j[shared ? "table_shared" : "table_rsi"] = t;
    for (const auto& r : ev.rows)
      if (r.mask.empty()) j[shared ? "null_shared" : "null_rsi"] = shared ? r.shared.h_norm : r.rsi.h_norm;
  }
  return j;
}

/// JSON rows of the per-class evaluation.
inline nlohmann::json to_json(const std::vector<ClassEvaluation>& rows) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& r : rows)
    a.push_back({{"mask", r.mask.to_string()},
                 {"class", to_string(r.motion_class)},
                 {"clip_seconds", r.reference_seconds},
                 {"clip_speed", r.reference_speed},
                 {"clip_forward_speed", r.reference_forward},
                 {"result", to_json(r.result)}});
  return a;
}

}  // namespace maskadapt::train
