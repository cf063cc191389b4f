#pragma once
/// \file arm_eval.hpp
/// Does a generator follow its arms prompt? A deliberately simple probe.
///
/// Arm features of a frame (12): the positions of L_Elbow, R_Elbow, L_Wrist, R_Wrist relative to
/// the pelvis, in the pelvis's heading frame (x forward, y left, z up; m). A span of frames is
/// summarised by the mean, the standard deviation, the minimum and the maximum over time of each
/// (48 values: `arm_summary`). `ArmClassifier` z-scores the summaries (per-dimension std over all
/// training samples) and assigns a class by one of three simple rules (`ArmProbe`): nearest class
/// mean, LDA (nearest mean in the metric of the pooled within-class covariance) or k nearest
/// neighbours.
///
/// `evaluate_prompts`: for every prompt, N rollouts of the generator from walking histories
/// (sample i: history i mod K, seed base + i), `lead_s` seconds to transition, then `span_s`
/// seconds classified (optionally after `before_s` seconds of another prompt, e.g. "walk": the
/// schedule "0:walk,2:wave right hand"). Reports the confusion matrix (rows: prompt, columns: predicted class),
/// accuracy per prompt, and diversity: the mean over pairs of samples with the same history and
/// prompt (so they differ only by the seed) of the RMS distance between their arm-feature
/// sequences (m).
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/tracking/arm_data.hpp>
#include <maskadapt/tracking/builtin_generator.hpp>
#include <maskadapt/tracking/generator.hpp>
#include <maskadapt/tracking/primitive_dataset.hpp>
#include <maskadapt/humanoid/synthetic.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace maskadapt::tracking {

inline constexpr Index kArmFeatureDim = 12;  ///< per frame
inline constexpr Index kArmSummaryDim = 48;  ///< mean, std, min, max over a span

/// Arm features (12 × n) of frames [begin, begin + n) of t (body_pos filled; see file comment).
inline MatrixXd arm_features(const Skeleton& skel, const Trajectory& t, Index begin, Index n) {
  require(begin >= 0 && n >= 1 && begin + n <= t.num_frames(), "arm feature span out of range", {{}, {}, "span"});
  require(t.body_pos.rows() == 3 * skel.num_bodies(), "trajectory has no body positions", {{}, {}, "body_pos"});
  const int bodies[4] = {skel.index_of("L_Elbow"), skel.index_of("R_Elbow"), skel.index_of("L_Wrist"),
                         skel.index_of("R_Wrist")};
  MatrixXd f(kArmFeatureDim, n);
  for (Index j = 0; j < n; ++j) {
    const Index i = begin + j;
    const double yaw = heading_angle(t.root_rot[static_cast<std::size_t>(i)]);
    const Eigen::Matrix3d Rt = Eigen::AngleAxisd(-yaw, Vec3::UnitZ()).toRotationMatrix();
    const Vec3 pelvis = t.body_pos.block<3, 1>(0, i);
    for (int k = 0; k < 4; ++k) f.block<3, 1>(3 * k, j) = Rt * (t.body_pos.block<3, 1>(3 * bodies[k], i) - pelvis);
  }
  return f;
}

/// What the issue-42 bars read from a span of frames (body_pos filled). Heights are world z
/// differences (m); the walking figures come from the root.
struct ArmWindowStats {
  double wrist_max = 0;        ///< max over the span and both wrists of the wrist's height above the pelvis (m)
  double wrist_range = 0;      ///< max − min over the span of that height, for the wrist that reaches highest (m)
  double wrist_freq = 0;       ///< that wrist's height: crossings of its span mean / (2 · span duration) (Hz)
  double right_over_head = 0;  ///< max over the span of R_Wrist z − Head z (m; > 0: the right wrist above the head)
  double left_over_head = 0;   ///< the same for L_Wrist (m)
  double pelvis_height = 0;    ///< mean root z (m)
  double speed = 0;            ///< net horizontal root displacement over the span / its duration (m/s)
};

