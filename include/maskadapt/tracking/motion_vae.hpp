#pragma once
/// \file motion_vae.hpp
/// A motion VAE over primitives: H history frames + F future frames (30 Hz), each frame encoded
/// as in frame_features.hpp (D values), all canonicalised to the first history frame.
///
///   encoder  q(z | h, f):  [h (H·D); f (F·D)]  → MLP → [μ (L); log σ² (L)]
///   sampling z = μ + σ ⊙ ε, ε ~ N(0, I)               (reparameterisation)
///   decoder  f̂ = g(h, z):  [h (H·D); z (L)]    → MLP → f̂ (F·D)
///   loss     mean‖f̂ − f‖² (per element, normalised units) + β · mean_batch KL(q ‖ N(0, I))
///
/// h and f are normalised per element with statistics of the training windows (`FeatureStats`).
/// Samples are columns; every matrix below is (rows × batch).
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/nn/adam.hpp>
#include <maskadapt/nn/mlp.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace maskadapt::tracking {

/// Per-element mean and standard deviation (floored at `min_std`).
struct FeatureStats {
  VectorXf mean;  ///< (dim)
  VectorXf std;   ///< (dim), every entry ≥ min_std

  Index dim() const { return mean.size(); }

  /// Statistics of the columns of x (dim × N), N ≥ 1.
  static FeatureStats of(const Eigen::Ref<const MatrixXf>& x, float min_std = 1e-2f) {
    require(x.cols() >= 1, "statistics need at least one sample", {{}, {}, "samples"});
    require_finite(x, "samples");
    FeatureStats s;
    const Eigen::VectorXd m = x.cast<double>().rowwise().mean();
    const Eigen::VectorXd v = (x.cast<double>().colwise() - m).array().square().rowwise().mean();
    s.mean = m.cast<float>();
    s.std = v.array().sqrt().max(static_cast<double>(min_std)).cast<float>();
    return s;
  }
  MatrixXf normalize(const Eigen::Ref<const MatrixXf>& x) const {
    require(x.rows() == dim(), "feature rows do not match the statistics", {{}, {}, "features"});
    return ((x.colwise() - mean).array().colwise() / std.array()).matrix();
  }
  MatrixXf denormalize(const Eigen::Ref<const MatrixXf>& x) const {
    require(x.rows() == dim(), "feature rows do not match the statistics", {{}, {}, "features"});
    return ((x.array().colwise() * std.array()).matrix().colwise() + mean);
  }
};

struct MotionVaeConfig {
  Index history = 5;                 ///< H frames
  Index future = 15;                 ///< F frames
  Index latent = 32;                 ///< L
  std::vector<Index> hidden = {256, 256};
  nn::Activation activation = nn::Activation::ELU;
  double kl_weight = 1e-4;           ///< β (per-element MSE vs per-sample KL; larger values collapse the posterior)
  float max_log_var = 8.0f;          ///< log σ² is clamped to ±max_log_var (no gradient outside)
};

struct VaeLosses {
  double recon = 0.0;  ///< mean squared error per element (normalised units)
  double kl = 0.0;     ///< mean KL per sample (nats)
  double total = 0.0;  ///< recon + β·kl
};

class MotionVae {
 public:
  MotionVae() = default;
  /// frame_dim = D (frame_feature_dim of the skeleton).
  MotionVae(Index frame_dim, MotionVaeConfig config, Rng& rng) : config_(std::move(config)), frame_dim_(frame_dim) {
    require(frame_dim > 0 && config_.history > 0 && config_.future > 0 && config_.latent > 0,
            "motion VAE sizes must be positive", {{}, {}, "MotionVaeConfig"});
    encoder_ = nn::Mlp<float>({history_dim() + future_dim(), config_.hidden, 2 * config_.latent, config_.activation}, rng);
    decoder_ = nn::Mlp<float>({history_dim() + config_.latent, config_.hidden, future_dim(), config_.activation}, rng);
  }

  const MotionVaeConfig& config() const { return config_; }
  Index frame_dim() const { return frame_dim_; }
  Index history_dim() const { return config_.history * frame_dim_; }  ///< H·D
  Index future_dim() const { return config_.future * frame_dim_; }    ///< F·D
  Index latent_dim() const { return config_.latent; }

  nn::Mlp<float>& encoder() { return encoder_; }
  nn::Mlp<float>& decoder() { return decoder_; }
  const nn::Mlp<float>& encoder() const { return encoder_; }
  const nn::Mlp<float>& decoder() const { return decoder_; }

  /// Normalisation of history (H·D) and future (F·D) windows.
  FeatureStats history_stats, future_stats;

