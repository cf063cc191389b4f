// Arm-switch training data (motion/blend.hpp blend_parts_switched, tracking/arm_data.hpp), per-window
// segment labels (primitive_dataset.hpp) and the arm-following probe (tracking/arm_eval.hpp).
#include "test_support.hpp"

#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/humanoid/synthetic.hpp>
#include <maskadapt/tracking/arm_data.hpp>
#include <maskadapt/tracking/arm_eval.hpp>

#include <gtest/gtest.h>

using namespace maskadapt;
using namespace maskadapt::tracking;

namespace {

bool is_arm_joint(const Skeleton& skel, int body) {
  return skel.parts[body] == BodyPart::LeftArm || skel.parts[body] == BodyPart::RightArm;
}

}  // namespace

TEST(ArmData, SwitchedBlendFadesTheArmsOnlyAndBack) {
  const Skeleton& skel = humanoid_skeleton();
  const MotionClip walk = synthetic_walk(), arms = synthetic_arm_circles();
  const PartMask m = PartMask::parse("arms", "test");
  const PartSwitch sw{0.2, 0.6, 0.2};  // the built-in walk is one 1-s cycle
  EXPECT_DOUBLE_EQ(sw.weight(0.19), 0.0);
  EXPECT_NEAR(sw.weight(0.3), 0.5, 1e-12);
  EXPECT_DOUBLE_EQ(sw.weight(0.5), 1.0);
  EXPECT_NEAR(sw.weight(0.7), 0.5, 1e-12);
  EXPECT_DOUBLE_EQ(sw.weight(0.85), 0.0);
  const MotionClip full = blend_parts(walk, arms, m, skel);
  const MotionClip s = blend_parts_switched(walk, arms, m, skel, sw);
  ASSERT_EQ(s.num_frames(), walk.num_frames());
  ASSERT_GE(walk.num_frames(), 28);
  EXPECT_EQ(s.root_pos, walk.root_pos);
  for (int t : {0, 5, 9, 15, 21, 27}) {  // 0, 0.17, 0.3, 0.5, 0.7, 0.9 s
    const double w = sw.weight(t / walk.fps);
    for (int b = 1; b < skel.num_bodies(); ++b) {
      const int k = humanoid_skeleton().dof_offset(b);
      const Vec3 got = s.q.col(t).segment<3>(k);
      if (!is_arm_joint(skel, b)) {
        EXPECT_EQ(got, Vec3(walk.q.col(t).segment<3>(k))) << "body " << b << " frame " << t;
      } else {
        const Vec3 want = (1 - w) * walk.q.col(t).segment<3>(k) + w * full.q.col(t).segment<3>(k);
        EXPECT_LT((got - want).norm(), 1e-12) << "body " << b << " frame " << t;
      }
    }
  }
  // the arms really change between the walk's swing and the circles
  const int k = humanoid_skeleton().dof_offset(skel.index_of("L_Shoulder"));
  EXPECT_GT((full.q.col(15).segment<3>(k) - walk.q.col(15).segment<3>(k)).norm(), 0.05);
  EXPECT_THROW(blend_parts_switched(walk, arms, m, skel, PartSwitch{2.0, 1.0, 0.3}), Error);
  EXPECT_THROW(blend_parts_switched(walk, arms, m, skel, PartSwitch{0.0, INFINITY, -1.0}), Error);
}

