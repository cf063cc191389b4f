#pragma once
/// \file discriminator.hpp
/// The AMP discriminator D(x | c), its update, its style reward, and a weighted list of them.
///
/// Input: x = a window of 5 consecutive frames of *unmasked* features, concatenated
/// (feature_dim rows), normalised by a running normaliser; optionally a conditioning vector c
/// (cond_dim rows, e.g. the 5 part-mask bits: then this is the mask-conditioned D(s, s' | m) of
/// stage 2), appended un-normalised. The network outputs one logit d.
///
/// One update on real (motion data) and fake (agent + replayed agent) batches minimises
///     L = L_obj(d_real, d_fake)                    BCE or LSGAN, see amp_loss.hpp
///       + w_gp · mean_real ‖∂d/∂x_norm‖²           gradient penalty on real samples (features only)
///       + w_logit · ‖W_out‖²                       logit regularisation (output layer weights)
///       + w_wd · Σ_l ‖W_l‖²                        weight decay (all weight matrices, not biases)
/// with one Adam step (non-finite guard: a NaN/inf loss or gradient skips the step).
/// Reward: BCE r = −log(max(1 − σ(d), 1e−4)); LSGAN r = max(0, 1 − ¼(d − 1)²); times reward_scale.
///
/// A CML-style baseline is a DiscriminatorSet: one discriminator per body-part group, each
/// producing one reward row (one PPO objective) with its own weight.
#include <maskadapt/core/collective.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/nn/adam.hpp>
#include <maskadapt/nn/mlp.hpp>
#include <maskadapt/nn/normalizer.hpp>
#include <maskadapt/rl/amp_loss.hpp>
#include <maskadapt/rl/gradient_penalty.hpp>
#include <maskadapt/rl/replay_buffer.hpp>

#include <cmath>
#include <string>
#include <vector>

namespace maskadapt::rl {

struct DiscriminatorConfig {
  Index feature_dim = 0;   ///< rows of a window (5 × per-frame AMP features)
  Index cond_dim = 0;      ///< conditioning rows (0: unconditional; 5: part mask bits)
  std::vector<Index> hidden{1024, 1024, 512};  ///< paper preset; cpu preset e.g. {256, 256}
  nn::Activation activation = nn::Activation::ReLU;
  DiscriminatorLoss loss = DiscriminatorLoss::BCE;
  double grad_penalty = 5.0;    ///< w_gp (paper 5)
  double logit_reg = 0.05;      ///< w_logit (AMP/ASE humanoid setting 0.05)
  double weight_decay = 1e-4;   ///< w_wd (AMP/ASE setting 1e−4)
  double lr = 1e-4;             ///< paper 1e−4
  double max_grad_norm = 1.0;   ///< global gradient clipping; ≤ 0 disables
  double reward_scale = 1.0;    ///< multiplies the style reward
  bool normalize_inputs = true;
  double normalizer_clip = 5.0;

  void validate() const {
    require(feature_dim > 0, "must be positive", {{}, {}, "DiscriminatorConfig.feature_dim"});
    require(cond_dim >= 0, "must be >= 0", {{}, {}, "DiscriminatorConfig.cond_dim"});
    require(grad_penalty >= 0 && logit_reg >= 0 && weight_decay >= 0, "regularisation weights must be >= 0",
            {{}, {}, "DiscriminatorConfig"});
  }
};

/// Statistics of one update.
struct DiscriminatorStats {
  double loss = 0;           ///< total L
  double objective = 0;      ///< L_obj
  double grad_penalty = 0;   ///< w_gp · mean ‖∂d/∂x‖²
  double logit_reg = 0;      ///< w_logit · ‖W_out‖²
  double weight_decay = 0;   ///< w_wd · Σ‖W‖²
  double real_mean = 0;      ///< mean D (BCE: probability) on real
  double fake_mean = 0;      ///< mean D on fake
  double accuracy = 0;       ///< fraction classified correctly
  double grad_norm = 0;      ///< pre-clip gradient norm
  bool skipped = false;      ///< true: a loss/gradient was non-finite; parameters unchanged
};

template <class T = float>
class Discriminator {
 public:
  Discriminator() = default;
  Discriminator(const DiscriminatorConfig& c, Rng& rng)
      : config_((c.validate(), c)),
        net_(nn::MlpSpec{c.feature_dim + c.cond_dim, c.hidden, 1, c.activation}, rng),
        normalizer_(c.feature_dim, c.normalizer_clip),
        opt_(nn::AdamConfig{.lr = c.lr, .max_grad_norm = c.max_grad_norm}) {}

