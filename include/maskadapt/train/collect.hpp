#pragma once
/// \file collect.hpp
/// The rollout collection loop, shared by stage 1 (base_trainer.hpp) and stage 2
/// (residual_trainer.hpp): `horizon` steps of N envs of an imitation task into a rollout buffer.
///
/// What differs between the stages is the agent: what it feeds the actor and critic, what it sends
/// to the simulator, and whether something besides the task ends an episode (stage 2's goal task).
/// The loop itself — timing, AMP windows, episode ends, the values of truncated episodes' last
/// observations and the bootstrap values — is written once, here.
#include <maskadapt/core/types.hpp>
#include <maskadapt/rl/rollout_buffer.hpp>
#include <maskadapt/train/progress.hpp>

#include <concepts>
#include <cstddef>

namespace maskadapt::train {

/// How one env's step ended, as the buffer records it: `terminated` (failure, no bootstrap) and
/// `truncated` (time limit, bootstrap from the last observation) never both.
struct StepEnd {
  bool terminated = false;
  bool truncated = false;
};

/// What the collection loop needs from a trainer.
///  - `act(t, c0)`: runs the actor and critic on the current observations, records step t (its
///    columns start at c0) with `buffer.record_policy_step`, and returns what the task steps with
///    (N columns: actions or PD targets);
///  - `end_step(e, column, end)`: after the simulator step, env e's outcome as the task reported
///    it; the agent may change it (a goal task ending the episode) and records its own per-sample
///    quantities in `column`;
///  - `final_values(final_obs)`: values (objectives × N) of the observations before the resets,
///    called only in steps where some episode was truncated;
///  - `bootstrap_values()`: values (objectives × N) of the observations after the last step.
/// The matrices returned are the agent's own (so that collection allocates nothing once sized).
template <class A>
concept CollectionAgent = requires(A& a, Index i, StepEnd& end, const MatrixX<float>& m) {
  { a.act(i, i) } -> std::convertible_to<const MatrixX<float>&>;
  a.end_step(i, i, end);
  { a.final_values(m) } -> std::convertible_to<const MatrixX<float>&>;
  { a.bootstrap_values() } -> std::convertible_to<const MatrixX<float>&>;
};

/// Collects `buf.spec.horizon` steps of `task` (an imitation task: step, terminated, truncated,
/// amp_windows, final_observations) into `buf`; inference and simulation times go into `st`.
template <class Task, CollectionAgent Agent>
void collect_rollout(Task& task, rl::RolloutBuffer<float>& buf, Agent& agent, IterationStats& st) {
  const Index N = task.num_envs(), H = buf.spec.horizon;
  for (Index t = 0; t < H; ++t) {
    Stopwatch inf;
    const Index c0 = buf.step_begin(t);
    const MatrixX<float>& to_sim = agent.act(t, c0);
    st.time_inference += inf.seconds();

    Stopwatch sim;
    task.step(to_sim);
    st.time_sim += sim.seconds();

    Stopwatch inf2;
    buf.amp_windows.middleCols(c0, N) = task.amp_windows();
    bool any_truncated = false;
    for (Index e = 0; e < N; ++e) {
      const auto ue = static_cast<std::size_t>(e);
      StepEnd end{task.terminated()[ue] != 0, task.truncated()[ue] != 0};
      agent.end_step(e, c0 + e, end);
      end.truncated = end.truncated && !end.terminated;
      buf.terminated[static_cast<std::size_t>(c0 + e)] = end.terminated ? 1 : 0;
      buf.truncated[static_cast<std::size_t>(c0 + e)] = end.truncated ? 1 : 0;
      any_truncated |= end.truncated;
    }
    if (any_truncated) {
      buf.final_values.middleCols(c0, N) = agent.final_values(task.final_observations());
    }
    st.time_inference += inf2.seconds();
  }
  Stopwatch inf;
  buf.bootstrap_values = agent.bootstrap_values();
  st.time_inference += inf.seconds();
}

}  // namespace maskadapt::train
