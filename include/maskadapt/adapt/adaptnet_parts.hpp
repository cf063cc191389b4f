#pragma once
/// \file adaptnet_parts.hpp
/// Building blocks of the AdaptNet baseline (adaptnet_policy.hpp): its configuration, the
/// trainable modules, the inference workspace and training cache, and the one frozen-layer
/// product that reproduces nn::Mlp's inference arithmetic bit for bit.
///
/// Paper: Xu, Xie, Karamouzas, "AdaptNet: Policy Adaptation for Physics-Based Character
/// Control" (SIGGRAPH Asia 2023), Sections 4 (latent space injection, LSA) and 5 (internal
/// adaptation, IA).
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/nn/chunks.hpp>
#include <maskadapt/nn/gemv.hpp>
#include <maskadapt/nn/mlp.hpp>
#include <maskadapt/nn/normalizer.hpp>
#include <maskadapt/nn/parameter_block.hpp>

#include <string>
#include <vector>

namespace maskadapt::adapt {

struct AdaptNetConfig {
  Index goal_dim = 0;  ///< rows of the new task's control input c (goal features); 0: none
  /// G_φ (Eq. 5, "an optional module to process the additional control input c_t"): hidden
  /// widths of an MLP on the normalised goal, activation after every layer. Empty: identity.
  std::vector<Index> goal_hidden{};
  /// F_φ (Eq. 5, "a fully-connected layer or a stack of multiple fully-connected layers"):
  /// hidden widths before its zero-initialised output layer. Empty: one FC layer.
  std::vector<Index> embed_hidden{};
  /// IA (Sec. 5, Eq. 7): a zero-initialised branch ΔW_i, Δb_i on every base layer between two
  /// latent spaces Z^{i-1} → Z^i (base layers 1 … L−2; Z^i lie "before the final action layer").
  bool internal_adaptation = true;
  bool adapt_action_layer = false;  ///< also adapt the action layer L−1 (not the paper's; off)
  /// 0: full-rank ΔW (the paper's IA, "a full-rank adaptation"). r > 0: LoRA ΔW = B·A with
  /// B (out × r) = 0, A (r × in) ~ U(±1/√in) (the paper's Sec. 9.3 LoRA-8 / LoRA-64 ablation).
  Index ia_rank = 0;
  bool learn_log_std = true;      ///< log σ trainable (initialised to the base's)
  bool normalize_inputs = true;   ///< running normaliser on the goal rows of x
  double normalizer_clip = 5.0;
};

/// Trainable modules φ, η, log σ and the input normaliser (what ResidualPolicy::residual() is to
/// the residual trainer: `.normalizer` is updated on x, `.log_std` read for the entropy).
template <class T>
struct AdaptNetModules {
  nn::Mlp<T> encoder;   ///< E_φ: copy of the base's layer 0, (obs_dim + 5) → h0, f after
  nn::Mlp<T> goal_net;  ///< G_φ: goal_dim → goal_hidden.back() (default-constructed when absent)
  nn::Mlp<T> embed;     ///< F_φ: (h0 + goal features) → h0; last layer zero at init
  nn::ParameterBlock<T> ia;       ///< η: per adapted layer [ΔW | Δb] (full) or [B | A | Δb] (LoRA)
  nn::ParameterBlock<T> log_std;  ///< (action_dim)
  nn::RunningNormalizer<T> normalizer;  ///< over x = [s ; c] (input_dim); only the c rows are used
};

/// Where base layer `layer`'s adaptor lives inside AdaptNetModules::ia.
struct AdaptNetIaSlot {
  Index layer = 0, out = 0, in = 0, rank = 0;  ///< rank 0: full ΔW
  Index w = 0;  ///< ΔW (out × in) or B (out × r)
  Index a = 0;  ///< A (r × in) (LoRA only)
  Index b = 0;  ///< Δb (out)
  Index size() const { return (rank == 0 ? out * in : rank * (out + in)) + out; }
};

/// Inference scratch (one per thread); nothing allocates once sized for a batch.
template <class T>
struct AdaptNetWorkspace {
  MatrixX<T> base_in, norm_in, norm_x, enc, gfeat, u, inj;
  std::vector<MatrixX<T>> pre, post, lora;  ///< per base layer (out_l × B); lora (r × B)
  nn::InferenceWorkspace<T> enc_ws, goal_ws, embed_ws;
};

/// Training cache for forward_train / log_prob_mean_grad / backward.
template <class T>
struct AdaptNetTrainCache {
  MatrixX<T> base_in, norm_in, norm_x, u, mu, dz, dz_prev, delta, tmp, du, dinj;
  std::vector<MatrixX<T>> pre, post, lora;  ///< base layers: z_l pre-activations, z^l outputs (post[0] = z^0 after injection)
  VectorX<T> log_std;   ///< (A) log σ used by this pass
  VectorX<T> dlog_std;  ///< (A) ∂L/∂log σ recorded by log_prob_mean_grad, added by backward
  nn::TrainCache<T> enc, goal, embed;
  /// I_φ(s, c) (h0 × B): F_φ's output.
  const MatrixX<T>& injection() const { return embed.output(); }
};

namespace detail {
/// P (out × B) = W·X + b, computed exactly as nn::Mlp's inference layer (gemv for one sample,
/// the same fixed chunks otherwise, bias added per element), so a frozen base layer run here
/// gives the base's own numbers bit for bit; X (in × B).
template <class T, class W, class Bv>
void frozen_affine(const W& w, const Bv& b, const MatrixX<T>& x, MatrixX<T>& p) {
  const Index out = w.rows(), in = w.cols(), B = x.cols();
  p.resize(out, B);
  ThreadPool* pool = nn::default_pool();
  if (B == 1) {
    const bool split = pool != nullptr && double(out) * double(in) * sizeof(T) >= nn::kMinSplitGemvBytes;
    nn::for_each_chunk(pool, out, split, [&](Index lo, Index hi) {
      nn::gemv_colmajor<T>(hi - lo, in, w.data() + lo, w.outerStride(), x.data(), p.data() + lo);
    });
    p.col(0) += b;
    return;
  }
  nn::for_each_block(pool, out, B, nn::worth_chunking(out, in, B), [&](Index r0, Index nr, Index c0, Index nc) {
    auto z = p.block(r0, c0, nr, nc);
    z.noalias() = w.middleRows(r0, nr) * x.middleCols(c0, nc);
    z.colwise() += b.segment(r0, nr);
  });
}

/// A running normaliser as the sections n/count, n/mean, n/m2 (ResidualPolicy's layout).
template <class T>
void put_norm(Checkpoint& ck, const std::string& n, const nn::RunningNormalizer<T>& z) {
  ck.put_double(n + "/count", z.count());
  ck.put(n + "/mean", z.mean());
  ck.put(n + "/m2", z.m2());
}
template <class T>
void get_norm(const Checkpoint& ck, const std::string& n, nn::RunningNormalizer<T>& z) {
  z.set_state(ck.get_double(n + "/count"), ck.get_vector<double>(n + "/mean", z.dim()),
              ck.get_vector<double>(n + "/m2", z.dim()));
}
}  // namespace detail

}  // namespace maskadapt::adapt