  const DiscriminatorConfig& config() const { return config_; }
  nn::Mlp<T>& net() { return net_; }
  const nn::Mlp<T>& net() const { return net_; }
  nn::RunningNormalizer<T>& normalizer() { return normalizer_; }
  const nn::RunningNormalizer<T>& normalizer() const { return normalizer_; }
  nn::Adam<T>& optimizer() { return opt_; }

  /// Network input [norm(features) ; cond] ((feature_dim + cond_dim) × B) into `out`.
  void make_input(const Eigen::Ref<const MatrixX<T>>& features, const Eigen::Ref<const MatrixX<T>>& cond,
                  MatrixX<T>& out) const {
    out.resize(config_.feature_dim + config_.cond_dim, features.cols());
    fill_input(features, cond, out);
  }
  /// make_input into columns of a larger matrix (`out` is ((feature_dim + cond_dim) × B)).
  void fill_input(const Eigen::Ref<const MatrixX<T>>& features, const Eigen::Ref<const MatrixX<T>>& cond,
                  Eigen::Ref<MatrixX<T>> out) const {
    require(features.rows() == config_.feature_dim, "expected " + std::to_string(config_.feature_dim) +
                                                        " feature rows, got " + std::to_string(features.rows()),
            {{}, {}, "Discriminator.features"});
    require(cond.rows() == config_.cond_dim && (config_.cond_dim == 0 || cond.cols() == features.cols()),
            "conditioning must be (" + std::to_string(config_.cond_dim) + " × batch)", {{}, {}, "Discriminator.cond"});
    require(out.rows() == config_.feature_dim + config_.cond_dim && out.cols() == features.cols(),
            "input block has the wrong shape", {{}, {}, "Discriminator.input"});
    if (config_.normalize_inputs) normalizer_.normalize(features, out.topRows(config_.feature_dim));
    else out.topRows(config_.feature_dim) = features;
    if (config_.cond_dim > 0) out.bottomRows(config_.cond_dim) = cond;
  }

  /// Logits d (1 × B). `cond` is (cond_dim × B); pass an empty matrix when cond_dim = 0.
  RowVectorX<T> logits(const Eigen::Ref<const MatrixX<T>>& features, const Eigen::Ref<const MatrixX<T>>& cond = MatrixX<T>()) const {
    MatrixX<T> in;
    make_input(features, cond, in);
    RowVectorX<T> d(features.cols());
    nn::InferenceWorkspace<T> ws;
    net_.forward(in, d, ws);
    return d;
  }

  /// Style reward (1 × B), see file comment.
  RowVectorX<T> reward(const Eigen::Ref<const MatrixX<T>>& features, const Eigen::Ref<const MatrixX<T>>& cond = MatrixX<T>()) const {
    RowVectorX<T> r(features.cols());
    RewardWorkspace ws;
    reward(features, cond, r, ws);
    return r;
  }

  /// Buffers of the allocation-free reward (sized on first use, reused).
  struct RewardWorkspace {
    MatrixX<T> input;
    RowVectorX<T> logits;
    nn::InferenceWorkspace<T> net;
  };
  /// The style reward into `out` (1 × B, resized), allocating nothing once `ws` has seen the
  /// batch size: the same numbers as reward().
  void reward(const Eigen::Ref<const MatrixX<T>>& features, const Eigen::Ref<const MatrixX<T>>& cond,
              Eigen::Ref<RowVectorX<T>, 0, Eigen::InnerStride<>> out, RewardWorkspace& ws) const {
    require(out.cols() == features.cols(), "reward output must be (1 × batch)", {{}, {}, "Discriminator.reward"});
    make_input(features, cond, ws.input);
    ws.logits.resize(features.cols());
    net_.forward(ws.input, ws.logits, ws.net);
    const T scale = static_cast<T>(config_.reward_scale);
    for (Index i = 0; i < out.cols(); ++i)
      out(i) = amp_reward_of_logit<T>(config_.loss, static_cast<double>(ws.logits(i))) * scale;
  }

