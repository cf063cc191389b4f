#pragma once
/// \file stage2_learner.hpp
/// What learns in stage 2 besides the discriminators: the multi-objective critic with PopArt, the
/// actor's and critic's Adam, and the PPO step on a stage-2 policy (residual or AdaptNet; the
/// frozen base is never stepped). The trainer (residual_trainer.hpp) collects, rewards and
/// checkpoints; this header does step 3 of its iteration.
///
/// PPO here: advantages normalised per objective (row) and combined with the objective weights;
/// PopArt rescales the critic's last layer to the new return statistics, then the critic regresses
/// the normalised returns (unclipped); the action-bound penalty acts on the PD targets beyond ±π rad
/// exactly as in stage 1; the adaptive learning-rate schedule (rsl_rl's KL rule) as in stage 1.
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/nn/adam.hpp>
#include <maskadapt/nn/popart.hpp>
#include <maskadapt/rl/actor_critic.hpp>
#include <maskadapt/rl/adaptive_lr.hpp>
#include <maskadapt/rl/ppo_loss.hpp>
#include <maskadapt/rl/rollout_buffer.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/config.hpp>
#include <maskadapt/train/progress.hpp>
#include <maskadapt/train/stage2_policy.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace maskadapt::train {

template <Stage2Policy Policy>
class Stage2Learner {
 public:
  Stage2Learner() = default;
  /// A critic over `critic_dim` inputs with `num_objectives` outputs (one per reward row).
  Stage2Learner(Index critic_dim, Index num_objectives, const BaseTrainConfig& cfg, nn::Activation activation, Rng& init)
      : K_(num_objectives) {
    rl::ActorCriticConfig cc;
    cc.policy_input_dim = critic_dim;
    cc.critic_input_dim = critic_dim;
    cc.action_dim = 1;
    cc.num_values = K_;
    cc.critic_hidden = cfg.net.critic_hidden;
    cc.activation = activation;
    critic_ = rl::Critic<float>(cc, init);
    popart_ = nn::PopArt<float>(K_, 1e-2);
    actor_opt_ = nn::Adam<float>({cfg.ppo.actor_lr, 0.9, 0.999, 1e-8, 0.0, false, cfg.ppo.max_grad_norm});
    critic_opt_ = nn::Adam<float>({cfg.ppo.critic_lr, 0.9, 0.999, 1e-8, 0.0, false, cfg.ppo.max_grad_norm});
  }

  rl::Critic<float>& critic() { return critic_; }
  const rl::Critic<float>& critic() const { return critic_; }

  /// Denormalised values (K × n) of critic inputs `cin` (critic_dim × n).
  void values(const MatrixXf& cin, MatrixXf& v) {
    vn_.resize(K_, cin.cols());
    critic_.value(cin, vn_, ws_, scratch_);
    v.resize(K_, cin.cols());
    popart_.denormalize(vn_, v);
  }

