#pragma once
/// \file diffusion.hpp
/// Gaussian diffusion over latent vectors (DDPM, Ho et al. 2020) with an x₀-predicting denoiser
/// and classifier-free guidance (Ho & Salimans 2022).
///
/// Indexing: diffusion steps are 0-based, t ∈ {0, …, T−1}. Step t adds noise with variance β_t:
///
///   q(x_t | x_{t−1}) = N(√α_t · x_{t−1}, β_t I),        α_t = 1 − β_t
///   q(x_t | x_0)     = N(√ᾱ_t · x_0, (1 − ᾱ_t) I),       ᾱ_t = ∏_{s=0}^{t} α_s
///   q(x_{t−1} | x_t, x_0) = N(c1_t · x_0 + c2_t · x_t, β̃_t I)
///       c1_t = √ᾱ_{t−1} β_t / (1 − ᾱ_t),  c2_t = √α_t (1 − ᾱ_{t−1}) / (1 − ᾱ_t),
///       β̃_t = β_t (1 − ᾱ_{t−1}) / (1 − ᾱ_t),   with ᾱ_{−1} = 1 (so c1_0 = 1, c2_0 = 0, β̃_0 = 0).
///
/// The denoiser predicts the clean sample x̂₀ = f(x_t, t, condition); ancestral sampling draws
/// x_{T−1} ~ N(0, I) and then x_{t−1} = c1_t x̂₀ + c2_t x_t + √β̃_t z for t = T−1 … 0 (no noise at t = 0,
/// where the result is x̂₀ itself). Samples are columns: x is (dim × batch).
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

namespace maskadapt::tracking {

/// Per-step coefficients of a discrete noise schedule; every vector has T entries (index t).
struct NoiseSchedule {
  VectorXd betas;                 ///< (T) β_t
  VectorXd alphas;                ///< (T) α_t = 1 − β_t
  VectorXd alpha_bars;            ///< (T) ᾱ_t = ∏_{s≤t} α_s
  VectorXd alpha_bars_prev;       ///< (T) ᾱ_{t−1}, with ᾱ_{−1} = 1
  VectorXd posterior_variance;    ///< (T) β̃_t = β_t (1 − ᾱ_{t−1}) / (1 − ᾱ_t)
  VectorXd posterior_coef_x0;     ///< (T) c1_t = √ᾱ_{t−1} β_t / (1 − ᾱ_t)
  VectorXd posterior_coef_xt;     ///< (T) c2_t = √α_t (1 − ᾱ_{t−1}) / (1 − ᾱ_t)

  int num_steps() const { return static_cast<int>(betas.size()); }