  /// Adds real and agent windows to the input normaliser (call when new data arrives).
  void update_normalizer(const Eigen::Ref<const MatrixX<T>>& features) {
    if (config_.normalize_inputs) normalizer_.update(features);
  }

  /// One optimisation step on a real batch and a fake batch (agent + replay, + negative
  /// expert samples if any). Conditioning matrices are (cond_dim × B) or empty.
  DiscriminatorStats update(const Eigen::Ref<const MatrixX<T>>& real, const Eigen::Ref<const MatrixX<T>>& real_cond,
                            const Eigen::Ref<const MatrixX<T>>& fake, const Eigen::Ref<const MatrixX<T>>& fake_cond) {
    DiscriminatorStats st;
    // real and fake samples go through the network as one batch [real | fake]: one forward and
    // one backward pass (wider GEMMs, the weights packed once), the penalty on the real columns
    const Index nr = real.cols(), nf = fake.cols();
    in_both_.resize(config_.feature_dim + config_.cond_dim, nr + nf);
    fill_input(real, real_cond, in_both_.leftCols(nr));
    fill_input(fake, fake_cond, in_both_.rightCols(nf));
    net_.zero_grad();
    auto grad = net_.grads();
    const MatrixX<T>& d = net_.forward_train(in_both_, cache_);
    const AmpObjective obj = amp_objective<T>(config_.loss, d.leftCols(nr), d.rightCols(nf), g_real_, g_fake_);
    g_both_.resize(1, nr + nf);
    g_both_.leftCols(nr) = g_real_;
    g_both_.rightCols(nf) = g_fake_;
    net_.backward(cache_, g_both_, grad);
    st.objective = obj.loss;
    st.real_mean = obj.real_mean;
    st.fake_mean = obj.fake_mean;
    st.accuracy = obj.accuracy;
    if (config_.grad_penalty > 0)
      st.grad_penalty =
          gradient_penalty<T>(net_, cache_, config_.feature_dim, config_.grad_penalty, grad, gp_ws_, nullptr, nr);
    const Index L = net_.num_layers();
    if (config_.logit_reg > 0) {
      st.logit_reg = config_.logit_reg * static_cast<double>(net_.weight(L - 1).squaredNorm());
      net_.weight_grad(L - 1) += static_cast<T>(2 * config_.logit_reg) * net_.weight(L - 1);
    }
    if (config_.weight_decay > 0) {
      for (Index l = 0; l < L; ++l) {
        st.weight_decay += config_.weight_decay * static_cast<double>(net_.weight(l).squaredNorm());
        net_.weight_grad(l) += static_cast<T>(2 * config_.weight_decay) * net_.weight(l);
      }
    }
    st.loss = st.objective + st.grad_penalty + st.logit_reg + st.weight_decay;
    if (!std::isfinite(st.loss) || !net_.grads().allFinite()) {
      st.skipped = true;
      return st;
    }
    const auto r = opt_.step(net_.block());
    st.grad_norm = r.grad_norm;
    st.skipped = !r.applied;
    return st;
  }

