#pragma once
/// \file kl.hpp
/// KL(p ‖ q) between diagonal Gaussians, batched, with gradients with respect to both sides.
///
/// p = N(μp, σp²), q = N(μq, σq²), σ = exp(log_std). Means are (d × B); each log-std is (d × 1)
/// (broadcast over the batch) or (d × B). Per sample j (sum over dimensions i):
///
///     KL_j = Σ_i [ logσq − logσp + (σp² + (μp − μq)²) / (2σq²) − ½ ]
///
///     ∂KL/∂μp    =  (μp − μq)/σq²          ∂KL/∂μq    = −(μp − μq)/σq²
///     ∂KL/∂logσp =  σp²/σq² − 1            ∂KL/∂logσq =  1 − (σp² + (μp − μq)²)/σq²
///
/// The mask-invariant loss uses p = π(·|s, m⁰) as a fixed target (stop-gradient) and
/// q = π(·|s̄, m) as the learner: pass `stop_gradient_p = true` (or null p-outputs).
#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Core>

#include "maskadapt/core/error.hpp"
#include "maskadapt/core/types.hpp"
#include "maskadapt/nn/gaussian.hpp"

namespace maskadapt::nn {

/// Where kl backward passes ADD their gradients. Null members are skipped. A non-null member
/// that is empty is resized (to the shape of the matching input) and zeroed; otherwise its shape
/// must equal that input's shape ((d × 1) log-std gradients are summed over the batch).
template <class T>
struct KlGrads {
  MatrixX<T>* mean_p = nullptr;
  MatrixX<T>* log_std_p = nullptr;
  MatrixX<T>* mean_q = nullptr;
  MatrixX<T>* log_std_q = nullptr;
};

struct KlOptions {
  bool stop_gradient_p = false;  ///< true: p is a constant target; its gradient outputs are not touched
  double weight = 1.0;           ///< gradients are of weight · (returned loss)
};

namespace detail {
template <class T>
void check_kl(const Eigen::Ref<const MatrixX<T>>& mean_p, const Eigen::Ref<const MatrixX<T>>& log_std_p,
              const Eigen::Ref<const MatrixX<T>>& mean_q, const Eigen::Ref<const MatrixX<T>>& log_std_q,
              const char* where) {
  check_same_shape<T>(mean_q, mean_p.rows(), mean_p.cols(), std::string(where) + ".mean_q");
  check_gaussian_shapes<T>(mean_p, log_std_p, where);
  check_gaussian_shapes<T>(mean_q, log_std_q, where);
}
template <class T>
void prepare_grad(MatrixX<T>* g, const Eigen::Ref<const MatrixX<T>>& like, const char* field) {
  if (g == nullptr) return;
  if (g->size() == 0) g->setZero(like.rows(), like.cols());
  check_same_shape<T>(*g, like.rows(), like.cols(), std::string("kl gradient.") + field);
}

/// The hot case, both log-stds shared (d × 1): one fused, vectorisable pass per column.
/// inv_vq = 1/σq², c_sum = Σ_i (logσq − logσp + ½σp²/σq² − ½), r = σp²/σq².
template <class T, class DklFn>
void kl_shared_columns(const Eigen::Ref<const MatrixX<T>>& mean_p, const Eigen::Ref<const MatrixX<T>>& mean_q,
                       const Eigen::Array<T, Eigen::Dynamic, 1>& inv_vq, T c_sum, RowVectorX<T>* kl_out,
                       const DklFn& dkl, const KlGrads<T>& g, bool any_grad, const Eigen::Array<T, Eigen::Dynamic, 1>& r) {
  using Col = Eigen::Array<T, Eigen::Dynamic, 1>;
  const Index d = mean_p.rows(), B = mean_p.cols();
  Col scaled(d), t(d);  // (μp − μq)/σq², (μp − μq)²/σq²
  Col glq = Col::Zero(g.log_std_q ? d : 0);
  T w_sum = 0;
  const T* ivq = inv_vq.data();
  for (Index j = 0; j < B; ++j) {
    const T* mp = mean_p.col(j).data();
    const T* mq = mean_q.col(j).data();
    T* sc = scaled.data();
    T* tt = t.data();
    for (Index i = 0; i < d; ++i) {
      const T diff = mp[i] - mq[i];
      sc[i] = diff * ivq[i];
      tt[i] = diff * sc[i];
    }
    if (kl_out) (*kl_out)[j] = c_sum + T(0.5) * t.sum();
    if (!any_grad) continue;
    const T w = dkl(j);
    w_sum += w;
    if (g.mean_p) {
      T* gp = g.mean_p->col(j).data();
      for (Index i = 0; i < d; ++i) gp[i] += w * sc[i];
    }
    if (g.mean_q) {
      T* gq = g.mean_q->col(j).data();
      for (Index i = 0; i < d; ++i) gq[i] -= w * sc[i];
    }
    if (g.log_std_q) {
      T* gl = glq.data();
      for (Index i = 0; i < d; ++i) gl[i] -= w * tt[i];
    }
  }
  // The batch-constant parts of ∂/∂logσp = r − 1 and ∂/∂logσq = 1 − r − t, added once.
  if (g.log_std_p) g.log_std_p->col(0).array() += w_sum * (r - T(1));
  if (g.log_std_q) g.log_std_q->col(0).array() += glq + w_sum * (T(1) - r);
}

/// kl_shared_columns for the fused mean (kl_diag_gaussian_mean): the same weight w for every
/// sample and no per-sample output, so the (d × B) block is walked as one flat array in tiles of
/// whole columns — no short per-column loops with scalar tails. Needs contiguous means and
/// gradients. Returns Σ_j KL_j.
template <class T>
T kl_shared_flat(const Eigen::Ref<const MatrixX<T>>& mean_p, const Eigen::Ref<const MatrixX<T>>& mean_q,
                 const Eigen::Array<T, Eigen::Dynamic, 1>& inv_vq, T c_sum, T w, const KlGrads<T>& g,
                 const Eigen::Array<T, Eigen::Dynamic, 1>& r) {
  using Col = Eigen::Array<T, Eigen::Dynamic, 1>;
  const Index d = mean_p.rows(), B = mean_p.cols(), n = d * B;
  const Index tile_cols = std::max<Index>(1, 2048 / d), tile = tile_cols * d;
  // 1/σq² repeated per column; Σ over tiles of t (per-thread buffers: no allocation once sized)
  thread_local Col ivq_tiled, acc, t_sum;
  ivq_tiled.resize(tile);
  acc.setZero(tile);
  for (Index c = 0; c < tile_cols; ++c) ivq_tiled.segment(c * d, d) = inv_vq;
  const T* mp = mean_p.data();
  const T* mq = mean_q.data();
  auto run = [&]<bool kGradP, bool kGradQ>() {
    T* gp = kGradP ? g.mean_p->data() : nullptr;
    T* gq = kGradQ ? g.mean_q->data() : nullptr;
    const T* ivq = ivq_tiled.data();
    T* a = acc.data();
    for (Index k0 = 0; k0 < n; k0 += tile) {
      const Index m = std::min(tile, n - k0);
      for (Index k = 0; k < m; ++k) {
        const T diff = mp[k0 + k] - mq[k0 + k];
        const T sc = diff * ivq[k];  // (μp − μq)/σq²
        a[k] += diff * sc;           // t = (μp − μq)²/σq²
        if constexpr (kGradP) gp[k0 + k] += w * sc;
        if constexpr (kGradQ) gq[k0 + k] -= w * sc;
      }
    }
  };
  if (g.mean_p && g.mean_q) run.template operator()<true, true>();
  else if (g.mean_p) run.template operator()<true, false>();
  else if (g.mean_q) run.template operator()<false, true>();
  else run.template operator()<false, false>();
  const T w_sum = w * static_cast<T>(B);
  if (g.log_std_p) g.log_std_p->col(0).array() += w_sum * (r - T(1));
  if (g.log_std_q) {
    t_sum.setZero(d);  // Σ_j t_ij
    for (Index c = 0; c < tile_cols; ++c) t_sum += acc.segment(c * d, d);
    g.log_std_q->col(0).array() += w_sum * (T(1) - r) - w * t_sum;
  }
  return static_cast<T>(B) * c_sum + T(0.5) * acc.sum();
}

/// Shared kernel: writes per-sample KL to kl_out (if non-null) and adds dkl_j·∂KL_j/∂· into grads.
///
/// With both log-stds shared (d × 1) — the policy's state-independent σ — every exponential and
/// the per-dimension constant are computed once and kl_shared_columns does one fused pass per
/// column; otherwise the terms are recomputed column by column.
template <class T, class DklFn>
void kl_kernel(const Eigen::Ref<const MatrixX<T>>& mean_p, const Eigen::Ref<const MatrixX<T>>& log_std_p,
               const Eigen::Ref<const MatrixX<T>>& mean_q, const Eigen::Ref<const MatrixX<T>>& log_std_q,
               RowVectorX<T>* kl_out, const DklFn& dkl, KlGrads<T> g, bool stop_gradient_p,
               T* kl_sum = nullptr, bool constant_weight = false) {
  using Col = Eigen::Array<T, Eigen::Dynamic, 1>;
  if (stop_gradient_p) g.mean_p = g.log_std_p = nullptr;
  prepare_grad<T>(g.mean_p, mean_p, "mean_p");
  prepare_grad<T>(g.log_std_p, log_std_p, "log_std_p");
  prepare_grad<T>(g.mean_q, mean_q, "mean_q");
  prepare_grad<T>(g.log_std_q, log_std_q, "log_std_q");
  const bool any_grad = g.mean_p || g.log_std_p || g.mean_q || g.log_std_q;
  const bool p_shared = log_std_p.cols() == 1, q_shared = log_std_q.cols() == 1, both_shared = p_shared && q_shared;
  const Index d = mean_p.rows(), B = mean_p.cols();
  // Per-dimension terms; recomputed per column only where a log-std is per-sample.
  // 1/σq², σp²/σq², logσq − logσp + ½r − ½: per-thread buffers, no allocation once sized
  thread_local Col inv_vq, r, c;
  inv_vq.resize(d);
  r.resize(d);
  c.resize(d);
  auto set_terms = [&](Index j) {
    const auto lsp = log_std_p.col(p_shared ? 0 : j).array();
    const auto lsq = log_std_q.col(q_shared ? 0 : j).array();
    inv_vq = (T(-2) * lsq).exp();
    r = (T(2) * (lsp - lsq)).exp();
    c = (lsq - lsp) + T(0.5) * r - T(0.5);
  };
  const bool contiguous = mean_p.outerStride() == d && mean_q.outerStride() == d;
  if (both_shared && kl_sum && !kl_out && constant_weight && contiguous && B > 0) {
    set_terms(0);
    *kl_sum = kl_shared_flat<T>(mean_p, mean_q, inv_vq, c.sum(), any_grad ? dkl(0) : T(0), g, r);
    return;
  }
  RowVectorX<T> per_sample;
  if (kl_sum && !kl_out) {
    per_sample.resize(B);
    kl_out = &per_sample;
  }
  if (both_shared) {
    set_terms(0);
    kl_shared_columns<T>(mean_p, mean_q, inv_vq, c.sum(), kl_out, dkl, g, any_grad, r);
    if (kl_sum) *kl_sum = kl_out->sum();
    return;
  }
  // A per-sample log-std on either side: the terms change per column (Eigen array expressions).
  Col diff(d), t(d), gm(d);
  Col glp_shared = Col::Zero(g.log_std_p && p_shared ? d : 0), glq_shared = Col::Zero(g.log_std_q && q_shared ? d : 0);
  for (Index j = 0; j < B; ++j) {
    set_terms(j);
    diff = mean_p.col(j).array() - mean_q.col(j).array();
    t = diff.square() * inv_vq;  // (μp − μq)²/σq²
    if (kl_out) (*kl_out)[j] = c.sum() + T(0.5) * t.sum();
    if (!any_grad) continue;
    const T w = dkl(j);
    if (g.mean_p || g.mean_q) {
      gm = w * diff * inv_vq;
      if (g.mean_p) g.mean_p->col(j).array() += gm;
      if (g.mean_q) g.mean_q->col(j).array() -= gm;
    }
    // ∂/∂logσp = r − 1, ∂/∂logσq = 1 − r − t (summed over the batch where the log-std is shared).
    if (g.log_std_p) {
      if (p_shared) glp_shared += w * (r - T(1));
      else g.log_std_p->col(j).array() += w * (r - T(1));
    }
    if (g.log_std_q) {
      if (q_shared) glq_shared += w * (T(1) - r - t);
      else g.log_std_q->col(j).array() += w * (T(1) - r - t);
    }
  }
  if (g.log_std_p && p_shared) g.log_std_p->col(0).array() += glp_shared;
  if (g.log_std_q && q_shared) g.log_std_q->col(0).array() += glq_shared;
  if (kl_sum) *kl_sum = kl_out->sum();
}
}  // namespace detail

/// Per-sample KL(p ‖ q) → out (1 × B).
template <class T>
void kl_diag_gaussian(const Eigen::Ref<const MatrixX<T>>& mean_p, const Eigen::Ref<const MatrixX<T>>& log_std_p,
                      const Eigen::Ref<const MatrixX<T>>& mean_q, const Eigen::Ref<const MatrixX<T>>& log_std_q,
                      RowVectorX<T>& out) {
  detail::check_kl<T>(mean_p, log_std_p, mean_q, log_std_q, "kl_diag_gaussian");
  out.resize(mean_p.cols());
  detail::kl_kernel<T>(mean_p, log_std_p, mean_q, log_std_q, &out, [](Index) { return T(0); }, KlGrads<T>{}, false);
}

/// Allocating convenience: per-sample KL(p ‖ q) (1 × B).
template <class T>
RowVectorX<T> kl_diag_gaussian(const Eigen::Ref<const MatrixX<T>>& mean_p, const Eigen::Ref<const MatrixX<T>>& log_std_p,
                               const Eigen::Ref<const MatrixX<T>>& mean_q, const Eigen::Ref<const MatrixX<T>>& log_std_q) {
  RowVectorX<T> out;
  kl_diag_gaussian<T>(mean_p, log_std_p, mean_q, log_std_q, out);
  return out;
}

/// Backward of the per-sample KL: given dkl = ∂L/∂KL_j (1 × B), ADDS ∂L/∂(each input) into the
/// non-null members of `grads`. With stop_gradient_p the p-members are ignored.
template <class T>
void kl_diag_gaussian_backward(const Eigen::Ref<const MatrixX<T>>& mean_p, const Eigen::Ref<const MatrixX<T>>& log_std_p,
                               const Eigen::Ref<const MatrixX<T>>& mean_q, const Eigen::Ref<const MatrixX<T>>& log_std_q,
                               const Eigen::Ref<const RowVectorX<T>>& dkl, KlGrads<T> grads,
                               bool stop_gradient_p = false) {
  detail::check_kl<T>(mean_p, log_std_p, mean_q, log_std_q, "kl_diag_gaussian_backward");
  require(dkl.size() == mean_p.cols(), "dkl must have B entries", {{}, std::nullopt, "kl_diag_gaussian_backward.dkl"});
  detail::kl_kernel<T>(mean_p, log_std_p, mean_q, log_std_q, nullptr, [&](Index j) { return dkl[j]; }, grads,
                       stop_gradient_p);
}

/// Fused loss + gradient (one pass): returns mean_j KL_j and ADDS the gradient of
/// options.weight · mean_j KL_j into `grads`.
template <class T>
T kl_diag_gaussian_mean(const Eigen::Ref<const MatrixX<T>>& mean_p, const Eigen::Ref<const MatrixX<T>>& log_std_p,
                        const Eigen::Ref<const MatrixX<T>>& mean_q, const Eigen::Ref<const MatrixX<T>>& log_std_q,
                        KlGrads<T> grads, KlOptions options = {}) {
  detail::check_kl<T>(mean_p, log_std_p, mean_q, log_std_q, "kl_diag_gaussian_mean");
  const Index B = mean_p.cols();
  require(B > 0, "empty batch", {{}, std::nullopt, "kl_diag_gaussian_mean"});
  const T w = static_cast<T>(options.weight / static_cast<double>(B));
  T kl_sum = 0;
  detail::kl_kernel<T>(mean_p, log_std_p, mean_q, log_std_q, nullptr, [w](Index) { return w; }, grads,
                       options.stop_gradient_p, &kl_sum, /*constant_weight=*/true);
  return kl_sum / static_cast<T>(B);
}

}  // namespace maskadapt::nn
