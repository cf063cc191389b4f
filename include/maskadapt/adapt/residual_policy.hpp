#pragma once
/// \file residual_policy.hpp
/// Stage 2: the residual policy on top of a FROZEN base policy.
///
///     â = w_gain ⊙ a_base + Δa        on the DoFs of masked parts,
///     â = a_base                       on every other DoF,
///
/// with a_base = μ_π(s̄, m) the base policy's mean on the masked observation [s̄ ; m] (the frozen
/// base is only ever run on the no-allocation inference path), and Δa ~ ψ(·|s, a_base, m [, g]) a
/// Gaussian MLP on the full observation s, the base action, the 5 mask bits and optional goal
/// features g (partial tracking).
///
/// How the residual is restricted to the masked parts: `action_parts(skeleton)` gives the body
/// part moved by every action DoF (3 hinges per body). For a mask m the DoF selector
/// M_m (action_dim) is 1 on DoFs whose part is in m and 0 elsewhere. The composite policy is the
/// diagonal Gaussian
///
///     N( μ̂ = μ_base + M_m ⊙ ((w − 1) ⊙ μ_base + μ_ψ),  σ̂ = σ_base on unmasked, σ_ψ on masked DoFs ).
///
/// Only the masked rows depend on trainable parameters, so the PPO log-probability is taken over
/// the masked rows only (`masked_log_prob`): unmasked rows contribute the same term to the old and
/// new probability, and an empty mask gives log-prob 0 (ratio 1, no gradient).
///
/// Zero initialisation: the residual's output layer (weights and bias) starts at exactly 0 and
/// w = 1, σ_ψ = σ_base, so at step 0 μ̂ = μ_base bit for bit and the composite samples the same
/// actions as the base policy from the same Rng (tests/adapt/test_residual_policy.cpp). With
/// `init_std` > 0 the mean is still the base's but the masked DoFs sample with σ_ψ = init_std.
///
/// Gain modes: Fixed (w stays at `init_gain`), Scalar (one learned w shared by every DoF) or
/// PerDof (one learned w per DoF).
///
/// Units: everything above lives in the BASE's action units. A base trained with normalised
/// actions (tasks/action_space.hpp) maps its actions to PD targets as offset + scale ⊙ a, so
/// a_base, Δa, σ_ψ (initialised to σ_base), μ̂ and the gain are in those normalised units, and the
/// PD targets sent to the simulator are offset + scale ⊙ â (`to_targets`). With a non-zero offset
/// w scales a_base about the offset pose (w = 0 on a DoF: target = offset), not about the zero
/// pose. Unmasked DoFs keep â = a_base, hence exactly the base's own PD targets. The policy holds
/// its base's action space (`actions()`; identity = the actions are the targets, the old meaning)
/// and saves it with the base as `base/actor/action_offset`, `base/actor/action_scale` (num_dofs,
/// float; written only when not the identity, absent ⇒ identity).
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/mask/apply.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/nn/gaussian.hpp>
#include <maskadapt/nn/mlp.hpp>
#include <maskadapt/nn/parameter_block.hpp>
#include <maskadapt/rl/actor_critic.hpp>
#include <maskadapt/tasks/action_space.hpp>  // (core-only header: actions → PD targets)

#include <array>
#include <cmath>
#include <numbers>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