/// Statistics of frames [begin, begin + n) of t (n ≥ 2; see ArmWindowStats).
inline ArmWindowStats window_stats(const Skeleton& skel, const Trajectory& t, Index begin, Index n) {
  require(begin >= 0 && n >= 2 && begin + n <= t.num_frames(), "window statistics need a span of ≥ 2 frames inside the trajectory",
          {{}, {}, "span"});
  require(t.body_pos.rows() == 3 * skel.num_bodies(), "trajectory has no body positions", {{}, {}, "body_pos"});
  const int lw = skel.index_of("L_Wrist"), rw = skel.index_of("R_Wrist"), head = skel.index_of("Head");
  const int pelvis = 0;
  const auto z = [&](int b, Index i) { return t.body_pos(3 * b + 2, begin + i); };
  VectorXd hl(n), hr(n);  // wrist heights above the pelvis (m), (n)
  ArmWindowStats s;
  s.right_over_head = s.left_over_head = -1e9;
  for (Index i = 0; i < n; ++i) {
    hl[i] = z(lw, i) - z(pelvis, i);
    hr[i] = z(rw, i) - z(pelvis, i);
    s.right_over_head = std::max(s.right_over_head, z(rw, i) - z(head, i));
    s.left_over_head = std::max(s.left_over_head, z(lw, i) - z(head, i));
    s.pelvis_height += t.root_pos(2, begin + i) / static_cast<double>(n);
  }
  const VectorXd& h = hl.maxCoeff() >= hr.maxCoeff() ? hl : hr;
  s.wrist_max = h.maxCoeff();
  s.wrist_range = h.maxCoeff() - h.minCoeff();
  const double mean = h.mean();
  int crossings = 0;
  for (Index i = 1; i < n; ++i) crossings += (h[i - 1] - mean) * (h[i] - mean) < 0 ? 1 : 0;
  const double duration = static_cast<double>(n - 1) / t.fps;
  s.wrist_freq = crossings / (2.0 * duration);
  s.speed = (t.root_pos.block<2, 1>(0, begin + n - 1) - t.root_pos.block<2, 1>(0, begin)).norm() / duration;
  return s;
}

/// Mean, std, minimum and maximum over time (48) of arm features (12 × n).
inline VectorXd arm_summary(const MatrixXd& f) {
  VectorXd s(kArmSummaryDim);
  const VectorXd mean = f.rowwise().mean();
  s.segment(0, kArmFeatureDim) = mean;
  s.segment(kArmFeatureDim, kArmFeatureDim) = ((f.colwise() - mean).array().square().rowwise().mean()).sqrt().matrix();
  s.segment(2 * kArmFeatureDim, kArmFeatureDim) = f.rowwise().minCoeff();
  s.segment(3 * kArmFeatureDim, kArmFeatureDim) = f.rowwise().maxCoeff();
  return s;
}

/// The arm probes. All z-score the summaries (per-dimension std over the training samples).
///  - NearestMean: the class whose mean is nearest (Euclidean).
///  - Lda: the nearest class mean after whitening by the pooled within-class covariance, shrunk
///    towards its diagonal by `shrinkage` (linear discriminant analysis with equal priors).
///  - NearestNeighbours: the majority class of the `k` nearest training samples (ties: the class
///    with the smaller index).
enum class ArmProbe { NearestMean, Lda, NearestNeighbours };

/// The default, 1-nearest neighbour, is the rule that recovered most held-out real windows of
/// walks with switched arms (95.4 % over five held-out sets; nearest mean 78.6 %, LDA 0.05
/// 93.9 %: docs/generator.md "Choosing the probe").
struct ArmProbeConfig {
  ArmProbe kind = ArmProbe::NearestNeighbours;
  double shrinkage = 0.1;  ///< Lda: weight of the diagonal, in [0, 1]
  int k = 1;               ///< NearestNeighbours
  std::string name() const {
    switch (kind) {
      case ArmProbe::NearestMean: return "nearest class mean";
      case ArmProbe::Lda: return "LDA (shrinkage " + std::to_string(shrinkage).substr(0, 4) + ")";
      case ArmProbe::NearestNeighbours: return std::to_string(k) + "-nearest neighbour" + (k > 1 ? "s" : "");
    }
    return "?";
  }
};

