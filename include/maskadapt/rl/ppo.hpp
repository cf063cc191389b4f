#pragma once
/// \file ppo.hpp
/// The PPO update (+ the mask-invariant term) over one filled RolloutBuffer.
///
/// For `epochs` passes over the buffer, split into `num_minibatches` random minibatches:
///   actor:  L_actor  = L_π(clip ε) − c_H·H + λ_MI·L_MI        (one Adam step, lr_actor)
///   critic: L_critic = c_V·L_V                               (one Adam step, lr_critic)
/// Advantages: each objective row is normalised over the whole buffer (if enabled), then the
/// rows are combined with `objective_weights` into one advantage per sample (multi-objective /
/// CML-style training; a single objective is simply normalised).
///
/// Non-finite guard: after computing all losses and gradients of a minibatch, if any loss or
/// gradient is NaN/inf the whole step is skipped (neither network changes, optimiser state and
/// step counters stay), it is counted in PpoStats::skipped_steps, and training goes on with the
/// next minibatch from the last good parameters.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/nn/adam.hpp>
#include <maskadapt/nn/gaussian.hpp>
#include <maskadapt/rl/actor_critic.hpp>
#include <maskadapt/rl/mi_loss.hpp>
#include <maskadapt/rl/ppo_loss.hpp>
#include <maskadapt/rl/rollout_buffer.hpp>

#include <cmath>
#include <functional>
#include <vector>

namespace maskadapt::rl {

/// Which buffer matrix the critic reads.
enum class CriticInput {
  FullState,    ///< buffer.obs: the full, unmasked state (the method's choice)
  PolicyInput,  ///< buffer.policy_input: exactly what the actor saw
};

struct PpoConfig {
  double clip = 0.2;                ///< ε (paper 0.2)
  double value_loss_weight = 5.0;   ///< c_V (paper 5)
  double value_clip = 0.0;          ///< ε_V for the clipped value loss; ≤ 0: unclipped
  double entropy_weight = 0.0;      ///< c_H (default 0: σ is fixed in AMP)
  int epochs = 5;                   ///< passes over the buffer per iteration
  Index num_minibatches = 4;        ///< minibatches per pass
  bool normalize_advantages = true; ///< per objective, over the buffer
  std::vector<double> objective_weights;  ///< one per objective; empty: all 1
  double actor_lr = 1e-5;           ///< paper 1e-5
  double critic_lr = 1e-4;          ///< paper 1e-4
  double max_grad_norm = 1.0;       ///< global clipping per network; ≤ 0 disables
  double lambda_mi = 1.0;           ///< λ_MI (paper 1.0); 0 disables the MI term (KL still reported)
  bool compute_mi = true;           ///< false: skip the MI forward passes entirely (plain AMP)
  CriticInput critic_input = CriticInput::FullState;

  void validate() const {
    require(clip > 0, "must be positive", {{}, {}, "PpoConfig.clip"});
    require(value_loss_weight >= 0, "must be >= 0", {{}, {}, "PpoConfig.value_loss_weight"});
    require(epochs > 0, "must be positive", {{}, {}, "PpoConfig.epochs"});
    require(num_minibatches > 0, "must be positive", {{}, {}, "PpoConfig.num_minibatches"});
    require(lambda_mi >= 0, "must be >= 0", {{}, {}, "PpoConfig.lambda_mi"});
    require(actor_lr >= 0 && critic_lr >= 0, "learning rates must be >= 0", {{}, {}, "PpoConfig.actor_lr/critic_lr"});
  }
};

/// Means over the applied minibatch steps of one update (skipped steps excluded).
struct PpoStats {
  double policy_loss = 0;       ///< L_π
  double value_loss = 0;        ///< L_V (before the weight c_V)
  double entropy = 0;           ///< H of the policy (per sample)
  double mi_kl = 0;             ///< mean KL(π(·|s,m⁰) ‖ π(·|s̄,m)) on the minibatches
  double approx_kl = 0;         ///< KL(old ‖ new) estimate
  double clip_frac = 0;         ///< fraction of clipped ratios
  double actor_grad_norm = 0;   ///< pre-clip global norms
  double critic_grad_norm = 0;
  Index steps = 0;              ///< applied minibatch steps
  Index skipped_steps = 0;      ///< steps skipped because a loss or gradient was non-finite
};

/// Builds the full-observation policy input (policy_input_dim × B) from observations s
/// (obs_dim × B). Default: [s ; 0] (null mask bits), see unmasked_policy_input (rl/mi_loss.hpp).
template <class T>
using FullInputFn = std::function<void(const MatrixX<T>& obs, MatrixX<T>& full_input)>;

template <class T = float>
class Ppo {
 public:
  explicit Ppo(PpoConfig config = {}) : config_(std::move(config)) {
    config_.validate();
    actor_opt_ = nn::Adam<T>(nn::AdamConfig{.lr = config_.actor_lr, .max_grad_norm = config_.max_grad_norm});
    critic_opt_ = nn::Adam<T>(nn::AdamConfig{.lr = config_.critic_lr, .max_grad_norm = config_.max_grad_norm});
  }

