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
///   actor/action_offset, actor/action_scale   (num_dofs, float) PD target = offset + scale ⊙ a;
///                                              absent ⇒ 0 and 1 (the actions are the targets)
///
/// A policy-only export (train/policy_export.hpp, `maskadapt export`) keeps `config` and the
/// actor/ sections under these names and drops the rest; load_base_policy reads either file.
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/nn/activation.hpp>
#include <maskadapt/motion/library.hpp>
#include <maskadapt/nn/normalizer.hpp>
#include <maskadapt/rl/actor_critic.hpp>
#include <maskadapt/rl/discriminator.hpp>
#include <maskadapt/tasks/action_space.hpp>
#include <maskadapt/train/config.hpp>
#include <maskadapt/train/policy_export.hpp>

#include <algorithm>
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
  Index amp_dim = 0;           ///< discriminator input (disc.window_frames · obs_dim; load_base_policy takes it from the config)
};

/// Networks of a base policy, and how its actions become PD targets.
struct BasePolicy {
  rl::ActorCritic<float> ac;
  rl::Discriminator<float> disc;  ///< amp_dim → 1 logit (normaliser + Adam inside)
  tasks::ActionSpace actions;     ///< PD target = offset + scale ⊙ a (identity: a is the target)
};

/// The action space a config describes (its resolved vectors). Throws naming the field when a
/// mode other than zero/one has not been resolved yet (resolve_action_space).
inline tasks::ActionSpace action_space_of(const BaseTrainConfig& c, Index num_dofs) {
  require(c.net.action_offset == "zero" || !c.net.action_offset_rad.empty(),
          "action offset '" + c.net.action_offset + "' was not resolved into net.action_offset_rad",
          {{}, std::nullopt, "net.action_offset_rad"});
  require(c.net.action_scale == "one" || !c.net.action_scale_rad.empty(),
          "action scale '" + c.net.action_scale + "' was not resolved into net.action_scale_rad",
          {{}, std::nullopt, "net.action_scale_rad"});
  tasks::ActionSpace a;
  if (!c.net.action_offset_rad.empty())
    a.offset = Eigen::Map<const VectorXd>(c.net.action_offset_rad.data(), static_cast<Index>(c.net.action_offset_rad.size())).cast<float>();
  if (!c.net.action_scale_rad.empty())
    a.scale = Eigen::Map<const VectorXd>(c.net.action_scale_rad.data(), static_cast<Index>(c.net.action_scale_rad.size())).cast<float>();
  if (num_dofs >= 0) a.validate(num_dofs, "net.action");  // (num_dofs < 0: the task validates)
  return a;
}

/// Fills net.action_offset_rad / net.action_scale_rad from their modes, when empty: `mean_pose`
/// = mean of every joint angle over all frames of `lib`'s clips, `mid_range` = (lower + upper)/2
/// of the skeleton's limits, `half_range` = (upper − lower)/2 (at least 0.05 rad). A config whose
/// vectors are filled (a resumed run) is left as it is.
inline void resolve_action_space(BaseTrainConfig& c, const Skeleton& skel, const MotionLibrary* lib) {
  const Index nd = skel.num_dofs();
  auto limit = [&](Index k, bool upper) {
    return upper ? skel.dof_upper(static_cast<int>(k)) : skel.dof_lower(static_cast<int>(k));
  };
  if (c.net.action_offset_rad.empty() && c.net.action_offset != "zero") {
    c.net.action_offset_rad.assign(static_cast<std::size_t>(nd), 0.0);
    if (c.net.action_offset == "mid_range") {
      for (Index k = 0; k < nd; ++k) c.net.action_offset_rad[static_cast<std::size_t>(k)] = 0.5 * (limit(k, false) + limit(k, true));
    } else {  // mean_pose
      require(lib != nullptr && lib->num_clips() > 0, "mean_pose needs the training motions", {{}, std::nullopt, "net.action_offset"});
      VectorXd sum = VectorXd::Zero(nd);
      double frames = 0;
      for (int i = 0; i < lib->num_clips(); ++i) {
        const MotionClip& clip = lib->clip(i);
        require(clip.num_dofs() == nd, "clip '" + clip.name + "' does not fit the skeleton", {{}, std::nullopt, "env.motions"});
        sum += clip.q.rowwise().sum();
        frames += clip.num_frames();
      }
      for (Index k = 0; k < nd; ++k) c.net.action_offset_rad[static_cast<std::size_t>(k)] = sum[k] / frames;
    }
  }
  if (c.net.action_scale_rad.empty() && c.net.action_scale == "half_range") {
    c.net.action_scale_rad.assign(static_cast<std::size_t>(nd), 1.0);
    for (Index k = 0; k < nd; ++k)
      c.net.action_scale_rad[static_cast<std::size_t>(k)] = std::max(0.05, 0.5 * (limit(k, true) - limit(k, false)));
  }
}