/// "nearest-mean", "lda" / "lda:SHRINKAGE", "knn" / "knn:K" (K ≥ 1) → the probe; anything else
/// throws naming `field` (a flag, say).
inline ArmProbeConfig parse_arm_probe(const std::string& text, const std::string& field = "probe") {
  ArmProbeConfig c;
  const auto colon = text.find(':');
  const std::string kind = text.substr(0, colon), arg = colon == std::string::npos ? "" : text.substr(colon + 1);
  const auto number = [&](double lo, double hi) {
    char* end = nullptr;
    const double v = std::strtod(arg.c_str(), &end);
    require(!arg.empty() && end && *end == '\0' && std::isfinite(v) && v >= lo && v <= hi,
            "'" + text + "': the value after ':' must be a number in [" + std::to_string(lo).substr(0, 3) + ", " +
                (std::isfinite(hi) ? std::to_string(hi).substr(0, 3) : std::string("∞")) + "]",
            {{}, {}, field});
    return v;
  };
  if (kind == "nearest-mean" && colon == std::string::npos) {
    c.kind = ArmProbe::NearestMean;
  } else if (kind == "lda") {
    c.kind = ArmProbe::Lda;
    if (colon != std::string::npos) c.shrinkage = number(0.0, 1.0);
  } else if (kind == "knn") {
    c.kind = ArmProbe::NearestNeighbours;
    if (colon != std::string::npos) {
      const double k = number(1.0, 1e6);
      require(k == std::floor(k), "'" + text + "': k must be a whole number", {{}, {}, field});
      c.k = static_cast<int>(k);
    }
  } else {
    throw Error("'" + text + "' is not a probe (nearest-mean, lda[:SHRINKAGE], knn[:K])", {{}, {}, field});
  }
  return c;
}

class ArmClassifier {
 public:
  ArmClassifier() = default;
  /// x: (48 × N) summaries, y: (N) class indices in [0, num_classes). Every class needs a sample.
  ArmClassifier(const MatrixXd& x, const std::vector<int>& y, int num_classes, const ArmProbeConfig& cfg = {})
      : cfg_(cfg) {
    require(x.cols() == static_cast<Index>(y.size()) && x.cols() > 0 && num_classes > 0, "classifier: bad training set",
            {{}, {}, "samples"});
    require(cfg.shrinkage >= 0 && cfg.shrinkage <= 1 && cfg.k >= 1, "classifier: shrinkage in [0, 1] and k ≥ 1",
            {{}, {}, "ArmProbeConfig"});
    mean_ = x.rowwise().mean();
    scale_ = ((x.colwise() - mean_).array().square().rowwise().mean()).sqrt().matrix().cwiseMax(1e-3);
    MatrixXd z = standardise(x);
    means_ = MatrixXd::Zero(x.rows(), num_classes);
    std::vector<int> count(static_cast<std::size_t>(num_classes), 0);
    for (Index j = 0; j < x.cols(); ++j) {
      const int c = y[static_cast<std::size_t>(j)];
      require(c >= 0 && c < num_classes, "classifier: class index out of range", {{}, {}, "labels"});
      means_.col(c) += z.col(j);
      ++count[static_cast<std::size_t>(c)];
    }
    for (int c = 0; c < num_classes; ++c) {
      require(count[static_cast<std::size_t>(c)] > 0, "classifier: class " + std::to_string(c) + " has no sample",
              {{}, {}, "labels"});
      means_.col(c) /= count[static_cast<std::size_t>(c)];
    }
    if (cfg.kind == ArmProbe::Lda) {
      MatrixXd r = z;  // within-class residuals
      for (Index j = 0; j < z.cols(); ++j) r.col(j) -= means_.col(y[static_cast<std::size_t>(j)]);
      MatrixXd cov = r * r.transpose() / static_cast<double>(z.cols());
      const VectorXd diag = cov.diagonal().cwiseMax(1e-6);
      cov = (1.0 - cfg.shrinkage) * cov;
      cov.diagonal() += cfg.shrinkage * diag;
      const Eigen::LLT<MatrixXd> llt(cov);
      require(llt.info() == Eigen::Success, "classifier: the within-class covariance is singular (raise the shrinkage)",
              {{}, {}, "shrinkage"});
      whiten_ = llt.matrixL().solve(MatrixXd::Identity(cov.rows(), cov.cols()));  // L⁻¹: ‖L⁻¹v‖² = vᵀΣ⁻¹v
      means_ = whiten_ * means_;
    }
    if (cfg.kind == ArmProbe::NearestNeighbours) {
      samples_ = std::move(z);
      labels_ = y;
    }
  }
  int num_classes() const { return static_cast<int>(means_.cols()); }
  const ArmProbeConfig& config() const { return cfg_; }
  int predict(const VectorXd& s) const {
    VectorXd z = standardise(s);
    if (cfg_.kind == ArmProbe::NearestNeighbours) {
      const VectorXd d = (samples_.colwise() - z).colwise().squaredNorm();
      std::vector<Index> order(static_cast<std::size_t>(d.size()));
      for (Index i = 0; i < d.size(); ++i) order[static_cast<std::size_t>(i)] = i;
      const auto k = std::min<std::size_t>(static_cast<std::size_t>(cfg_.k), order.size());
      std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(k), order.end(),
                        [&d](Index a, Index b) { return d[a] < d[b] || (d[a] == d[b] && a < b); });
      std::vector<int> votes(static_cast<std::size_t>(num_classes()), 0);
      for (std::size_t i = 0; i < k; ++i) ++votes[static_cast<std::size_t>(labels_[static_cast<std::size_t>(order[i])])];
      return static_cast<int>(std::max_element(votes.begin(), votes.end()) - votes.begin());
    }
    if (cfg_.kind == ArmProbe::Lda) z = whiten_ * z;
    Index best = 0;
    (means_.colwise() - z).colwise().squaredNorm().minCoeff(&best);
    return static_cast<int>(best);
  }

 private:
  MatrixXd standardise(const MatrixXd& x) const { return (x.colwise() - mean_).array().colwise() / scale_.array(); }
  ArmProbeConfig cfg_;
  MatrixXd means_;    ///< (48 × classes) z-scored (Lda: and whitened)
  VectorXd mean_, scale_;  ///< (48)
  MatrixXd whiten_;   ///< Lda: (48 × 48) L⁻¹ of the shrunk pooled covariance
  MatrixXd samples_;  ///< NearestNeighbours: (48 × N) z-scored training summaries
  std::vector<int> labels_;
};

