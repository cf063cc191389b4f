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
///
/// Per-part credit (optional, PartCredit; issue 39): the DoFs are split into groups, each with its
/// own objective weights, e.g. the arms credited with the composition discriminator alone and the
/// legs with the goal. The Gaussian factorises over DoFs, so the policy gradient of the sum of the
/// objectives splits into one term per group: group g's log-probability (its DoFs' terms) times
/// its own advantage A_g = Σ_k W_gk Â_k. Each group gets the clipped surrogate on its own ratio
///   L = −Σ_g mean_i min(ρ_gi A_gi, clip(ρ_gi, 1 ± ε) A_gi),   ρ_gi = exp(log π_g,new − log π_g,old),
/// and the approximate KL is the sum of the groups' (the factors are independent). The groups'
/// old log-probabilities are recomputed at the start of the update under the policy that
/// collected (its normaliser as updated during collection). With one group whose weights are
/// the objective weights this is the joint PPO step, up to that recomputation.
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/nn/adam.hpp>
#include <maskadapt/nn/popart.hpp>
#include <maskadapt/rl/actor_critic.hpp>
#include <maskadapt/rl/adaptive_lr.hpp>
#include <maskadapt/rl/ppo_loss.hpp>
#include <maskadapt/rl/rollout_buffer.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/config.hpp>
#include <maskadapt/train/distributed.hpp>
#include <maskadapt/train/progress.hpp>
#include <maskadapt/train/stage2_policy.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <string>
#include <vector>

namespace maskadapt::train {

/// Per-part credit of a stage-2 PPO step (see the file comment).
struct PartCredit {
  std::vector<Index> group_of_row;  ///< (action_dim) the group of each action row (DoF)
  MatrixXd weights;                 ///< (groups × objectives) each group's objective weights
  bool enabled() const { return !group_of_row.empty(); }
  Index groups() const { return weights.rows(); }
};

/// The groups of per-part credit: each DoF (action row, part `dof_parts[i]`) takes its part's
/// weights, or `default_weights` where its part has none; DoFs with equal weights form one group
/// (in order of first appearance). Every weight list must have one weight per objective.
inline PartCredit make_part_credit(const std::array<std::vector<double>, kNumParts>& part_weights,
                                   const std::vector<double>& default_weights, const std::vector<BodyPart>& dof_parts) {
  const std::size_t K = default_weights.size();
  std::vector<std::vector<double>> groups;
  PartCredit pc;
  for (const BodyPart part : dof_parts) {
    const auto& own = part_weights[static_cast<std::size_t>(part)];
    require(own.empty() || own.size() == K,
            std::string(part_name(part)) + " has " + std::to_string(own.size()) + " objective weights; this run has " +
                std::to_string(K) + " objective(s)",
            {{}, {}, "part_objective_weights"});
    const std::vector<double>& w = own.empty() ? default_weights : own;
    auto it = std::find(groups.begin(), groups.end(), w);
    if (it == groups.end()) it = groups.insert(groups.end(), w);
    pc.group_of_row.push_back(static_cast<Index>(it - groups.begin()));
  }
  pc.weights.resize(static_cast<Index>(groups.size()), static_cast<Index>(K));
  for (std::size_t g = 0; g < groups.size(); ++g)
    for (std::size_t k = 0; k < K; ++k) pc.weights(static_cast<Index>(g), static_cast<Index>(k)) = groups[g][k];
  return pc;
}

template <Stage2Policy Policy>
class Stage2Learner {
  /// Policies with per-DoF log-probabilities (the residual) support per-part credit.
  static constexpr bool kHasRows = requires(const Policy& p, const typename Stage2Types<Policy>::Cache& c, const MatrixXf& a,
                                            MatrixXf& o) {
    p.log_prob_rows(c, a, o);
    Policy::log_prob_rows_mean_grad(c, a, a, o);
  };

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

