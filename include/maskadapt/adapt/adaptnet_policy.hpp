#pragma once
/// \file adaptnet_policy.hpp
/// The AdaptNet baseline for stage 2 (Xu et al. 2023, "AdaptNet: Policy Adaptation for
/// Physics-Based Character Control", Secs. 4–5): a FROZEN stage-1 base actor π (an L-layer MLP
/// f_{L−1}(W_{L−1} … f_0(W_0 x + b_0) …), x = norm_π([s ; 0]), the base on the FULL observation
/// with the null mask) adapted by two zero-initialised components:
///
///  LSA — latent space injection (Sec. 4, Eqs. 4–5). The base's first layer is the encoder E_ξ
///   and its output the latent Z^0 (the paper's default injection point, "performed right after
///   the concatenation of o_t and g_t"; Sec. 9.2 finds Z^0 best). The latent becomes
///       z^0 = E_ξ(s) + α·I_φ(s, c),   I_φ(s, c) = F_φ([E_φ(s) ; G_φ(c)])        (h0 × B)
///   with E_φ a trainable copy of E_ξ ("copying the original encoder parameters ξ into the new
///   encoder E_φ"), G_φ an optional goal MLP (identity by default), F_φ an MLP whose last layer
///   starts at zero weight and bias, and α a runtime scale (injection_scale(), 1 by default;
///   "an extra scaling coefficient to the injection term", Sec. 4). The offset is added AFTER
///   the first layer's activation (to the latent itself), as Eq. 4 adds it to E_ξ(s).
///  IA — internal adaptation (Sec. 5, Eqs. 7–8). Every later layer between two latent spaces
///   (base layers 1 … L−2) gets a branch: z^i = f((W_i + ΔW_i) z^{i−1} + b_i + Δb_i), i.e. the
///   branch is added to the pre-activation so it merges into W ("a residual structure that
///   supports merging", Sec. 9). ΔW_i is FULL-rank and zero at init, as in the paper
///   (ia_rank = 0); ia_rank = r > 0 gives the LoRA ablation ΔW = B·A, B = 0 at init.
///
/// The action layer is not adapted by default (the paper's latents lie "before the final action
/// layer"), and the std is a learned log σ initialised to the base's. With every zero-initialised
/// block at 0 the mean and the samples are the base's, bit for bit (the frozen layers run the
/// same arithmetic as nn::Mlp's inference path; tests/adapt/test_adaptnet_policy.cpp).
///
/// Differences from ResidualPolicy (whose public surface this mirrors, so the stage-2 trainer
/// can be templated on the policy): there is no mask restriction. AdaptNet acts on ALL DoFs,
/// the masks passed to build_input / act / forward_train are ignored (the base always sees the
/// null mask), and log-probs are over all action rows. Its policy input is x = [s ; c]
/// (input_dim = obs_dim + goal_dim), not [s ; a_base ; m ; g], since the base has to be re-run
/// with the adaptation in every training pass. Not here (the trainer's business): Eq. 12's
/// κ‖η‖₂ weight decay (use Adam's weight_decay); its β‖I_φ‖ term is injection_penalty().
/// The paper's GRU state encoder is our base's first (dense) layer. Actions are in the base's
/// units; `to_targets` maps them through the base's action space as ResidualPolicy does.
#include <maskadapt/adapt/adaptnet_parts.hpp>
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/mask/apply.hpp>
#include <maskadapt/nn/activation.hpp>
#include <maskadapt/nn/gaussian.hpp>
#include <maskadapt/rl/actor_critic.hpp>
#include <maskadapt/tasks/action_space.hpp>

#include <cmath>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