/// Confusion matrix (rows: true class / prompt, columns: predicted), per-row accuracy, diversity.
struct ArmFollowingReport {
  std::vector<std::string> classes;
  Eigen::MatrixXi confusion;
  std::vector<double> accuracy;   ///< (classes) fraction of the row on the diagonal
  std::vector<double> diversity;  ///< (classes) mean pairwise RMS distance of arm features (m)
  double overall_accuracy() const {
    return confusion.sum() > 0 ? static_cast<double>(confusion.trace()) / confusion.sum() : 0.0;
  }
  nlohmann::json to_json() const {
    nlohmann::json j;
    j["classes"] = classes;
    std::vector<std::vector<int>> m;
    for (Index r = 0; r < confusion.rows(); ++r) {
      m.emplace_back();
      for (Index c = 0; c < confusion.cols(); ++c) m.back().push_back(confusion(r, c));
    }
    j["confusion"] = m;
    j["accuracy"] = accuracy;
    j["diversity_m"] = diversity;
    j["overall_accuracy"] = overall_accuracy();
    return j;
  }
};

/// Mean over pairs of the RMS distance between arm-feature sequences (each 12 × n, same n).
inline double mean_pairwise_rms(const std::vector<MatrixXd>& seqs) {
  double acc = 0.0;
  int n = 0;
  for (std::size_t a = 0; a < seqs.size(); ++a)
    for (std::size_t b = a + 1; b < seqs.size(); ++b) {
      acc += std::sqrt((seqs[a] - seqs[b]).squaredNorm() / static_cast<double>(seqs[a].cols() * 4));
      ++n;
    }
  return n > 0 ? acc / n : 0.0;
}

struct PromptEvalOptions {
  Index samples = 10;       ///< N per prompt
  double lead_s = 1.0;      ///< transition time before the classified span (s), counted from the prompt's start
  double span_s = 2.0;      ///< classified span (s)
  std::uint64_t seed = 1;   ///< sample i uses Rng(seed + i)
  std::string before;       ///< non-empty: the schedule is "0:<before>,<before_s>:<prompt>" (a switch)
  double before_s = 0.0;    ///< when the prompt takes over (s), with `before`
};