/// The discriminator's input dimension under `c`: its disc.window_frames frames of `obs_dim`
/// features (5 frames: the whole AMP window of the task).
inline Index disc_input_dim(const BaseTrainConfig& c, Index obs_dim) { return obs_dim * c.disc.window_frames; }

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
  if (p.actions.offset.size()) c.put("actor/action_offset", p.actions.offset);
  if (p.actions.scale.size()) c.put("actor/action_scale", p.actions.scale);
  p.ac.actor.save_hidden_groups(c, "actor/hidden_groups");  // (mask.hidden_value = mean)
}

/// Reads `actor/hidden_groups` into `actor` when present (a policy trained with mask.hidden_value
/// = mean); absent: the actor normalises every input row (hidden elements are zeros).
template <class Actor>
void load_hidden_groups(const Checkpoint& c, Actor& actor) {
  actor.load_hidden_groups(c, "actor/hidden_groups", kNumParts);
}

/// Reads the actor's sections (actor/params, actor/log_std, actor/norm, the action space) into a
/// policy of the same sizes; critic and discriminator are left as they are. Throws naming the
/// section on a missing section or a size mismatch.
inline void load_actor(const Checkpoint& c, BasePolicy& p) {
  c.copy_to<float>("actor/params", p.ac.actor.mean_net.params());
  c.copy_to<float>("actor/log_std", p.ac.actor.log_std.params());
  load_normalizer(c, "actor/norm", p.ac.actor.normalizer);
  load_hidden_groups(c, p.ac.actor);
  const Index nd = p.ac.actor.action_dim();
  p.actions = {};  // checkpoints without these sections (older, or identity) drive the targets directly
  if (c.contains("actor/action_offset")) p.actions.offset = c.get_vector<float>("actor/action_offset", nd);
  if (c.contains("actor/action_scale")) p.actions.scale = c.get_vector<float>("actor/action_scale", nd);
  p.actions.validate(nd, c.source().empty() ? "actor/action" : c.source() + ": actor/action");
}

/// Reads what save_policy wrote into networks of the same sizes; throws naming the section on
/// a missing section or a size mismatch.
inline void load_policy(const Checkpoint& c, BasePolicy& p) {
  load_actor(c, p);
  c.copy_to<float>("critic/params", p.ac.critic.net.params());
  c.copy_to<float>("disc/params", p.disc.net().params());
  load_normalizer(c, "critic/norm", p.ac.critic.normalizer);
  load_normalizer(c, "disc/norm", p.disc.normalizer());
}

/// A base policy and the configuration it was trained with, read from a stage-1 checkpoint or
/// a policy-only export.
struct LoadedBasePolicy {
  BaseTrainConfig config;
  BasePolicy policy;
  long long iteration = 0;  ///< training iterations done when the checkpoint was written
  /// True when read from a policy-only export (train/policy_export.hpp): the actor, its input
  /// normaliser and the action space are the trained ones, but policy.ac.critic and policy.disc
  /// are freshly initialised placeholders (seed 0) of the config's sizes — not trained; use the
  /// actor only (play, eval-base and stage 2 do). False: every network is the trained one.
  bool policy_only = false;
};

/// Loads the policy of a checkpoint written by BaseTrainer, or of its export (`maskadapt
/// export`; then only the actor, see LoadedBasePolicy::policy_only, after check_policy_export
/// against `dims`). The architecture comes from the `config` section. `source` labels errors
/// (e.g. the file path; "": the checkpoint's own source).
/// The character (env.character) a base checkpoint or export was trained on, from its config.
inline std::string checkpoint_character(const Checkpoint& c, const std::string& source = {}) {
  const std::string file = source.empty() ? c.source() : source;
  return config_from_string(c.get_string("config"), file + " (config)").env.character;
}

inline LoadedBasePolicy load_base_policy(const Checkpoint& c, const PolicyDims& dims, const std::string& source = {}) {
  const std::string file = source.empty() ? c.source() : source;
  LoadedBasePolicy out;
  out.policy_only = c.contains("model/kind");  // an export, or something claiming a model kind: checked next
  if (out.policy_only) (void)check_policy_export(c, ModelDims{dims.obs_dim, dims.policy_input_dim, dims.action_dim}, file);
  out.config = config_from_string(c.get_string("config"), file + " (config)");
  PolicyDims sized = dims;  // the discriminator's input is the config's (its disc.window_frames)
  sized.amp_dim = disc_input_dim(out.config, dims.obs_dim);
  Rng init(0);
  out.policy = make_base_policy(out.config, sized, init);
  if (out.policy_only) load_actor(c, out.policy);
  else load_policy(c, out.policy);
  if (c.contains("trainer/iteration")) out.iteration = c.get_int("trainer/iteration");
  return out;
}

}  // namespace maskadapt::train