  /// Turns per-part credit on (see the file comment); `pc.weights` must have one column per
  /// objective. Refused for a policy without per-DoF log-probabilities (AdaptNet).
  void set_part_credit(PartCredit pc) {
    require(kHasRows, "per-part credit needs a residual's per-DoF log-probabilities", {{}, {}, "part_objective_weights"});
    require(pc.enabled() && pc.weights.cols() == K_ && pc.weights.rows() >= 1,
            "per-part credit needs a group per DoF and one weight per objective (" + std::to_string(K_) + ")",
            {{}, {}, "part_objective_weights"});
    for (const Index g : pc.group_of_row)
      require(g >= 0 && g < pc.groups(), "a DoF's group is out of range", {{}, {}, "part_objective_weights"});
    credit_ = std::move(pc);
  }
  const PartCredit& part_credit() const { return credit_; }

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
  /// Distributed (`ranks`, docs/distributed.md): `buf` holds this rank's envs; advantages are
  /// normalised and PopArt updated with the statistics of all ranks' samples, the minibatches are
  /// drawn over all of them (from the replicated `rng`), each rank computes the gradients of the
  /// samples it holds scaled to its share of the minibatch, and the actor's and critic's gradients
  /// are summed over ranks before the Adam steps (the KL driving the adaptive rate likewise).
  void update(Policy& policy, const rl::RolloutBuffer<float>& buf, const std::vector<double>& weights,
              const PpoConfig& ppo, Rng& rng, IterationStats& st, const RankLayout& ranks = {}) {
    const bool dist = ranks.distributed();
    const Index K_ranks = dist ? ranks.comm->size() : 1;
    MatrixXf adv_k = buf.advantages;
    if (dist) normalize_rows_over_ranks(*ranks.comm, adv_k);
    else rl::normalize_rows(adv_k);
    if (credit_.enabled()) {  // each group's own weighting of the objectives
      require(static_cast<Index>(credit_.group_of_row.size()) == policy.action_dim(), "per-part credit: one group per DoF",
              {{}, {}, "part_objective_weights"});
      adv_g_ = credit_.weights.cast<float>() * adv_k;  // (groups × n)
      old_group_log_probs(policy, buf, ppo);
    } else {  // one advantage per sample: the weighted sum over objectives
      adv_.setZero(buf.size());
      for (Index k = 0; k < K_; ++k) adv_ += static_cast<float>(weights[static_cast<std::size_t>(k)]) * adv_k.row(k);
    }
    if (dist) update_popart_over_ranks(*ranks.comm, buf.returns);
    else popart_.update(buf.returns, critic_.net);
    ret_n_.resize(K_, buf.size());
    popart_.normalize(buf.returns, ret_n_);
    const Index n = buf.size() * K_ranks;  // (minibatches are drawn over every rank's samples)
    const Index nmb = std::max<Index>(1, std::min<Index>(n, n / std::max<Index>(1, ppo.minibatch_size)));
    PpoMinibatchMeans means;
    for (int epoch = 0; epoch < ppo.epochs; ++epoch) {
      for (const auto& all_idx : rl::minibatch_indices(n, nmb, rng)) {
        // this rank's samples of the minibatch (all of them in one process) and their share of it
        if (dist) my_columns(all_idx, ranks.envs_here, K_ranks, ranks.offset, my_idx_);
        const auto& idx = dist ? my_idx_ : all_idx;
        const Index B_all = static_cast<Index>(all_idx.size());
        const double share = static_cast<double>(idx.size()) / static_cast<double>(B_all);
        Minibatch mb;
        if (idx.empty()) {
          policy.zero_grad();
          critic_.net.zero_grad();
        } else {
          mb = minibatch_gradients(policy, buf, idx, B_all, share, ppo);
        }
        if (dist) mb = sum_over_ranks(*ranks.comm, policy, mb, share);
        const auto ar = actor_opt_.step(policy.trainable_blocks());
        if (!ar.applied) ++st.skipped_updates;
        if (ppo.actor_lr_schedule == "adaptive")  // next minibatch's step sized by this one's KL (as stage 1)
          actor_opt_.config().lr = rl::adapt_learning_rate(actor_opt_.config().lr, mb.approx_kl, ppo.adaptive_lr);
        const auto cr = critic_opt_.step(critic_.net.block());
        if (!cr.applied) ++st.skipped_updates;
        means.add(mb.policy_loss, mb.value_loss, mb.approx_kl, mb.clip_frac, 0.0, ar.grad_norm);
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
  /// Losses of one minibatch: means over this rank's samples (× share), then over all ranks'.
  struct Minibatch {
    double policy_loss = 0, value_loss = 0, approx_kl = 0, clip_frac = 0;
  };

  /// The actor's and critic's gradients of the samples `idx` (columns of `buf`) of a minibatch of
  /// B_all samples, `share` = |idx| / B_all, into their grads(); returns the losses. The
  /// critic's gradient does not depend on the actor's step, which the caller takes after both are
  /// complete (and summed over ranks). In one process (share 1) the arithmetic is unscaled.
  Minibatch minibatch_gradients(Policy& policy, const rl::RolloutBuffer<float>& buf, const std::vector<Index>& idx, Index B_all,
                                double share, const PpoConfig& ppo) {
    const bool scaled = share != 1.0;
    rl::gather_columns(buf.policy_input, idx, x_);
    rl::gather_columns(buf.actions, idx, act_);
    rl::gather_columns(buf.obs, idx, cin_);
    rl::gather_columns(ret_n_, idx, target_);
    const Index B = static_cast<Index>(idx.size());
    ms_.resize(static_cast<std::size_t>(B));
    for (Index j = 0; j < B; ++j) ms_[static_cast<std::size_t>(j)] = buf.masks[static_cast<std::size_t>(idx[static_cast<std::size_t>(j)])];
    if (!credit_.enabled()) {  // (per-part credit gathers its groups' own, in part_credit_surrogate)
      lp_old_.resize(B);
      a_mb_.resize(B);
      for (Index j = 0; j < B; ++j) {
        const Index c = idx[static_cast<std::size_t>(j)];
        lp_old_[j] = buf.log_probs[c];
        a_mb_[j] = adv_[c];
      }
    }
    policy.zero_grad();
    const MatrixXf& mu = policy.forward_train(x_, ms_, cache_);
    rl::SurrogateResult sur;
    if (credit_.enabled()) {
      if constexpr (kHasRows) sur = part_credit_surrogate(policy, idx, ppo, scaled ? share : 1.0);
    } else {
      policy.log_prob(cache_, act_, lp_new_);
      sur = rl::clipped_surrogate<float>(lp_new_, lp_old_, a_mb_, ppo.clip, dlogp_);
      if (scaled) dlogp_ *= static_cast<float>(share);
      Policy::log_prob_mean_grad(cache_, act_, dlogp_, dmu_);
    }
    // action-bound penalty on the PD targets beyond ±π rad, as in stage 1 (target = offset +
    // scale ⊙ μ̂, so ∂/∂μ̂ carries a factor scale; the identity's target is μ̂ itself); a mean
    // over the whole minibatch
    const float bound = static_cast<float>(M_PI), wb = static_cast<float>(ppo.action_bound_weight);
    const tasks::ActionSpace& space = policy.actions();
    if (space.identity()) {
      dmu_.array() += wb / static_cast<float>(B_all) * ((mu.array() - bound).max(0.0f) + (mu.array() + bound).min(0.0f)) * 2.0f;
    } else {
      space.add_bound_penalty_grad(mu, bound, wb / static_cast<float>(B_all), bound_targets_, dmu_);
    }
    policy.backward(cache_, dmu_);
    critic_.net.zero_grad();
    critic_.normalize(cin_, norm_cin_);
    const MatrixXf& v = critic_.net.forward_train(norm_cin_, critic_cache_);
    vold_ = v;
    const double vl = rl::value_loss<float>(v, vold_, target_, 0.0, dv_);
    dv_ *= static_cast<float>(scaled ? ppo.critic_weight * share : ppo.critic_weight);
    critic_.net.backward(critic_cache_, dv_, critic_.net.grads());
    return {sur.loss, vl, sur.approx_kl, sur.clip_frac};
  }

  /// Group sums (groups × B) of per-DoF log-probabilities `rows` (A × B), each column's rows added
  /// in order (so one group holding every DoF gives `log_prob` bit for bit).
  void group_sums(const MatrixXf& rows, MatrixXf& out) const {
    out.setZero(credit_.groups(), rows.cols());
    for (Index j = 0; j < rows.cols(); ++j)
      for (Index i = 0; i < rows.rows(); ++i) out(credit_.group_of_row[static_cast<std::size_t>(i)], j) += rows(i, j);
  }

  /// lp_old_g_ (groups × n): every sample's group log-probabilities under the current policy (the
  /// one that collected `buf`), in chunks of a minibatch.
  void old_group_log_probs(Policy& policy, const rl::RolloutBuffer<float>& buf, const PpoConfig& ppo) {
    if constexpr (kHasRows) {
      const Index n = buf.size(), chunk = std::max<Index>(1, ppo.minibatch_size);
      lp_old_g_.resize(credit_.groups(), n);
      std::vector<Index> idx;
      for (Index start = 0; start < n; start += chunk) {
        const Index b = std::min(chunk, n - start);
        idx.resize(static_cast<std::size_t>(b));
        for (Index j = 0; j < b; ++j) idx[static_cast<std::size_t>(j)] = start + j;
        rl::gather_columns(buf.policy_input, idx, x_);
        rl::gather_columns(buf.actions, idx, act_);
        ms_.resize(static_cast<std::size_t>(b));
        for (Index j = 0; j < b; ++j) ms_[static_cast<std::size_t>(j)] = buf.masks[static_cast<std::size_t>(start + j)];
        (void)policy.forward_train(x_, ms_, cache_);
        policy.log_prob_rows(cache_, act_, rows_);
        group_sums(rows_, gsum_);
        lp_old_g_.middleCols(start, b) = gsum_;
      }
    }
  }

  /// The per-part-credit surrogate of the minibatch `idx` (x_, act_ and the cache hold its forward
  /// pass): the groups' clipped surrogates summed, their ∂/∂μ̂ into dmu_ (× share).
  rl::SurrogateResult part_credit_surrogate(const Policy& policy, const std::vector<Index>& idx, const PpoConfig& ppo,
                                            double share) {
    const Index B = static_cast<Index>(idx.size()), G = credit_.groups();
    policy.log_prob_rows(cache_, act_, rows_);
    group_sums(rows_, gsum_);
    rl::gather_columns(lp_old_g_, idx, lp_old_gmb_);
    rl::gather_columns(adv_g_, idx, adv_gmb_);
    dlogp_rows_.resize(rows_.rows(), B);
    rl::SurrogateResult total;
    for (Index g = 0; g < G; ++g) {
      lp_new_ = gsum_.row(g);
      lp_old_ = lp_old_gmb_.row(g);
      a_mb_ = adv_gmb_.row(g);
      const auto sur = rl::clipped_surrogate<float>(lp_new_, lp_old_, a_mb_, ppo.clip, dlogp_);
      total.loss += sur.loss;
      total.approx_kl += sur.approx_kl;  // KL of independent factors adds up
      total.clip_frac += sur.clip_frac / static_cast<double>(G);
      for (Index i = 0; i < rows_.rows(); ++i)
        if (credit_.group_of_row[static_cast<std::size_t>(i)] == g) dlogp_rows_.row(i) = dlogp_;
    }
    if (share != 1.0) dlogp_rows_ *= static_cast<float>(share);
    Policy::log_prob_rows_mean_grad(cache_, act_, dlogp_rows_, dmu_);
    return total;
  }

  /// Sums the actor's (trainable blocks) and critic's gradients over ranks (one all-reduce) and
  /// turns this rank's loss means into the minibatch's.
  Minibatch sum_over_ranks(Collective& comm, Policy& policy, const Minibatch& mine, double share) {
    std::vector<std::span<float>> grads;
    for (nn::ParameterBlock<float>* b : policy.trainable_blocks()) {
      auto g = b->grads();
      grads.emplace_back(g.data(), static_cast<std::size_t>(g.size()));
    }
    auto gc = critic_.net.grads();
    grads.emplace_back(gc.data(), static_cast<std::size_t>(gc.size()));
    all_reduce_gradients(comm, grads, reduce_f_);
    double m[4] = {mine.policy_loss * share, mine.value_loss * share, mine.approx_kl * share, mine.clip_frac * share};
    comm.all_reduce_sum(std::span<double>(m, 4));
    return {m[0], m[1], m[2], m[3]};
  }

  /// PopArt's update with the moments of all ranks' returns (K × n each): Σy and Σy² summed over
  /// ranks, divided by the total count.
  void update_popart_over_ranks(Collective& comm, const MatrixXf& returns) {
    const MatrixXd y = returns.cast<double>();
    std::vector<double> sums(static_cast<std::size_t>(2 * K_));
    for (Index k = 0; k < K_; ++k) {
      sums[static_cast<std::size_t>(k)] = y.row(k).sum();
      sums[static_cast<std::size_t>(K_ + k)] = y.row(k).array().square().sum();
    }
    comm.all_reduce_sum(std::span<double>(sums));
    const double count = static_cast<double>(returns.cols()) * comm.size();
    const Eigen::Map<const VectorXd> s1(sums.data(), K_), s2(sums.data() + K_, K_);
    popart_.update_from_moments(s1 / count, s2 / count, critic_.net);
  }

  Index K_ = 1;
  rl::Critic<float> critic_;
  nn::PopArt<float> popart_;
  nn::Adam<float> actor_opt_, critic_opt_;
  typename Stage2Types<Policy>::Cache cache_;
  nn::InferenceWorkspace<float> ws_;
  nn::TrainCache<float> critic_cache_;
  MatrixXf vn_, scratch_, bound_targets_;
  // update's buffers (sized on the first update, then reused)
  RowVectorX<float> adv_, lp_old_, a_mb_, lp_new_, dlogp_;
  MatrixXf ret_n_, x_, act_, cin_, norm_cin_, dmu_, dv_, target_, vold_;
  PartCredit credit_;  ///< per-part credit (off unless set)
  // per-part credit's buffers: advantages and old log-probabilities per group (groups × n), and a
  // minibatch's per-DoF log-probabilities (A × B), group sums and gathered columns (groups × B)
  MatrixXf adv_g_, lp_old_g_, rows_, gsum_, lp_old_gmb_, adv_gmb_, dlogp_rows_;
  std::vector<PartMask> ms_;
  std::vector<Index> my_idx_;   ///< this rank's columns of the current minibatch
  std::vector<float> reduce_f_; ///< gradients of one minibatch, packed for the all-reduce
};

}  // namespace maskadapt::train
