#pragma once
/// \file builtin_generator.hpp
/// The built-in text-conditioned generator: motion VAE (motion_vae.hpp) + latent diffusion
/// (diffusion.hpp, latent_denoiser.hpp) + hashed text features (text_encoder.hpp). It satisfies
/// `TrajectoryGenerator` (H = 5, F = 15 by default).
///
/// generate(text, history): h = normalise(encode_frames(history)) (H·D); the latent is sampled by
/// DDPM (T = 10, cosine schedule) with classifier-free guidance, x̂₀ = w·f(x_t, t, e, h) +
/// (1 − w)·f(x_t, t, 0, h), w = 5, its noise scaled by the temperature τ (config; 1 = plain DDPM);
/// the VAE decoder maps (h, latent_scale · x₀) to the F future
/// frames, which are denormalised and decoded to a Trajectory in the history's canonical frame.
///
/// Save/load (core/checkpoint.hpp): section "generator.config" (JSON: sizes, activations,
/// T, w, skeleton body names), the four networks' parameters ("vae.encoder", "vae.decoder",
/// "denoiser.projection", "denoiser.net"), the normalisation statistics and "latent_scale"; and,
/// optional (absent in older files): "generator.arms_pool" (JSON list of the arms prompts it was
/// trained on: what partial tracking samples), "generator.provenance" (JSON: command, data,
/// seed, budget, git commit, machine — see models/README.md) and "generator.training_labels" (JSON
/// list of the label sets it was trained on, each a list of texts: its vocabulary; written since
/// issue 42, absent from the shipped models/text_generator.bin — `generator_training_labels` in
/// prompt_words.hpp derives them from the training data then).
///
/// Words it has not seen: `set_prompt_mapper` (lexicon.hpp) maps a prompt's unknown words onto the
/// training vocabulary, and such a prompt is conditioned on the training text it lands on
/// (`conditioning_text`); prompts of known words are unchanged.
///
/// Training (`train_generator`): stage 1 fits the VAE on all windows; stage 2 freezes it, encodes
/// every window once to (μ, σ), and trains the denoiser on z = μ + σ ε / latent_scale with a
/// random description of the window's clip as the condition (dropped with probability 0.1).
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/motion/skeleton.hpp>
#include <maskadapt/nn/adam.hpp>
#include <maskadapt/tracking/diffusion.hpp>
#include <maskadapt/tracking/frame_features.hpp>
#include <maskadapt/tracking/generator.hpp>
#include <maskadapt/tracking/latent_denoiser.hpp>
#include <maskadapt/tracking/lexicon.hpp>
#include <maskadapt/tracking/motion_vae.hpp>
#include <maskadapt/tracking/primitive_dataset.hpp>
#include <maskadapt/tracking/text_encoder.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace maskadapt::tracking {

struct BuiltinGeneratorConfig {
  MotionVaeConfig vae;             ///< H = 5, F = 15, L = 32, hidden [256, 256]
  DenoiserConfig denoiser;         ///< K = 256, E = 32, hidden [256, 256], dropout 0.1
  int diffusion_steps = 10;        ///< T
  double guidance = 5.0;           ///< classifier-free guidance weight w
  /// Sampling temperature τ ∈ (0, 1]: x_{T−1} and every ancestral step's noise are scaled by τ
  /// (τ = 1: plain DDPM; smaller: samples nearer the conditional mode, less diverse).
  double temperature = 1.0;
};

class BuiltinGenerator {
 public:
  BuiltinGenerator() = default;
  BuiltinGenerator(const Skeleton& skel, BuiltinGeneratorConfig config, Rng& rng)
      : skel_(skel), config_(std::move(config)), text_(config_.denoiser.text_features) {
    skel_.validate();
    vae_ = MotionVae(frame_feature_dim(skel_), config_.vae, rng);
    denoiser_ = LatentDenoiser(config_.vae.latent, vae_.history_dim(), config_.denoiser, rng);
    schedule_ = cosine_schedule(config_.diffusion_steps);
    latent_scale_ = 1.0f;
  }

