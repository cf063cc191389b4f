#pragma once
/// \file gradient_penalty.hpp
/// Gradient penalty on a scalar-output MLP, with its exact parameter gradient (double backprop).
///
/// For a network d = D(x) with scalar output (identity output activation) and a batch x
/// (inputs × B):
///
///     P = (w / B) · Σ_j ‖S ∂d_j/∂x_j‖²
///
/// where S selects the rows `[0, penalised_rows)` (e.g. the motion features, not the discrete
/// conditioning bits). The AMP discriminator applies it on real samples with w = 5.
///
/// Forward graph (layer l = 0 … L−1):  z_l = W_l a_{l−1} + b_l,  a_l = f_l(z_l),  a_{−1} = x.
/// Input gradient (the "backward" graph, with g_{L−1} = 1):
///     q_l = W_lᵀ g_l,   g_{l−1} = f'_{l−1}(z_{l−1}) ⊙ q_l,   ∂d/∂x = q_0.
/// Reverse mode through that graph, from q̄_0 = (2w/B)·S q_0:
///     ∂P/∂W_l += g_l q̄_lᵀ,   ḡ_l = W_l q̄_l,
///     z̄_l = f''_l(z_l) ⊙ q_{l+1} ⊙ ḡ_l,   q̄_{l+1} = f'_l(z_l) ⊙ ḡ_l          (l < L−1)
/// and then through the forward graph with the z̄_l injected at every layer:
///     δ_l = z̄_l + f'_l(z_l) ⊙ W_{l+1}ᵀ δ_{l+1},   ∂P/∂W_l += δ_l a_{l−1}ᵀ,   ∂P/∂b_l += Σ_j δ_l.
/// With piecewise-linear activations (ReLU, identity) f'' = 0 almost everywhere, so every z̄_l and
/// δ_l is exactly zero: that last pass adds nothing and is skipped (a third of the penalty's GEMMs).
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/core/thread_pool.hpp>
#include <maskadapt/nn/activation.hpp>
#include <maskadapt/nn/chunks.hpp>
#include <maskadapt/nn/mlp.hpp>

#include <type_traits>
#include <vector>