  const PpoConfig& config() const { return config_; }
  nn::Adam<T>& actor_optimizer() { return actor_opt_; }
  nn::Adam<T>& critic_optimizer() { return critic_opt_; }
  /// Replaces how the MI target input is built from buffer.obs (default [s ; 0]).
  void set_full_input_fn(FullInputFn<T> f) { full_input_fn_ = std::move(f); }

  /// Runs the update on `buf` (advantages and returns must be filled, see compute_gae).
  PpoStats update(ActorCritic<T>& ac, const RolloutBuffer<T>& buf, Rng& rng) {
    const Index n = buf.size(), K = buf.spec.num_objectives;
    require(buf.policy_input.rows() == ac.actor.input_dim(), "buffer policy_input rows differ from the actor input",
            {{}, {}, "RolloutBuffer.policy_input"});
    require(buf.actions.rows() == ac.actor.action_dim(), "buffer action rows differ from the actor output",
            {{}, {}, "RolloutBuffer.actions"});
    require(ac.critic.net.outputs() == K, "critic outputs must equal the number of objectives",
            {{}, {}, "ActorCriticConfig.num_values"});
    const MatrixX<T>& critic_src = config_.critic_input == CriticInput::FullState ? buf.obs : buf.policy_input;
    require(critic_src.rows() == ac.critic.net.inputs(), "critic input rows differ from the buffer",
            {{}, {}, "critic_input"});
    std::vector<double> w = config_.objective_weights;
    if (w.empty()) w.assign(static_cast<std::size_t>(K), 1.0);
    require(static_cast<Index>(w.size()) == K, "need one weight per objective", {{}, {}, "PpoConfig.objective_weights"});

    // One advantage per sample.
    MatrixX<T> adv_k = buf.advantages;
    if (config_.normalize_advantages) normalize_rows(adv_k);
    RowVectorX<T> adv = RowVectorX<T>::Zero(n);
    for (Index k = 0; k < K; ++k) adv += static_cast<T>(w[static_cast<std::size_t>(k)]) * adv_k.row(k);

    const bool mi = config_.compute_mi;
    if (mi && !full_input_fn_) {
      const Index pid = ac.actor.input_dim();
      full_input_fn_ = [pid](const MatrixX<T>& obs, MatrixX<T>& out) { unmasked_policy_input<T>(obs, pid, out); };
    }

    PpoStats st;
    for (int epoch = 0; epoch < config_.epochs; ++epoch) {
      const auto batches = minibatch_indices(n, std::min(config_.num_minibatches, n), rng);
      for (const auto& idx : batches) step(ac, buf, critic_src, adv, idx, mi, st);
    }
    if (st.steps > 0) {
      const double s = static_cast<double>(st.steps);
      st.policy_loss /= s;
      st.value_loss /= s;
      st.entropy /= s;
      st.mi_kl /= s;
      st.approx_kl /= s;
      st.clip_frac /= s;
      st.actor_grad_norm /= s;
      st.critic_grad_norm /= s;
    }
    return st;
  }