  /// μ and log σ² (each L × B) of q(z | h, f); h (H·D × B), f (F·D × B) normalised.
  std::pair<MatrixXf, MatrixXf> encode(const Eigen::Ref<const MatrixXf>& h, const Eigen::Ref<const MatrixXf>& f) const {
    check(h, history_dim(), "history");
    check(f, future_dim(), "future");
    require(h.cols() == f.cols(), "history and future batches differ", {{}, {}, "future"});
    MatrixXf x(h.rows() + f.rows(), h.cols());
    x << h, f;
    const MatrixXf y = encoder_.forward(x);
    MatrixXf lv = y.bottomRows(config_.latent).cwiseMax(-config_.max_log_var).cwiseMin(config_.max_log_var);
    return {y.topRows(config_.latent), lv};
  }

  /// f̂ (F·D × B, normalised) = g(h, z).
  MatrixXf decode(const Eigen::Ref<const MatrixXf>& h, const Eigen::Ref<const MatrixXf>& z) const {
    check(h, history_dim(), "history");
    check(z, latent_dim(), "latent");
    require(h.cols() == z.cols(), "history and latent batches differ", {{}, {}, "latent"});
    MatrixXf x(h.rows() + z.rows(), h.cols());
    x << h, z;
    return decoder_.forward(x);
  }

  /// One gradient step on a batch of normalised windows (gradients zeroed, computed, applied).
  VaeLosses train_step(const Eigen::Ref<const MatrixXf>& h, const Eigen::Ref<const MatrixXf>& f, nn::Adam<float>& adam,
                       Rng& rng) {
    check(h, history_dim(), "history");
    check(f, future_dim(), "future");
    const Index B = h.cols(), L = config_.latent;
    encoder_.zero_grad();
    decoder_.zero_grad();
    MatrixXf xe(h.rows() + f.rows(), B);
    xe << h, f;
    const MatrixXf& ye = encoder_.forward_train(xe, enc_cache_);
    const MatrixXf mu = ye.topRows(L);
    const MatrixXf lv_raw = ye.bottomRows(L);
    const MatrixXf lv = lv_raw.cwiseMax(-config_.max_log_var).cwiseMin(config_.max_log_var);
    const MatrixXf sigma = (0.5f * lv.array()).exp().matrix();
    MatrixXf eps(L, B);
    for (Index i = 0; i < eps.size(); ++i) eps.data()[i] = static_cast<float>(rng.normal());
    const MatrixXf z = mu + sigma.cwiseProduct(eps);
    MatrixXf xd(h.rows() + L, B);
    xd << h, z;
    const MatrixXf& fhat = decoder_.forward_train(xd, dec_cache_);
    const MatrixXf err = fhat - f;
    const double n_el = static_cast<double>(err.size());
    VaeLosses out;
    out.recon = err.squaredNorm() / n_el;
    out.kl = 0.5 * (mu.array().square() + lv.array().exp() - 1.0f - lv.array()).cast<double>().sum() / B;
    out.total = out.recon + config_.kl_weight * out.kl;
    // Backward: decoder, then through z into the encoder outputs.
    const MatrixXf dfhat = (2.0 / n_el) * err;
    MatrixXf dxd;
    decoder_.backward(dec_cache_, dfhat, decoder_.grads(), &dxd);
    const MatrixXf dz = dxd.bottomRows(L);
    const float beta_b = static_cast<float>(config_.kl_weight / B);
    MatrixXf dye(2 * L, B);
    dye.topRows(L) = dz + beta_b * mu;
    MatrixXf dlv = dz.cwiseProduct(eps).cwiseProduct(0.5f * sigma) + (0.5f * beta_b) * (lv.array().exp() - 1.0f).matrix();
    for (Index i = 0; i < dlv.size(); ++i)
      if (std::abs(lv_raw.data()[i]) > config_.max_log_var) dlv.data()[i] = 0.0f;
    dye.bottomRows(L) = dlv;
    encoder_.backward(enc_cache_, dye, encoder_.grads());
    adam.step({&encoder_.block(), &decoder_.block()});
    return out;
  }

 private:
  static void check(const Eigen::Ref<const MatrixXf>& x, Index rows, const char* what) {
    require(x.rows() == rows, std::string(what) + " has " + std::to_string(x.rows()) + " rows, expected " +
                                  std::to_string(rows), {{}, {}, what});
    require_finite(x, what);
  }

  MotionVaeConfig config_;
  Index frame_dim_ = 0;
  nn::Mlp<float> encoder_, decoder_;
  nn::TrainCache<float> enc_cache_, dec_cache_;
};

}  // namespace maskadapt::tracking