namespace maskadapt::adapt {

template <class T = float>
class AdaptNetPolicy {
 public:
  AdaptNetPolicy() = default;
  /// `base`: the stage-1 actor on [s ; m] (copied; never modified). `obs_dim`: rows of s.
  /// `base_actions`: how the base's actions become PD targets (identity by default).
  AdaptNetPolicy(rl::GaussianActor<T> base, Index obs_dim, AdaptNetConfig cfg, Rng& rng, tasks::ActionSpace base_actions = {})
      : base_(std::move(base)), cfg_(std::move(cfg)), obs_dim_(obs_dim), actions_(std::move(base_actions)) {
    const nn::Mlp<T>& net = base_.mean_net;
    const Index L = net.num_layers(), A = base_.action_dim(), h0 = net.spec().layer_outputs(0);
    actions_.validate(A, "base.actions");
    require(base_.input_dim() == obs_dim + kNumParts, "base policy input has " + std::to_string(base_.input_dim()) +
                " rows, expected obs_dim + 5 = " + std::to_string(obs_dim + kNumParts), {{}, {}, "base.actor"});
    require(L >= 2, "the base needs a hidden layer (its first layer is the encoder)", {{}, {}, "base.actor"});
    require(cfg_.goal_dim >= 0 && cfg_.ia_rank >= 0, "goal_dim and ia_rank must be >= 0", {{}, {}, "adaptnet.config"});
    require(cfg_.goal_dim > 0 || cfg_.goal_hidden.empty(), "goal_hidden needs goal_dim > 0", {{}, {}, "adaptnet.goal_hidden"});
    const nn::Activation act = net.spec().activation;
    // E_φ ← copy of E_ξ (base layer 0, activation after it)
    mod_.encoder = nn::Mlp<T>(nn::MlpSpec{net.inputs(), {}, h0, act, act});
    mod_.encoder.weight(0) = net.weight(0);
    mod_.encoder.bias(0) = net.bias(0);
    Index gf = cfg_.goal_dim;
    if (!cfg_.goal_hidden.empty()) {
      std::vector<Index> hid(cfg_.goal_hidden.begin(), cfg_.goal_hidden.end() - 1);
      gf = cfg_.goal_hidden.back();
      mod_.goal_net = nn::Mlp<T>(nn::MlpSpec{cfg_.goal_dim, hid, gf, act, act}, rng);
    }
    mod_.embed = nn::Mlp<T>(nn::MlpSpec{h0 + gf, cfg_.embed_hidden, h0, act, nn::Activation::Identity}, rng);
    // η: one slot per adapted layer, laid out one after another in mod_.ia
    Index off = 0;
    for (Index l = 1; cfg_.internal_adaptation && l < L; ++l) {
      if (l == L - 1 && !cfg_.adapt_action_layer) break;
      AdaptNetIaSlot s{l, net.spec().layer_outputs(l), net.spec().layer_inputs(l), cfg_.ia_rank};
      s.w = off;
      s.a = off + s.out * s.rank;
      s.b = off + s.size() - s.out;
      off += s.size();
      ia_.push_back(s);
    }
    mod_.ia = nn::ParameterBlock<T>(off);
    for (const auto& s : ia_)  // LoRA's A ~ U(±1/√in); B, Δb (and a full ΔW) stay 0
      for (Index i = 0; i < s.rank * s.in; ++i)
        mod_.ia.params()[s.a + i] = static_cast<T>(rng.uniform(-1.0, 1.0) / std::sqrt(double(s.in)));
    mod_.log_std = nn::ParameterBlock<T>(A);
    mod_.log_std.params() = base_.log_std.params();
    mod_.normalizer = nn::RunningNormalizer<T>(input_dim(), cfg_.normalizer_clip);
    zero_adaptation();
  }