namespace maskadapt::adapt {

enum class GainMode { Fixed, Scalar, PerDof };

inline GainMode gain_mode_from_name(const std::string& s) {
  if (s == "fixed") return GainMode::Fixed;
  if (s == "scalar") return GainMode::Scalar;
  if (s == "per_dof") return GainMode::PerDof;
  throw Error("unknown gain mode '" + s + "' (expected fixed, scalar or per_dof)", {{}, {}, "residual.gain"});
}
inline std::string gain_mode_name(GainMode g) {
  return g == GainMode::Fixed ? "fixed" : g == GainMode::Scalar ? "scalar" : "per_dof";
}

struct ResidualConfig {
  std::vector<Index> hidden{256, 256};  ///< residual MLP widths (cpu-sized; not from the paper)
  nn::Activation activation = nn::Activation::ReLU;
  GainMode gain = GainMode::Scalar;
  double init_gain = 1.0;    ///< w at step 0 (1 ⇒ composite == base)
  /// σ_ψ on every DoF (base action units, fixed during training); 0 ⇒ the base's own σ. A base
  /// trained with AMP's fixed σ ≈ 0.055 explores a new motion of large amplitude (arm circles)
  /// only slowly; a wider σ_ψ lets the residual find it (docs/training.md, "Residual σ").
  double init_std = 0.0;
  /// σ_ψ per body part (base action units), overriding `init_std` on that part's DoFs; 0 leaves
  /// the part at `init_std` (or the base's σ). Lets the residual explore a composed motion wide
  /// (the arms' swim) while the legs that carry the walker explore narrowly.
  std::array<double, kNumParts> part_std{};
  Index goal_dim = 0;        ///< extra goal features g appended to the residual input (tracking)
  bool normalize_inputs = true;
  /// true: the base sees the masked observation [s̄ ; m] (ours: the mask-invariant base ignores
  /// the adapted parts). false: it sees the full [s ; 0] (null mask) — the CML-style baseline,
  /// whose base reacts to the adapted parts' state.
  bool masked_base_input = true;
  /// Parts the residual moves besides the mask's, on every sample (goal tasks: the legs, to walk
  /// to a target while the arms compose a new motion). They stay visible to the base and are not
  /// part of the mask the base, the discriminators and the input's mask bits see.
  PartMask goal_parts = PartMask::none();
};

/// DoF selector M_m (action_dim × 1): 1 on DoFs whose part is in m.
template <class T = float>
VectorX<T> dof_selector(const std::vector<BodyPart>& dof_parts, PartMask m) {
  VectorX<T> s(static_cast<Index>(dof_parts.size()));
  for (std::size_t i = 0; i < dof_parts.size(); ++i) s[static_cast<Index>(i)] = m.has(dof_parts[i]) ? T(1) : T(0);
  return s;
}

/// Σ over rows with sel(i, j) = 1 of the Gaussian log density; (1 × B).
/// mean, x, log_std, sel: (A × B).
template <class T>
void masked_log_prob(const MatrixX<T>& mean, const MatrixX<T>& log_std, const MatrixX<T>& sel, const MatrixX<T>& x,
                     RowVectorX<T>& out) {
  const T half_log_2pi = static_cast<T>(0.5 * std::log(2.0 * std::numbers::pi));
  out.setZero(mean.cols());
  for (Index j = 0; j < mean.cols(); ++j)
    for (Index i = 0; i < mean.rows(); ++i)
      if (sel(i, j) != T(0)) {
        const T z = (x(i, j) - mean(i, j)) * std::exp(-log_std(i, j));
        out[j] += T(-0.5) * z * z - log_std(i, j) - half_log_2pi;
      }
}

/// Inference scratch (one per thread); nothing allocates once sized.
template <class T>
struct ResidualWorkspace {
  MatrixX<T> base_in, base_mu, res_mu, scratch, log_std, sel;
  nn::InferenceWorkspace<T> base_ws, res_ws;
};

/// Training cache for `forward_train` / `backward`.
template <class T>
struct ResidualTrainCache {
  MatrixX<T> norm_in, base_mu, sel, mu, log_std;
  nn::TrainCache<T> net;
};

template <class T = float>
class ResidualPolicy {
 public:
  ResidualPolicy() = default;
  /// `base`: the stage-1 actor (copied; never modified afterwards). `obs_dim`: rows of s.
  /// `dof_parts`: part of every action DoF (humanoid: action_parts(skeleton)). `base_actions`:
  /// how the base's actions become PD targets (identity by default; see the file comment).
  ResidualPolicy(rl::GaussianActor<T> base, Index obs_dim, std::vector<BodyPart> dof_parts, ResidualConfig cfg, Rng& rng,
                 tasks::ActionSpace base_actions = {})
      : base_(std::move(base)), cfg_(std::move(cfg)), obs_dim_(obs_dim), dof_parts_(std::move(dof_parts)),
        actions_(std::move(base_actions)) {
    const Index A = base_.action_dim();
    actions_.validate(A, "base.actions");
    require(base_.input_dim() == obs_dim + kNumParts,
            "base policy input has " + std::to_string(base_.input_dim()) + " rows, expected obs_dim + 5 = " +
                std::to_string(obs_dim + kNumParts), {{}, {}, "base.actor"});
    require(static_cast<Index>(dof_parts_.size()) == A, "dof_parts must have one entry per action DoF",
            {{}, {}, "dof_parts"});
    require(cfg_.goal_dim >= 0, "goal_dim must be ≥ 0", {{}, {}, "residual.goal_dim"});
    require(std::isfinite(cfg_.init_gain), "init_gain must be finite", {{}, {}, "residual.init_gain"});
    require(std::isfinite(cfg_.init_std) && cfg_.init_std >= 0, "init_std must be finite and ≥ 0 (0 = the base's σ)",
            {{}, {}, "residual.init_std"});
    for (int p = 0; p < kNumParts; ++p)
      require(std::isfinite(cfg_.part_std[static_cast<std::size_t>(p)]) && cfg_.part_std[static_cast<std::size_t>(p)] >= 0,
              "must be finite and ≥ 0 (0 = init_std)", {{}, {}, "residual.part_std." + std::string(kPartNames[static_cast<std::size_t>(p)])});
    rl::ActorCriticConfig ac;
    ac.policy_input_dim = input_dim();
    ac.critic_input_dim = input_dim();
    ac.action_dim = A;
    ac.actor_hidden = cfg_.hidden;
    ac.activation = cfg_.activation;
    ac.normalize_inputs = cfg_.normalize_inputs;
    ac.learn_log_std = false;
    res_ = rl::GaussianActor<T>(ac, rng);
    res_.log_std.params() = base_.log_std.params();  // σ_ψ = σ_base at step 0 …
    if (cfg_.init_std > 0) res_.log_std.params().setConstant(static_cast<T>(std::log(cfg_.init_std)));  // … or as asked
    for (Index i = 0; i < A; ++i) {  // … or per part
      const double sp = cfg_.part_std[static_cast<std::size_t>(dof_parts_[static_cast<std::size_t>(i)])];
      if (sp > 0) res_.log_std.params()[i] = static_cast<T>(std::log(sp));
    }
    zero_output_layer();
    gain_ = nn::ParameterBlock<T>(cfg_.gain == GainMode::PerDof ? A : 1);
    gain_.params().setConstant(static_cast<T>(cfg_.init_gain));
  }