 private:
  void step(ActorCritic<T>& ac, const RolloutBuffer<T>& buf, const MatrixX<T>& critic_src, const RowVectorX<T>& adv,
            const std::vector<Index>& idx, bool mi, PpoStats& st) {
    GaussianActor<T>& actor = ac.actor;
    Critic<T>& critic = ac.critic;
    const Index B = static_cast<Index>(idx.size()), d = actor.action_dim();
    gather_columns(buf.policy_input, idx, x_);
    gather_columns(buf.actions, idx, a_);
    gather_columns(buf.log_probs, idx, lp_old_);
    gather_columns(adv, idx, adv_mb_);
    gather_columns(buf.returns, idx, ret_);
    gather_columns(buf.values, idx, v_old_);
    gather_columns(critic_src, idx, c_);
    actor.zero_grad();
    critic.net.zero_grad();

    // ---- actor: surrogate + entropy + MI ----
    actor.normalize(x_, xn_);
    const MatrixX<T>& mu = actor.mean_net.forward_train(xn_, actor_cache_);
    const auto ls = actor.log_std_col();
    lp_new_.resize(B);
    nn::gaussian_log_prob<T>(mu, ls, a_, lp_new_);
    const SurrogateResult sur = clipped_surrogate<T>(lp_new_, lp_old_, adv_mb_, config_.clip, dlogp_);
    dmu_.setZero(d, B);
    dls_.setZero(d, 1);
    nn::gaussian_log_prob_backward<T>(mu, ls, a_, dlogp_, &dmu_, &dls_);
    const double entropy = static_cast<double>(nn::gaussian_entropy<T>(ls)(0));
    dls_.array() -= static_cast<T>(config_.entropy_weight);  // ∂(−c_H·H)/∂logσ = −c_H
    double mi_kl = 0;
    if (mi) {
      gather_columns(buf.obs, idx, obs_);
      full_input_fn_(obs_, full_);
      actor.normalize(full_, full_n_);
      mu_full_.resize(d, B);
      actor.mean_net.forward(full_n_, mu_full_, ws_);
      mi_kl = mi_loss_on_means<T>(mu_full_, mu, ls, config_.lambda_mi, dmu_, &dls_).kl;
    }
    actor.mean_net.backward(actor_cache_, dmu_, actor.mean_net.grads());
    if (actor.learn_log_std) actor.log_std.grads() += dls_.col(0);

    // ---- critic ----
    critic.normalize(c_, cn_);
    const MatrixX<T>& v = critic.net.forward_train(cn_, critic_cache_);
    const double vloss = value_loss<T>(v, v_old_, ret_, config_.value_clip, dv_);
    dv_ *= static_cast<T>(config_.value_loss_weight);
    critic.net.backward(critic_cache_, dv_, critic.net.grads());

    // ---- non-finite guard, then both optimiser steps ----
    const bool finite = std::isfinite(sur.loss) && std::isfinite(vloss) && std::isfinite(mi_kl) &&
                        std::isfinite(sur.approx_kl) && actor.mean_net.grads().allFinite() &&
                        actor.log_std.grads().allFinite() && critic.net.grads().allFinite();
    if (!finite) {
      ++st.skipped_steps;
      return;
    }
    const auto ra = actor_opt_.step(actor.trainable_blocks());
    const auto rc = critic_opt_.step(critic.net.block());
    ++st.steps;
    st.policy_loss += sur.loss;
    st.value_loss += vloss;
    st.entropy += entropy;
    st.mi_kl += mi_kl;
    st.approx_kl += sur.approx_kl;
    st.clip_frac += sur.clip_frac;
    st.actor_grad_norm += ra.grad_norm;
    st.critic_grad_norm += rc.grad_norm;
  }

  PpoConfig config_;
  nn::Adam<T> actor_opt_, critic_opt_;
  FullInputFn<T> full_input_fn_;
  // Minibatch scratch (reused).
  MatrixX<T> x_, xn_, a_, ret_, v_old_, c_, cn_, dmu_, dls_, dv_, obs_, full_, full_n_, mu_full_;
  RowVectorX<T> lp_old_, lp_new_, adv_mb_, dlogp_;
  nn::TrainCache<T> actor_cache_, critic_cache_;
  nn::InferenceWorkspace<T> ws_;
};

}  // namespace maskadapt::rl