/// See file comment. `histories`: K ≥ 1 world-frame walking histories (≥ H frames each);
/// `classify` gets the prompt's index into `prompts` as truth.
/// `stats` (optional): per prompt, per sample, the ArmWindowStats of the classified span
/// ((prompts) × (samples)); it changes no random draw, so the report is the same with or without.
template <TrajectoryGenerator G>
ArmFollowingReport evaluate_prompts(G& g, const std::vector<std::string>& prompts, const std::vector<Trajectory>& histories,
                                    const ArmClassifier& clf, const PromptEvalOptions& opt,
                                    std::vector<std::vector<ArmWindowStats>>* stats = nullptr) {
  require(!prompts.empty() && !histories.empty() && opt.samples >= 1 && opt.lead_s >= 0 && opt.span_s > 0,
          "evaluate_prompts: need prompts, histories, samples ≥ 1, span > 0", {{}, {}, "PromptEvalOptions"});
  require(clf.num_classes() == static_cast<int>(prompts.size()), "classifier classes and prompts differ",
          {{}, {}, "classifier"});
  const Skeleton& skel = g.skeleton();
  const double start_s = (opt.before.empty() ? 0.0 : opt.before_s) + opt.lead_s;
  const Index lead = static_cast<Index>(std::lround(start_s * 30.0)), span = static_cast<Index>(std::lround(opt.span_s * 30.0));
  ArmFollowingReport r;
  r.classes = prompts;
  const int C = static_cast<int>(prompts.size());
  r.confusion = Eigen::MatrixXi::Zero(C, C);
  const std::size_t K = histories.size();
  if (stats) stats->assign(static_cast<std::size_t>(C), {});
  for (int p = 0; p < C; ++p) {
    std::vector<std::vector<MatrixXd>> by_history(K);
    const std::string& prompt = prompts[static_cast<std::size_t>(p)];
    const auto schedule = opt.before.empty() ? std::vector<TimedText>{{0.0, prompt}}
                                             : std::vector<TimedText>{{0.0, opt.before}, {opt.before_s, prompt}};
    for (Index i = 0; i < opt.samples; ++i) {
      Rng rng(opt.seed + static_cast<std::uint64_t>(i));
      const std::size_t h = static_cast<std::size_t>(i) % K;
      Trajectory t = rollout(g, schedule, histories[h], lead + span, rng);
      compute_body_positions(skel, t);
      const MatrixXd f = arm_features(skel, t, lead, span);
      ++r.confusion(p, clf.predict(arm_summary(f)));
      if (stats) (*stats)[static_cast<std::size_t>(p)].push_back(window_stats(skel, t, lead, span));
      by_history[h].push_back(f);
    }
    r.accuracy.push_back(static_cast<double>(r.confusion(p, p)) / static_cast<double>(opt.samples));
    double d = 0.0;
    int n = 0;
    for (const auto& s : by_history)
      if (s.size() >= 2) {
        d += mean_pairwise_rms(s);
        ++n;
      }
    r.diversity.push_back(n > 0 ? d / n : 0.0);
  }
  return r;
}

/// Labelled arm samples of real (or blended) clips: for every clip, every segment (or the whole
/// clip when it has none) whose first text is one of `prompts` yields windows of `span` frames,
/// starting `skip` frames into the segment (after its cross-fade) and every `step` frames, that
/// lie inside it. Summaries (48 × N), class indices and the feature sequences (for diversity).
struct ArmSamples {
  MatrixXd summaries;  ///< (48 × N)
  std::vector<int> labels;
  std::vector<MatrixXd> features;  ///< (N) 12 × span each
  std::vector<int> clip;           ///< (N) index of the source clip
  std::vector<ArmWindowStats> stats;  ///< (N) the window's statistics (window_stats)
};

inline ArmSamples collect_arm_samples(const Skeleton& skel, const std::vector<LabelledTrajectory>& clips,
                                      const std::vector<std::string>& prompts, Index span, Index skip, Index step) {
  require(span >= 1 && skip >= 0 && step >= 1, "collect_arm_samples: span, step ≥ 1 and skip ≥ 0", {{}, {}, "span"});
  ArmSamples out;
  std::vector<VectorXd> cols;
  for (std::size_t ci = 0; ci < clips.size(); ++ci) {
    const auto& c = clips[ci];
    std::vector<TextSegment> segs = c.segments;
    if (segs.empty()) segs.push_back({0, c.texts});
    Trajectory t = c.motion;
    compute_body_positions(skel, t);
    for (std::size_t k = 0; k < segs.size(); ++k) {
      if (segs[k].texts.empty()) continue;
      const auto it = std::find(prompts.begin(), prompts.end(), segs[k].texts.front());
      if (it == prompts.end()) continue;
      const Index begin = segs[k].start_frame + (segs[k].start_frame > 0 ? skip : 0);
      const Index end = k + 1 < segs.size() ? segs[k + 1].start_frame : t.num_frames();
      for (Index s = begin; s + span <= end; s += step) {
        MatrixXd f = arm_features(skel, t, s, span);
        cols.push_back(arm_summary(f));
        out.features.push_back(std::move(f));
        out.labels.push_back(static_cast<int>(it - prompts.begin()));
        out.clip.push_back(static_cast<int>(ci));
        if (span >= 2) out.stats.push_back(window_stats(skel, t, s, span));
      }
    }
  }
  out.summaries.resize(kArmSummaryDim, static_cast<Index>(cols.size()));
  for (std::size_t j = 0; j < cols.size(); ++j) out.summaries.col(static_cast<Index>(j)) = cols[j];
  return out;
}