  const AdaptNetConfig& config() const { return cfg_; }
  const rl::GaussianActor<T>& base() const { return base_; }  ///< the frozen actor
  AdaptNetModules<T>& adapter() { return mod_; }
  const AdaptNetModules<T>& adapter() const { return mod_; }
  /// ResidualPolicy's name for the trainable part (the trainer reads `.normalizer`, `.log_std`).
  AdaptNetModules<T>& residual() { return mod_; }
  const AdaptNetModules<T>& residual() const { return mod_; }
  const std::vector<AdaptNetIaSlot>& ia_slots() const { return ia_; }
  /// α in z^0 = E_ξ(s) + α·I_φ (1: the trained policy, 0: the base; runtime only, not saved).
  T injection_scale() const { return scale_; }
  void set_injection_scale(T k) { scale_ = k; }
  const tasks::ActionSpace& actions() const { return actions_; }
  Index obs_dim() const { return obs_dim_; }
  Index action_dim() const { return base_.action_dim(); }
  Index goal_dim() const { return cfg_.goal_dim; }
  /// Policy input rows: x = [s (obs_dim) ; c (goal_dim)].
  Index input_dim() const { return obs_dim_ + cfg_.goal_dim; }

  /// PD targets (A × B) of actions a (A × B, base units): offset + scale ⊙ a.
  void to_targets(const Eigen::Ref<const MatrixX<T>>& a, MatrixX<T>& targets) const {
    require(a.rows() == action_dim(), "actions have " + std::to_string(a.rows()) + " rows, expected " +
                                          std::to_string(action_dim()), {{}, {}, "adaptnet.actions"});
    targets.resize(a.rows(), a.cols());
    if (actions_.identity()) {
      targets = a;
    } else if constexpr (std::is_same_v<T, float>) {
      actions_.to_targets(a, targets);
    } else {  // (the action space is float)
      MatrixXf t(a.rows(), a.cols());
      actions_.to_targets(a.template cast<float>(), t);
      targets = t.template cast<T>();
    }
  }

  /// φ (E_φ, G_φ, F_φ), η (unless there is no adapted layer) and log σ (when learned). Never the base.
  std::vector<nn::ParameterBlock<T>*> trainable_blocks() {
    std::vector<nn::ParameterBlock<T>*> b{&mod_.encoder.block()};
    if (mod_.goal_net.num_params() > 0) b.push_back(&mod_.goal_net.block());
    b.push_back(&mod_.embed.block());
    if (mod_.ia.size() > 0) b.push_back(&mod_.ia);
    if (cfg_.learn_log_std) b.push_back(&mod_.log_std);
    return b;
  }
  void zero_grad() {
    for (auto* b : trainable_blocks()) b->zero_grad();
  }
  /// F_φ's last layer, every ΔW (or LoRA B) and Δb to exactly 0: the policy is the base again.
  void zero_adaptation() {
    const Index L = mod_.embed.num_layers() - 1;
    mod_.embed.weight(L).setZero();
    mod_.embed.bias(L).setZero();
    for (const auto& s : ia_) {
      mod_.ia.params().segment(s.w, s.out * (s.rank == 0 ? s.in : s.rank)).setZero();
      mod_.ia.params().segment(s.b, s.out).setZero();
    }
  }

  /// x (input_dim × B) = [obs (obs_dim × B) ; goals (goal_dim × B, ignored when goal_dim = 0)].
  /// `part_elements` and `masks` are accepted for ResidualPolicy's signature and unused.
  void build_input(const PartElements& /*part_elements*/, const Eigen::Ref<const MatrixX<T>>& obs,
                   std::span<const PartMask> masks, const Eigen::Ref<const MatrixX<T>>& goals, MatrixX<T>& x,
                   AdaptNetWorkspace<T>& /*ws*/) const {
    const Index B = obs.cols();
    require(obs.rows() == obs_dim_, "observations have " + std::to_string(obs.rows()) + " rows, expected " +
                                        std::to_string(obs_dim_), {{}, {}, "adaptnet.obs"});
    require(masks.empty() || static_cast<Index>(masks.size()) == B, "one mask per column (or none)", {{}, {}, "adaptnet.masks"});
    if (cfg_.goal_dim > 0)
      require(goals.rows() == cfg_.goal_dim && goals.cols() == B, "goals must be (" + std::to_string(cfg_.goal_dim) +
                  " × " + std::to_string(B) + ")", {{}, {}, "adaptnet.goals"});
    x.resize(input_dim(), B);
    x.topRows(obs_dim_) = obs;
    if (cfg_.goal_dim > 0) x.bottomRows(cfg_.goal_dim) = goals;
  }

