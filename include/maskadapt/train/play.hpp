#pragma once
/// \file play.hpp
/// Running a trained base policy (`maskadapt play`): one env on any `Simulator`, a fixed or
/// scheduled part mask, and the rollout recorded three ways —
///  - a viewer rollout (eval/rollout_file.hpp): body poses, the active mask and contacts per frame;
///  - a humanoid MotionClip (joint angles recovered from the simulated body orientations), which
///    humanoid/retarget.hpp's clip_to_bvh turns into a BVH file;
///  - the root's ground trajectory (t, x, y) for plots.
///
/// The initial state comes from the reset sampler (RSI from the motion library in the CLI), drawn
/// with Rng::stream(seed, 0). Actions are sampled from π(·|s̄, m) with Rng::stream(seed, 0x91A7)
/// (or its mean with `deterministic`). By default a fall does not reset the humanoid — the
/// recording stays continuous and shows what the policy does; falls are counted and timed.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/eval/rollout_file.hpp>
#include <maskadapt/mask/sampler.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/motion/rotation.hpp>
#include <maskadapt/sim/termination.hpp>
#include <maskadapt/tasks/imitation.hpp>
#include <maskadapt/train/base_policy.hpp>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <optional>
#include <string>
#include <vector>

namespace maskadapt::train {

struct PlayOptions {
  double seconds = 30.0;        ///< length of the recording (s)
  /// Masks over time (MaskSampler::fixed / ::scheduled); nullopt ⇒ the null mask throughout.
  std::optional<MaskSampler> masks;
  bool deterministic = false;   ///< act with the policy mean instead of sampling
  bool reset_on_fall = false;   ///< reset by RSI when the humanoid falls (default: keep recording)
  std::uint64_t seed = 1;
};

struct PlayResult {
  eval::Rollout rollout;           ///< per frame: body poses, mask, contacts
  MotionClip clip;                 ///< the same frames as a humanoid clip (joint angles)
  Matrix3X root;                   ///< (3 × frames) root positions (m)
  std::vector<double> fall_times;  ///< s; times at which a fall began
  long long resets = 0;            ///< RSI resets after falls (reset_on_fall) or failed physics
  double dt = 0;                   ///< s per frame
};

/// Joint angles of a pose from world body orientations: body i's local rotation R_p(i)ᵀ R_i
/// decomposed into its hinges — three about x, y, z (the humanoid's) nearest to `hint` (previous
/// frame; keeps sequences continuous), or one hinge about any axis a: the angle of the local
/// rotation about a, 2·atan2(v·a, w) for its quaternion (w, v), unwrapped towards `hint`.
/// Returns (num_dofs). Throws for a joint of two hinges, or of three about other axes, whose
/// angles a rotation alone does not fix here.
inline VectorXd joint_angles_from_body_states(const Skeleton& skel, const BodyStates& b, const VectorXd& hint) {
  VectorXd q(skel.num_dofs());
  const bool hinted = hint.size() == q.size();
  for (int i = 1; i < skel.num_bodies(); ++i) {
    const int k = skel.dof_offset(i);
    const Quat local = b.rot[static_cast<std::size_t>(skel.parents[i])].conjugate() * b.rot[static_cast<std::size_t>(i)];
    if (skel.num_dofs_of(i) == 1) {
      const double angle = 2.0 * std::atan2(local.vec().dot(skel.dof_axis(k)), local.w());
      q[k] = hinted ? hint[k] + wrap_angle(angle - hint[k]) : wrap_angle(angle);
      continue;
    }
    if (!skel.has_xyz_hinges(i))
      skel.require_xyz_hinges(i, "joint_angles_from_body_states (one hinge of any axis, or three about x, y, z)");
    q.segment<3>(k) = joint_angles_near(local, hinted ? Vec3(hint.segment<3>(k)) : Vec3::Zero());
  }
  return q;
}

/// Appends the pose of `b` as the next frame of `clip` (allocated for `skel`).
inline void append_clip_frame(const Skeleton& skel, const BodyStates& b, MotionClip& clip) {
  const int t = clip.num_frames();
  const VectorXd hint = t > 0 ? VectorXd(clip.q.col(t - 1)) : VectorXd();
  const VectorXd q = joint_angles_from_body_states(skel, b, hint);
  clip.root_pos.conservativeResize(3, t + 1);
  clip.root_rot.conservativeResize(4, t + 1);
  clip.q.conservativeResize(skel.num_dofs(), t + 1);
  clip.root_pos.col(t) = b.pos.col(0);
  clip.set_rot(t, b.rot[0]);
  clip.q.col(t) = q;
}

/// Runs `policy` on env 0 of `sim` for opt.seconds and records it. `rollout` supplies the
/// viewer skeleton (e.g. eval::make_rollout(humanoid_description())); frames are appended to a
/// copy. Frame 0 is the initial state; one frame per control step follows.
template <Simulator Sim>
PlayResult play_base_policy(Sim& sim, const BasePolicy& policy, tasks::ResetSampler reset, const PlayOptions& opt,
                            eval::Rollout rollout, std::optional<FallCriteria> fall = std::nullopt,
                            double min_head_height = 0.3) {
  require(std::isfinite(opt.seconds) && opt.seconds > 0, "seconds must be > 0", {{}, {}, "seconds"});
  tasks::ImitationTaskConfig tc;
  tc.fall = std::move(fall);
  tc.min_head_height = min_head_height;
  tc.episode_seconds = opt.seconds + 1.0;  // no truncation inside the recording
  tc.early_termination = opt.reset_on_fall;
  tc.masking = false;
  tc.actions = policy.actions;  // the policy's actions → PD targets
  Rng mask_rng = Rng::stream(opt.seed, 0x3A5CULL);
  auto mask_at = [&](double t) { return opt.masks ? opt.masks->sample(mask_rng, t) : PartMask::none(); };
  tc.fixed_mask = mask_at(0.0);
  tasks::ImitationTask<Sim> task(sim, std::move(reset), tc, opt.seed);
  require(policy.ac.actor.input_dim() == task.policy_input_dim() && policy.ac.actor.action_dim() == task.action_dim(),
          "the policy's sizes (" + std::to_string(policy.ac.actor.input_dim()) + " → " +
              std::to_string(policy.ac.actor.action_dim()) + ") do not fit this simulator (" +
              std::to_string(task.policy_input_dim()) + " → " + std::to_string(task.action_dim()) + ")",
          {{}, {}, "checkpoint"});
  const FallCriteria criteria = *task.config().fall;
  const Skeleton& skel = sim.skeleton();
  const Index N = task.num_envs();

  PlayResult out;
  out.dt = sim.control_dt();
  out.rollout = std::move(rollout);
  out.rollout.fps = 1.0 / out.dt;
  out.clip.fps = 1.0 / out.dt;
  out.clip.resize(0, skel.num_dofs());
  const long long steps = std::max<long long>(1, std::llround(opt.seconds / out.dt));
  out.root.resize(3, steps + 1);
  bool was_fallen = false;
  auto record = [&](long long f, PartMask mask) {
    const BodyStates& b = sim.body_states(0);
    eval::add_frame(out.rollout, b, mask, sim.contacts(0));
    append_clip_frame(skel, b, out.clip);
    out.root.col(f) = b.pos.col(0);
    const bool fallen = has_fallen(criteria, b, sim.contacts(0));
    if (fallen && !was_fallen) out.fall_times.push_back(static_cast<double>(f) * out.dt);
    was_fallen = fallen;
  };

  Rng act_rng = Rng::stream(opt.seed, 0x91A7ULL);
  nn::InferenceWorkspace<float> ws;
  MatrixXf actions(task.action_dim(), N), mu(task.action_dim(), N), scratch;
  RowVectorX<float> logp;
  record(0, task.masks()[0]);
  for (long long f = 1; f <= steps; ++f) {
    if (opt.deterministic) {
      policy.ac.actor.mean(task.policy_inputs(), mu, ws, scratch);
      actions = mu;
    } else {
      policy.ac.actor.act(task.policy_inputs(), act_rng, actions, logp, mu, ws, scratch);
    }
    task.step(actions);
    if (task.terminated()[0]) {
      ++out.resets;
      was_fallen = false;
    }
    const double t = static_cast<double>(f) * out.dt;
    const PartMask m = mask_at(t);
    if (!(m == task.masks()[0])) task.set_fixed_mask(m);
    record(f, task.masks()[0]);
  }
  return out;
}

/// Writes the root's ground trajectory as CSV: header `t,x,y`, one row per frame (s, m, m).
inline void write_root_xy_csv(const std::string& path, const Matrix3X& root, double dt) {
  std::ofstream f(path);
  require(static_cast<bool>(f), "cannot open for writing", {path, std::nullopt, {}});
  f << "t,x,y\n" << std::setprecision(9);
  for (Index i = 0; i < root.cols(); ++i) f << static_cast<double>(i) * dt << ',' << root(0, i) << ',' << root(1, i) << '\n';
  require(static_cast<bool>(f), "write failed", {path, std::nullopt, {}});
}

}  // namespace maskadapt::train