namespace maskadapt::rl {

/// Scratch for gradient_penalty (reused between calls).
template <class T>
struct GradientPenaltyWorkspace {
  std::vector<MatrixX<T>> g, q, qbar, zbar;  // per layer
  std::vector<MatrixX<T>> fp, fpp, gbar, delta;  // per layer: f'(z_l), f''(z_l), ḡ_l, δ_l (each keeps its shape)
};

/// True when f'' = 0 wherever it is defined (the penalty's z̄ terms vanish).
inline bool has_zero_second_derivative(nn::Activation a) {
  return a == nn::Activation::ReLU || a == nn::Activation::Identity;
}

/// Computes P for the forward pass recorded in `cache` (filled by net.forward_train on x) and
/// ADDS ∂P/∂θ into `grad` (num_params, layout of net.params()). Returns P.
/// Also returns, via `input_grad_sq` if non-null, the mean ‖S ∂d/∂x‖² (for logging).
/// `columns` ≥ 0 penalises only the first `columns` samples of the cached batch (a pass that ran
/// real and fake samples together, real first); −1: all of them.
template <class T>
double gradient_penalty(const nn::Mlp<T>& net, const nn::TrainCache<T>& cache, Index penalised_rows, double weight,
                        std::type_identity_t<Eigen::Ref<VectorX<T>>> grad, GradientPenaltyWorkspace<T>& w,
                        double* input_grad_sq = nullptr, Index columns = -1) {
  const auto& spec = net.spec();
  require(net.outputs() == 1 && spec.output_activation == nn::Activation::Identity,
          "the gradient penalty needs a scalar logit with identity output activation", {{}, {}, "gradient_penalty"});
  require(static_cast<Index>(cache.pre.size()) == net.num_layers() && cache.input.rows() == net.inputs(),
          "cache was not filled by forward_train of this network", {{}, {}, "gradient_penalty.cache"});
  require(penalised_rows >= 0 && penalised_rows <= net.inputs(), "penalised_rows out of range",
          {{}, {}, "gradient_penalty.penalised_rows"});
  require(grad.size() == net.num_params(), "grad has the wrong size", {{}, {}, "gradient_penalty.grad"});
  require(columns >= -1 && columns <= cache.batch() && columns != 0, "columns must be in [1, batch] or -1",
          {{}, {}, "gradient_penalty.columns"});
  const Index L = net.num_layers(), B = columns < 0 ? cache.batch() : columns;
  const auto act = [&](Index l) { return spec.layer_activation(l); };
  const auto pre = [&](Index l) { return cache.pre[static_cast<std::size_t>(l)].leftCols(B); };
  bool piecewise_linear = true;
  for (Index l = 0; l + 1 < L; ++l) piecewise_linear = piecewise_linear && has_zero_second_derivative(act(l));
  const auto Lz = static_cast<std::size_t>(L);
  for (auto* v : {&w.g, &w.q, &w.qbar, &w.zbar, &w.fp, &w.fpp, &w.gbar, &w.delta}) v->resize(Lz);

  // The products run in the Mlp's fixed chunks (nn/chunks.hpp) on the cache's pool, each with its
  // element-wise epilogue: bit-identical for any pool size, including none.
  ThreadPool* pool = cache.pool ? cache.pool : nn::default_pool();

  // Input gradient: g_{L−1} = 1; q_l = W_lᵀ g_l; g_{l−1} = f'(z_{l−1}) ⊙ q_l (f'_l kept in fp[l]).
  w.g[Lz - 1].setOnes(1, B);
  for (Index l = L - 1; l >= 0; --l) {
    const auto i = static_cast<std::size_t>(l);
    const Index out = spec.layer_outputs(l), in = spec.layer_inputs(l);
    w.q[i].resize(in, B);
    if (l > 0) {
      w.fp[i - 1].resize(in, B);
      w.g[i - 1].resize(in, B);
    }
    const auto W = net.weight(l);
    nn::for_each_block(pool, in, B, nn::worth_chunking(in, out, B), [&](Index r0, Index nr, Index c0, Index nc) {
      auto q = w.q[i].block(r0, c0, nr, nc);
      q.noalias() = W.middleCols(r0, nr).transpose() * w.g[i].middleCols(c0, nc);
      if (l == 0) return;
      auto fp = w.fp[i - 1].block(r0, c0, nr, nc);
      nn::activation_derivative<T>(act(l - 1), pre(l - 1).block(r0, c0, nr, nc), fp);
      w.g[i - 1].block(r0, c0, nr, nc) = fp.cwiseProduct(q);
    });
  }
  const auto u = w.q[0].topRows(penalised_rows);  // S ∂d/∂x (penalised_rows × B)
  const double sq = static_cast<double>(u.squaredNorm());
  if (input_grad_sq) *input_grad_sq = sq / static_cast<double>(B);
  const double P = weight * sq / static_cast<double>(B);
  if (weight == 0) return 0.0;

  // Reverse through the input-gradient graph.
  w.qbar[0].setZero(net.inputs(), B);
  w.qbar[0].topRows(penalised_rows) = static_cast<T>(2.0 * weight / static_cast<double>(B)) * u;
  for (Index l = 0; l < L; ++l) {
    const auto i = static_cast<std::size_t>(l);
    const Index out = spec.layer_outputs(l), in = spec.layer_inputs(l);
    const bool split = nn::worth_chunking(out, in, B);  // both products below are out·in·B
    Eigen::Map<MatrixX<T>> gW(grad.data() + net.weight_offset(l), out, in);
    nn::for_each_block(pool, out, in, split, [&](Index r0, Index nr, Index c0, Index nc) {
      gW.block(r0, c0, nr, nc).noalias() += w.g[i].middleRows(r0, nr) * w.qbar[i].middleRows(c0, nc).transpose();
    }, /*rows_on_tie=*/true);
    if (l == L - 1) {
      if (!piecewise_linear) w.zbar[i].setZero(out, B);  // f'' of the identity output is 0
      break;  // (ḡ of the output layer feeds nothing)
    }
    // ḡ_l = W_l q̄_l (out_l × B), then q̄_{l+1} = f'_l(z_l) ⊙ ḡ_l (and z̄_l) block by block
    w.gbar[i].resize(out, B);
    w.qbar[i + 1].resize(out, B);
    if (!piecewise_linear) {
      w.fpp[i].resize(out, B);
      w.zbar[i].resize(out, B);
    }
    const auto W = net.weight(l);
    nn::for_each_block(pool, out, B, split, [&](Index r0, Index nr, Index c0, Index nc) {
      auto gbar = w.gbar[i].block(r0, c0, nr, nc);
      gbar.noalias() = W.middleRows(r0, nr) * w.qbar[i].middleCols(c0, nc);
      if (!piecewise_linear) {
        auto fpp = w.fpp[i].block(r0, c0, nr, nc);
        nn::activation_second_derivative<T>(act(l), pre(l).block(r0, c0, nr, nc), fpp);
        w.zbar[i].block(r0, c0, nr, nc) = fpp.cwiseProduct(w.q[i + 1].block(r0, c0, nr, nc)).cwiseProduct(gbar);
      }
      w.qbar[i + 1].block(r0, c0, nr, nc) = w.fp[i].block(r0, c0, nr, nc).cwiseProduct(gbar);
    });
  }
  if (piecewise_linear) return P;  // every z̄_l is 0, so is every δ_l
  // Reverse through the forward graph with z̄ injected at every layer.
  for (Index l = L - 1; l >= 0; --l) {
    const auto i = static_cast<std::size_t>(l);
    if (l == L - 1) {
      w.delta[i] = w.zbar[i];
    } else {
      w.gbar[i].noalias() = net.weight(l + 1).transpose() * w.delta[i + 1];  // (reused as scratch)
      w.delta[i] = w.zbar[i] + w.fp[i].cwiseProduct(w.gbar[i]);
    }
    Eigen::Map<MatrixX<T>> gW(grad.data() + net.weight_offset(l), spec.layer_outputs(l), spec.layer_inputs(l));
    Eigen::Map<VectorX<T>> gb(grad.data() + net.bias_offset(l), spec.layer_outputs(l));
    gW.noalias() += w.delta[i] * cache.layer_input(l).leftCols(B).transpose();
    gb += w.delta[i].rowwise().sum();
  }
  return P;
}

}  // namespace maskadapt::rl
