#pragma once
/// \file goal_eval.hpp
/// Success rate of a stage-2 policy on a goal task (location, heading, strike; the paper's
/// Table 3): `sim`'s envs run the policy (mean by default) with a fixed adapted-part mask while the
/// goal task draws goals on its own schedule; fallen envs are reset by RSI and keep running. The
/// run stops once at least `min_trials` trials have ended (a trial: one goal, see
/// tasks/goal_task.hpp) and reports the success rate with its Wilson 95 % interval over the
/// trials that ended. It refuses to report fewer trials: a `max_steps` budget that ends first
/// throws, naming the count reached.
///
/// Actions go to the simulator as the PD targets offset + scale ⊙ â of the base's action space,
/// exactly as in training; the goal task's side of every step is tasks::advance_goal, the same
/// function the trainer calls.
///
/// The composed motion (Table 3's cells compose a motion B on some parts while pursuing the goal):
/// given B and its parts, every simulated frame's features of those parts are compared with every
/// frame of B, exactly as evaluate_composition's adapted side (residual_eval.hpp): H_norm(parts | B)
/// and the share of frames within threshold_per_body · √(bodies) of some frame of B. So a cell that
/// reaches its goal by giving up the swim or the punch shows it beside its success rate.
#include <maskadapt/adapt/residual_policy.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/sim/termination.hpp>
#include <maskadapt/tasks/goal_task.hpp>
#include <maskadapt/tasks/imitation.hpp>
#include <maskadapt/train/residual_eval.hpp>
#include <maskadapt/train/stage2_policy.hpp>

#include <cmath>
#include <optional>
#include <string>
#include <vector>