  // ---- TrajectoryGenerator ----------------------------------------------------------------
  const Skeleton& skeleton() const { return skel_; }
  Index history_frames() const { return config_.vae.history; }
  Index future_frames() const { return config_.vae.future; }

  /// F future frames after `history` (H frames, canonical; see generator.hpp).
  Trajectory generate(const TextCondition& c, const Trajectory& history, Rng& rng) const {
    require(history.num_frames() == history_frames(), "history must have H = " + std::to_string(history_frames()) +
                                                          " frames, got " + std::to_string(history.num_frames()),
            {{}, {}, "history"});
    Trajectory h = history;
    compute_body_positions(skel_, h);
    const MatrixXf hf = encode_frames<float>(skel_, h);
    const MatrixXf hn = vae_.history_stats.normalize(Eigen::Map<const MatrixXf>(hf.data(), hf.size(), 1));
    const MatrixXf z = sample_latents(text_features(c), hn, rng);
    const MatrixXf fut = vae_.future_stats.denormalize(vae_.decode(hn, z));
    return decode_frames<float>(skel_, Eigen::Map<const MatrixXf>(fut.data(), vae_.frame_dim(), future_frames()), h.fps);
  }

  // ---- pieces ---------------------------------------------------------------------------------
  /// Text features (K): the condition's embedding when given, else hashed features of the text
  /// (zeros for an empty prompt = unconditional) — of the text as the prompt mapper maps it when one
  /// is set (throws, naming the prompt, when none of its words is known or maps onto one).
  VectorXf text_features(const TextCondition& c) const {
    if (c.embedding.size() > 0) {
      require(c.embedding.size() == config_.denoiser.text_features,
              "text embedding has " + std::to_string(c.embedding.size()) + " values, the generator expects " +
                  std::to_string(config_.denoiser.text_features), {{}, {}, "embedding"});
      require_finite(c.embedding, "embedding");
      return c.embedding;
    }
    return text_.features(conditioning_text(c.text));
  }

  /// The text a prompt is featurised as. Without a prompt mapper, or when every word of the prompt
  /// is known: the prompt itself. Otherwise the prompt *lands* on a training text and is
  /// conditioned on it (the generator was trained on those texts only): among the training texts
  /// the mapped prompt shares most weighted words with (`PromptVocabularyMapper::lexical_landing`),
  /// the one whose learned embedding is nearest by cosine to the mapped prompt's (ties: the first);
  /// when it shares no word with any, the mapped prompt itself (featurised as it is). Throws, naming
  /// the prompt, when none of its words is known or maps onto one.
  std::string conditioning_text(const std::string& prompt) const {
    if (!prompt_mapper_) return prompt;
    const PromptMapping m = prompt_mapper_->map(prompt);
    if (!m.changed()) return prompt;
    const LexicalLanding l = prompt_mapper_->lexical_landing(m.text);
    const auto& texts = prompt_mapper_->training_texts();
    if (l.texts.empty()) return m.text;
    if (l.texts.size() == 1) return texts[l.texts.front()];
    std::vector<std::string> tied;
    for (const std::size_t i : l.texts) tied.push_back(texts[i]);
    return tied[nearest_by_embedding(text_embedding(m.text), tied).first];
  }

  /// The learned embedding (E) of `text`'s hashed features, as given (no prompt mapping).
  VectorXf text_embedding(const std::string& text) const { return denoiser_.embed(text_.features(text)); }