  /// Mean μ (A × B) of inputs x (input_dim × B); masks ignored.
  void mean(const Eigen::Ref<const MatrixX<T>>& x, std::span<const PartMask> /*masks*/, MatrixX<T>& mu,
            AdaptNetWorkspace<T>& w) const {
    check_x(x);
    const Index B = x.cols(), h0 = mod_.embed.outputs();
    base_input(x, w.base_in, w.norm_in);
    w.enc.resize(h0, B);
    mod_.encoder.forward(w.norm_in, w.enc, w.enc_ws);
    const MatrixX<T>* g = goal_input(x, w.norm_x);
    if (g && mod_.goal_net.num_params() > 0) {
      w.gfeat.resize(mod_.goal_net.outputs(), B);
      mod_.goal_net.forward(*g, w.gfeat, w.goal_ws);
      g = &w.gfeat;
    }
    concat(w.enc, g, w.u);
    w.inj.resize(h0, B);
    mod_.embed.forward(w.u, w.inj, w.embed_ws);
    run_base(w.norm_in, w.inj, w.pre, w.post, w.lora);
    mu = w.post.back();
  }

  /// log σ (A × B), the same for every column.
  void log_std(std::span<const PartMask> masks, MatrixX<T>& out) const {
    out = mod_.log_std.params().replicate(1, static_cast<Index>(masks.size()));
  }

  /// Samples actions (A × B) and their log-probs over all rows (1 × B); μ in `mu`.
  void act(const Eigen::Ref<const MatrixX<T>>& x, std::span<const PartMask> masks, Rng& rng, MatrixX<T>& actions,
           RowVectorX<T>& log_prob, MatrixX<T>& mu, AdaptNetWorkspace<T>& w) const {
    mean(x, masks, mu, w);
    const Eigen::Map<const MatrixX<T>> ls(mod_.log_std.params().data(), action_dim(), 1);
    actions.resize(mu.rows(), mu.cols());
    log_prob.resize(mu.cols());
    nn::gaussian_sample<T>(mu, ls, rng, actions);
    nn::gaussian_log_prob<T>(mu, ls, actions, log_prob);
  }

  /// Training forward: μ (A × B) with caches for `backward` (same numbers as `mean`).
  const MatrixX<T>& forward_train(const Eigen::Ref<const MatrixX<T>>& x, std::span<const PartMask> /*masks*/,
                                  AdaptNetTrainCache<T>& c) const {
    check_x(x);
    base_input(x, c.base_in, c.norm_in);
    const MatrixX<T>& enc = mod_.encoder.forward_train(c.norm_in, c.enc);
    const MatrixX<T>* g = goal_input(x, c.norm_x);
    if (g && mod_.goal_net.num_params() > 0) g = &mod_.goal_net.forward_train(*g, c.goal);
    concat(enc, g, c.u);
    const MatrixX<T>& inj = mod_.embed.forward_train(c.u, c.embed);
    run_base(c.norm_in, inj, c.pre, c.post, c.lora);
    c.mu = c.post.back();
    c.log_std = mod_.log_std.params();
    c.dlog_std.setZero(action_dim());
    c.dinj.resize(0, 0);
    return c.mu;
  }

  /// log N(actions | μ, σ) over all rows (1 × B) under the cached pass.
  void log_prob(const AdaptNetTrainCache<T>& c, const MatrixX<T>& actions, RowVectorX<T>& out) const {
    out.resize(c.mu.cols());
    nn::gaussian_log_prob<T>(c.mu, c.log_std, actions, out);
  }