TEST(ArmData, WindowsTakeTheTextsOfTheSegmentOfTheirFirstFutureFrame) {
  const Skeleton& skel = humanoid_skeleton();
  LabelledTrajectory c{"c", {"all"}, test::make_motion(60, 1.0, 0.0, 0.5), {{0, {"walk"}}, {30, {"wave"}}}};
  const auto d = make_primitive_dataset(skel, {c}, 5, 15, 1);
  ASSERT_EQ(d.size(), 41);
  ASSERT_EQ(d.label.size(), 41u);
  ASSERT_EQ(d.label_texts.size(), 2u);
  for (Index s = 0; s < d.size(); ++s) {
    const int want = s + 5 >= 30 ? 1 : 0;  // first future frame = s + H
    EXPECT_EQ(d.label[static_cast<std::size_t>(s)], want) << "window " << s;
    // transition: the first future frame lies in [30, 30 + H + F) — the switch and its first 20 frames
    const int in_transition = s + 5 >= 30 && s + 5 < 50 ? 1 : 0;
    EXPECT_EQ(d.transition[static_cast<std::size_t>(s)], in_transition) << "window " << s;
  }
  EXPECT_EQ(d.label_texts[1], std::vector<std::string>{"wave"});
  // a clip without segments: one label set, its texts
  LabelledTrajectory plain{"p", {"run"}, test::make_motion(40, 2.0, 0.0, 0.5), {}};
  const auto d2 = make_primitive_dataset(skel, {plain, c}, 5, 15, 5);
  EXPECT_EQ(d2.label_texts.size(), 3u);
  EXPECT_EQ(d2.label.front(), 0);
  EXPECT_EQ(d2.label_texts[0], std::vector<std::string>{"run"});
  for (Index s = 0; s < 5; ++s) EXPECT_EQ(d2.transition[static_cast<std::size_t>(s)], 0);  // no segments: none
  c.segments = {{5, {"x"}}};
  EXPECT_THROW(make_primitive_dataset(skel, {c}, 5, 15, 1), Error);
}

TEST(ArmData, SwitchClipsLabelTheirSegments) {
  const Skeleton& skel = humanoid_skeleton();
  const ArmData arms = load_arm_data("");  // no data: the synthetic class only
  ASSERT_EQ(arms.classes.size(), 1u);
  EXPECT_EQ(arms.prompts(), std::vector<std::string>{"rotate arms"});
  ArmSwitchOptions o;
  o.active_seconds_per_class = 10.0;
  Rng r1(3), r2(3);
  const auto a = make_arm_switch_clips({synthetic_walk()}, arms, skel, r1, o);
  const auto b = make_arm_switch_clips({synthetic_walk()}, arms, skel, r2, o);
  ASSERT_FALSE(a.empty());
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].motion.q, b[i].motion.q);  // deterministic given the rng
    ASSERT_GE(a[i].segments.size(), 2u);
    EXPECT_EQ(a[i].segments[0].start_frame, 0);
    EXPECT_EQ(a[i].segments[0].texts.front(), "walk forward");
    EXPECT_EQ(a[i].segments[1].texts.front(), "rotate arms");
    EXPECT_GT(a[i].segments[1].start_frame, 0);
    if (a[i].segments.size() == 3) {
      EXPECT_EQ(a[i].segments[2].texts.front(), "walk forward");
    }
  }
  EXPECT_THROW(make_arm_switch_clips({}, arms, skel, r1, o), Error);
}

TEST(ArmEval, FeaturesIgnoreTheHeadingAndTheClassifierSeparatesArmPoses) {
  const Skeleton& skel = humanoid_skeleton();
  Trajectory t = test::make_motion(40, 1.0, 0.3, 0.8);
  const MatrixXd f = arm_features(skel, t, 0, 40);
  HeadingFrame h;
  h.origin = Vec3(2.0, -1.0, 0.0);
  h.yaw = 1.1;
  const Trajectory moved = transform_to_world(t, h);
  EXPECT_LT((arm_features(skel, moved, 0, 40) - f).cwiseAbs().maxCoeff(), 1e-9);
  // two arm motions (swing 0.3 rad vs 1.4 rad): summaries of short spans are told apart
  const Trajectory small = test::make_motion(120, 1.0, 0.0, 0.3), large = test::make_motion(120, 1.0, 0.0, 1.4, 1.0);
  std::vector<LabelledTrajectory> clips = {{"s", {"small"}, small, {}}, {"l", {"large"}, large, {}}};
  const std::vector<std::string> prompts = {"small", "large"};
  const ArmSamples s = collect_arm_samples(skel, clips, prompts, 30, 0, 15);
  ASSERT_EQ(s.labels.size(), 14u);
  const ArmClassifier clf(s.summaries, s.labels, 2);
  const ArmFollowingReport r = evaluate_samples(s, prompts, clf);
  EXPECT_EQ(r.overall_accuracy(), 1.0);
  EXPECT_GT(r.diversity[0], 0.0);
  EXPECT_THROW(ArmClassifier(s.summaries, s.labels, 3), Error);  // class 2 has no sample
}