  /// The text of `candidates` whose `text_embedding` is nearest to `e` (E) by cosine, ties the
  /// first: (index, cosine).
  std::pair<std::size_t, double> nearest_by_embedding(const VectorXf& e, const std::vector<std::string>& candidates) const {
    require(!candidates.empty(), "no candidate texts", {{}, {}, "candidates"});
    std::size_t best = 0;
    double best_c = -2.0;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      const VectorXf f = text_embedding(candidates[i]);
      const double c = static_cast<double>(e.dot(f)) / std::max(1e-12, static_cast<double>(e.norm() * f.norm()));
      if (c > best_c) {
        best_c = c;
        best = i;
      }
    }
    return {best, best_c};
  }

  /// VAE latents (L × B) for normalised histories hn (H·D × B) and text features (K × 1 or K × B):
  /// guided DDPM, rescaled by latent_scale. An all-zero text feature column is sampled
  /// unconditionally (no guidance).
  MatrixXf sample_latents(const Eigen::Ref<const MatrixXf>& text_features, const Eigen::Ref<const MatrixXf>& hn,
                          Rng& rng) const {
    const Index B = hn.cols();
    require(text_features.cols() == 1 || text_features.cols() == B, "one text per batch column (or one for all)",
            {{}, {}, "text_features"});
    MatrixXf tf = text_features.cols() == B ? MatrixXf(text_features) : MatrixXf(text_features.replicate(1, B));
    const MatrixXf e = denoiser_.embed(tf);
    const MatrixXf zero = MatrixXf::Zero(e.rows(), B);
    const bool unconditional = tf.cwiseAbs().maxCoeff() == 0.0f;
    const double w = config_.guidance;
    auto predict = [&](const MatrixXf& xt, int t) -> MatrixXf {
      const MatrixXf cond = denoiser_.predict(xt, t, unconditional ? zero : e, hn);
      if (unconditional || w == 1.0) return cond;
      return guided_prediction<float>(cond, denoiser_.predict(xt, t, zero, hn), w);
    };
    if (config_.temperature == 1.0) return latent_scale_ * ddpm_sample<float>(schedule_, vae_.latent_dim(), B, predict, rng);
    // ddpm_sample with the noise scaled by τ (same draws from rng, in the same order)
    const float tau = static_cast<float>(config_.temperature);
    MatrixXf x(vae_.latent_dim(), B);
    for (Index j = 0; j < B; ++j)
      for (Index i = 0; i < x.rows(); ++i) x(i, j) = tau * static_cast<float>(rng.normal());
    for (int t = schedule_.num_steps() - 1; t >= 0; --t) {
      const MatrixXf x0_hat = predict(x, t);
      require_finite(x0_hat, "x0_hat");
      MatrixXf next = posterior_mean<float>(schedule_, t, x0_hat, x);
      if (t > 0) {
        const float sigma = tau * static_cast<float>(std::sqrt(schedule_.posterior_variance[t]));
        for (Index j = 0; j < B; ++j)
          for (Index i = 0; i < next.rows(); ++i) next(i, j) += sigma * static_cast<float>(rng.normal());
      }
      x = std::move(next);
    }
    return latent_scale_ * x;
  }

  // ---- persistence ---------------------------------------------------------------------------
  void save(const std::filesystem::path& path) const {
    Checkpoint ck;
    ck.put_string("generator.format", "maskadapt.builtin_generator.v1");
    ck.put_string("generator.config", config_json().dump());
    ck.put("vae.encoder", vae_.encoder().params());
    ck.put("vae.decoder", vae_.decoder().params());
    ck.put("denoiser.projection", denoiser_.projection().params());
    ck.put("denoiser.net", denoiser_.network().params());
    ck.put("vae.history_mean", vae_.history_stats.mean);
    ck.put("vae.history_std", vae_.history_stats.std);
    ck.put("vae.future_mean", vae_.future_stats.mean);
    ck.put("vae.future_std", vae_.future_stats.std);
    ck.put_double("latent_scale", latent_scale_);
    if (!arms_pool_.empty()) ck.put_string("generator.arms_pool", nlohmann::json(arms_pool_).dump());
    if (!provenance_.empty()) ck.put_string("generator.provenance", provenance_.dump());
    if (!training_labels_.empty()) ck.put_string("generator.training_labels", nlohmann::json(training_labels_).dump());
    save_checkpoint(path, ck);
  }

  /// Loads a generator saved by save(); `skel` must be the skeleton it was trained on (checked
  /// by body names). Every problem throws Error naming the file and section.
  static BuiltinGenerator load(const std::filesystem::path& path, const Skeleton& skel) {
    const Checkpoint ck = load_checkpoint(path);
    const std::string file = path.string();
    require(ck.get_string("generator.format") == "maskadapt.builtin_generator.v1", "not a built-in generator checkpoint",
            {file, {}, "generator.format"});
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(ck.get_string("generator.config"));
    } catch (const std::exception& e) {
      throw Error(std::string("malformed generator config: ") + e.what(), {file, {}, "generator.config"});
    }
    BuiltinGeneratorConfig c;
    std::vector<std::string> names;
    try {
      c.vae.history = j.at("history").get<Index>();
      c.vae.future = j.at("future").get<Index>();
      c.vae.latent = j.at("latent").get<Index>();
      c.vae.hidden = j.at("vae_hidden").get<std::vector<Index>>();
      c.vae.activation = nn::activation_from_string(j.at("vae_activation").get<std::string>());
      c.vae.kl_weight = j.at("kl_weight").get<double>();
      c.denoiser.text_features = j.at("text_features").get<Index>();
      c.denoiser.text_embed = j.at("text_embed").get<Index>();
      c.denoiser.time_embed = j.at("time_embed").get<Index>();
      c.denoiser.hidden = j.at("denoiser_hidden").get<std::vector<Index>>();
      c.denoiser.activation = nn::activation_from_string(j.at("denoiser_activation").get<std::string>());
      c.denoiser.cond_dropout = j.at("cond_dropout").get<double>();
      c.diffusion_steps = j.at("diffusion_steps").get<int>();
      c.guidance = j.at("guidance").get<double>();
      c.temperature = j.value("temperature", 1.0);  // absent in files written before it existed
      names = j.at("bodies").get<std::vector<std::string>>();
    } catch (const Error&) {
      throw;
    } catch (const std::exception& e) {
      throw Error(std::string("bad generator config: ") + e.what(), {file, {}, "generator.config"});
    }
    require(names == skel.names, "checkpoint was trained on another skeleton", {file, {}, "generator.config.bodies"});
    require(c.temperature > 0 && c.temperature <= 1, "temperature must lie in (0, 1]", {file, {}, "generator.config.temperature"});
    Rng rng(0);
    BuiltinGenerator g(skel, c, rng);
    // Read everything first (validated), then assign.
    const VectorXf enc = ck.get_vector<float>("vae.encoder", g.vae_.encoder().num_params());
    const VectorXf dec = ck.get_vector<float>("vae.decoder", g.vae_.decoder().num_params());
    const VectorXf proj = ck.get_vector<float>("denoiser.projection", g.denoiser_.projection().num_params());
    const VectorXf net = ck.get_vector<float>("denoiser.net", g.denoiser_.network().num_params());
    const Index hd = g.vae_.history_dim(), fd = g.vae_.future_dim();
    FeatureStats hs{ck.get_vector<float>("vae.history_mean", hd), ck.get_vector<float>("vae.history_std", hd)};
    FeatureStats fs{ck.get_vector<float>("vae.future_mean", fd), ck.get_vector<float>("vae.future_std", fd)};
    const double scale = ck.get_double("latent_scale");
    for (const VectorXf* v : std::initializer_list<const VectorXf*>{&enc, &dec, &proj, &net, &hs.mean, &hs.std, &fs.mean, &fs.std})
      require_finite(*v, "parameters", file);
    require((hs.std.array() > 0).all() && (fs.std.array() > 0).all(), "statistics have a non-positive std",
            {file, {}, "vae.history_std"});
    require(std::isfinite(scale) && scale > 0, "latent scale must be positive", {file, {}, "latent_scale"});
    g.vae_.encoder().params() = enc;
    g.vae_.decoder().params() = dec;
    g.denoiser_.projection().params() = proj;
    g.denoiser_.network().params() = net;
    g.vae_.history_stats = std::move(hs);
    g.vae_.future_stats = std::move(fs);
    g.latent_scale_ = static_cast<float>(scale);
    try {
      if (ck.contains("generator.arms_pool"))
        g.arms_pool_ = nlohmann::json::parse(ck.get_string("generator.arms_pool")).get<std::vector<std::string>>();
      if (ck.contains("generator.provenance")) g.provenance_ = nlohmann::json::parse(ck.get_string("generator.provenance"));
    } catch (const std::exception& e) {
      throw Error(std::string("malformed optional section: ") + e.what(), {file, {}, "generator.arms_pool/provenance"});
    }
    if (ck.contains("generator.training_labels")) {
      try {
        g.training_labels_ =
            nlohmann::json::parse(ck.get_string("generator.training_labels")).get<std::vector<std::vector<std::string>>>();
      } catch (const std::exception& e) {
        throw Error(std::string("malformed training labels (a JSON list of lists of texts): ") + e.what(),
                    {file, {}, "generator.training_labels"});
      }
    }
    require(g.provenance_.is_null() || g.provenance_.is_object(), "provenance must be a JSON object",
            {file, {}, "generator.provenance"});
    return g;
  }

  /// Sizes and settings as JSON (what save() stores).
  nlohmann::json config_json() const {
    return {{"history", config_.vae.history},
            {"future", config_.vae.future},
            {"latent", config_.vae.latent},
            {"vae_hidden", config_.vae.hidden},
            {"vae_activation", std::string(nn::to_string(config_.vae.activation))},
            {"kl_weight", config_.vae.kl_weight},
            {"text_features", config_.denoiser.text_features},
            {"text_embed", config_.denoiser.text_embed},
            {"time_embed", config_.denoiser.time_embed},
            {"denoiser_hidden", config_.denoiser.hidden},
            {"denoiser_activation", std::string(nn::to_string(config_.denoiser.activation))},
            {"cond_dropout", config_.denoiser.cond_dropout},
            {"diffusion_steps", config_.diffusion_steps},
            {"guidance", config_.guidance},
            {"temperature", config_.temperature},
            {"bodies", skel_.names}};
  }

  const BuiltinGeneratorConfig& config() const { return config_; }
  BuiltinGeneratorConfig& config() { return config_; }  ///< e.g. change the guidance weight
  MotionVae& vae() { return vae_; }
  const MotionVae& vae() const { return vae_; }
  LatentDenoiser& denoiser() { return denoiser_; }
  const LatentDenoiser& denoiser() const { return denoiser_; }
  const NoiseSchedule& schedule() const { return schedule_; }
  const HashedTextFeatures& text_encoder() const { return text_; }
  /// The arms prompts the generator was trained on (empty for older checkpoints).
  const std::vector<std::string>& arms_pool() const { return arms_pool_; }
  void set_arms_pool(std::vector<std::string> p) { arms_pool_ = std::move(p); }
  /// The label sets it was trained on (each a list of texts; `train_generator` records them; empty
  /// for checkpoints written before issue 42, such as the shipped one).
  const std::vector<std::vector<std::string>>& training_labels() const { return training_labels_; }
  void set_training_labels(std::vector<std::vector<std::string>> l) { training_labels_ = std::move(l); }
  /// Maps prompts' unseen words onto the training vocabulary before featurisation (null: off, the
  /// prompt is hashed as given). Shared, immutable: safe from several threads.
  void set_prompt_mapper(std::shared_ptr<const PromptVocabularyMapper> m) { prompt_mapper_ = std::move(m); }
  const PromptVocabularyMapper* prompt_mapper() const { return prompt_mapper_.get(); }
  /// How it was trained (JSON object; null for older checkpoints).
  const nlohmann::json& provenance() const { return provenance_; }
  void set_provenance(nlohmann::json p) {
    require(p.is_object(), "provenance must be a JSON object", {{}, {}, "provenance"});
    provenance_ = std::move(p);
  }
  /// Latents are divided by this before diffusion (std of the training latents).
  float latent_scale() const { return latent_scale_; }
  void set_latent_scale(float s) {
    require(std::isfinite(s) && s > 0.0f, "latent scale must be positive", {{}, {}, "latent_scale"});
    latent_scale_ = s;
  }

 private:
  Skeleton skel_;
  BuiltinGeneratorConfig config_;
  HashedTextFeatures text_{256};
  MotionVae vae_;
  LatentDenoiser denoiser_;
  NoiseSchedule schedule_;
  float latent_scale_ = 1.0f;
  std::vector<std::string> arms_pool_;
  nlohmann::json provenance_;
  std::vector<std::vector<std::string>> training_labels_;
  std::shared_ptr<const PromptVocabularyMapper> prompt_mapper_;
};

