#pragma once
/// \file actor_critic.hpp
/// Gaussian actor and critic, each an nn::Mlp behind its own running input normaliser.
///
///   actor:  a ~ N(μ(norm_π(x)), diag(exp(2·log_std)))   x = policy input (e.g. [s̄ ; m]), (policy_input_dim × B)
///           log_std is state-independent (action_dim), fixed by default (AMP/ASE: −2.9) or learned.
///   critic: V(norm_V(c)) (num_values × B)               c = critic input; the value function may
///           see the full, unmasked state (critic_input_dim = obs_dim), one row per objective.
///
/// Presets: `paper` hidden sizes [1024, 1024, 512] for both networks (the paper's); `cpu`
/// [256, 256] (our small preset for 2-core runs and tests — not from the paper).
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/nn/chunks.hpp>
#include <maskadapt/nn/gaussian.hpp>
#include <maskadapt/nn/mlp.hpp>
#include <maskadapt/nn/normalizer.hpp>
#include <maskadapt/nn/parameter_block.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace maskadapt::rl {

struct ActorCriticConfig {
  Index policy_input_dim = 0;  ///< actor input rows (humanoid: 328 + 5)
  Index critic_input_dim = 0;  ///< critic input rows (humanoid: 328, the full state)
  Index action_dim = 0;        ///< action rows
  Index num_values = 1;        ///< critic outputs: one per objective
  std::vector<Index> actor_hidden{1024, 1024, 512};   ///< paper
  std::vector<Index> critic_hidden{1024, 1024, 512};  ///< paper
  nn::Activation activation = nn::Activation::ReLU;
  double init_log_std = -2.9;  ///< σ = e^−2.9 ≈ 0.055 (ASE/AMP humanoid setting)
  bool learn_log_std = false;  ///< AMP keeps σ fixed; true learns it (then the MI KL also moves it)
  bool normalize_inputs = true;
  double normalizer_clip = 5.0;  ///< normalised inputs clipped to ±5

  /// The paper's sizes [1024, 1024, 512].
  static ActorCriticConfig paper(Index policy_input_dim, Index critic_input_dim, Index action_dim) {
    ActorCriticConfig c;
    c.policy_input_dim = policy_input_dim;
    c.critic_input_dim = critic_input_dim;
    c.action_dim = action_dim;
    return c;
  }
  /// Small preset for CPU runs and tests: [256, 256] (ours, not the paper's).
  static ActorCriticConfig cpu(Index policy_input_dim, Index critic_input_dim, Index action_dim) {
    ActorCriticConfig c = paper(policy_input_dim, critic_input_dim, action_dim);
    c.actor_hidden = {256, 256};
    c.critic_hidden = {256, 256};
    return c;
  }
  void validate() const {
    require(policy_input_dim > 0, "must be positive", {{}, {}, "ActorCriticConfig.policy_input_dim"});
    require(critic_input_dim > 0, "must be positive", {{}, {}, "ActorCriticConfig.critic_input_dim"});
    require(action_dim > 0, "must be positive", {{}, {}, "ActorCriticConfig.action_dim"});
    require(num_values > 0, "must be positive", {{}, {}, "ActorCriticConfig.num_values"});
    require(std::isfinite(init_log_std), "must be finite", {{}, {}, "ActorCriticConfig.init_log_std"});
  }
};

/// Gaussian policy: mean network + state-independent log-std (its own ParameterBlock).
template <class T = float>
struct GaussianActor {
  nn::Mlp<T> mean_net;               ///< policy_input_dim → action_dim
  nn::ParameterBlock<T> log_std;     ///< (action_dim) parameters; grads used only when learned
  bool learn_log_std = false;
  bool normalize_inputs = true;
  nn::RunningNormalizer<T> normalizer;  ///< over the policy input
  /// Hidden elements at their mean (empty: off, every row is normalised as it comes). For a
  /// policy input [s̄ ; m] — n rows of s̄, then G = input_dim − n rows of 0/1 group flags (the
  /// part mask) — `hidden_groups[i]` ∈ [0, G) is the group of row i of s̄. Then normalize() writes 0 — the running mean — for every element whose group
  /// flag is set in its column, and passes the G flag rows through unnormalised. The normaliser's
  /// statistics must then come from unmasked inputs (the trainer feeds it [s ; 0]), so a hidden
  /// element is indistinguishable from an average one and the flags keep their 0/1 scale however
  /// rarely they were set while the statistics were gathered.
  std::vector<std::uint8_t> hidden_groups;