  /// dmu (A × B) = ∂/∂μ of Σ_j dlogp_j · log p_j; also records ∂/∂log σ in the cache (c.dlog_std),
  /// which `backward` adds to log σ's gradient (hence the non-const cache).
  static void log_prob_mean_grad(AdaptNetTrainCache<T>& c, const MatrixX<T>& actions, const RowVectorX<T>& dlogp,
                                 MatrixX<T>& dmu) {
    dmu.setZero(c.mu.rows(), c.mu.cols());
    MatrixX<T> dls = MatrixX<T>::Zero(c.mu.rows(), 1);
    nn::gaussian_log_prob_backward<T>(c.mu, c.log_std, actions, dlogp, &dmu, &dls);
    c.dlog_std = dls.col(0);
  }

  /// Eq. 12's β‖I_φ‖ regulariser as β·mean_j ‖I_φ(s_j, c_j)‖²: returns it and records its
  /// gradient for the next `backward` (call after forward_train, before backward). The paper
  /// uses β = 0.01 for style transfer and none elsewhere (Sec. 10.2).
  double injection_penalty(AdaptNetTrainCache<T>& c, double beta) const {
    const MatrixX<T>& inj = c.injection();
    const double B = static_cast<double>(inj.cols());
    c.dinj = inj * static_cast<T>(2.0 * beta / B);
    return beta * static_cast<double>(inj.squaredNorm()) / B;
  }

  /// ADDS ∂L/∂(φ, η, log σ) given dmu = ∂L/∂μ (A × B) and what the cache recorded. The base's
  /// weights are only read (their Wᵀδ carries the gradient down to z^0).
  void backward(AdaptNetTrainCache<T>& c, const MatrixX<T>& dmu) {
    const nn::Mlp<T>& net = base_.mean_net;
    if (cfg_.learn_log_std && c.dlog_std.size() == action_dim()) mod_.log_std.grads() += c.dlog_std;
    c.dz = dmu;
    for (Index l = net.num_layers() - 1; l >= 1; --l) {
      const auto ul = static_cast<std::size_t>(l);
      const MatrixX<T>& a = c.post[ul - 1];  // z^{l−1} (in × B)
      c.delta = c.dz;                         // δ_l = dz^l ⊙ f'(pre_l) (out × B)
      const nn::Activation act = net.spec().layer_activation(l);
      if (act != nn::Activation::Identity) c.delta.array() *= c.pre[ul].unaryExpr([act](T z) { return nn::activation_derivative(act, z); }).array();
      c.dz_prev.noalias() = net.weight(l).transpose() * c.delta;
      if (const AdaptNetIaSlot* s = slot(l)) {
        auto g = mod_.ia.grads();
        g.segment(s->b, s->out) += c.delta.rowwise().sum();
        if (s->rank == 0) {
          Eigen::Map<MatrixX<T>>(g.data() + s->w, s->out, s->in).noalias() += c.delta * a.transpose();
          c.dz_prev.noalias() += dW(*s).transpose() * c.delta;
        } else {
          Eigen::Map<MatrixX<T>>(g.data() + s->w, s->out, s->rank).noalias() += c.delta * c.lora[ul].transpose();
          c.tmp.noalias() = lB(*s).transpose() * c.delta;  // (r × B)
          Eigen::Map<MatrixX<T>>(g.data() + s->a, s->rank, s->in).noalias() += c.tmp * a.transpose();
          c.dz_prev.noalias() += lA(*s).transpose() * c.tmp;
        }
      }
      std::swap(c.dz, c.dz_prev);
    }
    // c.dz = ∂L/∂z^0; z^0 = E_ξ(s) + α·I_φ and E_ξ is frozen
    c.dz *= scale_;
    if (c.dinj.size() == c.dz.size()) c.dz += c.dinj;
    mod_.embed.backward(c.embed, c.dz, mod_.embed.grads(), &c.du);
    const Index h0 = mod_.encoder.outputs();
    mod_.encoder.backward(c.enc, c.du.topRows(h0), mod_.encoder.grads());
    if (mod_.goal_net.num_params() > 0) mod_.goal_net.backward(c.goal, c.du.bottomRows(c.du.rows() - h0), mod_.goal_net.grads());
  }