static_assert(TrajectoryGenerator<BuiltinGenerator>);

struct GeneratorTrainConfig {
  Index vae_iterations = 2000;
  Index diffusion_iterations = 2000;
  double max_seconds = 0.0;  ///< > 0: wall-clock budget, split 50/50 between the stages (iterations become caps)
  Index batch = 64;
  double lr = 1e-3;
  double max_grad_norm = 1.0;
  Index log_every = 100;
  /// Stage 2: the share of every batch drawn from the dataset's transition windows (a behaviour
  /// switching, e.g. walking arms → waving; `PrimitiveDataset::transition`), the rest uniformly
  /// from all windows. 0 (default): uniform. The generator is asked for exactly these moments —
  /// a prompt applied to a history that shows something else — and they are ~10 % of the windows
  /// (4,732 of 47,768 in the arm-switch corpus).
  double transition_fraction = 0.0;
  /// Stage 2: exponential moving average of the denoiser's weights (projection and network),
  /// θ̄ ← d·θ̄ + (1 − d)·θ after every step, with d warmed up as min(d, (1 + it) / (10 + it)). The
  /// generator keeps θ̄ (or the selected snapshot of it), not the last θ. 0: off (the last weights).
  double ema_decay = 0.0;
  /// Stage 2: every `select_every` iterations (and after the last) the weights the generator would
  /// keep are scored by `select` (a held-out measure, higher is better) and the best are kept:
  /// early stopping without stopping. 0: off.
  Index select_every = 0;
};

