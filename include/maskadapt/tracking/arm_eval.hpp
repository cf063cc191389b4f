#pragma once
/// \file arm_eval.hpp
/// Does a generator follow its arms prompt? A deliberately simple probe.
///
/// Arm features of a frame (12): the positions of L_Elbow, R_Elbow, L_Wrist, R_Wrist relative to
/// the pelvis, in the pelvis's heading frame (x forward, y left, z up; m). A span of frames is
/// summarised by the mean, the standard deviation, the minimum and the maximum over time of each
/// (48 values: `arm_summary`). `NearestMeanClassifier` z-scores the summaries (per-dimension std over all
/// training samples) and assigns the class with the nearest mean (Euclidean).
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

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
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

class NearestMeanClassifier {
 public:
  NearestMeanClassifier() = default;
  /// x: (48 × N) summaries, y: (N) class indices in [0, num_classes). Every class needs a sample.
  NearestMeanClassifier(const MatrixXd& x, const std::vector<int>& y, int num_classes) {
    require(x.cols() == static_cast<Index>(y.size()) && x.cols() > 0 && num_classes > 0, "classifier: bad training set",
            {{}, {}, "samples"});
    const VectorXd mu = x.rowwise().mean();
    scale_ = ((x.colwise() - mu).array().square().rowwise().mean()).sqrt().matrix();
    scale_ = scale_.cwiseMax(1e-3);
    means_ = MatrixXd::Zero(x.rows(), num_classes);
    std::vector<int> count(static_cast<std::size_t>(num_classes), 0);
    for (Index j = 0; j < x.cols(); ++j) {
      const int c = y[static_cast<std::size_t>(j)];
      require(c >= 0 && c < num_classes, "classifier: class index out of range", {{}, {}, "labels"});
      means_.col(c) += x.col(j).cwiseQuotient(scale_);
      ++count[static_cast<std::size_t>(c)];
    }
    for (int c = 0; c < num_classes; ++c) {
      require(count[static_cast<std::size_t>(c)] > 0, "classifier: class " + std::to_string(c) + " has no sample",
              {{}, {}, "labels"});
      means_.col(c) /= count[static_cast<std::size_t>(c)];
    }
  }
  int num_classes() const { return static_cast<int>(means_.cols()); }
  int predict(const VectorXd& s) const {
    Index best = 0;
    (means_.colwise() - s.cwiseQuotient(scale_)).colwise().squaredNorm().minCoeff(&best);
    return static_cast<int>(best);
  }

 private:
  MatrixXd means_;  ///< (48 × classes) in z-scored units
  VectorXd scale_;  ///< (48)
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
template <TrajectoryGenerator G>
ArmFollowingReport evaluate_prompts(G& g, const std::vector<std::string>& prompts, const std::vector<Trajectory>& histories,
                                    const NearestMeanClassifier& clf, const PromptEvalOptions& opt) {
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
                                           const NearestMeanClassifier& clf, std::size_t max_pairs_samples = 40) {
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
/// (their prompts, catalog order), the classifier fitted on walks with switched arms, the raw
/// (standing) arm clips as a second reference, and K = 2 walking histories.
struct GeneratorEvalSet {
  std::vector<std::string> prompts;
  ArmSamples train;  ///< 2-s windows of walks whose arms switched (fitted on)
  ArmSamples raw;    ///< 2-s windows of the arm clips as recorded
  NearestMeanClassifier classifier;
  std::vector<Trajectory> histories;  ///< world frame, H = 5 frames each
};

/// Builds the set from data_dir (the folder holding motions/); throws naming the directory when
/// the real arm clips are absent. rng draws the blends (walk, arm clip, phase, switch time).
inline GeneratorEvalSet make_generator_eval_set(const std::string& data_dir, const Skeleton& skel, Rng& rng,
                                                Index history_frames = 5) {
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
  std::vector<LabelledTrajectory> raw;
  for (const auto& cls : arms.clips)
    for (const auto& c : cls) raw.push_back(labelled_from_clip(c, skel));
  e.raw = collect_arm_samples(skel, raw, e.prompts, 60, 0, 30);
  e.classifier = NearestMeanClassifier(e.train.summaries, e.train.labels, static_cast<int>(e.prompts.size()));
  for (std::size_t k = 0; k < 2; ++k) {
    const LabelledTrajectory w = labelled_from_clip(walks[k % walks.size()], skel);
    const Index end = std::min<Index>(w.motion.num_frames(), 60 + 30 * static_cast<Index>(k));
    e.histories.push_back(w.motion.slice(end - history_frames, history_frames));
  }
  return e;
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
  const VectorXf e = g.denoiser().embed(g.text_encoder().features(text));
  std::size_t best = 0;
  double best_c = -2.0;
  for (std::size_t i = 0; i < prompts.size(); ++i) {
    const VectorXf f = g.denoiser().embed(g.text_encoder().features(prompts[i]));
    const double c = static_cast<double>(e.dot(f)) / std::max(1e-12, static_cast<double>(e.norm() * f.norm()));
    if (c > best_c) {
      best_c = c;
      best = i;
    }
  }
  return {best, best_c};
}

}  // namespace maskadapt::tracking