  // ---- checkpoint sections ----------------------------------------------------------------

  /// Writes adaptnet/{encoder, goal_net (when present), embed, ia (when any), log_std, norm/*}
  /// and, with `with_base`, the base/* sections exactly as ResidualPolicy writes them.
  void save(Checkpoint& ck, bool with_base = true) const {
    ck.put("adaptnet/encoder", mod_.encoder.params());
    if (mod_.goal_net.num_params() > 0) ck.put("adaptnet/goal_net", mod_.goal_net.params());
    ck.put("adaptnet/embed", mod_.embed.params());
    if (mod_.ia.size() > 0) ck.put("adaptnet/ia", mod_.ia.params());
    ck.put("adaptnet/log_std", mod_.log_std.params());
    detail::put_norm<T>(ck, "adaptnet/norm", mod_.normalizer);
    if (with_base) {
      ck.put("base/actor/params", base_.mean_net.params());
      ck.put("base/actor/log_std", base_.log_std.params());
      detail::put_norm<T>(ck, "base/actor/norm", base_.normalizer);
      base_.save_hidden_groups(ck, "base/actor/hidden_groups");
      if (actions_.offset.size()) ck.put("base/actor/action_offset", actions_.offset);
      if (actions_.scale.size()) ck.put("base/actor/action_scale", actions_.scale);
    }
  }
  /// Reads what `save` wrote into a policy of the same configuration; a section of another size
  /// (or a missing one) throws maskadapt::Error naming it.
  void load(const Checkpoint& ck, bool with_base = true) {
    ck.copy_to<T>("adaptnet/encoder", mod_.encoder.params());
    if (mod_.goal_net.num_params() > 0) ck.copy_to<T>("adaptnet/goal_net", mod_.goal_net.params());
    ck.copy_to<T>("adaptnet/embed", mod_.embed.params());
    if (mod_.ia.size() > 0) ck.copy_to<T>("adaptnet/ia", mod_.ia.params());
    else require(!ck.contains("adaptnet/ia"), "checkpoint has internal-adaptation weights, this policy none",
                 {ck.source(), std::nullopt, "adaptnet/ia"});
    ck.copy_to<T>("adaptnet/log_std", mod_.log_std.params());
    detail::get_norm<T>(ck, "adaptnet/norm", mod_.normalizer);
    if (with_base) {
      ck.copy_to<T>("base/actor/params", base_.mean_net.params());
      ck.copy_to<T>("base/actor/log_std", base_.log_std.params());
      detail::get_norm<T>(ck, "base/actor/norm", base_.normalizer);
      base_.load_hidden_groups(ck, "base/actor/hidden_groups", kNumParts);
      tasks::ActionSpace a;
      const Index A = action_dim();
      if (ck.contains("base/actor/action_offset")) a.offset = ck.get_vector<float>("base/actor/action_offset", A);
      if (ck.contains("base/actor/action_scale")) a.scale = ck.get_vector<float>("base/actor/action_scale", A);
      a.validate(A, ck.source().empty() ? "base/actor/action" : ck.source() + ": base/actor/action");
      actions_ = std::move(a);
    }
  }