  /// Builds every derived coefficient from β (each β_t must lie in (0, 1)).
  static NoiseSchedule from_betas(const VectorXd& betas) {
    require(betas.size() >= 1, "a noise schedule needs at least one step", {{}, {}, "betas"});
    for (Index t = 0; t < betas.size(); ++t)
      require(std::isfinite(betas[t]) && betas[t] > 0.0 && betas[t] < 1.0,
              "beta_" + std::to_string(t) + " = " + std::to_string(betas[t]) + " is outside (0, 1)",
              {{}, {}, "betas"});
    NoiseSchedule s;
    const Index T = betas.size();
    s.betas = betas;
    s.alphas = (1.0 - betas.array()).matrix();
    s.alpha_bars.resize(T);
    s.alpha_bars_prev.resize(T);
    double prod = 1.0;
    for (Index t = 0; t < T; ++t) {
      s.alpha_bars_prev[t] = prod;
      prod *= s.alphas[t];
      s.alpha_bars[t] = prod;
    }
    s.posterior_variance.resize(T);
    s.posterior_coef_x0.resize(T);
    s.posterior_coef_xt.resize(T);
    for (Index t = 0; t < T; ++t) {
      const double one_minus_ab = 1.0 - s.alpha_bars[t];
      s.posterior_variance[t] = s.betas[t] * (1.0 - s.alpha_bars_prev[t]) / one_minus_ab;
      s.posterior_coef_x0[t] = std::sqrt(s.alpha_bars_prev[t]) * s.betas[t] / one_minus_ab;
      s.posterior_coef_xt[t] = std::sqrt(s.alphas[t]) * (1.0 - s.alpha_bars_prev[t]) / one_minus_ab;
    }
    return s;
  }
};

/// Linear β from `beta_start` to `beta_end` over T steps (Ho et al.; their T = 1000 values scaled
/// by 1000/T when `scale_to_T` so short schedules still end near pure noise).
inline NoiseSchedule linear_schedule(int T, double beta_start = 1e-4, double beta_end = 0.02,
                                     bool scale_to_T = true) {
  require(T >= 1, "number of diffusion steps must be ≥ 1", {{}, {}, "T"});
  const double scale = scale_to_T ? 1000.0 / T : 1.0;
  VectorXd b(T);
  for (int t = 0; t < T; ++t) {
    const double f = T == 1 ? 0.0 : static_cast<double>(t) / (T - 1);
    b[t] = std::min(0.999, scale * (beta_start + f * (beta_end - beta_start)));
  }
  return NoiseSchedule::from_betas(b);
}

/// Cosine schedule (Nichol & Dhariwal 2021): ᾱ(t) = f(t)/f(0), f(t) = cos²(((t/T) + s)/(1 + s) · π/2),
/// β_t = min(1 − ᾱ(t+1)/ᾱ(t), max_beta). The default for the built-in generator (T = 10).
inline NoiseSchedule cosine_schedule(int T, double s = 0.008, double max_beta = 0.999) {
  require(T >= 1, "number of diffusion steps must be ≥ 1", {{}, {}, "T"});
  auto f = [&](double t) {
    const double c = std::cos((t / T + s) / (1.0 + s) * std::numbers::pi / 2.0);
    return c * c;
  };
  VectorXd b(T);
  for (int t = 0; t < T; ++t) b[t] = std::min(1.0 - f(t + 1) / f(t), max_beta);
  return NoiseSchedule::from_betas(b);
}

/// Forward noising x_t = √ᾱ_t x₀ + √(1 − ᾱ_t) ε, one step index per column.
/// \param x0 (dim × batch) clean samples; \param t (batch) step per column; \param noise (dim × batch) ε.
template <class T>
MatrixX<T> q_sample(const NoiseSchedule& s, const Eigen::Ref<const MatrixX<T>>& x0, const std::vector<int>& t,
                    const Eigen::Ref<const MatrixX<T>>& noise) {
  require(static_cast<Index>(t.size()) == x0.cols(), "one diffusion step per column is required", {{}, {}, "t"});
  require(noise.rows() == x0.rows() && noise.cols() == x0.cols(), "noise has the wrong shape", {{}, {}, "noise"});
  MatrixX<T> xt(x0.rows(), x0.cols());
  for (Index j = 0; j < x0.cols(); ++j) {
    const int tj = t[j];
    require(tj >= 0 && tj < s.num_steps(), "diffusion step out of range", {{}, {}, "t"});
    const T a = static_cast<T>(std::sqrt(s.alpha_bars[tj]));
    const T b = static_cast<T>(std::sqrt(1.0 - s.alpha_bars[tj]));
    xt.col(j) = a * x0.col(j) + b * noise.col(j);
  }
  return xt;
}

/// Posterior mean μ̃_t(x_t, x₀) = c1_t x₀ + c2_t x_t (the same step t for the whole batch).
template <class T>
MatrixX<T> posterior_mean(const NoiseSchedule& s, int t, const Eigen::Ref<const MatrixX<T>>& x0,
                          const Eigen::Ref<const MatrixX<T>>& xt) {
  require(t >= 0 && t < s.num_steps(), "diffusion step out of range", {{}, {}, "t"});
  require(x0.rows() == xt.rows() && x0.cols() == xt.cols(), "x0 and x_t shapes differ", {{}, {}, "x0"});
  return static_cast<T>(s.posterior_coef_x0[t]) * x0 + static_cast<T>(s.posterior_coef_xt[t]) * xt;
}

/// Classifier-free guidance on x̂₀: uncond + w · (cond − uncond). w = 1 gives the conditional
/// prediction, w = 0 the unconditional one; the built-in generator uses w = 5. Evaluated as
/// w·cond + (1 − w)·uncond, which is the same number algebraically and makes w = 1 (and w = 0) exact.
template <class T>
MatrixX<T> guided_prediction(const Eigen::Ref<const MatrixX<T>>& cond, const Eigen::Ref<const MatrixX<T>>& uncond,
                             double w) {
  require(cond.rows() == uncond.rows() && cond.cols() == uncond.cols(),
          "conditional and unconditional predictions have different shapes", {{}, {}, "cond"});
  return static_cast<T>(w) * cond + static_cast<T>(1.0 - w) * uncond;
}

/// One ancestral step: x_{t−1} = μ̃_t(x_t, x̂₀) + √β̃_t z, z ~ N(0, I) drawn from `rng` (column by
/// column, row by row); at t = 0 no noise is drawn and the result is μ̃_0 = x̂₀.
template <class T>
MatrixX<T> ddpm_step(const NoiseSchedule& s, int t, const Eigen::Ref<const MatrixX<T>>& xt,
                     const Eigen::Ref<const MatrixX<T>>& x0_hat, Rng& rng) {
  MatrixX<T> out = posterior_mean<T>(s, t, x0_hat, xt);
  if (t > 0) {
    const T sigma = static_cast<T>(std::sqrt(s.posterior_variance[t]));
    for (Index j = 0; j < out.cols(); ++j)
      for (Index i = 0; i < out.rows(); ++i) out(i, j) += sigma * static_cast<T>(rng.normal());
  }
  return out;
}

/// DDPM ancestral sampling. `predict_x0(x_t, t)` returns x̂₀ (dim × batch) for the (dim × batch)
/// x_t at step t — wrap a guided model with `guided_prediction` inside it. Draws x_{T−1} ~ N(0, I)
/// then one `ddpm_step` per t = T−1 … 0, all from `rng`. Throws if the denoiser returns a
/// wrongly-shaped or non-finite prediction.
template <class T, class PredictX0>
MatrixX<T> ddpm_sample(const NoiseSchedule& s, Index dim, Index batch, PredictX0&& predict_x0, Rng& rng) {
  require(dim >= 1 && batch >= 1, "sample dimension and batch must be ≥ 1", {{}, {}, "dim"});
  MatrixX<T> x(dim, batch);
  for (Index j = 0; j < batch; ++j)
    for (Index i = 0; i < dim; ++i) x(i, j) = static_cast<T>(rng.normal());
  for (int t = s.num_steps() - 1; t >= 0; --t) {
    const MatrixX<T> x0_hat = predict_x0(static_cast<const MatrixX<T>&>(x), t);
    require(x0_hat.rows() == dim && x0_hat.cols() == batch, "denoiser returned the wrong shape",
            {{}, {}, "x0_hat"});
    require_finite(x0_hat, "x0_hat");
    x = ddpm_step<T>(s, t, x, x0_hat, rng);
  }
  return x;
}

/// Training targets for an x₀-predicting denoiser: draws t uniformly per column and ε ~ N(0, I),
/// returns x_t = q_sample(x₀, t, ε); the loss is ‖f(x_t, t, c) − x₀‖².
template <class T>
struct DiffusionBatch {
  std::vector<int> t;  ///< (batch) step per column
  MatrixX<T> noise;    ///< (dim × batch) ε
  MatrixX<T> xt;       ///< (dim × batch) noised inputs
};

template <class T>
DiffusionBatch<T> make_diffusion_batch(const NoiseSchedule& s, const Eigen::Ref<const MatrixX<T>>& x0, Rng& rng) {
  DiffusionBatch<T> b;
  b.t.resize(x0.cols());
  for (auto& ti : b.t) ti = static_cast<int>(rng.uniform_int(static_cast<std::uint64_t>(s.num_steps())));
  b.noise.resize(x0.rows(), x0.cols());
  for (Index j = 0; j < x0.cols(); ++j)
    for (Index i = 0; i < x0.rows(); ++i) b.noise(i, j) = static_cast<T>(rng.normal());
  b.xt = q_sample<T>(s, x0, b.t, b.noise);
  return b;
}

/// Sinusoidal embedding of the step t (Vaswani et al.): (dim) = [sin(t·ω_k), cos(t·ω_k)],
/// ω_k = 1 / 10000^{2k/dim}; dim must be even.
template <class T>
VectorX<T> timestep_embedding(int t, Index dim) {
  require(dim >= 2 && dim % 2 == 0, "timestep embedding dimension must be even and ≥ 2", {{}, {}, "dim"});
  VectorX<T> e(dim);
  const Index half = dim / 2;
  for (Index k = 0; k < half; ++k) {
    const double w = std::pow(10000.0, -static_cast<double>(k) / static_cast<double>(half));
    e[k] = static_cast<T>(std::sin(t * w));
    e[half + k] = static_cast<T>(std::cos(t * w));
  }
  return e;
}

}  // namespace maskadapt::tracking