  GaussianActor() = default;
  GaussianActor(const ActorCriticConfig& c, Rng& rng)
      : mean_net(nn::MlpSpec{c.policy_input_dim, c.actor_hidden, c.action_dim, c.activation}, rng),
        log_std(c.action_dim),
        learn_log_std(c.learn_log_std),
        normalize_inputs(c.normalize_inputs),
        normalizer(c.policy_input_dim, c.normalizer_clip) {
    log_std.params().setConstant(static_cast<T>(c.init_log_std));
  }

  Index input_dim() const { return mean_net.inputs(); }
  Index action_dim() const { return mean_net.outputs(); }
  /// log-std as a (action_dim × 1) matrix view.
  Eigen::Map<const MatrixX<T>> log_std_col() const { return {log_std.params().data(), action_dim(), 1}; }

  /// norm(x) (input_dim × B) into out (resized); identity when normalisation is off; with
  /// hidden_groups, hidden elements at 0 and the group flags as they are (see hidden_groups).
  void normalize(const Eigen::Ref<const MatrixX<T>>& x, MatrixX<T>& out) const {
    out.resize(x.rows(), x.cols());
    if (normalize_inputs) normalizer.normalize(x, out);
    else out = x;
    if (hidden_groups.empty()) return;
    const Index n = static_cast<Index>(hidden_groups.size()), G = x.rows() - n;
    nn::for_each_column_chunk(nn::default_pool(), x.rows(), x.cols(), [&](Index c0, Index c1) {
      for (Index j = c0; j < c1; ++j) {
        out.col(j).tail(G) = x.col(j).tail(G);
        bool any = false;
        for (Index g = 0; g < G; ++g) any = any || x(n + g, j) != T(0);
        if (!any) continue;
        for (Index i = 0; i < n; ++i)
          if (x(n + hidden_groups[static_cast<std::size_t>(i)], j) != T(0)) out(i, j) = T(0);
      }
    });
  }

  /// Sets hidden_groups (one group per row of s̄; the remaining input rows are the group flags).
  void set_hidden_groups(std::vector<std::uint8_t> groups) {
    const Index n = static_cast<Index>(groups.size()), G = input_dim() - n;
    require(n > 0 && G > 0, "hidden groups must cover the observation rows and leave the flag rows",
            {{}, {}, "GaussianActor.hidden_groups"});
    for (std::uint8_t g : groups)
      require(static_cast<Index>(g) < G, "group index beyond the flag rows", {{}, {}, "GaussianActor.hidden_groups"});
    hidden_groups = std::move(groups);
  }