/// The report of the classifier on labelled samples (the real clips' reference numbers); the
/// diversity of a class is the mean pairwise RMS distance of its samples' feature sequences (at
/// most `max_pairs_samples` evenly spaced samples per class, to bound the cost).
inline ArmFollowingReport evaluate_samples(const ArmSamples& s, const std::vector<std::string>& prompts,
                                           const ArmClassifier& clf, std::size_t max_pairs_samples = 40) {
  const int C = static_cast<int>(prompts.size());
  ArmFollowingReport r;
  r.classes = prompts;
  r.confusion = Eigen::MatrixXi::Zero(C, C);
  std::vector<std::vector<const MatrixXd*>> per(static_cast<std::size_t>(C));
  for (std::size_t j = 0; j < s.labels.size(); ++j) {
    ++r.confusion(s.labels[j], clf.predict(s.summaries.col(static_cast<Index>(j))));
    per[static_cast<std::size_t>(s.labels[j])].push_back(&s.features[j]);
  }
  for (int c = 0; c < C; ++c) {
    const int n = r.confusion.row(c).sum();
    r.accuracy.push_back(n > 0 ? static_cast<double>(r.confusion(c, c)) / n : 0.0);
    const auto& v = per[static_cast<std::size_t>(c)];
    std::vector<MatrixXd> pick;
    const std::size_t m = std::min(v.size(), max_pairs_samples);
    for (std::size_t i = 0; i < m; ++i) pick.push_back(*v[i * v.size() / m]);
    r.diversity.push_back(mean_pairwise_rms(pick));
  }
  return r;
}

/// What eval-generator and the tests probe with: the arm classes found under the data directory
/// (their prompts, catalog order), the classifier fitted on walks with switched arms, a second set
/// of such walks drawn after it (other walks, phases and switch times: the probe's held-out
/// test), the raw (standing) arm clips as a third reference, and K = 2 walking histories.
struct GeneratorEvalSet {
  std::vector<std::string> prompts;
  ArmSamples train;    ///< 2-s windows of walks whose arms switched (fitted on)
  ArmSamples heldout;  ///< the same kind of windows, drawn after `train` (not fitted on)
  ArmSamples raw;      ///< 2-s windows of the arm clips as recorded
  ArmClassifier classifier;
  std::vector<Trajectory> histories;  ///< world frame, H = 5 frames each
};

/// Builds the set from data_dir (the folder holding motions/); throws naming the directory when
/// the real arm clips are absent. rng draws the blends (walk, arm clip, phase, switch time): the
/// training windows first, then the held-out ones.
inline GeneratorEvalSet make_generator_eval_set(const std::string& data_dir, const Skeleton& skel, Rng& rng,
                                                const ArmProbeConfig& probe = {}, Index history_frames = 5) {
  GeneratorEvalSet e;
  const ArmData arms = load_arm_data(data_dir);
  require(arms.classes.size() > 1, "the probe needs the shared arm clips (motions/bandai/gestures, motions/styles, motions/cmu)",
          {data_dir, {}, "MASKADAPT_DATA_DIR"});
  std::vector<MotionClip> walks;
  if (const MotionSetSpec* spec = find_motion_set("bandai-walk-straight"))
    walks = load_motion_set(*spec, data_dir);
  e.prompts = arms.prompts();
  ArmSwitchOptions o;
  o.active_seconds_per_class = 40.0;
  o.back_probability = 0.0;
  const auto sw = make_arm_switch_clips(walks, arms, skel, rng, o);
  e.train = collect_arm_samples(skel, sw, e.prompts, 60, 15, 30);
  e.heldout = collect_arm_samples(skel, make_arm_switch_clips(walks, arms, skel, rng, o), e.prompts, 60, 15, 30);
  std::vector<LabelledTrajectory> raw;
  for (const auto& cls : arms.clips)
    for (const auto& c : cls) raw.push_back(labelled_from_clip(c, skel));
  e.raw = collect_arm_samples(skel, raw, e.prompts, 60, 0, 30);
  e.classifier = ArmClassifier(e.train.summaries, e.train.labels, static_cast<int>(e.prompts.size()), probe);
  for (std::size_t k = 0; k < 2; ++k) {
    const LabelledTrajectory w = labelled_from_clip(walks[k % walks.size()], skel);
    const Index end = std::min<Index>(w.motion.num_frames(), 60 + 30 * static_cast<Index>(k));
    e.histories.push_back(w.motion.slice(end - history_frames, history_frames));
  }
  return e;
}

