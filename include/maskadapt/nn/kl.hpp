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

/// Shared kernel: writes per-sample KL to kl_out (if non-null) and adds dkl_j·∂KL_j/∂· into grads.
template <class T, class DklFn>
void kl_kernel(const Eigen::Ref<const MatrixX<T>>& mean_p, const Eigen::Ref<const MatrixX<T>>& log_std_p,
               const Eigen::Ref<const MatrixX<T>>& mean_q, const Eigen::Ref<const MatrixX<T>>& log_std_q,
               RowVectorX<T>* kl_out, const DklFn& dkl, KlGrads<T> g, bool stop_gradient_p) {
  if (stop_gradient_p) g.mean_p = g.log_std_p = nullptr;
  prepare_grad<T>(g.mean_p, mean_p, "mean_p");
  prepare_grad<T>(g.log_std_p, log_std_p, "log_std_p");
  prepare_grad<T>(g.mean_q, mean_q, "mean_q");
  prepare_grad<T>(g.log_std_q, log_std_q, "log_std_q");
  const bool any_grad = g.mean_p || g.log_std_p || g.mean_q || g.log_std_q;
  const bool p_shared = log_std_p.cols() == 1, q_shared = log_std_q.cols() == 1;
  const Index d = mean_p.rows();
  // With (d × 1) log-stds the exponentials depend on i only: compute them once.
  VectorX<T> inv_vq_shared, r_shared;
  if (q_shared) inv_vq_shared = (T(-2) * log_std_q.col(0).array()).exp().matrix();
  if (p_shared && q_shared) r_shared = (T(2) * (log_std_p.col(0) - log_std_q.col(0)).array()).exp().matrix();
  for (Index j = 0; j < mean_p.cols(); ++j) {
    const T w = any_grad ? dkl(j) : T(0);
    T acc = 0;
    for (Index i = 0; i < d; ++i) {
      const T lsp = ls_at(log_std_p, i, j), lsq = ls_at(log_std_q, i, j);
      const T inv_vq = q_shared ? inv_vq_shared[i] : std::exp(T(-2) * lsq);
      const T r = (p_shared && q_shared) ? r_shared[i] : std::exp(T(2) * (lsp - lsq));  // σp²/σq²
      const T diff = mean_p(i, j) - mean_q(i, j);
      const T t = diff * diff * inv_vq;
      acc += (lsq - lsp) + T(0.5) * (r + t) - T(0.5);
      if (any_grad) {
        const T gm = w * diff * inv_vq;
        if (g.mean_p) (*g.mean_p)(i, j) += gm;
        if (g.mean_q) (*g.mean_q)(i, j) -= gm;
        if (g.log_std_p) (*g.log_std_p)(i, p_shared ? 0 : j) += w * (r - T(1));
        if (g.log_std_q) (*g.log_std_q)(i, q_shared ? 0 : j) += w * (T(1) - r - t);
      }
    }
    if (kl_out) (*kl_out)[j] = acc;
  }
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
  RowVectorX<T> kl(B);
  detail::kl_kernel<T>(mean_p, log_std_p, mean_q, log_std_q, &kl, [w](Index) { return w; }, grads,
                       options.stop_gradient_p);
  return kl.mean();
}

}  // namespace maskadapt::nn
