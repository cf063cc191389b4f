#include <maskadapt/core/rng.hpp>
#include <maskadapt/eval/visitation_entropy.hpp>

#include <gtest/gtest.h>

#include <cmath>

using namespace maskadapt;
using maskadapt::eval::normalized_entropy;
using maskadapt::eval::visitation_entropy;

namespace {

// Reference frames on a line: r_i = (10·i, 0) — far apart, so a threshold of 1 isolates them.
MatrixXf line_frames(const std::vector<float>& xs) {
  MatrixXf m = MatrixXf::Zero(2, static_cast<Index>(xs.size()));
  for (std::size_t i = 0; i < xs.size(); ++i) m(0, static_cast<Index>(i)) = xs[i];
  return m;
}

// The definition, evaluated the slow way: O(n · m · d).
std::vector<std::int64_t> brute_force_counts(const MatrixXd& ref, const MatrixXd& gen, double thr) {
  std::vector<std::int64_t> c(static_cast<std::size_t>(ref.cols()), 0);
  for (Index i = 0; i < ref.cols(); ++i)
    for (Index j = 0; j < gen.cols(); ++j) c[static_cast<std::size_t>(i)] += (ref.col(i) - gen.col(j)).norm() <= thr;
  return c;
}

}  // namespace

TEST(NormalizedEntropy, UniformCountsGiveOne) {
  EXPECT_NEAR(normalized_entropy({3, 3, 3, 3, 3}), 1.0, 1e-12);
  EXPECT_NEAR(normalized_entropy({1, 1}), 1.0, 1e-12);
}

TEST(NormalizedEntropy, SingleVisitedFrameGivesZero) {
  EXPECT_DOUBLE_EQ(normalized_entropy({0, 0, 7, 0}), 0.0);
}

TEST(NormalizedEntropy, ClosedFormIntermediateCase) {
  // p = (1/2, 1/4, 1/4, 0): H = 1.5 log 2, n = 4 → H_norm = 1.5 log 2 / log 4 = 0.75.
  double h = 0.0;
  EXPECT_NEAR(normalized_entropy({2, 1, 1, 0}, &h), 0.75, 1e-12);
  EXPECT_NEAR(h, 1.5 * std::log(2.0), 1e-12);
  // p = (1/3, 2/3) over n = 3 frames.
  const double expected = -(1.0 / 3 * std::log(1.0 / 3) + 2.0 / 3 * std::log(2.0 / 3)) / std::log(3.0);
  EXPECT_NEAR(normalized_entropy({1, 2, 0}), expected, 1e-12);
}

TEST(NormalizedEntropy, DegenerateCasesFollowTheDocumentedConventions) {
  EXPECT_DOUBLE_EQ(normalized_entropy({5}), 0.0);        // n = 1
  EXPECT_DOUBLE_EQ(normalized_entropy({0, 0, 0}), 0.0);  // nothing visited
  EXPECT_THROW(normalized_entropy({1, -1}), Error);
}

TEST(VisitationEntropy, VisitingEveryReferenceFrameEquallyGivesOne) {
  const MatrixXf ref = line_frames({0, 10, 20, 30, 40});
  const MatrixXf gen = line_frames({0.2f, 10.1f, 19.9f, 30, 40.3f, 0, 10, 20, 30, 40});
  const auto r = visitation_entropy(ref, gen, 1.0);
  EXPECT_NEAR(r.h_norm, 1.0, 1e-12);
  EXPECT_EQ(r.total_count, 10);
  EXPECT_EQ(r.matched_generated, 10);
  EXPECT_EQ(r.visited_reference, 5);
}

TEST(VisitationEntropy, StayingOnOneFrameGivesZero) {
  const MatrixXf ref = line_frames({0, 10, 20, 30});
  const MatrixXf gen = line_frames({20, 20.5f, 19.6f, 20});
  const auto r = visitation_entropy(ref, gen, 1.0);
  EXPECT_DOUBLE_EQ(r.h_norm, 0.0);
  EXPECT_EQ(r.counts, (std::vector<std::int64_t>{0, 0, 4, 0}));
}

TEST(VisitationEntropy, ClosedFormWithUnmatchedFrames) {
  const MatrixXf ref = line_frames({0, 10, 20, 30});
  // Two visits to frame 0, one to 10, one to 20; the frame at 55 matches nothing.
  const MatrixXf gen = line_frames({0, 0.5f, 10, 20, 55});
  const auto r = visitation_entropy(ref, gen, 1.0);
  EXPECT_EQ(r.counts, (std::vector<std::int64_t>{2, 1, 1, 0}));
  EXPECT_NEAR(r.h_norm, 0.75, 1e-12);
  EXPECT_EQ(r.matched_generated, 4);
}