/// One source of walking histories for the per-source probe (issue 42): K histories (world frame,
/// H frames each) and, per history, the statistics of the second of motion that ends with it (30
/// frames, or the whole clip up to there when shorter): the pelvis height and walking speed that
/// the generated frames are compared with.
struct WalkingHistorySource {
  std::string name;
  std::vector<Trajectory> histories;        ///< (K) world frame, H frames each
  std::vector<ArmWindowStats> reference;    ///< (K) statistics of the second ending with each history
};

/// History k: the H frames of clips[k mod size] ending at frame ends[k] (clamped to [H, frames]).
inline WalkingHistorySource walking_history_source(const std::string& name, const Skeleton& skel,
                                                   const std::vector<LabelledTrajectory>& clips,
                                                   const std::vector<Index>& ends, Index history_frames = 5) {
  require(!clips.empty() && !ends.empty() && history_frames >= 2, "a history source needs clips, end frames and H ≥ 2",
          {{}, {}, name});
  WalkingHistorySource s;
  s.name = name;
  for (std::size_t k = 0; k < ends.size(); ++k) {
    Trajectory m = clips[k % clips.size()].motion;
    require(m.num_frames() >= history_frames, "clip '" + clips[k % clips.size()].name + "' is shorter than the history",
            {{}, {}, name});
    if (m.body_pos.rows() != 3 * skel.num_bodies()) compute_body_positions(skel, m);
    const Index end = std::clamp<Index>(ends[k], history_frames, m.num_frames());
    s.histories.push_back(m.slice(end - history_frames, history_frames));
    const Index ref = std::min<Index>(30, end);
    s.reference.push_back(window_stats(skel, m, end - ref, ref));
  }
  return s;
}

/// The walking sources of the shared data (issue 42), each with K = 2 histories ending at `ends`
/// (default 2 s and 3 s: frames 60 and 90, clamped to the clip): "bandai" (the straight walks 1
/// and 2; with the default ends exactly the histories of make_generator_eval_set), then the groups
/// of other_walk_groups: "cmu 02_01", "cmu 07_01", "styles walk", "styles female-walk" (their
/// single clip at both ends) and the built-in "synthetic walk". A source whose file is absent is
/// left out and named in `missing`.
inline std::vector<WalkingHistorySource> walking_history_sources(const std::string& data_dir, const Skeleton& skel,
                                                                 Index history_frames = 5,
                                                                 std::vector<std::string>* missing = nullptr,
                                                                 const std::vector<Index>& ends = {60, 90}) {
  namespace fs = std::filesystem;
  std::vector<WalkingHistorySource> out;
  if (const MotionSetSpec* spec = find_motion_set("bandai-walk-straight");
      spec && !data_dir.empty() && fs::is_directory(fs::path(data_dir) / spec->folder)) {
    const auto walks = load_motion_set(*spec, data_dir);
    std::vector<LabelledTrajectory> two;
    for (std::size_t k = 0; k < 2 && k < walks.size(); ++k) two.push_back(labelled_from_clip(walks[k], skel));
    out.push_back(walking_history_source("bandai", skel, two, ends, history_frames));
  } else if (missing) {
    missing->push_back((fs::path(data_dir) / "motions/bandai/locomotion").string());
  }
  for (const WalkGroup& g : other_walk_groups(data_dir, missing)) {
    std::vector<LabelledTrajectory> l;
    for (const auto& c : g.clips) l.push_back(labelled_from_clip(c, skel));
    out.push_back(walking_history_source(g.name, skel, l, ends, history_frames));
  }
  return out;
}

/// The per-source figures of issue 42 (NaN where the pool lacks the prompt):
///  - accuracy: the probe's, over every prompt;
///  - arms_high_share: share of "arms high" samples whose wrist reaches ≥ 0.6 m above the pelvis;
///  - wave_share[0..2]: share of "wave right hand" / "wave left hand" / "wave both hands" samples
///    whose right / left / both wrists rise above the head;
///  - pelvis_ratio, speed_ratio: generated over the history's reference (ArmWindowStats), the mean
///    over all samples, and the prompt whose mean ratio lies farthest from 1 (its ratio).
struct SourceSummary {
  std::string source;
  double accuracy = 0;
  double arms_high_share = NAN, arms_high_median = NAN;  ///< share; median wrist_max (m)
  double wave_share[3] = {NAN, NAN, NAN};
  double pelvis_ratio = 0, pelvis_worst = 1, speed_ratio = 0, speed_worst = 1;
  std::string pelvis_worst_prompt, speed_worst_prompt;
  /// The bars: accuracy ≥ 0.85, arms high in ≥ 80 % of samples, every wave above the head in
  /// ≥ 80 %, and the mean pelvis and speed ratios within 10 % of 1.
  bool meets_bars() const {
    const auto ok = [](double v) { return !std::isfinite(v) || v >= 0.8; };
    return accuracy >= 0.85 && ok(arms_high_share) && ok(wave_share[0]) && ok(wave_share[1]) && ok(wave_share[2]) &&
           std::abs(pelvis_ratio - 1) <= 0.1 && std::abs(speed_ratio - 1) <= 0.1;
  }
};