  /// PPO epochs over the rollout `buf` (advantages and returns computed) on `policy`'s trainable
  /// blocks and the critic; `weights` (K) combine the normalised per-objective advantages.
  void update(Policy& policy, const rl::RolloutBuffer<float>& buf, const std::vector<double>& weights,
              const PpoConfig& ppo, Rng& rng, IterationStats& st) {
    MatrixXf adv_k = buf.advantages;
    rl::normalize_rows(adv_k);
    RowVectorX<float> adv = RowVectorX<float>::Zero(buf.size());
    for (Index k = 0; k < K_; ++k) adv += static_cast<float>(weights[static_cast<std::size_t>(k)]) * adv_k.row(k);
    popart_.update(buf.returns, critic_.net);
    MatrixXf ret_n(K_, buf.size());
    popart_.normalize(buf.returns, ret_n);
    const Index n = buf.size();
    const Index nmb = std::max<Index>(1, std::min<Index>(n, n / std::max<Index>(1, ppo.minibatch_size)));
    PpoMinibatchMeans means;
    MatrixXf x, act, cin, norm_cin, dmu, dv, target, vold;
    RowVectorX<float> lp_old, a_mb, lp_new, dlogp;
    std::vector<PartMask> ms;
    for (int epoch = 0; epoch < ppo.epochs; ++epoch) {
      for (const auto& idx : rl::minibatch_indices(n, nmb, rng)) {
        rl::gather_columns(buf.policy_input, idx, x);
        rl::gather_columns(buf.actions, idx, act);
        rl::gather_columns(buf.obs, idx, cin);
        rl::gather_columns(ret_n, idx, target);
        const Index B = static_cast<Index>(idx.size());
        ms.resize(static_cast<std::size_t>(B));
        lp_old.resize(B);
        a_mb.resize(B);
        for (Index j = 0; j < B; ++j) {
          const Index c = idx[static_cast<std::size_t>(j)];
          lp_old[j] = buf.log_probs[c];
          a_mb[j] = adv[c];
          ms[static_cast<std::size_t>(j)] = buf.masks[static_cast<std::size_t>(c)];
        }
        policy.zero_grad();
        const MatrixXf& mu = policy.forward_train(x, ms, cache_);
        policy.log_prob(cache_, act, lp_new);
        const auto sur = rl::clipped_surrogate<float>(lp_new, lp_old, a_mb, ppo.clip, dlogp);
        Policy::log_prob_mean_grad(cache_, act, dlogp, dmu);
        // action-bound penalty on the PD targets beyond ±π rad, as in stage 1 (target = offset +
        // scale ⊙ μ̂, so ∂/∂μ̂ carries a factor scale; the identity's target is μ̂ itself)
        const float bound = static_cast<float>(M_PI), wb = static_cast<float>(ppo.action_bound_weight);
        const tasks::ActionSpace& space = policy.actions();
        if (space.identity()) {
          dmu.array() += wb / static_cast<float>(B) * ((mu.array() - bound).max(0.0f) + (mu.array() + bound).min(0.0f)) * 2.0f;
        } else {
          space.add_bound_penalty_grad(mu, bound, wb / static_cast<float>(B), bound_targets_, dmu);
        }
        policy.backward(cache_, dmu);
        const auto ar = actor_opt_.step(policy.trainable_blocks());
        if (!ar.applied) ++st.skipped_updates;
        if (ppo.actor_lr_schedule == "adaptive")  // next minibatch's step sized by this one's KL (as stage 1)
          actor_opt_.config().lr = rl::adapt_learning_rate(actor_opt_.config().lr, sur.approx_kl, ppo.adaptive_lr);
        critic_.net.zero_grad();
        critic_.normalize(cin, norm_cin);
        const MatrixXf& v = critic_.net.forward_train(norm_cin, critic_cache_);
        vold = v;
        const double vl = rl::value_loss<float>(v, vold, target, 0.0, dv);
        dv *= static_cast<float>(ppo.critic_weight);
        critic_.net.backward(critic_cache_, dv, critic_.net.grads());
        const auto cr = critic_opt_.step(critic_.net.block());
        if (!cr.applied) ++st.skipped_updates;
        means.add(sur.loss, vl, sur.approx_kl, sur.clip_frac, 0.0, ar.grad_norm);
      }
    }
    means.write(st);  // (no MI term in stage 2: mi_kl 0)
    st.entropy = nn::gaussian_entropy<float>(
        Eigen::Map<const MatrixXf>(policy.residual().log_std.params().data(), policy.action_dim(), 1))(0);
    st.actor_lr = actor_opt_.config().lr;  // moves under ppo.actor_lr_schedule = adaptive
  }

  /// The critic's parameters, normaliser and PopArt statistics (what a policy-and-value export needs).
  void save(Checkpoint& c) const {
    c.put("critic/params", critic_.net.params());
    save_normalizer(critic_.normalizer, "critic/norm", c);
    c.put("popart/mean", popart_.mean());
    c.put("popart/nu", popart_.second_moment());
  }
  void load(const Checkpoint& c) {
    c.copy_to<float>("critic/params", critic_.net.params());
    load_normalizer(c, "critic/norm", critic_.normalizer);
    popart_.set_state(c.get_vector<double>("popart/mean", K_), c.get_vector<double>("popart/nu", K_));
  }

  /// Adam moments and step counts of the actor's `blocks` and the critic, and the actor's rate.
  void save_state(Checkpoint& c, const std::vector<nn::ParameterBlock<float>*>& blocks) const {
    for (std::size_t i = 0; i < blocks.size(); ++i) c.put("state/actor/" + std::to_string(i), blocks[i]->storage());
    c.put("state/critic", const_cast<rl::Critic<float>&>(critic_).net.block().storage());
    c.put_int("state/actor_steps", actor_opt_.step_count());
    c.put_double("state/actor_lr", actor_opt_.config().lr);
    c.put_int("state/critic_steps", critic_opt_.step_count());
  }
  void load_state(const Checkpoint& c, const std::vector<nn::ParameterBlock<float>*>& blocks) {
    for (std::size_t i = 0; i < blocks.size(); ++i) c.copy_to<float>("state/actor/" + std::to_string(i), blocks[i]->storage());
    c.copy_to<float>("state/critic", critic_.net.block().storage());
    actor_opt_.set_step_count(c.get_int("state/actor_steps"));
    if (c.contains("state/actor_lr")) {  // (checkpoints before stage 2's adaptive schedule: the config's rate)
      const double lr = c.get_double("state/actor_lr");
      require(std::isfinite(lr) && lr >= 0, "actor learning rate must be finite and >= 0",
              {c.source(), std::nullopt, "state/actor_lr"});
      actor_opt_.config().lr = lr;
    }
    critic_opt_.set_step_count(c.get_int("state/critic_steps"));
  }

 private:
  Index K_ = 1;
  rl::Critic<float> critic_;
  nn::PopArt<float> popart_;
  nn::Adam<float> actor_opt_, critic_opt_;
  typename Stage2Types<Policy>::Cache cache_;
  nn::InferenceWorkspace<float> ws_;
  nn::TrainCache<float> critic_cache_;
  MatrixXf vn_, scratch_, bound_targets_;
};

}  // namespace maskadapt::train
