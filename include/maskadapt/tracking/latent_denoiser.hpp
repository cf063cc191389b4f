#pragma once
/// \file latent_denoiser.hpp
/// The text- and history-conditioned denoiser of the latent diffusion model: it predicts the
/// clean latent x̂₀ from (x_t, t, text embedding, history).
///
///   e    = P · φ(text)                      learned linear projection (E × K) of the text
///                                           features φ (K, e.g. HashedTextFeatures), trained jointly
///   in   = [x_t (L); τ(t) (time_dim); e (E); h (H·D)]     τ: sinusoidal step embedding
///   x̂₀  = MLP(in) (L)
///
/// The unconditional prediction replaces e by 0 (the "null" embedding). Training drops the
/// condition with probability `cond_dropout` per sample, so one network gives both predictions
/// needed by classifier-free guidance. Samples are columns.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/nn/adam.hpp>
#include <maskadapt/nn/mlp.hpp>
#include <maskadapt/tracking/diffusion.hpp>

#include <vector>

namespace maskadapt::tracking {

struct DenoiserConfig {
  Index text_features = 256;  ///< K (input of the projection)
  Index text_embed = 32;      ///< E
  Index time_embed = 16;      ///< sinusoidal step embedding size (even)
  std::vector<Index> hidden = {256, 256};
  nn::Activation activation = nn::Activation::ELU;
  double cond_dropout = 0.1;  ///< probability of training a sample unconditionally
};

class LatentDenoiser {
 public:
  LatentDenoiser() = default;
  /// latent = L, history_dim = H·D.
  LatentDenoiser(Index latent, Index history_dim, DenoiserConfig config, Rng& rng)
      : config_(std::move(config)), latent_(latent), history_dim_(history_dim) {
    require(latent > 0 && history_dim > 0 && config_.text_features > 0 && config_.text_embed > 0,
            "denoiser sizes must be positive", {{}, {}, "DenoiserConfig"});
    require(config_.cond_dropout >= 0.0 && config_.cond_dropout <= 1.0, "cond_dropout must lie in [0, 1]",
            {{}, {}, "cond_dropout"});
    projection_ = nn::Mlp<float>({config_.text_features, {}, config_.text_embed, nn::Activation::Identity}, rng);
    net_ = nn::Mlp<float>({input_dim(), config_.hidden, latent, config_.activation}, rng);
  }

  const DenoiserConfig& config() const { return config_; }
  Index latent_dim() const { return latent_; }
  Index history_dim() const { return history_dim_; }
  Index input_dim() const { return latent_ + config_.time_embed + config_.text_embed + history_dim_; }
  nn::Mlp<float>& projection() { return projection_; }
  nn::Mlp<float>& network() { return net_; }
  const nn::Mlp<float>& projection() const { return projection_; }
  const nn::Mlp<float>& network() const { return net_; }

  /// Text embedding e (E × B) of text features (K × B).
  MatrixXf embed(const Eigen::Ref<const MatrixXf>& text_features) const {
    require(text_features.rows() == config_.text_features, "text features have " + std::to_string(text_features.rows()) +
                                                               " rows, expected " + std::to_string(config_.text_features),
            {{}, {}, "text_features"});
    return projection_.forward(text_features);
  }

  /// x̂₀ (L × B) for x_t (L × B) at step t, embedding e (E × B; pass zeros for unconditional),
  /// normalised history h (H·D × B).
  MatrixXf predict(const Eigen::Ref<const MatrixXf>& xt, int t, const Eigen::Ref<const MatrixXf>& e,
                   const Eigen::Ref<const MatrixXf>& h) const {
    return net_.forward(assemble(xt, std::vector<int>(static_cast<std::size_t>(xt.cols()), t), e, h));
  }

  /// One training step on clean latents x0 (L × B), text features (K × B), histories (H·D × B):
  /// draws t, ε and the dropout mask from rng, minimises mean‖x̂₀ − x₀‖². Returns the loss.
  double train_step(const NoiseSchedule& s, const Eigen::Ref<const MatrixXf>& x0,
                    const Eigen::Ref<const MatrixXf>& text_features, const Eigen::Ref<const MatrixXf>& h,
                    nn::Adam<float>& adam, Rng& rng) {
    const Index B = x0.cols();
    require(text_features.cols() == B && h.cols() == B, "batch sizes differ", {{}, {}, "batch"});
    projection_.zero_grad();
    net_.zero_grad();
    const auto batch = make_diffusion_batch<float>(s, x0, rng);
    const MatrixXf& e_full = projection_.forward_train(text_features, proj_cache_);
    MatrixXf e = e_full;
    std::vector<char> dropped(static_cast<std::size_t>(B), 0);
    for (Index j = 0; j < B; ++j)
      if (rng.bernoulli(config_.cond_dropout)) {
        dropped[static_cast<std::size_t>(j)] = 1;
        e.col(j).setZero();
      }
    const MatrixXf in = assemble(batch.xt, batch.t, e, h);
    const MatrixXf& pred = net_.forward_train(in, net_cache_);
    const MatrixXf err = pred - x0;
    const double n_el = static_cast<double>(err.size());
    const double loss = err.squaredNorm() / n_el;
    MatrixXf din;
    net_.backward(net_cache_, (2.0 / n_el) * err, net_.grads(), &din);
    MatrixXf de = din.middleRows(latent_ + config_.time_embed, config_.text_embed);
    for (Index j = 0; j < B; ++j)
      if (dropped[static_cast<std::size_t>(j)]) de.col(j).setZero();
    projection_.backward(proj_cache_, de, projection_.grads());
    adam.step({&projection_.block(), &net_.block()});
    return loss;
  }

 private:
  MatrixXf assemble(const Eigen::Ref<const MatrixXf>& xt, const std::vector<int>& t, const Eigen::Ref<const MatrixXf>& e,
                    const Eigen::Ref<const MatrixXf>& h) const {
    const Index B = xt.cols();
    require(xt.rows() == latent_, "x_t has the wrong number of rows", {{}, {}, "x_t"});
    require(e.rows() == config_.text_embed && e.cols() == B, "text embedding has the wrong shape", {{}, {}, "text_embedding"});
    require(h.rows() == history_dim_ && h.cols() == B, "history has the wrong shape", {{}, {}, "history"});
    MatrixXf in(input_dim(), B);
    in.topRows(latent_) = xt;
    for (Index j = 0; j < B; ++j)
      in.block(latent_, j, config_.time_embed, 1) = timestep_embedding<float>(t[static_cast<std::size_t>(j)], config_.time_embed);
    in.middleRows(latent_ + config_.time_embed, config_.text_embed) = e;
    in.bottomRows(history_dim_) = h;
    return in;
  }

  DenoiserConfig config_;
  Index latent_ = 0, history_dim_ = 0;
  nn::Mlp<float> projection_, net_;
  nn::TrainCache<float> proj_cache_, net_cache_;
};

}  // namespace maskadapt::tracking