namespace {

// Brute-force forms of the three probes on z-scored data (z = (x − μ) / σ, σ over all samples).
struct ProbeReference {
  MatrixXd z;
  std::vector<int> y;
  VectorXd mu, sd;
  int classes;
  VectorXd zscore(const VectorXd& x) const { return (x - mu).cwiseQuotient(sd); }
  MatrixXd class_means() const {
    MatrixXd m = MatrixXd::Zero(z.rows(), classes);
    VectorXd n = VectorXd::Zero(classes);
    for (Index j = 0; j < z.cols(); ++j) {
      m.col(y[j]) += z.col(j);
      n[y[j]] += 1;
    }
    for (int c = 0; c < classes; ++c) m.col(c) /= n[c];
    return m;
  }
  int nearest_mean(const VectorXd& x, const MatrixXd& metric) const {  // argmin (q − m)ᵀ metric (q − m)
    const MatrixXd m = class_means();
    const VectorXd q = zscore(x);
    int best = 0;
    double bd = INFINITY;
    for (int c = 0; c < classes; ++c) {
      const VectorXd d = q - m.col(c);
      const double v = d.dot(metric * d);
      if (v < bd) {
        bd = v;
        best = c;
      }
    }
    return best;
  }
  int lda(const VectorXd& x, double shrink) const {
    const MatrixXd m = class_means();
    MatrixXd S = MatrixXd::Zero(z.rows(), z.rows());
    for (Index j = 0; j < z.cols(); ++j) S += (z.col(j) - m.col(y[j])) * (z.col(j) - m.col(y[j])).transpose();
    S /= static_cast<double>(z.cols());
    MatrixXd shrunk = (1 - shrink) * S;
    shrunk.diagonal() += shrink * S.diagonal();
    return nearest_mean(x, shrunk.inverse());
  }
  int knn(const VectorXd& x, int k) const {
    const VectorXd q = zscore(x);
    std::vector<std::pair<double, Index>> d;
    for (Index j = 0; j < z.cols(); ++j) d.push_back({(z.col(j) - q).squaredNorm(), j});
    std::sort(d.begin(), d.end());
    std::vector<int> votes(static_cast<std::size_t>(classes), 0);
    for (int i = 0; i < k; ++i) ++votes[static_cast<std::size_t>(y[static_cast<std::size_t>(d[static_cast<std::size_t>(i)].second)])];
    return static_cast<int>(std::max_element(votes.begin(), votes.end()) - votes.begin());
  }
};

}  // namespace

TEST(ArmEval, ProbesEqualTheirBruteForceDefinitions) {
  // 3 classes × 25 samples in 5 dimensions with correlated, unequal within-class spread, so that
  // the three rules disagree on many queries.
  Rng rng(5);
  const int C = 3, per = 25, dims = 5;
  MatrixXd mix = MatrixXd::Zero(dims, dims);
  for (Index i = 0; i < dims; ++i)
    for (Index j = 0; j < dims; ++j) mix(i, j) = rng.normal() * (i == j ? 2.0 : 0.7);
  MatrixXd x(dims, C * per);
  std::vector<int> y;
  for (int c = 0; c < C; ++c)
    for (int k = 0; k < per; ++k) {
      VectorXd e(dims);
      for (Index i = 0; i < dims; ++i) e[i] = rng.normal();
      x.col(c * per + k) = mix * e + VectorXd::Constant(dims, 1.5 * c) + VectorXd::Unit(dims, c) * 2.0;
      y.push_back(c);
    }
  ProbeReference ref{x, y, x.rowwise().mean(), VectorXd(), C};
  ref.sd = ((x.colwise() - ref.mu).array().square().rowwise().mean()).sqrt().matrix();
  for (Index j = 0; j < x.cols(); ++j) ref.z.col(j) = ref.zscore(x.col(j));
  const ArmClassifier mean_probe(x, y, C, parse_arm_probe("nearest-mean"));
  const ArmClassifier lda0(x, y, C, parse_arm_probe("lda:0")), lda3(x, y, C, parse_arm_probe("lda:0.3"));
  const ArmClassifier nn1(x, y, C, parse_arm_probe("knn")), nn5(x, y, C, parse_arm_probe("knn:5"));
  int disagree = 0;
  for (int q = 0; q < 300; ++q) {
    VectorXd p(dims);
    for (Index i = 0; i < dims; ++i) p[i] = rng.uniform(-6.0, 9.0);
    const int a = ref.nearest_mean(p, MatrixXd::Identity(dims, dims));
    EXPECT_EQ(mean_probe.predict(p), a) << "query " << q;
    EXPECT_EQ(lda0.predict(p), ref.lda(p, 0.0)) << "query " << q;
    EXPECT_EQ(lda3.predict(p), ref.lda(p, 0.3)) << "query " << q;
    EXPECT_EQ(nn1.predict(p), ref.knn(p, 1)) << "query " << q;
    EXPECT_EQ(nn5.predict(p), ref.knn(p, 5)) << "query " << q;
    disagree += ref.lda(p, 0.0) != a;
  }
  EXPECT_GT(disagree, 10);  // the metric matters on these data: the test tells the rules apart
  // 1-NN recovers every training sample's own class
  for (Index j = 0; j < x.cols(); ++j) EXPECT_EQ(nn1.predict(x.col(j)), y[static_cast<std::size_t>(j)]);
}

