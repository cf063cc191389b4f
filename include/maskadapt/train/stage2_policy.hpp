#pragma once
/// \file stage2_policy.hpp
/// What the stage-2 trainer and evaluations need from a policy on a frozen base
/// (`Stage2Policy`), the two that model it — adapt::ResidualPolicy (ours, cml, scratch) and
/// adapt::AdaptNetPolicy (the AdaptNet baseline, goal tasks only) — and how each is built for a
/// run and read back from a train-residual checkpoint.
///
/// Stage2Policy, for `P& p`, `const P& cp`, its workspace `ws` and training cache `c`
/// (`Stage2Types<P>`), inputs and outputs as (rows × batch) float matrices:
///
/// | expression | meaning |
/// | --- | --- |
/// | `cp.input_dim()`, `cp.action_dim()`, `cp.goal_dim()`, `cp.obs_dim()` | sizes |
/// | `cp.build_input(pe, obs, masks, goals, x, ws)` | the policy input of a batch |
/// | `cp.act(x, masks, rng, a, logp, mu, ws)`, `cp.mean(x, masks, mu, ws)` | sample / mean actions (the base's units) |
/// | `cp.forward_train(x, masks, c)`, `cp.log_prob(c, a, lp)`, `P::log_prob_mean_grad(c, a, dlogp, dmu)`, `p.backward(c, dmu)` | PPO's pass |
/// | `p.zero_grad()`, `p.trainable_blocks()` | what Adam steps (never the base) |
/// | `p.residual().normalizer`, `p.residual().log_std` | the input normaliser and the learned log σ |
/// | `cp.actions()`, `cp.to_targets(a, targets)` | the base's action space: PD targets |
/// | `cp.save(ck, with_base)`, `p.load(ck, with_base)` | checkpoint sections |
/// | `cp.base()` | the frozen stage-1 actor |
#include <maskadapt/adapt/adaptnet_policy.hpp>
#include <maskadapt/adapt/residual_policy.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/train/residual_config.hpp>

#include <concepts>
#include <span>
#include <vector>

namespace maskadapt::train {

/// Workspace and training-cache types of a stage-2 policy.
template <class P>
struct Stage2Types;
template <>
struct Stage2Types<adapt::ResidualPolicy<float>> {
  using Workspace = adapt::ResidualWorkspace<float>;
  using Cache = adapt::ResidualTrainCache<float>;
};
template <>
struct Stage2Types<adapt::AdaptNetPolicy<float>> {
  using Workspace = adapt::AdaptNetWorkspace<float>;
  using Cache = adapt::AdaptNetTrainCache<float>;
};

template <class P>
concept Stage2Policy = requires(P& p, const P& cp, typename Stage2Types<P>::Cache& c, typename Stage2Types<P>::Workspace& ws,
                                const PartElements& pe, MatrixXf& m, RowVectorX<float>& r, Rng& rng, Checkpoint& ck,
                                const Checkpoint& cck, std::span<const PartMask> masks) {
  { cp.input_dim() } -> std::convertible_to<Index>;
  { cp.action_dim() } -> std::convertible_to<Index>;
  { cp.goal_dim() } -> std::convertible_to<Index>;
  { cp.obs_dim() } -> std::convertible_to<Index>;
  cp.build_input(pe, m, masks, m, m, ws);
  cp.act(m, masks, rng, m, r, m, ws);
  cp.mean(m, masks, m, ws);
  { cp.forward_train(m, masks, c) } -> std::same_as<const MatrixXf&>;
  cp.log_prob(c, m, r);
  P::log_prob_mean_grad(c, m, r, m);
  p.backward(c, m);
  p.zero_grad();
  { p.trainable_blocks() } -> std::same_as<std::vector<nn::ParameterBlock<float>*>>;
  p.residual().normalizer.update(m);
  p.residual().log_std.params();
  { cp.actions() } -> std::same_as<const tasks::ActionSpace&>;
  cp.to_targets(m, m);
  cp.save(ck, true);
  p.load(cck, true);
  cp.base();
};
static_assert(Stage2Policy<adapt::ResidualPolicy<float>>);
static_assert(Stage2Policy<adapt::AdaptNetPolicy<float>>);

/// AdaptNet's settings for a run: the goal rows, F_φ with the run's residual hidden widths
/// (`residual_hidden`), full-rank internal adaptation on the hidden layers.
inline adapt::AdaptNetConfig adaptnet_config(const ResidualTrainConfig& c, Index goal_dim) {
  adapt::AdaptNetConfig a;
  a.goal_dim = goal_dim;
  a.embed_hidden = c.residual_hidden;
  return a;
}

/// A run's stage-2 policy on `base` (zero-initialised adaptation: it acts as the base at step 0).
template <class P>
P make_stage2_policy(FrozenBase base, Index obs_dim, const Skeleton& skel, const ResidualTrainConfig& c, Index goal_dim, Rng& init) {
  if constexpr (std::same_as<P, adapt::AdaptNetPolicy<float>>) {
    return P(std::move(base.actor), obs_dim, adaptnet_config(c, goal_dim), init, std::move(base.actions));
  } else {
    adapt::ResidualConfig rc = residual_net_config(c, skel);
    rc.goal_dim = goal_dim;
    return P(std::move(base.actor), obs_dim, action_parts(skel), rc, init, std::move(base.actions));
  }
}

/// The stage-2 policy stored in a train-residual checkpoint (`config` receives the run's config).
/// Throws naming `method` when the checkpoint's method does not train a P.
template <class P>
P stage2_policy_from_checkpoint(const Checkpoint& ck, const Skeleton& skel, ResidualTrainConfig* config = nullptr) {
  if constexpr (std::same_as<P, adapt::ResidualPolicy<float>>) {
    return residual_policy_from_checkpoint(ck, skel, config);
  } else {
    const ResidualTrainConfig c =
        residual_config_from_json(nlohmann::json::parse(ck.get_string("residual_config")), ck.source());
    require(c.method == "adaptnet", "the checkpoint's method is " + c.method + ", not adaptnet", {ck.source(), std::nullopt, "method"});
    const Index obs_dim = observation_dim(skel), A = skel.num_dofs();
    Rng init(0);
    P pol(base_actor_like(c, obs_dim, A), obs_dim, adaptnet_config(c, task_goal_dim(c, skel)), init);
    pol.load(ck, true);
    if (config) *config = c;
    return pol;
  }
}

}  // namespace maskadapt::train