namespace maskadapt::train {

struct GoalEvalOptions {
  long long min_trials = 100;      ///< stop once this many trials have ended
  long long max_steps = 100000;    ///< control steps (per env) before giving up
  double episode_seconds = 10.0;   ///< episode limit (s)
  bool deterministic = true;       ///< policy mean (false: sample)
  std::uint64_t seed = 1;
};

/// The motion B a goal cell composes, on which parts (see the file comment).
struct ComposedMotion {
  const MotionLibrary* set = nullptr;  ///< B (not owned)
  PartMask parts;                      ///< the parts B is composed on (a cell's first training mask)
  double threshold_per_body = 0.1;     ///< m, as evaluate_composition's
};

/// How much of B the evaluation's frames show on the composed parts.
struct ComposedMotionMeasure {
  PartMask parts;
  double threshold_per_body = 0.1;  ///< m
  double h_norm = 0;                ///< H_norm(parts | B)
  double matched = 0;               ///< share of simulated frames within the threshold of some frame of B
};

struct GoalEvalResult {
  std::string task;
  tasks::TrialCounter trials;
  tasks::TrialOutcomes outcomes;   ///< how the trials ended, where the task says (tasks/goal_task.hpp)
  double ci_low = 0, ci_high = 1;  ///< Wilson 95 % interval of the success rate
  double mean_reward = 0;          ///< the goal task's reward, mean over env-steps
  double fall_rate = NAN;          ///< falls / ended episodes
  long long steps = 0;             ///< control steps per env it took
  std::optional<ComposedMotionMeasure> composed;  ///< when the evaluation was given a ComposedMotion
};

/// See the file comment. `goal` is copied: the caller's task is left as it was. `composed`
/// (optional): the cell's composed motion, measured beside the success rate.
template <Simulator Sim, class Policy>
GoalEvalResult evaluate_goal_task(Sim& sim, const Policy& policy, tasks::AnyGoalTask<Sim> goal,
                                  PartMask mask, tasks::ResetSampler reset, std::optional<FallCriteria> fall,
                                  const GoalEvalOptions& opt, ThreadPool* pool = nullptr,
                                  std::optional<ComposedMotion> composed = std::nullopt) {
  require(static_cast<bool>(goal), "no goal task to evaluate", {{}, {}, "task"});
  require(opt.min_trials >= 1 && opt.max_steps >= 1, "min_trials and max_steps must be >= 1", {{}, {}, "trials"});
  if (composed) {
    require(composed->set != nullptr && composed->set->num_clips() > 0, "no composed motion to measure",
            {{}, {}, "new_motions"});
    require(!composed->parts.empty() && composed->parts != PartMask::all(),
            "the composed parts must be neither empty nor every part", {{}, {}, "masks"});
    require(std::isfinite(composed->threshold_per_body) && composed->threshold_per_body >= 0,
            "the composition threshold must be finite and >= 0", {{}, {}, "threshold"});
  }
  tasks::ImitationTask<Sim> task(sim, std::move(reset), evaluation_task_config(policy, std::move(fall), opt.episode_seconds),
                                 opt.seed, pool);
  require(policy.obs_dim() == task.obs_dim() && policy.action_dim() == task.action_dim() && policy.goal_dim() == goal.goal_dim(),
          "the residual policy does not fit this simulator / goal task (goal rows " + std::to_string(policy.goal_dim()) +
              " vs the task's " + std::to_string(goal.goal_dim()) + ")",
          {{}, {}, "checkpoint"});
  const Index N = task.num_envs();
  for (Index e = 0; e < N; ++e) goal.new_episode(sim, e);
  goal.clear_trials();
  const PartElements pe(task.obs_parts());
  const std::vector<PartMask> masks(static_cast<std::size_t>(N), mask);
  MatrixXf goals(goal.goal_dim(), N), x, mu, actions;
  RowVectorX<float> logp;
  typename Stage2Types<Policy>::Workspace ws;
  Rng rng = Rng::stream(opt.seed, 0x60A1ULL);
  task.stats().clear();
  GoalEvalResult r;
  r.task = goal.name();
  double reward_sum = 0;
  const Skeleton& skel = sim.skeleton();
  std::vector<VectorXf> composed_frames;  // (3·bodies of the composed parts) per simulated frame
  long long t = 0;
  for (; t < opt.max_steps && goal.trials().trials < opt.min_trials; ++t) {
    for (Index e = 0; e < N; ++e) goal.goal(sim, e, goals.col(e));
    policy.build_input(pe, task.observations(), masks, goals, x, ws);
    if (opt.deterministic) policy.mean(x, masks, actions, ws);
    else policy.act(x, masks, rng, actions, logp, mu, ws);
    task.step(actions);
    for (Index e = 0; e < N; ++e) reward_sum += tasks::advance_goal(goal, task, e).reward;
    if (composed)
      for (Index e = 0; e < N; ++e)
        composed_frames.push_back(visitation_features(skel, sim.body_states(static_cast<std::size_t>(e)), composed->parts));
  }
  require(goal.trials().trials >= opt.min_trials,
          "only " + std::to_string(goal.trials().trials) + " trials ended within " + std::to_string(opt.max_steps) +
              " steps (need " + std::to_string(opt.min_trials) + "; raise the step budget or the env count)",
          {{}, {}, "max_steps"});
  r.trials = goal.trials();
  r.outcomes = goal.trial_outcomes();
  std::tie(r.ci_low, r.ci_high) = r.trials.wilson95();
  r.steps = t;
  r.mean_reward = reward_sum / static_cast<double>(t * N);
  r.fall_rate = task.stats().fall_rate();
  if (composed) {
    const MatrixXf ref = library_features(*composed->set, composed->parts);  // (3·bodies × frames of B)
    MatrixXf gen(ref.rows(), static_cast<Index>(composed_frames.size()));
    for (Index k = 0; k < gen.cols(); ++k) gen.col(k) = composed_frames[static_cast<std::size_t>(k)];
    const auto v = eval::visitation_entropy(ref, gen, composed->threshold_per_body * std::sqrt(bodies_in(skel, composed->parts)));
    r.composed = ComposedMotionMeasure{composed->parts, composed->threshold_per_body, v.h_norm,
                                       static_cast<double>(v.matched_generated) / static_cast<double>(gen.cols())};
  }
  return r;
}

}  // namespace maskadapt::train