TEST(ArmEval, ProbeNamesParseAndBadOnesAreRefusedNamingTheFlag) {
  EXPECT_EQ(parse_arm_probe("nearest-mean").kind, ArmProbe::NearestMean);
  EXPECT_EQ(parse_arm_probe("lda").kind, ArmProbe::Lda);
  EXPECT_DOUBLE_EQ(parse_arm_probe("lda:0.25").shrinkage, 0.25);
  EXPECT_EQ(parse_arm_probe("knn").k, 1);
  EXPECT_EQ(parse_arm_probe("knn:7").k, 7);
  EXPECT_EQ(parse_arm_probe("knn:3").name(), "3-nearest neighbours");
  for (const char* bad : {"", "knn:0", "knn:2.5", "knn:x", "lda:1.5", "lda:", "lda:nan", "nearest-mean:2", "svm"}) {
    try {
      (void)parse_arm_probe(bad, "--probe");
      ADD_FAILURE() << "'" << bad << "' was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("--probe"), std::string::npos) << e.what();
    }
  }
}

// Issue 42: the statistics the per-source bars read, on a trajectory whose heights and root path
// are closed forms (body positions written directly: window_stats reads body_pos and root_pos).
TEST(ArmEval, WindowStatsEqualTheirClosedForms) {
  const Skeleton& skel = humanoid_skeleton();
  const Index n = 61;  // 2 s at 30 Hz
  Trajectory t = Trajectory::zeros(skel, n);
  const int lw = skel.index_of("L_Wrist"), rw = skel.index_of("R_Wrist"), head = skel.index_of("Head");
  const double v = 1.2, f = 1.0, a = 0.5, phase = 0.3;  // m/s, Hz, m, rad
  for (Index i = 0; i < n; ++i) {
    const double time = i / 30.0;
    t.root_pos.col(i) = Vec3(v * time, 0.1, 0.95);
    t.body_pos.block<3, 1>(0, i) = t.root_pos.col(i);
    t.body_pos(3 * rw + 2, i) = 0.95 + a * std::sin(2 * M_PI * f * time + phase);  // swings ± a about the pelvis
    t.body_pos(3 * lw + 2, i) = 0.95 - 0.1;                                         // hangs 0.1 m below it
    t.body_pos(3 * head + 2, i) = 0.95 + 0.6;
  }
  const ArmWindowStats s = window_stats(skel, t, 0, n);
  double hi = -1e9, lo = 1e9;
  for (Index i = 0; i < n; ++i) {
    hi = std::max(hi, a * std::sin(2 * M_PI * f * i / 30.0 + phase));
    lo = std::min(lo, a * std::sin(2 * M_PI * f * i / 30.0 + phase));
  }
  EXPECT_NEAR(s.wrist_max, hi, 1e-12);  // the right wrist reaches higher than the left
  EXPECT_NEAR(s.wrist_range, hi - lo, 1e-12);
  EXPECT_NEAR(s.wrist_freq, f, 1e-12);  // 2 periods: 4 crossings of the mean in 2 s
  EXPECT_NEAR(s.right_over_head, hi - 0.6, 1e-12);
  EXPECT_NEAR(s.left_over_head, -0.7, 1e-12);
  EXPECT_NEAR(s.pelvis_height, 0.95, 1e-12);
  EXPECT_NEAR(s.speed, v, 1e-12);
  EXPECT_THROW(window_stats(skel, t, 0, 1), Error);
  EXPECT_THROW(window_stats(skel, t, 10, n), Error);
}

