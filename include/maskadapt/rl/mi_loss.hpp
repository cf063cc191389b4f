#pragma once
/// \file mi_loss.hpp
/// The mask-invariant (MI) loss of the base policy.
///
///     L_MI = mean_j KL( π(·|s_j, m⁰)  ‖  π(·|s̄_j, m_j) ),     s̄ = (1 − m) ⊙ s
///
/// p = π(·|s, m⁰) — the policy on the full, unmasked observation with the null mask — is the
/// *target*: gradients do not flow through it (stop-gradient). q = π(·|s̄, m), the policy on the
/// masked input, is pulled towards it. The total actor loss is L_PPO + λ_MI·L_MI (λ_MI = 1.0 in
/// the paper; 0 disables the term).
///
/// Both distributions share the state-independent log-std, so KL reduces to the mean term
/// ½ Σ_i (μp,i − μq,i)²/σ_i²; when the log-std is *learned*, the gradient w.r.t. q's
/// log-std (1 − (σp² + (μp−μq)²)/σq², with σp fixed as target) is added to it too.
///
/// Gradient modes (`MiGradient`):
///  - `TargetStopped` — the form written above: p is a constant target, only q gets gradients.
///  - `Both` (default) — the exact gradient of KL(p‖q) w.r.t. the shared parameters, through p
///    and q. Measured (tests/adapt/test_mi_loss.cpp, `MiLoss.OnAFixedBatchTheStoppedTargetDivergesTheExactGradientConvergesTheEmaTargetStaysBounded`;
///    docs/algorithms.md): with one shared network, the stopped-target update is unstable — a
///    step that moves μ(s̄, m) towards μ(s, m⁰) moves μ(s, m⁰) further the same way (the full input
///    has more non-zero features), so on a fixed batch KL grows geometrically under Adam
///    (59 → 130 in 200 steps at lr 1e-5, → 4·10⁴ at 1e-4), while the exact gradient lowers it
///    (59 → 18). Choose `TargetStopped` to reproduce the paper's formulation literally.
///  - `TargetFrozen` — p is the policy as it was when the iteration's update began (μ(s, m⁰) of
///    the pre-update parameters, computed once per iteration, like PPO's old log-probs): a
///    constant target that does not move while q is pulled towards it (mi_loss_on_fixed_target).
///    Measured on a walking base in docs/results.md: it still diverges across iterations, since
///    each iteration's update moves μ(s, m⁰) the way it moved μ(s̄, m) and the next target starts
///    from there (KL 4 → 8,000 in 0.5 M samples).
///  - `TargetEma` — p is a slowly moving copy of the policy: its parameters follow the policy's
///    as an exponential moving average, θ̄ ← (1 − τ)·θ̄ + τ·θ once per iteration (the target
///    networks of DQN/DDPG, BYOL's teacher). The stop-gradient target of the paper's formula, kept
///    still long enough for q to reach it. The loss is taken over every column, null-mask ones
///    included: for those, q = π(·|s, m⁰) itself, so its KL to the target keeps the unmasked
///    policy near the target instead of letting it drift along with every step of the masked
///    one (with the paper's moving target that term is 0 by construction). τ = 1 gives
///    `TargetFrozen`'s target with that anchor added.
///
/// Input layout assumed by `unmasked_policy_input` / `masked_policy_input`: the policy input is
/// [s ; mask bits] with one 0/1 row per body part (null mask = all zeros), as mask/apply.hpp
/// builds it.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/nn/kl.hpp>
#include <maskadapt/nn/mlp.hpp>
#include <maskadapt/rl/actor_critic.hpp>
#include <maskadapt/rl/rollout_buffer.hpp>

#include <string>
#include <type_traits>
#include <vector>