/// One scored snapshot of stage 2 (`GeneratorTrainConfig::select_every`).
struct GeneratorSnapshotScore {
  Index iteration = 0;
  double score = 0.0;
};

struct GeneratorTrainReport {
  Index vae_iterations = 0, diffusion_iterations = 0;
  double vae_seconds = 0.0, diffusion_seconds = 0.0;
  VaeLosses vae_final;              ///< mean over the last log window
  double diffusion_final = 0.0;     ///< mean x₀ loss over the last log window
  std::vector<GeneratorSnapshotScore> snapshots;  ///< scored snapshots, in order (selection on)
  Index selected_iteration = 0;     ///< the snapshot kept (selection on); else the last iteration
  double select_seconds = 0.0;      ///< time spent scoring (not part of diffusion_seconds' budget check)
};

/// The distinct non-empty label sets among `sets` (each a list of texts naming one behaviour), in
/// order of first use: a generator's vocabulary. `train_generator` records those of its dataset's
/// `label_texts`; prompt_words.hpp derives them from clips for checkpoints without that record.
inline std::vector<std::vector<std::string>> distinct_label_sets(const std::vector<std::vector<std::string>>& sets) {
  std::vector<std::vector<std::string>> out;
  for (const auto& texts : sets)
    if (!texts.empty() && std::find(out.begin(), out.end(), texts) == out.end()) out.push_back(texts);
  return out;
}