  /// update() on K ranks that all hold the same batch (real: feature_dim × B_r, fake:
  /// feature_dim × B_f, B_r, B_f ≥ K; conditioned: with their cond_dim rows of each): rank r back-propagates its slices of it —
  /// columns [B·r/K, B·(r+1)/K) of each — with the objective's and the gradient penalty's
  /// gradients scaled by the slices' shares of the batch, the ranks' gradients are summed over
  /// `comm` (rank order), and then every rank adds the same regularisers and takes the same
  /// Adam step. The statistics are those of the whole batch. The discriminator's parameters,
  /// normaliser and optimiser must be equal on every rank (they stay so).
  DiscriminatorStats update_on_ranks(const Eigen::Ref<const MatrixX<T>>& real, const Eigen::Ref<const MatrixX<T>>& fake,
                                     Collective& comm) {
    require(config_.cond_dim == 0, "this discriminator is conditioned: pass the conditioning of both batches",
            {{}, {}, "Discriminator.cond"});
    const MatrixX<T> no_cond;
    return update_on_ranks(real, no_cond, fake, no_cond, comm);
  }
  /// The same with conditioning (cond_dim × B_r and cond_dim × B_f, or empty when cond_dim = 0).
  DiscriminatorStats update_on_ranks(const Eigen::Ref<const MatrixX<T>>& real, const Eigen::Ref<const MatrixX<T>>& real_cond,
                                     const Eigen::Ref<const MatrixX<T>>& fake, const Eigen::Ref<const MatrixX<T>>& fake_cond,
                                     Collective& comm) {
    const Index K = comm.size(), r = comm.rank(), NR = real.cols(), NF = fake.cols();
    require(NR >= K && NF >= K, "each rank needs at least one real and one fake sample of the batch",
            {{}, {}, "Discriminator.batch"});
    const Index r0 = NR * r / K, nr = NR * (r + 1) / K - r0, f0 = NF * r / K, nf = NF * (r + 1) / K - f0;
    const double share_r = static_cast<double>(nr) / static_cast<double>(NR);
    const double share_f = static_cast<double>(nf) / static_cast<double>(NF);
    DiscriminatorStats st;
    in_both_.resize(config_.feature_dim + config_.cond_dim, nr + nf);
    if (config_.cond_dim > 0) {
      require(real_cond.cols() == NR && fake_cond.cols() == NF, "conditioning must have a column per sample",
              {{}, {}, "Discriminator.cond"});
      fill_input(real.middleCols(r0, nr), real_cond.middleCols(r0, nr), in_both_.leftCols(nr));
      fill_input(fake.middleCols(f0, nf), fake_cond.middleCols(f0, nf), in_both_.rightCols(nf));
    } else {
      const MatrixX<T> no_cond;
      fill_input(real.middleCols(r0, nr), no_cond, in_both_.leftCols(nr));
      fill_input(fake.middleCols(f0, nf), no_cond, in_both_.rightCols(nf));
    }
    net_.zero_grad();
    auto grad = net_.grads();
    const MatrixX<T>& d = net_.forward_train(in_both_, cache_);
    const AmpObjective obj = amp_objective<T>(config_.loss, d.leftCols(nr), d.rightCols(nf), g_real_, g_fake_);
    g_both_.resize(1, nr + nf);
    g_both_.leftCols(nr) = g_real_ * static_cast<T>(share_r);
    g_both_.rightCols(nf) = g_fake_ * static_cast<T>(share_f);
    net_.backward(cache_, g_both_, grad);
    double gp = 0;
    if (config_.grad_penalty > 0)
      gp = gradient_penalty<T>(net_, cache_, config_.feature_dim, config_.grad_penalty * share_r, grad, gp_ws_, nullptr, nr);
    comm.all_reduce_sum(std::span<T>(grad.data(), static_cast<std::size_t>(grad.size())));
    // (the objective's halves are means over real and fake; the batch halves are equal in the
    // trainer, so the share-weighted sum of the ranks' objectives is the batch's)
    double sums[5] = {obj.loss * share_r, obj.real_mean * share_r, obj.fake_mean * share_f, obj.accuracy * share_r, gp};
    comm.all_reduce_sum(std::span<double>(sums, 5));
    st.objective = sums[0];
    st.real_mean = sums[1];
    st.fake_mean = sums[2];
    st.accuracy = sums[3];
    st.grad_penalty = sums[4];
    const Index L = net_.num_layers();
    if (config_.logit_reg > 0) {
      st.logit_reg = config_.logit_reg * static_cast<double>(net_.weight(L - 1).squaredNorm());
      net_.weight_grad(L - 1) += static_cast<T>(2 * config_.logit_reg) * net_.weight(L - 1);
    }
    if (config_.weight_decay > 0) {
      for (Index l = 0; l < L; ++l) {
        st.weight_decay += config_.weight_decay * static_cast<double>(net_.weight(l).squaredNorm());
        net_.weight_grad(l) += static_cast<T>(2 * config_.weight_decay) * net_.weight(l);
      }
    }
    st.loss = st.objective + st.grad_penalty + st.logit_reg + st.weight_decay;
    if (!std::isfinite(st.loss) || !net_.grads().allFinite()) {  // (the same on every rank: the sums are)
      st.skipped = true;
      return st;
    }
    const auto res = opt_.step(net_.block());
    st.grad_norm = res.grad_norm;
    st.skipped = !res.applied;
    return st;
  }