  /// Writes hidden_groups as the int64 section `name` (nothing when they are empty).
  void save_hidden_groups(Checkpoint& c, const std::string& name) const {
    if (hidden_groups.empty()) return;
    VectorX<std::int64_t> g(static_cast<Index>(hidden_groups.size()));
    for (Index i = 0; i < g.size(); ++i) g[i] = hidden_groups[static_cast<std::size_t>(i)];
    c.put(name, g);
  }
  /// Reads what save_hidden_groups wrote for an input whose last `flag_rows` rows are the group
  /// flags; an absent section clears them (every row normalised). Throws naming the section on a
  /// size other than input_dim − flag_rows or a group beyond the flag rows.
  void load_hidden_groups(const Checkpoint& c, const std::string& name, Index flag_rows) {
    hidden_groups.clear();
    if (!c.contains(name)) return;
    const Index n = input_dim() - flag_rows;
    const VectorX<std::int64_t> g = c.get_vector<std::int64_t>(name, n);
    std::vector<std::uint8_t> groups(static_cast<std::size_t>(n));
    for (Index i = 0; i < n; ++i) {
      require(g[i] >= 0 && g[i] < flag_rows, "body part index out of range", {c.source(), std::nullopt, name});
      groups[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(g[i]);
    }
    set_hidden_groups(std::move(groups));
  }

  /// Mean action μ (action_dim × B) for inputs x (inference path; `scratch` holds the normalised input).
  void mean(const Eigen::Ref<const MatrixX<T>>& x, Eigen::Ref<MatrixX<T>> mu, nn::InferenceWorkspace<T>& ws,
            MatrixX<T>& scratch) const {
    normalize(x, scratch);
    mean_net.forward(scratch, mu, ws);
  }

  /// Samples actions (action_dim × B) and their log-probs (1 × B); also returns μ in `mu`.
  void act(const Eigen::Ref<const MatrixX<T>>& x, Rng& rng, MatrixX<T>& actions, RowVectorX<T>& log_prob,
           MatrixX<T>& mu, nn::InferenceWorkspace<T>& ws, MatrixX<T>& scratch) const {
    mu.resize(action_dim(), x.cols());
    mean(x, mu, ws, scratch);
    actions.resize(action_dim(), x.cols());
    log_prob.resize(x.cols());
    nn::gaussian_sample<T>(mu, log_std_col(), rng, actions);
    nn::gaussian_log_prob<T>(mu, log_std_col(), actions, log_prob);
  }

  /// Parameter blocks an optimiser steps (log-std only when learned).
  std::vector<nn::ParameterBlock<T>*> trainable_blocks() {
    std::vector<nn::ParameterBlock<T>*> b{&mean_net.block()};
    if (learn_log_std) b.push_back(&log_std);
    return b;
  }
  void zero_grad() {
    mean_net.zero_grad();
    log_std.zero_grad();
  }
};

/// Value function: one output row per objective.
template <class T = float>
struct Critic {
  nn::Mlp<T> net;  ///< critic_input_dim → num_values
  bool normalize_inputs = true;
  nn::RunningNormalizer<T> normalizer;

  Critic() = default;
  Critic(const ActorCriticConfig& c, Rng& rng)
      : net(nn::MlpSpec{c.critic_input_dim, c.critic_hidden, c.num_values, c.activation}, rng),
        normalize_inputs(c.normalize_inputs),
        normalizer(c.critic_input_dim, c.normalizer_clip) {}

  void normalize(const Eigen::Ref<const MatrixX<T>>& x, MatrixX<T>& out) const {
    out.resize(x.rows(), x.cols());
    if (normalize_inputs) normalizer.normalize(x, out);
    else out = x;
  }
  /// V (num_values × B) of critic inputs c (critic_input_dim × B).
  void value(const Eigen::Ref<const MatrixX<T>>& c, Eigen::Ref<MatrixX<T>> v, nn::InferenceWorkspace<T>& ws,
             MatrixX<T>& scratch) const {
    normalize(c, scratch);
    net.forward(scratch, v, ws);
  }
  MatrixX<T> value(const Eigen::Ref<const MatrixX<T>>& c) const {
    MatrixX<T> v(net.outputs(), c.cols()), scratch;
    nn::InferenceWorkspace<T> ws;
    value(c, v, ws, scratch);
    return v;
  }
};

template <class T = float>
struct ActorCritic {
  ActorCriticConfig config;
  GaussianActor<T> actor;
  Critic<T> critic;

  ActorCritic() = default;
  ActorCritic(const ActorCriticConfig& c, Rng& rng) : config((c.validate(), c)), actor(c, rng), critic(c, rng) {}

  /// Adds a batch to both input normalisers (call during collection, not during updates).
  void update_normalizers(const Eigen::Ref<const MatrixX<T>>& policy_input, const Eigen::Ref<const MatrixX<T>>& critic_input) {
    if (actor.normalize_inputs) actor.normalizer.update(policy_input);
    if (critic.normalize_inputs) critic.normalizer.update(critic_input);
  }
};

}  // namespace maskadapt::rl