/// Scores a generator for `GeneratorTrainConfig::select_every` (higher is better).
using GeneratorScore = std::function<double(const BuiltinGenerator&)>;

/// Trains `g` on `data` (windows of g's H and F frames). `log` receives progress lines.
inline GeneratorTrainReport train_generator(BuiltinGenerator& g, const PrimitiveDataset& data,
                                            const GeneratorTrainConfig& cfg, Rng& rng,
                                            const std::function<void(const std::string&)>& log = {},
                                            const GeneratorScore& select = {}) {
  require(data.history_frames == g.history_frames() && data.future_frames == g.future_frames() &&
              data.frame_dim == g.vae().frame_dim(),
          "dataset windows do not match the generator's H, F or frame size", {{}, {}, "dataset"});
  require(data.size() >= 1 && cfg.batch >= 1, "need data and a positive batch", {{}, {}, "batch"});
  require(cfg.transition_fraction >= 0.0 && cfg.transition_fraction <= 1.0, "transition_fraction must lie in [0, 1]",
          {{}, {}, "transition_fraction"});
  require(cfg.ema_decay >= 0.0 && cfg.ema_decay < 1.0, "ema_decay must lie in [0, 1)", {{}, {}, "ema_decay"});
  require(cfg.select_every >= 0, "select_every must be ≥ 0", {{}, {}, "select_every"});
  require(cfg.select_every == 0 || static_cast<bool>(select), "select_every needs a score function", {{}, {}, "select"});
  using clock = std::chrono::steady_clock;
  auto say = [&](const std::string& s) { if (log) log(s); };
  GeneratorTrainReport rep;
  MotionVae& vae = g.vae();
  vae.history_stats = FeatureStats::of(data.history);
  vae.future_stats = FeatureStats::of(data.future);
  const MatrixXf hn_all = vae.history_stats.normalize(data.history);
  const MatrixXf fn_all = vae.future_stats.normalize(data.future);
  nn::AdamConfig ac;
  ac.lr = cfg.lr;
  ac.max_grad_norm = cfg.max_grad_norm;
  const double stage_budget = cfg.max_seconds > 0 ? 0.5 * cfg.max_seconds : 0.0;
  const Index log_every = std::max<Index>(1, cfg.log_every);

  // Stage 1: VAE.
  {
    nn::Adam<float> adam(ac);
    const auto t0 = clock::now();
    VaeLosses acc;
    Index n_acc = 0;
    for (Index it = 0; it < cfg.vae_iterations; ++it) {
      const double el = std::chrono::duration<double>(clock::now() - t0).count();
      if (stage_budget > 0 && el > stage_budget) break;
      const auto idx = sample_indices(data.size(), cfg.batch, rng);
      const VaeLosses l = vae.train_step(gather_columns(hn_all, idx), gather_columns(fn_all, idx), adam, rng);
      acc.recon += l.recon; acc.kl += l.kl; acc.total += l.total; ++n_acc;
      ++rep.vae_iterations;
      if ((it + 1) % log_every == 0 || it + 1 == cfg.vae_iterations) {
        rep.vae_final = {acc.recon / n_acc, acc.kl / n_acc, acc.total / n_acc};
        say("vae " + std::to_string(it + 1) + ": recon " + std::to_string(rep.vae_final.recon) + " kl " +
            std::to_string(rep.vae_final.kl));
        acc = {};
        n_acc = 0;
      }
    }
    if (n_acc > 0) rep.vae_final = {acc.recon / n_acc, acc.kl / n_acc, acc.total / n_acc};
    rep.vae_seconds = std::chrono::duration<double>(clock::now() - t0).count();
  }

  // Stage 2: latent diffusion on the frozen VAE's posteriors.
  {
    const auto [mu, logvar] = vae.encode(hn_all, fn_all);
    const MatrixXf sigma = (0.5f * logvar.array()).exp().matrix();
    const double var = (mu.array().square().mean() + sigma.array().square().mean());
    g.set_latent_scale(static_cast<float>(std::sqrt(std::max(var, 1e-8))));
    const float inv_scale = 1.0f / g.latent_scale();
    // Text features of every description, per label set (a clip's texts or a segment's).
    require(data.label.size() == static_cast<std::size_t>(data.size()), "dataset has no per-window labels",
            {{}, {}, "dataset.label"});
    std::vector<std::vector<VectorXf>> label_feats(data.label_texts.size());
    g.set_training_labels(distinct_label_sets(data.label_texts));  // its vocabulary ("generator.training_labels")
    for (std::size_t c = 0; c < data.label_texts.size(); ++c)
      for (const auto& t : data.label_texts[c]) label_feats[c].push_back(g.text_encoder().features(t));
    nn::Adam<float> adam(ac);
    const auto t0 = clock::now();
    double acc = 0.0;
    Index n_acc = 0;
    const Index K = g.denoiser().config().text_features, L = vae.latent_dim();
    std::vector<Index> transitions;
    for (std::size_t n = 0; n < data.transition.size(); ++n)
      if (data.transition[n]) transitions.push_back(static_cast<Index>(n));
    const double oversample = transitions.empty() ? 0.0 : cfg.transition_fraction;
    // The weights kept: the EMA θ̄ when on, else θ. `with_kept_weights` swaps them into g for scoring.
    auto& proj = g.denoiser().projection().block();
    auto& net = g.denoiser().network().block();
    VectorXf ema_proj = proj.params(), ema_net = net.params();
    VectorXf best_proj, best_net;
    double best_score = -std::numeric_limits<double>::infinity();
    auto with_kept_weights = [&](const auto& fn) {
      if (cfg.ema_decay > 0) {
        VectorXf live_proj = proj.params(), live_net = net.params();
        proj.params() = ema_proj;
        net.params() = ema_net;
        fn();
        proj.params() = live_proj;
        net.params() = live_net;
      } else {
        fn();
      }
    };
    auto score_snapshot = [&](Index iteration) {
      const auto s0 = clock::now();
      with_kept_weights([&] {
        const double sc = select(g);
        rep.snapshots.push_back({iteration, sc});
        if (sc > best_score) {
          best_score = sc;
          best_proj = proj.params();
          best_net = net.params();
          rep.selected_iteration = iteration;
        }
        say("diffusion " + std::to_string(iteration) + ": held-out score " + std::to_string(sc) +
            (rep.selected_iteration == iteration ? " (best so far)" : ""));
      });
      rep.select_seconds += std::chrono::duration<double>(clock::now() - s0).count();
    };
    for (Index it = 0; it < cfg.diffusion_iterations; ++it) {
      // (time spent scoring, rep.select_seconds, is not charged to the stage's budget)
      const double el = std::chrono::duration<double>(clock::now() - t0).count() - rep.select_seconds;
      if (stage_budget > 0 && el > stage_budget) break;
      auto idx = sample_indices(data.size(), cfg.batch, rng);
      if (oversample > 0)
        for (auto& i : idx)
          if (rng.bernoulli(oversample)) i = transitions[rng.uniform_int(transitions.size())];
      MatrixXf x0(L, cfg.batch), tf = MatrixXf::Zero(K, cfg.batch);
      for (Index j = 0; j < cfg.batch; ++j) {
        const Index n = idx[static_cast<std::size_t>(j)];
        for (Index i = 0; i < L; ++i) x0(i, j) = (mu(i, n) + sigma(i, n) * static_cast<float>(rng.normal())) * inv_scale;
        const auto& feats = label_feats[static_cast<std::size_t>(data.label[static_cast<std::size_t>(n)])];
        if (!feats.empty()) tf.col(j) = feats[rng.uniform_int(feats.size())];
      }
      acc += g.denoiser().train_step(g.schedule(), x0, tf, gather_columns(hn_all, idx), adam, rng);
      if (cfg.ema_decay > 0) {
        const float d = static_cast<float>(std::min(cfg.ema_decay, (1.0 + static_cast<double>(it)) / (10.0 + static_cast<double>(it))));
        ema_proj = d * ema_proj + (1.0f - d) * proj.params();
        ema_net = d * ema_net + (1.0f - d) * net.params();
      }
      ++n_acc;
      ++rep.diffusion_iterations;
      if ((it + 1) % log_every == 0 || it + 1 == cfg.diffusion_iterations) {
        rep.diffusion_final = acc / n_acc;
        say("diffusion " + std::to_string(it + 1) + ": x0 loss " + std::to_string(rep.diffusion_final));
        acc = 0.0;
        n_acc = 0;
      }
      if (cfg.select_every > 0 && (it + 1) % cfg.select_every == 0 && it + 1 < cfg.diffusion_iterations)
        score_snapshot(it + 1);
    }
    if (n_acc > 0) rep.diffusion_final = acc / n_acc;
    if (cfg.select_every > 0 && (rep.snapshots.empty() || rep.snapshots.back().iteration != rep.diffusion_iterations))
      score_snapshot(rep.diffusion_iterations);
    if (cfg.select_every > 0) {
      proj.params() = best_proj;
      net.params() = best_net;
    } else {
      rep.selected_iteration = rep.diffusion_iterations;
      if (cfg.ema_decay > 0) {
        proj.params() = ema_proj;
        net.params() = ema_net;
      }
    }
    rep.diffusion_seconds = std::chrono::duration<double>(clock::now() - t0).count() - rep.select_seconds;
  }
  return rep;
}

}  // namespace maskadapt::tracking