 private:
  void check_x(const Eigen::Ref<const MatrixX<T>>& x) const {
    require(x.rows() == input_dim(), "policy input has " + std::to_string(x.rows()) + " rows, expected " +
                                         std::to_string(input_dim()), {{}, {}, "adaptnet.x"});
  }
  /// norm_in ((obs_dim + 5) × B) = norm_π([s ; 0]): the base's own (frozen) normaliser, null mask.
  void base_input(const Eigen::Ref<const MatrixX<T>>& x, MatrixX<T>& base_in, MatrixX<T>& norm_in) const {
    base_in.resize(obs_dim_ + kNumParts, x.cols());
    base_in.topRows(obs_dim_) = x.topRows(obs_dim_);
    base_in.bottomRows(kNumParts).setZero();
    base_.normalize(base_in, norm_in);
  }
  /// The normalised goal rows (goal_dim × B) in `norm_x`, or null without a goal.
  const MatrixX<T>* goal_input(const Eigen::Ref<const MatrixX<T>>& x, MatrixX<T>& norm_x) const {
    if (cfg_.goal_dim == 0) return nullptr;
    MatrixX<T> all(x.rows(), x.cols());
    if (cfg_.normalize_inputs) mod_.normalizer.normalize(x, all);
    else all = x;
    norm_x = all.bottomRows(cfg_.goal_dim);
    return &norm_x;
  }
  /// u = [enc (h0 × B) ; g (gf × B)].
  static void concat(const MatrixX<T>& enc, const MatrixX<T>* g, MatrixX<T>& u) {
    u.resize(enc.rows() + (g ? g->rows() : 0), enc.cols());
    u.topRows(enc.rows()) = enc;
    if (g) u.bottomRows(g->rows()) = *g;
  }

  /// The base network with the injection at z^0 and the IA branches: pre[l], post[l] (out_l × B),
  /// lora[l] (r × B) = A_l z^{l−1}; post.back() is μ.
  void run_base(const MatrixX<T>& norm_in, const MatrixX<T>& inj, std::vector<MatrixX<T>>& pre,
                std::vector<MatrixX<T>>& post, std::vector<MatrixX<T>>& lora) const {
    const nn::Mlp<T>& net = base_.mean_net;
    const Index L = net.num_layers();
    pre.resize(static_cast<std::size_t>(L));
    post.resize(static_cast<std::size_t>(L));
    lora.resize(static_cast<std::size_t>(L));
    for (Index l = 0; l < L; ++l) {
      const auto ul = static_cast<std::size_t>(l);
      const MatrixX<T>& in = l == 0 ? norm_in : post[ul - 1];
      detail::frozen_affine<T>(net.weight(l), net.bias(l), in, pre[ul]);
      if (const AdaptNetIaSlot* s = slot(l)) {
        if (s->rank == 0) {
          pre[ul].noalias() += dW(*s) * in;
        } else {
          lora[ul].noalias() = lA(*s) * in;
          pre[ul].noalias() += lB(*s) * lora[ul];
        }
        pre[ul].colwise() += mod_.ia.params().segment(s->b, s->out);
      }
      post[ul].resize(pre[ul].rows(), pre[ul].cols());
      nn::apply_activation<T>(net.spec().layer_activation(l), pre[ul], post[ul]);
      if (l == 0) post[0] += scale_ * inj;  // z^0 = E_ξ(s) + α·I_φ(s, c)
    }
  }

  const AdaptNetIaSlot* slot(Index l) const {
    for (const auto& s : ia_)
      if (s.layer == l) return &s;
    return nullptr;
  }
  Eigen::Map<const MatrixX<T>> dW(const AdaptNetIaSlot& s) const { return {mod_.ia.params().data() + s.w, s.out, s.in}; }
  Eigen::Map<const MatrixX<T>> lB(const AdaptNetIaSlot& s) const { return {mod_.ia.params().data() + s.w, s.out, s.rank}; }
  Eigen::Map<const MatrixX<T>> lA(const AdaptNetIaSlot& s) const { return {mod_.ia.params().data() + s.a, s.rank, s.in}; }

  rl::GaussianActor<T> base_;
  AdaptNetConfig cfg_;
  Index obs_dim_ = 0;
  tasks::ActionSpace actions_;  ///< the base's: PD target = offset + scale ⊙ a
  AdaptNetModules<T> mod_;
  std::vector<AdaptNetIaSlot> ia_;
  T scale_ = T(1);
};

}  // namespace maskadapt::adapt