 private:
  DiscriminatorConfig config_;
  nn::Mlp<T> net_;
  nn::RunningNormalizer<T> normalizer_;
  nn::Adam<T> opt_;
  MatrixX<T> in_both_, g_both_;  ///< [real | fake] network input and ∂L_obj/∂d
  RowVectorX<T> g_real_, g_fake_;
  nn::TrainCache<T> cache_;
  GradientPenaltyWorkspace<T> gp_ws_;
};

/// Builds the fake batch of one discriminator step: `agent` windows (dim × n) plus, when the
/// replay buffer holds data, `num_replay` windows drawn from it; then pushes `agent` into the
/// replay buffer (so a batch never replays itself). out: (dim × (n + drawn)).
template <class T>
void mix_with_replay(const Eigen::Ref<const MatrixX<T>>& agent, ReplayBuffer<T>& replay, Index num_replay, Rng& rng,
                     MatrixX<T>& out) {
  MatrixX<T> old;
  const Index m = replay.empty() ? 0 : num_replay;
  if (m > 0) replay.sample(m, rng, old);
  out.resize(agent.rows(), agent.cols() + m);
  out.leftCols(agent.cols()) = agent;
  if (m > 0) out.rightCols(m) = old;
  replay.push(agent);
}

/// A weighted list of discriminators (e.g. one per body-part group for the CML-style baseline).
/// Member k produces reward row k; `weights` become PPO's objective weights.
template <class T = float>
struct DiscriminatorSet {
  std::vector<std::string> names;
  std::vector<Discriminator<T>> members;
  std::vector<double> weights;

  void add(std::string name, Discriminator<T> d, double weight) {
    require(std::isfinite(weight) && weight >= 0, "weight must be finite and >= 0", {{}, {}, "DiscriminatorSet." + name});
    names.push_back(std::move(name));
    members.push_back(std::move(d));
    weights.push_back(weight);
  }
  Index size() const { return static_cast<Index>(members.size()); }

  /// Rewards (size() × B): row k = members[k].reward(features[k], conds[k]). `conds` may be
  /// empty (no member is conditioned).
  MatrixX<T> rewards(const std::vector<MatrixX<T>>& features, const std::vector<MatrixX<T>>& conds = {}) const {
    require(static_cast<Index>(features.size()) == size() && (conds.empty() || conds.size() == features.size()),
            "need one feature matrix (and one conditioning matrix) per discriminator", {{}, {}, "DiscriminatorSet.rewards"});
    require(size() > 0, "empty discriminator set", {{}, {}, "DiscriminatorSet"});
    const Index B = features[0].cols();
    MatrixX<T> r(size(), B);
    for (Index k = 0; k < size(); ++k) {
      const auto i = static_cast<std::size_t>(k);
      require(features[i].cols() == B, "all members must score the same batch", {{}, {}, "DiscriminatorSet.rewards"});
      r.row(k) = conds.empty() ? members[i].reward(features[i]) : members[i].reward(features[i], conds[i]);
    }
    return r;
  }
  /// Σ_k weights[k] · rewards.row(k) (1 × B), for single-objective use.
  RowVectorX<T> weighted_reward(const MatrixX<T>& rewards) const {
    require(rewards.rows() == size(), "rewards must have one row per discriminator", {{}, {}, "DiscriminatorSet"});
    RowVectorX<T> out = RowVectorX<T>::Zero(rewards.cols());
    for (Index k = 0; k < size(); ++k) out += static_cast<T>(weights[static_cast<std::size_t>(k)]) * rewards.row(k);
    return out;
  }
};

}  // namespace maskadapt::rl