// A catalog span: frames [b, e] of the clip, and to and fro: b..e then e-1..b+1 (continuous when looped).
TEST(ArmData, ClipSpanCutsAndPlaysToAndFro) {
  MotionClip c = synthetic_walk();
  const int n = c.num_frames();
  ASSERT_GE(n, 20);
  const MotionClip s = clip_span(c, 5 / 30.0, 12 / 30.0, false);
  ASSERT_EQ(s.num_frames(), 8);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(s.q.col(i), c.q.col(5 + i));
  const MotionClip p = clip_span(c, 5 / 30.0, 12 / 30.0, true);
  ASSERT_EQ(p.num_frames(), 14);  // 8 forwards, 6 back (12 and 5 not repeated)
  const int want[14] = {5, 6, 7, 8, 9, 10, 11, 12, 11, 10, 9, 8, 7, 6};
  for (int i = 0; i < 14; ++i) {
    EXPECT_EQ(p.q.col(i), c.q.col(want[i])) << i;
    EXPECT_EQ(p.root_pos.col(i), c.root_pos.col(want[i])) << i;
  }
  EXPECT_EQ(clip_span(c, 0, INFINITY, false).q, c.q);
  EXPECT_THROW(clip_span(c, 3.0 * n, INFINITY, false), Error);  // past the end: one frame left
}

// Weighted walks: a walk of weight 0 is never blended onto; the draw's frequencies follow the
// weights; bad weights are refused naming the field.
TEST(ArmData, WalkWeightsChooseTheWalks) {
  Rng rng(5);
  const std::vector<double> w = {0.0, 1.0, 3.0};
  int count[3] = {0, 0, 0};
  const int N = 20000;
  for (int i = 0; i < N; ++i) ++count[draw_weighted(w, rng)];
  EXPECT_EQ(count[0], 0);
  EXPECT_NEAR(count[2] / double(N), 0.75, 4 * std::sqrt(0.75 * 0.25 / N));  // 4 standard errors
  const Skeleton& skel = humanoid_skeleton();
  const ArmData arms = load_arm_data("");
  MotionClip a = synthetic_walk(), b = synthetic_walk();
  a.name = "walk_a";
  b.name = "walk_b";
  ArmSwitchOptions o;
  o.active_seconds_per_class = 10.0;
  o.walk_weights = {0.0, 1.0};
  Rng r(3);
  for (const auto& c : make_arm_switch_clips({a, b}, arms, skel, r, o)) EXPECT_EQ(c.name.rfind("walk_b+", 0), 0u) << c.name;
  o.walk_weights = {1.0};  // one weight for two walks
  try {
    (void)make_arm_switch_clips({a, b}, arms, skel, r, o);
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("walk_weights"), std::string::npos) << e.what();
  }
  o.walk_weights = {0.0, 0.0};
  EXPECT_THROW(make_arm_switch_clips({a, b}, arms, skel, r, o), Error);
}

// A history source: history k is the H frames of clip k mod K ending at ends[k] (clamped), and its
// reference is the second ending there.
TEST(ArmEval, HistorySourcesSliceTheirClips) {
  const Skeleton& skel = humanoid_skeleton();
  const LabelledTrajectory w = labelled_from_clip(synthetic_walk(), skel);
  const Index n = w.motion.num_frames();
  const WalkingHistorySource s = walking_history_source("w", skel, {w}, {20, 10 * n}, 5);
  ASSERT_EQ(s.histories.size(), 2u);
  EXPECT_EQ(s.histories[0].q, w.motion.slice(15, 5).q);
  EXPECT_EQ(s.histories[1].q, w.motion.slice(n - 5, 5).q);  // clamped to the clip's end
  const ArmWindowStats ref = window_stats(skel, w.motion, 0, 20);  // fewer than 30 frames before frame 20
  EXPECT_DOUBLE_EQ(s.reference[0].speed, ref.speed);
  EXPECT_DOUBLE_EQ(s.reference[0].pelvis_height, ref.pelvis_height);
  EXPECT_THROW(walking_history_source("w", skel, {}, {20}, 5), Error);
  // without data only the built-in walk remains, and the missing files are named
  std::vector<std::string> missing;
  const auto none = walking_history_sources("", skel, 5, &missing);
  ASSERT_EQ(none.size(), 1u);
  EXPECT_EQ(none[0].name, "synthetic walk");
  EXPECT_EQ(missing.size(), 5u);
}
