#pragma once
/// \file base_policy.hpp
/// The networks of a stage-1 base policy and their checkpoint sections, shared by the trainer,
/// `maskadapt play`, `maskadapt eval-base` and stage 2.
///
/// A base policy is
///  - the actor–critic (rl/actor_critic.hpp): Gaussian actor π(a | [s̄ ; m]) with its input
///    normaliser ((obs_dim + 5) → action_dim), critic V(s) on the full state (obs_dim → 1);
///  - the AMP discriminator (rl/discriminator.hpp) over 5-frame windows of unmasked features
///    (5·obs_dim → 1 logit), with its normaliser and Adam state, gradient penalty on real samples.
///
/// Checkpoint sections (names are stable; stage 2 reads `config`, `actor/params`, `actor/norm`):
///   config                    the BaseTrainConfig as JSON text (architecture + everything else)
///   actor/params, actor/log_std, critic/params, disc/params        network parameters (float)
///   actor/norm/{count,mean,m2}, critic/norm/…, disc/norm/…         running normalisers (double)
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/nn/activation.hpp>
#include <maskadapt/nn/normalizer.hpp>
#include <maskadapt/rl/actor_critic.hpp>
#include <maskadapt/rl/discriminator.hpp>
#include <maskadapt/train/config.hpp>

#include <string>

namespace maskadapt::train {

inline nn::Activation activation_from_name(const std::string& name) {
  if (name == "relu") return nn::Activation::ReLU;
  if (name == "elu") return nn::Activation::ELU;
  if (name == "silu") return nn::Activation::SiLU;
  if (name == "tanh") return nn::Activation::Tanh;
  throw Error("unknown activation '" + name + "'", {{}, std::nullopt, "net.activation"});
}

/// Dimensions a base policy is built for (humanoid: obs 328, policy input 333, actions 63,
/// discriminator windows 5 × 328).
struct PolicyDims {
  Index obs_dim = 0;           ///< full observation s
  Index policy_input_dim = 0;  ///< [s̄ ; m] = obs_dim + 5
  Index action_dim = 0;        ///< PD targets (num_dofs)
  Index amp_dim = 0;           ///< discriminator window (5 · obs_dim)
};

/// Networks of a base policy.
struct BasePolicy {
  rl::ActorCritic<float> ac;
  rl::Discriminator<float> disc;  ///< amp_dim → 1 logit (normaliser + Adam inside)
};

/// The discriminator configuration implied by a trainer config.
inline rl::DiscriminatorConfig discriminator_config(const BaseTrainConfig& c, Index amp_dim) {
  rl::DiscriminatorConfig d;
  d.feature_dim = amp_dim;
  d.hidden = c.net.disc_hidden;
  d.activation = activation_from_name(c.net.activation);
  d.loss = c.disc.lsgan ? rl::DiscriminatorLoss::LSGAN : rl::DiscriminatorLoss::BCE;
  d.grad_penalty = c.disc.gradient_penalty;
  d.logit_reg = c.disc.logit_reg;
  d.weight_decay = c.disc.weight_decay;
  d.lr = c.disc.lr;
  d.max_grad_norm = c.ppo.max_grad_norm;
  d.reward_scale = c.disc.reward_scale;
  return d;
}

/// Freshly initialised networks for `c` (actor–critic first, then the discriminator, from `init`).
inline BasePolicy make_base_policy(const BaseTrainConfig& c, const PolicyDims& dims, Rng& init) {
  rl::ActorCriticConfig ac;
  ac.policy_input_dim = dims.policy_input_dim;
  ac.critic_input_dim = dims.obs_dim;
  ac.action_dim = dims.action_dim;
  ac.actor_hidden = c.net.actor_hidden;
  ac.critic_hidden = c.net.critic_hidden;
  ac.activation = activation_from_name(c.net.activation);
  ac.init_log_std = c.net.init_log_std;
  ac.learn_log_std = c.net.learn_log_std;
  BasePolicy p;
  p.ac = rl::ActorCritic<float>(ac, init);
  p.disc = rl::Discriminator<float>(discriminator_config(c, dims.amp_dim), init);
  return p;
}

inline void save_normalizer(const nn::RunningNormalizer<float>& n, const std::string& name, Checkpoint& c) {
  c.put_double(name + "/count", n.count());
  c.put(name + "/mean", n.mean());
  c.put(name + "/m2", n.m2());
}
inline void load_normalizer(const Checkpoint& c, const std::string& name, nn::RunningNormalizer<float>& n) {
  n.set_state(c.get_double(name + "/count"), c.get_vector<double>(name + "/mean", n.dim()),
              c.get_vector<double>(name + "/m2", n.dim()));
}

/// Writes the policy's parameters and normalisers (not the optimiser states).
inline void save_policy(const BasePolicy& p, Checkpoint& c) {
  c.put("actor/params", p.ac.actor.mean_net.params());
  c.put("actor/log_std", p.ac.actor.log_std.params());
  c.put("critic/params", p.ac.critic.net.params());
  c.put("disc/params", p.disc.net().params());
  save_normalizer(p.ac.actor.normalizer, "actor/norm", c);
  save_normalizer(p.ac.critic.normalizer, "critic/norm", c);
  save_normalizer(p.disc.normalizer(), "disc/norm", c);
}

/// Reads what save_policy wrote into networks of the same sizes; throws naming the section on
/// a missing section or a size mismatch.
inline void load_policy(const Checkpoint& c, BasePolicy& p) {
  c.copy_to<float>("actor/params", p.ac.actor.mean_net.params());
  c.copy_to<float>("actor/log_std", p.ac.actor.log_std.params());
  c.copy_to<float>("critic/params", p.ac.critic.net.params());
  c.copy_to<float>("disc/params", p.disc.net().params());
  load_normalizer(c, "actor/norm", p.ac.actor.normalizer);
  load_normalizer(c, "critic/norm", p.ac.critic.normalizer);
  load_normalizer(c, "disc/norm", p.disc.normalizer());
}

/// A base policy and the configuration it was trained with, read from a stage-1 checkpoint.
struct LoadedBasePolicy {
  BaseTrainConfig config;
  BasePolicy policy;
  long long iteration = 0;  ///< training iterations done when the checkpoint was written
};

/// Loads the policy of a checkpoint written by BaseTrainer (architecture from its `config`
/// section). `source` labels errors (e.g. the file path).
inline LoadedBasePolicy load_base_policy(const Checkpoint& c, const PolicyDims& dims, const std::string& source = {}) {
  LoadedBasePolicy out;
  out.config = config_from_string(c.get_string("config"), source + " (config)");
  Rng init(0);
  out.policy = make_base_policy(out.config, dims, init);
  load_policy(c, out.policy);
  if (c.contains("trainer/iteration")) out.iteration = c.get_int("trainer/iteration");
  return out;
}

}  // namespace maskadapt::train