  const ResidualConfig& config() const { return cfg_; }
  /// The frozen base actor (read-only by construction).
  const rl::GaussianActor<T>& base() const { return base_; }
  rl::GaussianActor<T>& residual() { return res_; }
  const rl::GaussianActor<T>& residual() const { return res_; }
  nn::ParameterBlock<T>& gain() { return gain_; }
  const nn::ParameterBlock<T>& gain() const { return gain_; }
  const std::vector<BodyPart>& dof_parts() const { return dof_parts_; }
  /// The base's action space: PD target = offset + scale ⊙ â (identity: â is the target).
  const tasks::ActionSpace& actions() const { return actions_; }
  /// PD targets (action_dim × B, rad) of composite actions â (action_dim × B, base units):
  /// offset + scale ⊙ â; a plain copy with the identity action space.
  void to_targets(const Eigen::Ref<const MatrixX<T>>& a, MatrixX<T>& targets) const {
    require(a.rows() == action_dim(), "actions have " + std::to_string(a.rows()) + " rows, expected " +
                                          std::to_string(action_dim()), {{}, {}, "residual.actions"});
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
  Index obs_dim() const { return obs_dim_; }
  Index action_dim() const { return base_.action_dim(); }
  Index goal_dim() const { return cfg_.goal_dim; }
  /// Residual input rows: [s (obs_dim) ; a_base (action_dim) ; m (5) ; g (goal_dim)].
  Index input_dim() const { return obs_dim_ + action_dim() + kNumParts + cfg_.goal_dim; }

  /// Trainable blocks (the residual mean network, plus the gain unless Fixed).
  std::vector<nn::ParameterBlock<T>*> trainable_blocks() {
    std::vector<nn::ParameterBlock<T>*> b{&res_.mean_net.block()};
    if (cfg_.gain != GainMode::Fixed) b.push_back(&gain_);
    return b;
  }
  void zero_grad() {
    res_.zero_grad();
    gain_.zero_grad();
  }

  /// Sets the residual's output layer to exactly zero (done at construction).
  void zero_output_layer() {
    const Index L = res_.mean_net.num_layers() - 1;
    res_.mean_net.weight(L).setZero();
    res_.mean_net.bias(L).setZero();
  }

  /// Builds the residual input x (input_dim × B) for observations s (obs_dim × B), masks (B) and
  /// goals (goal_dim × B, ignored when goal_dim = 0); runs the frozen base on [s̄ ; m].
  /// `part_elements`: the observation's part layout (observation_parts).
  void build_input(const PartElements& part_elements, const Eigen::Ref<const MatrixX<T>>& obs,
                   std::span<const PartMask> masks, const Eigen::Ref<const MatrixX<T>>& goals, MatrixX<T>& x,
                   ResidualWorkspace<T>& w) const {
    const Index B = obs.cols(), A = action_dim();
    require(obs.rows() == obs_dim_, "observations have " + std::to_string(obs.rows()) + " rows, expected " +
                                        std::to_string(obs_dim_), {{}, {}, "residual.obs"});
    require(static_cast<Index>(masks.size()) == B, "one mask per column needed", {{}, {}, "residual.masks"});
    if (cfg_.goal_dim > 0)
      require(goals.rows() == cfg_.goal_dim && goals.cols() == B,
              "goals must be (" + std::to_string(cfg_.goal_dim) + " × " + std::to_string(B) + ")", {{}, {}, "residual.goals"});
    w.base_in.resize(obs_dim_ + kNumParts, B);
    if (cfg_.masked_base_input) {
      build_policy_input<T>(part_elements, obs, masks, w.base_in);
    } else {
      w.base_in.topRows(obs_dim_) = obs;
      w.base_in.bottomRows(kNumParts).setZero();
    }
    w.base_mu.resize(A, B);
    base_.mean(w.base_in, w.base_mu, w.base_ws, w.scratch);
    x.resize(input_dim(), B);
    x.topRows(obs_dim_) = obs;
    x.middleRows(obs_dim_, A) = w.base_mu;
    for (Index j = 0; j < B; ++j) {
      const auto bits = masks[static_cast<std::size_t>(j)].template as_array<T>();
      for (int p = 0; p < kNumParts; ++p) x(obs_dim_ + A + p, j) = bits[static_cast<std::size_t>(p)];
    }
    if (cfg_.goal_dim > 0) x.bottomRows(cfg_.goal_dim) = goals;
  }

  /// Composite mean μ̂ (A × B) from a residual input x (see build_input) and masks.
  void mean(const Eigen::Ref<const MatrixX<T>>& x, std::span<const PartMask> masks, MatrixX<T>& mu,
            ResidualWorkspace<T>& w) const {
    const Index B = x.cols(), A = action_dim();
    w.res_mu.resize(A, B);
    res_.mean(x, w.res_mu, w.res_ws, w.scratch);
    selectors(masks, w.sel);
    compose(x.middleRows(obs_dim_, A), w.res_mu, w.sel, mu);
  }

  /// Composite log-std σ̂ (A × B): base on unmasked rows, residual on masked rows.
  void log_std(std::span<const PartMask> masks, MatrixX<T>& out) const {
    MatrixX<T> sel;
    selectors(masks, sel);
    composite_log_std(sel, out);
  }

  /// Samples composite actions (A × B) and their masked log-probs (1 × B) for residual inputs x.
  void act(const Eigen::Ref<const MatrixX<T>>& x, std::span<const PartMask> masks, Rng& rng, MatrixX<T>& actions,
           RowVectorX<T>& log_prob, MatrixX<T>& mu, ResidualWorkspace<T>& w) const {
    mean(x, masks, mu, w);
    composite_log_std(w.sel, w.log_std);
    actions.resize(mu.rows(), mu.cols());
    nn::gaussian_sample<T>(mu, w.log_std, rng, actions);
    masked_log_prob<T>(mu, w.log_std, w.sel, actions, log_prob);
  }

  /// Training forward: composite mean μ̂ (A × B) with caches for `backward`.
  const MatrixX<T>& forward_train(const Eigen::Ref<const MatrixX<T>>& x, std::span<const PartMask> masks,
                                  ResidualTrainCache<T>& c) const {
    const Index A = action_dim();
    res_.normalize(x, c.norm_in);
    const MatrixX<T>& res_mu = res_.mean_net.forward_train(c.norm_in, c.net);
    c.base_mu = x.middleRows(obs_dim_, A);
    selectors(masks, c.sel);
    compose(c.base_mu, res_mu, c.sel, c.mu);
    composite_log_std(c.sel, c.log_std);
    return c.mu;
  }

  /// Masked log-prob of `actions` under the cached composite (1 × B).
  void log_prob(const ResidualTrainCache<T>& c, const MatrixX<T>& actions, RowVectorX<T>& out) const {
    masked_log_prob<T>(c.mu, c.log_std, c.sel, actions, out);
  }

  /// ∂/∂μ̂ of Σ_j dlogp_j · masked_log_prob_j, (A × B).
  static void log_prob_mean_grad(const ResidualTrainCache<T>& c, const MatrixX<T>& actions,
                                 const RowVectorX<T>& dlogp, MatrixX<T>& dmu) {
    dmu.resize(c.mu.rows(), c.mu.cols());
    for (Index j = 0; j < c.mu.cols(); ++j)
      for (Index i = 0; i < c.mu.rows(); ++i)
        dmu(i, j) = c.sel(i, j) * (actions(i, j) - c.mu(i, j)) * std::exp(T(-2) * c.log_std(i, j)) * dlogp[j];
  }

  /// The terms of `log_prob` before the sum over rows (A × B): the Gaussian log density of each
  /// row the residual moves (sel = 1), 0 on the others. Summed over the rows of a column in order,
  /// they are that column's `log_prob`, bit for bit (per-part credit, train/stage2_learner.hpp).
  void log_prob_rows(const ResidualTrainCache<T>& c, const MatrixX<T>& actions, MatrixX<T>& out) const {
    const T half_log_2pi = static_cast<T>(0.5 * std::log(2.0 * std::numbers::pi));
    out.setZero(c.mu.rows(), c.mu.cols());
    for (Index j = 0; j < c.mu.cols(); ++j)
      for (Index i = 0; i < c.mu.rows(); ++i)
        if (c.sel(i, j) != T(0)) {
          const T z = (actions(i, j) - c.mu(i, j)) * std::exp(-c.log_std(i, j));
          out(i, j) = T(-0.5) * z * z - c.log_std(i, j) - half_log_2pi;
        }
  }

  /// ∂/∂μ̂ of Σ_ij dlogp(i, j) · log_prob_rows(i, j), (A × B): log_prob_mean_grad with a weight
  /// per row instead of per column.
  static void log_prob_rows_mean_grad(const ResidualTrainCache<T>& c, const MatrixX<T>& actions, const MatrixX<T>& dlogp,
                                      MatrixX<T>& dmu) {
    dmu.resize(c.mu.rows(), c.mu.cols());
    for (Index j = 0; j < c.mu.cols(); ++j)
      for (Index i = 0; i < c.mu.rows(); ++i)
        dmu(i, j) = c.sel(i, j) * (actions(i, j) - c.mu(i, j)) * std::exp(T(-2) * c.log_std(i, j)) * dlogp(i, j);
  }

  /// Accumulates ∂L/∂θ (residual net, gain) given dmu = ∂L/∂μ̂ (A × B).
  void backward(ResidualTrainCache<T>& c, const MatrixX<T>& dmu) {
    const MatrixX<T> dres = c.sel.cwiseProduct(dmu);  // ∂μ̂/∂μ_ψ = M
    res_.mean_net.backward(c.net, dres, res_.mean_net.grads());
    if (cfg_.gain == GainMode::Fixed) return;
    const MatrixX<T> dw = dres.cwiseProduct(c.base_mu);  // ∂μ̂/∂w = M ⊙ μ_base
    if (cfg_.gain == GainMode::Scalar) gain_.grads()[0] += dw.sum();
    else gain_.grads() += dw.rowwise().sum();
  }

  // ---- checkpoint sections ----------------------------------------------------------------

  /// Writes residual/* (and, with `with_base`, base/*: the frozen actor and, unless the
  /// identity, its action space base/actor/action_offset, base/actor/action_scale) sections.
  void save(Checkpoint& ck, bool with_base = true) const {
    ck.put("residual/params", res_.mean_net.params());
    ck.put("residual/log_std", res_.log_std.params());
    ck.put("residual/gain", gain_.params());
    put_norm(ck, "residual/norm", res_.normalizer);
    if (with_base) {
      ck.put("base/actor/params", base_.mean_net.params());
      ck.put("base/actor/log_std", base_.log_std.params());
      put_norm(ck, "base/actor/norm", base_.normalizer);
      base_.save_hidden_groups(ck, "base/actor/hidden_groups");  // (a base trained with mask.hidden_value = mean)
      if (actions_.offset.size()) ck.put("base/actor/action_offset", actions_.offset);
      if (actions_.scale.size()) ck.put("base/actor/action_scale", actions_.scale);
    }
  }
  /// Reads what `save` wrote (same sizes; throws naming the section otherwise). With `with_base`
  /// the action space is the checkpoint's: absent sections (identity bases, older checkpoints)
  /// give the identity.
  void load(const Checkpoint& ck, bool with_base = true) {
    ck.copy_to<T>("residual/params", res_.mean_net.params());
    ck.copy_to<T>("residual/log_std", res_.log_std.params());
    ck.copy_to<T>("residual/gain", gain_.params());
    get_norm(ck, "residual/norm", res_.normalizer);
    if (with_base) {
      ck.copy_to<T>("base/actor/params", base_.mean_net.params());
      ck.copy_to<T>("base/actor/log_std", base_.log_std.params());
      get_norm(ck, "base/actor/norm", base_.normalizer);
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
  static void put_norm(Checkpoint& ck, const std::string& n, const nn::RunningNormalizer<T>& z) {
    ck.put_double(n + "/count", z.count());
    ck.put(n + "/mean", z.mean());
    ck.put(n + "/m2", z.m2());
  }
  static void get_norm(const Checkpoint& ck, const std::string& n, nn::RunningNormalizer<T>& z) {
    z.set_state(ck.get_double(n + "/count"), ck.get_vector<double>(n + "/mean", z.dim()),
                ck.get_vector<double>(n + "/m2", z.dim()));
  }

  void selectors(std::span<const PartMask> masks, MatrixX<T>& sel) const {
    const Index A = action_dim(), B = static_cast<Index>(masks.size());
    sel.resize(A, B);
    for (Index j = 0; j < B; ++j)
      for (Index i = 0; i < A; ++i) {
        const PartMask moved = masks[static_cast<std::size_t>(j)] | cfg_.goal_parts;
        sel(i, j) = moved.has(dof_parts_[static_cast<std::size_t>(i)]) ? T(1) : T(0);
      }
  }

  /// μ̂ = μ_base on unmasked rows, w ⊙ μ_base + μ_ψ on masked rows (exact when w = 1, μ_ψ = 0).
  void compose(const Eigen::Ref<const MatrixX<T>>& base_mu, const MatrixX<T>& res_mu, const MatrixX<T>& sel,
               MatrixX<T>& mu) const {
    mu.resize(base_mu.rows(), base_mu.cols());
    for (Index j = 0; j < mu.cols(); ++j)
      for (Index i = 0; i < mu.rows(); ++i) {
        const T w = gain_.params()[cfg_.gain == GainMode::PerDof ? i : 0];
        mu(i, j) = sel(i, j) != T(0) ? w * base_mu(i, j) + res_mu(i, j) : base_mu(i, j);
      }
  }

  void composite_log_std(const MatrixX<T>& sel, MatrixX<T>& out) const {
    out.resize(sel.rows(), sel.cols());
    for (Index j = 0; j < sel.cols(); ++j)
      for (Index i = 0; i < sel.rows(); ++i)
        out(i, j) = sel(i, j) != T(0) ? res_.log_std.params()[i] : base_.log_std.params()[i];
  }

  rl::GaussianActor<T> base_;
  ResidualConfig cfg_;
  Index obs_dim_ = 0;
  std::vector<BodyPart> dof_parts_;
  tasks::ActionSpace actions_;  ///< the base's: PD target = offset + scale ⊙ â
  rl::GaussianActor<T> res_;
  nn::ParameterBlock<T> gain_;
};

}  // namespace maskadapt::adapt