inline double median_of(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// Summarises one source's report and statistics (evaluate_prompts' `stats`); sample i of a
/// prompt continued history i mod K, whose reference it is compared with.
inline SourceSummary summarise_source(const WalkingHistorySource& src, const ArmFollowingReport& r,
                                      const std::vector<std::vector<ArmWindowStats>>& stats) {
  require(stats.size() == r.classes.size() && !src.reference.empty(), "statistics and prompts differ", {{}, {}, src.name});
  SourceSummary s;
  s.source = src.name;
  s.accuracy = r.overall_accuracy();
  const auto find = [&](const char* p) {
    const auto it = std::find(r.classes.begin(), r.classes.end(), p);
    return it == r.classes.end() ? -1 : static_cast<int>(it - r.classes.begin());
  };
  if (const int p = find("arms high"); p >= 0) {
    std::vector<double> m;
    for (const auto& w : stats[static_cast<std::size_t>(p)]) m.push_back(w.wrist_max);
    s.arms_high_share = static_cast<double>(std::count_if(m.begin(), m.end(), [](double v) { return v >= 0.6; })) / m.size();
    s.arms_high_median = median_of(m);
  }
  const char* waves[3] = {"wave right hand", "wave left hand", "wave both hands"};
  for (int k = 0; k < 3; ++k)
    if (const int p = find(waves[k]); p >= 0) {
      const auto& v = stats[static_cast<std::size_t>(p)];
      const auto up = [k](const ArmWindowStats& w) {
        return k == 0 ? w.right_over_head > 0 : k == 1 ? w.left_over_head > 0 : std::min(w.right_over_head, w.left_over_head) > 0;
      };
      s.wave_share[k] = static_cast<double>(std::count_if(v.begin(), v.end(), up)) / v.size();
    }
  double sp = 0, ss = 0;
  std::size_t n = 0;
  for (std::size_t p = 0; p < stats.size(); ++p) {
    double pp = 0, ps = 0;
    for (std::size_t i = 0; i < stats[p].size(); ++i) {
      const ArmWindowStats& ref = src.reference[i % src.reference.size()];
      pp += stats[p][i].pelvis_height / ref.pelvis_height;
      ps += stats[p][i].speed / std::max(ref.speed, 1e-6);
    }
    sp += pp;
    ss += ps;
    n += stats[p].size();
    pp /= static_cast<double>(stats[p].size());
    ps /= static_cast<double>(stats[p].size());
    if (std::abs(pp - 1) >= std::abs(s.pelvis_worst - 1)) s.pelvis_worst = pp, s.pelvis_worst_prompt = r.classes[p];
    if (std::abs(ps - 1) >= std::abs(s.speed_worst - 1)) s.speed_worst = ps, s.speed_worst_prompt = r.classes[p];
  }
  s.pelvis_ratio = sp / static_cast<double>(n);
  s.speed_ratio = ss / static_cast<double>(n);
  return s;
}

/// Paraphrases of the catalog's prompts made of known words (docs/generator.md reports them).
inline const std::vector<std::string>& default_paraphrases() {
  static const std::vector<std::string> p = {
      "wave your left hand", "wave your right hand", "wave the left hand while walking", "wave both your hands",
      "throw a punch",       "punch while walking",  "wipe with your hand",              "swim with your arms",
      "do jumping jacks",    "raise your arms high", "lift your arm",                    "fight with a sword",
      "wash",                "rotate your arms",     "wave"};
  return p;
}

/// The prompt whose learned text embedding (the generator's projection of the hashed features)
/// is nearest to `text`'s by cosine similarity: (index into prompts, cosine).
inline std::pair<std::size_t, double> nearest_prompt(const BuiltinGenerator& g, const std::string& text,
                                                     const std::vector<std::string>& prompts) {
  require(!prompts.empty(), "no prompts", {{}, {}, "prompts"});
  return g.nearest_by_embedding(g.text_embedding(text), prompts);
}

}  // namespace maskadapt::tracking
