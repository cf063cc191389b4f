#pragma once
/// \file simulator.hpp
/// The `Simulator` concept: what the library needs from a physics engine.
///
/// A simulator steps `num_envs()` independent copies of one articulated body (described by
/// `skeleton()`) at a fixed control rate. It reports *canonical* rigid-body quantities per env
/// (world positions, orientations, linear and angular velocities of every body, ground-contact
/// flags) and accepts PD targets for all envs at once. The library computes every feature, mask,
/// reward and termination from these, so no learning code includes an engine's headers.
///
/// Requirements, for `S& s`, `const S& cs`, env index `e` < num_envs():
///
/// | expression                  | returns                      | meaning |
/// | --------------------------- | ---------------------------- | ------- |
/// | `cs.num_envs()`             | convertible to `std::size_t` | number of envs |
/// | `cs.skeleton()`             | `const Skeleton&`            | bodies, parents, DoF layout, parts |
/// | `cs.control_dt()`           | convertible to `double`      | seconds per `step` |
/// | `s.reset(e, pose)`          | (any)                        | place env e at a `KinematicState` (pose + velocities) |
/// | `s.step(targets)`           | (any)                        | one control step of every env; `targets` is (num_dofs × num_envs) PD joint targets (rad), `Eigen::Ref<const MatrixXf>` |
/// | `cs.body_states(e)`         | `const BodyStates&`          | world states of every body after the last step/reset |
/// | `cs.contacts(e)`            | `const ContactFlags&`        | (num_bodies) 1 where the body touches the ground |
/// | `cs.step_stats()`           | `const StepStats&`           | counters, and which envs the engine had to reset in the last step |
///
/// Implementations must reject non-finite targets with `maskadapt::Error` and must never report
/// non-finite body states: an env whose physics fails is reset (to its last reset pose) and
/// flagged in `StepStats::physics_reset`, so the caller can end that episode.
///
/// Refinements: `tasks::StateSavingSimulator` (tasks/imitation.hpp: save/load one env's exact
/// state, for bit-exact resume) and `SceneSimulator` (sim/scene.hpp: rigid objects beside the
/// character, for tasks such as strike).
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/motion/skeleton.hpp>

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace maskadapt {

/// Per-body ground-contact flags, (num_bodies): 1 ⇔ the body touches the ground.
using ContactFlags = std::vector<std::uint8_t>;

/// Statistics of a simulator's stepping.
struct StepStats {
  std::uint64_t control_steps = 0;          ///< calls to step() so far
  std::uint64_t physics_resets = 0;         ///< envs reset because their physics failed, in total
  std::vector<std::uint8_t> physics_reset;  ///< (num_envs) 1 ⇔ env was reset during the last step()
};

template <class S>
concept Simulator = requires(S& s, const S& cs, std::size_t env, const KinematicState& pose,
                             const Eigen::Ref<const MatrixXf>& targets) {
  { cs.num_envs() } -> std::convertible_to<std::size_t>;
  { cs.skeleton() } -> std::same_as<const Skeleton&>;
  { cs.control_dt() } -> std::convertible_to<double>;
  s.reset(env, pose);
  s.step(targets);
  { cs.body_states(env) } -> std::same_as<const BodyStates&>;
  { cs.contacts(env) } -> std::same_as<const ContactFlags&>;
  { cs.step_stats() } -> std::same_as<const StepStats&>;
};

/// Checks a (num_dofs × num_envs) target matrix: dimensions and finiteness. Throws Error naming
/// "targets" and the first bad (row, column).
template <class Derived>
void check_targets(const Eigen::MatrixBase<Derived>& targets, Index num_dofs, Index num_envs) {
  require(targets.rows() == num_dofs && targets.cols() == num_envs,
          "targets are " + std::to_string(targets.rows()) + "x" + std::to_string(targets.cols()) + ", expected " +
              std::to_string(num_dofs) + "x" + std::to_string(num_envs) + " (num_dofs × num_envs)",
          {{}, {}, "targets"});
  require_finite(targets, "targets");
}

/// Checks a reset pose against a skeleton: sizes and finiteness. Throws Error naming the field.
inline void check_pose(const Skeleton& skel, const KinematicState& pose) {
  require(pose.q.size() == skel.num_dofs(),
          "pose has " + std::to_string(pose.q.size()) + " joint angles, expected " + std::to_string(skel.num_dofs()),
          {{}, {}, "pose.q"});
  require(pose.qd.size() == skel.num_dofs() || pose.qd.size() == 0,
          "pose has " + std::to_string(pose.qd.size()) + " joint rates, expected " + std::to_string(skel.num_dofs()),
          {{}, {}, "pose.qd"});
  require_finite(pose.root_pos, "pose.root_pos");
  require_finite(pose.root_rot.coeffs(), "pose.root_rot");
  require(pose.root_rot.norm() > 1e-9, "root quaternion has zero norm", {{}, {}, "pose.root_rot"});
  require_finite(pose.q, "pose.q");
  require_finite(pose.root_lin_vel, "pose.root_lin_vel");
  require_finite(pose.root_ang_vel, "pose.root_ang_vel");
  if (pose.qd.size()) require_finite(pose.qd, "pose.qd");
}

}  // namespace maskadapt