TEST(VisitationEntropy, OneGeneratedFrameCanCountForSeveralReferenceFrames) {
  const MatrixXf ref = line_frames({0, 1, 2, 30});
  const MatrixXf gen = line_frames({1});  // within 1.5 of 0, 1 and 2
  const auto r = visitation_entropy(ref, gen, 1.5);
  EXPECT_EQ(r.counts, (std::vector<std::int64_t>{1, 1, 1, 0}));
  EXPECT_NEAR(r.h_norm, std::log(3.0) / std::log(4.0), 1e-12);
}

TEST(VisitationEntropy, MatchesTheBruteForceDefinitionOnRandomData) {
  Rng rng(7);
  const Index d = 6, n = 157, m = 1043;  // m not a multiple of the block: exercises the tail block
  MatrixXd ref(d, n), gen(d, m);
  for (Index k = 0; k < ref.size(); ++k) ref.data()[k] = rng.normal();
  for (Index k = 0; k < gen.size(); ++k) gen.data()[k] = rng.normal();
  for (double thr : {1.5, 2.5, 3.5}) {
    const auto expected = brute_force_counts(ref, gen, thr);
    const auto r = visitation_entropy(ref, gen, thr, eval::VisitCounting::all_within, 128);
    EXPECT_EQ(r.counts, expected) << "threshold " << thr;
    EXPECT_NEAR(r.h_norm, normalized_entropy(expected), 1e-12);
    EXPECT_GT(r.h_norm, 0.0);
    EXPECT_LT(r.h_norm, 1.0);
  }
}

// Nearest mode against its definition computed pair by pair: each generated frame adds one count
// to its nearest reference frame (ties: lowest index) if that is within the threshold.
TEST(VisitationEntropy, NearestCountingMatchesTheBruteForceDefinition) {
  Rng rng(11);
  const Index d = 5, n = 143, m = 1031;
  MatrixXd ref(d, n), gen(d, m);
  for (Index k = 0; k < ref.size(); ++k) ref.data()[k] = rng.normal();
  for (Index k = 0; k < gen.size(); ++k) gen.data()[k] = rng.normal();
  for (double thr : {0.8, 1.5, 100.0}) {
    std::vector<std::int64_t> expected(static_cast<std::size_t>(n), 0);
    std::int64_t matched = 0;
    for (Index j = 0; j < m; ++j) {
      Index best = 0;
      for (Index i = 1; i < n; ++i)
        if ((gen.col(j) - ref.col(i)).squaredNorm() < (gen.col(j) - ref.col(best)).squaredNorm()) best = i;
      if ((gen.col(j) - ref.col(best)).norm() <= thr) {
        ++expected[static_cast<std::size_t>(best)];
        ++matched;
      }
    }
    const auto r = visitation_entropy(ref, gen, thr, eval::VisitCounting::nearest, 128);
    EXPECT_EQ(r.counts, expected) << "threshold " << thr;
    EXPECT_EQ(r.matched_generated, matched);
    EXPECT_EQ(r.total_count, matched) << "one count per matched frame";
    EXPECT_NEAR(r.h_norm, normalized_entropy(expected), 1e-12);
  }
}

// A frozen pose visits one reference frame in nearest mode whatever the threshold; in all_within
// mode a threshold that covers the data makes it look fully diverse.
TEST(VisitationEntropy, AFrozenPoseScoresZeroWhenCountingTheNearestFrameOnly) {
  const MatrixXf ref = line_frames({0, 1, 2, 3, 4, 5, 6, 7});
  const MatrixXf frozen = MatrixXf(ref.col(3)).replicate(1, 50);
  EXPECT_DOUBLE_EQ(visitation_entropy(ref, frozen, 100.0, eval::VisitCounting::nearest).h_norm, 0.0);
  EXPECT_NEAR(visitation_entropy(ref, frozen, 100.0, eval::VisitCounting::all_within).h_norm, 1.0, 1e-12);
  EXPECT_EQ(eval::visit_counting_from_string("nearest"), eval::VisitCounting::nearest);
  EXPECT_THROW(eval::visit_counting_from_string("closest"), Error);
}

TEST(VisitationEntropy, RejectsBadInput) {
  const MatrixXf ref = line_frames({0, 1});
  EXPECT_THROW(visitation_entropy(ref, MatrixXf::Zero(3, 2), 1.0), Error);  // dimension mismatch
  EXPECT_THROW(visitation_entropy(MatrixXf::Zero(2, 0), ref, 1.0), Error);  // no reference frames
  EXPECT_THROW(visitation_entropy(ref, ref, -1.0), Error);
  MatrixXf bad = ref;
  bad(1, 1) = std::nanf("");
  try {
    visitation_entropy(ref, bad, 1.0);
    FAIL() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "generated");
  }
}

TEST(SelectRows, PicksTheRequestedRowsInOrder) {
  MatrixXf f(4, 2);
  f << 1, 2, 3, 4, 5, 6, 7, 8;
  const MatrixXf s = eval::select_rows(f, {3, 1});
  ASSERT_EQ(s.rows(), 2);
  EXPECT_EQ(s(0, 0), 7);
  EXPECT_EQ(s(1, 1), 4);
  EXPECT_THROW(eval::select_rows(f, {4}), Error);
}