namespace maskadapt::rl {

/// Which distributions the MI gradient flows through (see the file comment).
enum class MiGradient { Both, TargetStopped, TargetFrozen, TargetEma };

inline MiGradient mi_gradient_from_string(const std::string& s, const std::string& field = "mi_gradient") {
  if (s == "both") return MiGradient::Both;
  if (s == "target_stopped") return MiGradient::TargetStopped;
  if (s == "target_frozen") return MiGradient::TargetFrozen;
  if (s == "target_ema") return MiGradient::TargetEma;
  throw Error("unknown MI gradient mode '" + s + "' (expected both, target_stopped, target_frozen or target_ema)",
              {{}, {}, field});
}
inline const char* to_string(MiGradient g) {
  switch (g) {
    case MiGradient::Both: return "both";
    case MiGradient::TargetStopped: return "target_stopped";
    case MiGradient::TargetFrozen: return "target_frozen";
    case MiGradient::TargetEma: return "target_ema";
  }
  return "?";
}
/// True for the modes whose target is computed once per iteration by the trainer
/// (mi_loss_on_fixed_target) rather than by a pass of the current network.
inline bool has_fixed_target(MiGradient g) { return g == MiGradient::TargetFrozen || g == MiGradient::TargetEma; }

/// λ_MI (paper: 1.0; 0 disables).
struct MiLossConfig {
  double lambda = 1.0;
  MiGradient gradient = MiGradient::Both;
};

struct MiLossResult {
  double kl = 0;    ///< mean_j KL_j (reported even when λ = 0)
  double loss = 0;  ///< λ·kl
};

/// Core of the loss on action means. p = N(mu_full, σ), q = N(mu_masked, σ) with the shared
/// log_std (action_dim × 1). Returns mean KL; ADDS λ·∂L_MI/∂mu_masked into `dmu_masked`
/// (action_dim × B, resized+zeroed if empty) and, when `dlog_std` is non-null, λ·∂L_MI/∂logσ_q
/// into it (action_dim × 1). Nothing is added when λ = 0.
/// With `dmu_full` non-null, the gradient through the target, λ·∂L_MI/∂mu_full, is ADDED into it
/// too (MiGradient::Both); with a learned log-std shared by p and q, `dlog_std` then receives the
/// sum of both sides' log-std gradients.
template <class T>
MiLossResult mi_loss_on_means(const Eigen::Ref<const MatrixX<T>>& mu_full, const Eigen::Ref<const MatrixX<T>>& mu_masked,
                              const Eigen::Ref<const MatrixX<T>>& log_std, double lambda, MatrixX<T>& dmu_masked,
                              MatrixX<T>* dlog_std, MatrixX<T>* dmu_full = nullptr) {
  require(lambda >= 0, "lambda_MI must be >= 0", {{}, {}, "lambda_mi"});
  nn::KlGrads<T> g;
  MatrixX<T> dlog_std_p;
  if (lambda > 0) {
    g.mean_q = &dmu_masked;
    g.log_std_q = dlog_std;
    if (dmu_full) {
      g.mean_p = dmu_full;
      if (dlog_std) g.log_std_p = &dlog_std_p;
    }
  }
  MiLossResult r;
  r.kl = static_cast<double>(nn::kl_diag_gaussian_mean<T>(mu_full, log_std, mu_masked, log_std, g,
                                                          nn::KlOptions{dmu_full == nullptr, lambda}));
  if (dlog_std && dlog_std_p.size()) *dlog_std += dlog_std_p;
  r.loss = lambda * r.kl;
  return r;
}

/// Reusable buffers for mi_loss and mi_loss_on_masked_pass (the K columns are those whose mask
/// is not the null mask).
template <class T>
struct MiWorkspace {
  MatrixX<T> norm_full, norm_masked, mu_full, dmu, dmu_full, dlog_std;
  MatrixX<T> full_k, mu_masked_k, dmu_k;  ///< (input_dim × K), (d × K), (d × K)
  std::vector<Index> cols;                ///< (K) columns with a non-null mask
  nn::InferenceWorkspace<T> ws;
  nn::TrainCache<T> cache, cache_full;
};

/// Which columns of a minibatch the MI term covers.
enum class MiColumns {
  Masked,  ///< those with a non-null mask (for the others KL(π(·|s,m⁰) ‖ π(·|s,m⁰)) = 0 exactly)
  All,     ///< every column (a target other than the current policy: null-mask columns count too)
};

/// Writes into `cols` the columns of `masked_input` ([s̄ ; m], input_dim × B, the mask's kNumParts
/// flag rows last) that `which` selects; returns their number K.
template <class T>
Index select_mi_columns(const Eigen::Ref<const MatrixX<T>>& masked_input, MiColumns which, std::vector<Index>& cols) {
  cols.clear();
  for (Index j = 0; j < masked_input.cols(); ++j)
    if (which == MiColumns::All || !(masked_input.col(j).tail(kNumParts).array() == T(0)).all()) cols.push_back(j);
  return static_cast<Index>(cols.size());
}

/// The MI term for a minibatch whose masked pass the caller has already run — the PPO surrogate's
/// `forward_train` on [s̄ ; m] gave `mu_masked` (d × B) — so that the masked network pass is run
/// once per minibatch, not twice. Only the full pass π(·|s, m⁰) is run here, and only on the K
/// columns whose mask is not the null mask: for a null-mask column [s̄ ; m] == [s ; 0], so its KL
/// is exactly 0 and so is its gradient (20 % of the samples at mask probability 0.8).
///
/// full_input = [s ; 0] and masked_input = [s̄ ; m] are (input_dim × B); a column's mask is read
/// from masked_input's last kNumParts rows. L_MI is the mean over all B columns. ADDS
/// λ·∂L_MI/∂μ_masked into `dmu_masked` (d × B), for the caller to back-propagate through its
/// masked pass together with its own gradient; with MiGradient::Both, back-propagates the full
/// pass here, adding into actor.mean_net.grads(); adds the log-std gradient into
/// actor.log_std.grads() when the log-std is learned.
template <class T>
MiLossResult mi_loss_on_masked_pass(rl::GaussianActor<T>& actor,
                                    const std::type_identity_t<Eigen::Ref<const MatrixX<T>>>& full_input,
                                    const std::type_identity_t<Eigen::Ref<const MatrixX<T>>>& masked_input,
                                    const std::type_identity_t<Eigen::Ref<const MatrixX<T>>>& mu_masked, double lambda,
                                    MiWorkspace<T>& w, MiGradient gradient, MatrixX<T>& dmu_masked) {
  const Index B = full_input.cols(), d = actor.action_dim(), D = actor.input_dim();
  require(full_input.rows() == D && masked_input.rows() == D && masked_input.cols() == B && B > 0 && D > kNumParts,
          "full and masked inputs must both be (policy_input_dim × B) with B > 0", {{}, {}, "mi_loss"});
  require(mu_masked.rows() == d && mu_masked.cols() == B && dmu_masked.rows() == d && dmu_masked.cols() == B,
          "mu_masked and dmu_masked must be (action_dim × B)", {{}, {}, "mi_loss.mu_masked"});
  require(lambda >= 0, "lambda_MI must be >= 0", {{}, {}, "lambda_mi"});
  require(!has_fixed_target(gradient), "a target computed before the update goes through mi_loss_on_fixed_target",
          {{}, {}, "mi_gradient"});
  const Index K = select_mi_columns<T>(masked_input, MiColumns::Masked, w.cols);
  MiLossResult r;
  if (K == 0) return r;
  rl::gather_columns(full_input, w.cols, w.full_k);
  rl::gather_columns(mu_masked, w.cols, w.mu_masked_k);
  const bool through_target = gradient == MiGradient::Both && lambda > 0;
  actor.normalize(w.full_k, w.norm_full);
  if (through_target) {
    w.mu_full = actor.mean_net.forward_train(w.norm_full, w.cache_full);
  } else {
    w.mu_full.resize(d, K);
    actor.mean_net.forward(w.norm_full, w.mu_full, w.ws);  // stopped target: no cache, no gradient
  }
  // mean over B = (K/B)·mean over K: the K-column loss with weight λK/B has the same gradients
  const double share = static_cast<double>(K) / static_cast<double>(B);
  w.dmu_k.setZero(d, K);
  w.dmu_full.setZero(through_target ? d : 0, through_target ? K : 0);
  w.dlog_std.setZero(d, 1);
  const MiLossResult rk = mi_loss_on_means<T>(w.mu_full, w.mu_masked_k, actor.log_std_col(), lambda * share, w.dmu_k,
                                              actor.learn_log_std ? &w.dlog_std : nullptr,
                                              through_target ? &w.dmu_full : nullptr);
  r.kl = rk.kl * share;
  r.loss = lambda * r.kl;
  if (lambda > 0) {
    for (Index k = 0; k < K; ++k) dmu_masked.col(w.cols[static_cast<std::size_t>(k)]) += w.dmu_k.col(k);
    if (through_target) actor.mean_net.backward(w.cache_full, w.dmu_full, actor.mean_net.grads());
    if (actor.learn_log_std) actor.log_std.grads() += w.dlog_std.col(0);
  }
  return r;
}

/// The MI term against a target computed before the update (MiGradient::TargetFrozen: the
/// pre-update policy; MiGradient::TargetEma: the moving-average copy): `mu_target` (d × B) holds
/// the target's μ(s, m⁰) for the minibatch's columns; `masked_input` = [s̄ ; m] and `mu_masked`
/// (d × B) are the surrogate's masked pass. `columns` says which columns contribute (`Masked` for
/// TargetFrozen, `All` for TargetEma, whose null-mask columns anchor the unmasked policy to the
/// target). L_MI is the mean over all B columns; ADDS λ·∂L_MI/∂μ_masked into `dmu_masked`
/// (d × B) and the log-std gradient into actor.log_std.grads() when it is learned. Nothing flows
/// into the target.
template <class T>
MiLossResult mi_loss_on_fixed_target(rl::GaussianActor<T>& actor,
                                     const std::type_identity_t<Eigen::Ref<const MatrixX<T>>>& mu_target,
                                     const std::type_identity_t<Eigen::Ref<const MatrixX<T>>>& masked_input,
                                     const std::type_identity_t<Eigen::Ref<const MatrixX<T>>>& mu_masked, double lambda,
                                     MiWorkspace<T>& w, MatrixX<T>& dmu_masked, MiColumns columns) {
  const Index B = masked_input.cols(), d = actor.action_dim();
  require(masked_input.rows() == actor.input_dim() && B > 0, "masked input must be (policy_input_dim × B) with B > 0",
          {{}, {}, "mi_loss"});
  require(mu_target.rows() == d && mu_target.cols() == B && mu_masked.rows() == d && mu_masked.cols() == B &&
              dmu_masked.rows() == d && dmu_masked.cols() == B,
          "mu_target, mu_masked and dmu_masked must be (action_dim × B)", {{}, {}, "mi_loss.mu_target"});
  require(lambda >= 0, "lambda_MI must be >= 0", {{}, {}, "lambda_mi"});
  const Index K = select_mi_columns<T>(masked_input, columns, w.cols);
  MiLossResult r;
  if (K == 0) return r;
  rl::gather_columns(mu_target, w.cols, w.mu_full);
  rl::gather_columns(mu_masked, w.cols, w.mu_masked_k);
  const double share = static_cast<double>(K) / static_cast<double>(B);
  w.dmu_k.setZero(d, K);
  w.dlog_std.setZero(d, 1);
  const MiLossResult rk = mi_loss_on_means<T>(w.mu_full, w.mu_masked_k, actor.log_std_col(), lambda * share, w.dmu_k,
                                              actor.learn_log_std ? &w.dlog_std : nullptr, nullptr);
  r.kl = rk.kl * share;
  r.loss = lambda * r.kl;
  if (lambda > 0) {
    for (Index k = 0; k < K; ++k) dmu_masked.col(w.cols[static_cast<std::size_t>(k)]) += w.dmu_k.col(k);
    if (actor.learn_log_std) actor.log_std.grads() += w.dlog_std.col(0);
  }
  return r;
}

/// θ̄ ← (1 − τ)·θ̄ + τ·θ: one step of the moving-average target (MiGradient::TargetEma) towards
/// the policy's mean network (same architecture; only the parameters move).
template <class T>
void update_ema_target(nn::Mlp<T>& target, const nn::Mlp<T>& policy, double tau) {
  require(tau > 0 && tau <= 1, "EMA rate must be in (0, 1]", {{}, {}, "mask.mi_target_tau"});
  require(target.num_params() == policy.num_params(), "EMA target and policy differ in size",
          {{}, {}, "mi_target"});
  target.params() = (T(1) - static_cast<T>(tau)) * target.params() + static_cast<T>(tau) * policy.params();
}

/// Whole MI loss for `actor`: full_input = policy input with the null mask (input_dim × B),
/// masked_input = [s̄ ; m] (input_dim × B). Returns the loss and ADDS λ·∂L_MI/∂θ into
/// actor.mean_net.grads() (and into actor.log_std.grads() when the log-std is learned). Runs the
/// masked pass itself; a trainer that already ran it for its surrogate calls
/// mi_loss_on_masked_pass instead.
template <class T>
MiLossResult mi_loss(rl::GaussianActor<T>& actor, const std::type_identity_t<Eigen::Ref<const MatrixX<T>>>& full_input,
                     const std::type_identity_t<Eigen::Ref<const MatrixX<T>>>& masked_input, double lambda,
                     MiWorkspace<T>& w, MiGradient gradient = MiGradient::Both) {
  require(full_input.rows() == actor.input_dim() && masked_input.rows() == actor.input_dim() &&
              full_input.cols() == masked_input.cols() && full_input.cols() > 0,
          "full and masked inputs must both be (policy_input_dim × B) with B > 0", {{}, {}, "mi_loss"});
  actor.normalize(masked_input, w.norm_masked);  // (mi_loss_on_masked_pass checks λ before adding anything)
  const MatrixX<T>& mu_masked = actor.mean_net.forward_train(w.norm_masked, w.cache);
  w.dmu.setZero(actor.action_dim(), masked_input.cols());
  const MiLossResult r = mi_loss_on_masked_pass<T>(actor, full_input, masked_input, mu_masked, lambda, w, gradient, w.dmu);
  if (lambda > 0) actor.mean_net.backward(w.cache, w.dmu, actor.mean_net.grads());
  return r;
}

/// [s ; 0] (policy_input_dim × B): the policy input of the full observation with the null mask.
template <class T>
void unmasked_policy_input(const Eigen::Ref<const MatrixX<T>>& obs, Index policy_input_dim, MatrixX<T>& out) {
  require(policy_input_dim >= obs.rows(), "policy input is smaller than the observation",
          {{}, {}, "unmasked_policy_input"});
  out.setZero(policy_input_dim, obs.cols());
  out.topRows(obs.rows()) = obs;
}

/// [(1 − m)⊙s ; mask bits] (obs_dim + kNumParts × B) for one mask per column.
/// \param element_parts part of every observation element (obs_dim)
template <class T>
void masked_policy_input(const Eigen::Ref<const MatrixX<T>>& obs, const std::vector<BodyPart>& element_parts,
                         const std::vector<PartMask>& masks, MatrixX<T>& out) {
  require(static_cast<Index>(element_parts.size()) == obs.rows(), "need one body part per observation element",
          {{}, {}, "element_parts"});
  require(static_cast<Index>(masks.size()) == obs.cols(), "need one mask per column", {{}, {}, "masks"});
  out.resize(obs.rows() + kNumParts, obs.cols());
  for (Index j = 0; j < obs.cols(); ++j) {
    const PartMask m = masks[static_cast<std::size_t>(j)];
    for (Index i = 0; i < obs.rows(); ++i) out(i, j) = m.has(element_parts[static_cast<std::size_t>(i)]) ? T(0) : obs(i, j);
    for (int p = 0; p < kNumParts; ++p) out(obs.rows() + p, j) = m.has(static_cast<BodyPart>(p)) ? T(1) : T(0);
  }
}

}  // namespace maskadapt::rl
