// Trajectories, canonicalisation, frame features, the generator concept and rollout.
#include "test_support.hpp"

#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/tracking/frame_features.hpp>
#include <maskadapt/tracking/generator.hpp>

#include <gtest/gtest.h>

using namespace maskadapt;
using namespace maskadapt::tracking;

TEST(Generator, CanonicalizePutsFrameZeroAtTheOriginFacingX) {
  const Trajectory t = test::make_motion(10, 1.0, 0.5, 0.5);
  const auto [local, frame] = canonicalize(t, 0);
  EXPECT_NEAR(local.root_pos(0, 0), 0.0, 1e-12);
  EXPECT_NEAR(local.root_pos(1, 0), 0.0, 1e-12);
  EXPECT_NEAR(local.root_pos(2, 0), t.root_pos(2, 0), 1e-12);
  EXPECT_NEAR(heading_angle(local.root_rot[0]), 0.0, 1e-12);
  // The body positions move rigidly with the root: FK of the local poses gives local.body_pos.
  Trajectory again = local;
  compute_body_positions(humanoid_skeleton(), again);
  EXPECT_LT((again.body_pos - local.body_pos).cwiseAbs().maxCoeff(), 1e-12);
  // And back.
  const Trajectory world = transform_to_world(local, frame);
  EXPECT_LT((world.root_pos - t.root_pos).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((world.body_pos - t.body_pos).cwiseAbs().maxCoeff(), 1e-12);
  for (Index i = 0; i < t.num_frames(); ++i)
    EXPECT_LT(world.root_rot[i].angularDistance(t.root_rot[i]), 1e-9);
}

TEST(Generator, SixDRotationRoundTrip) {
  Rng rng(4);
  for (int k = 0; k < 50; ++k) {
    const Quat q = Quat(rng.normal(), rng.normal(), rng.normal(), rng.normal()).normalized();
    EXPECT_LT(rotation_from_6d(rotation_to_6d(q)).angularDistance(q), 1e-9);
  }
  // Gram–Schmidt of a perturbed 6-vector still gives a rotation.
  Eigen::Matrix<double, 6, 1> v;
  v << 2, 0.1, 0, 0.3, 1, 0;
  const Mat3 R = rotation_from_6d(v).toRotationMatrix();
  EXPECT_NEAR((R.transpose() * R - Mat3::Identity()).norm(), 0.0, 1e-12);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
}

TEST(Generator, FrameFeaturesRoundTrip) {
  const Skeleton& skel = humanoid_skeleton();
  const auto [local, frame] = canonicalize(test::make_motion(20, 1.0, 0.3, 0.9), 0);
  const MatrixXd f = encode_frames<double>(skel, local);
  const FrameLayout L = FrameLayout::of(skel);
  ASSERT_EQ(f.rows(), 202);
  ASSERT_EQ(L.dim, 202);
  EXPECT_EQ(f.middleRows(L.root_delta, 4).col(0).norm(), 0.0);
  EXPECT_NEAR(f(L.root_delta, 5), local.root_pos(0, 5) - local.root_pos(0, 4), 1e-12);
  EXPECT_NEAR(f(L.yaw_delta, 5), 0.3 / 30.0, 1e-6);  // make_motion turns at 0.3 rad/s
  const Trajectory back = decode_frames<double>(skel, f);
  EXPECT_LT((back.root_pos - local.root_pos).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((back.q - local.q).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((back.body_pos - local.body_pos).cwiseAbs().maxCoeff(), 1e-9);
  MatrixXd bad = f;
  bad(3, 2) = NAN;
  EXPECT_THROW(decode_frames<double>(skel, bad), Error);
  EXPECT_THROW(decode_frames<double>(skel, MatrixXd(201, 2)), Error);
}

TEST(Generator, PrimitiveDatasetWindows) {
  const Skeleton& skel = humanoid_skeleton();
  const auto clips = test::make_clips();
  const auto d = make_primitive_dataset(skel, clips, 5, 15, 2);
  // (90 − 20)/2 + 1 = 36 windows per clip.
  EXPECT_EQ(d.size(), 72);
  EXPECT_EQ(d.history.rows(), 5 * 202);
  EXPECT_EQ(d.future.rows(), 15 * 202);
  EXPECT_EQ(d.clip[0], 0);
  EXPECT_EQ(d.clip[71], 1);
  // Window 3 of clip 0 starts at frame 6: its features equal those of the canonicalised slice.
  const auto [local, frame] = canonicalize(clips[0].motion.slice(6, 20), 0);
  const MatrixXf f = encode_frames<float>(skel, local);
  EXPECT_LT((d.history.col(3) - Eigen::Map<const VectorXf>(f.data(), 5 * 202)).cwiseAbs().maxCoeff(), 1e-5f);
  EXPECT_LT((d.future.col(3) - Eigen::Map<const VectorXf>(f.data() + 5 * 202, 15 * 202)).cwiseAbs().maxCoeff(), 1e-5f);
  std::vector<LabelledTrajectory> short_clip = {{"short", {"x"}, test::make_motion(10, 1, 0, 0), {}}};
  EXPECT_THROW(make_primitive_dataset(skel, short_clip, 5, 15), Error);
}

// The (N × H × D) and (N × F × D) views lie on the flat (H·D × N), (F·D × N) columns, and the
// windows written through them are bit for bit the encoded frames of the canonicalised slices,
// as when each window was encoded into a matrix of its own and its columns copied (the layout
// before the views).
TEST(Generator, PrimitiveDatasetTensorViewsAreTheFlatColumns) {
  const Skeleton& skel = humanoid_skeleton();
  const auto clips = test::make_clips();
  const Index H = 5, F = 15, stride = 4;
  const auto d = make_primitive_dataset(skel, clips, H, F, stride);
  const Index D = d.frame_dim, N = d.size();
  const auto hist = history_tensor(d);
  const auto fut = future_tensor(d);
  ASSERT_EQ(hist.shape(0), std::size_t(N));
  ASSERT_EQ(hist.shape(1), std::size_t(H));
  ASSERT_EQ(hist.shape(2), std::size_t(D));
  ASSERT_EQ(fut.shape(1), std::size_t(F));
  EXPECT_EQ(&hist(7, 3, 11), &d.history(3 * D + 11, 7));  // no copy: the same floats
  EXPECT_EQ(&fut(N - 1, F - 1, D - 1), &d.future(F * D - 1, N - 1));

  // the reference: every window encoded on its own, its (D × W) columns copied in turn
  MatrixXf history(H * D, N), future(F * D, N);
  Index n = 0;
  for (const auto& clip : clips) {
    Trajectory world = clip.motion;
    compute_body_positions(skel, world);
    for (Index s = 0; s + H + F <= world.num_frames(); s += stride, ++n) {
      const MatrixXf w = encode_frames<float>(skel, canonicalize(world.slice(s, H + F), 0).first);
      history.col(n) = Eigen::Map<const VectorXf>(w.data(), H * D);
      future.col(n) = Eigen::Map<const VectorXf>(w.data() + H * D, F * D);
      if (n == 9) {  // and in the tensor's own terms: window 9, frame j, feature i is w(i, j)
        for (Index j = 0; j < H + F; ++j)
          for (Index i = 0; i < D; i += 13)
            EXPECT_EQ(j < H ? hist(9, j, i) : fut(9, j - H, i), w(i, j)) << j << " " << i;
      }
    }
  }
  ASSERT_EQ(n, N);
  EXPECT_TRUE(d.history == history);
  EXPECT_TRUE(d.future == future);

  // writes through the view land in the flat column; a view of the wrong shape is refused by name
  PrimitiveDataset e = d;
  history_tensor(e)(2, 4, 5) = 42.0f;
  EXPECT_EQ(e.history(4 * D + 5, 2), 42.0f);
  e.history_frames = H + 1;
  try {
    (void)history_tensor(e);
    FAIL() << "no error";
  } catch (const Error& err) {
    EXPECT_EQ(err.context().field, "history");
    EXPECT_NE(std::string(err.what()).find("needs " + std::to_string(N * (H + 1) * D) + " values"), std::string::npos)
        << err.what();
  }
}

namespace {
/// A plug-in generator that continues the history at constant velocity: checks the concept and
/// that rollout re-canonicalises and stitches primitives correctly.
struct ConstantVelocityGenerator {
  const Skeleton& skeleton() const { return humanoid_skeleton(); }
  Index history_frames() const { return 5; }
  Index future_frames() const { return 15; }
  std::vector<std::string> seen_texts;
  Trajectory generate(const TextCondition& c, const Trajectory& h, Rng&) {
    seen_texts.push_back(c.text);
    EXPECT_NEAR(h.root_pos(0, 0), 0.0, 1e-9);
    EXPECT_NEAR(heading_angle(h.root_rot[0]), 0.0, 1e-9);
    const Vec3 v = h.root_pos.col(4) - h.root_pos.col(3);
    Trajectory f = Trajectory::zeros(skeleton(), 15);
    for (Index i = 0; i < 15; ++i) {
      f.root_pos.col(i) = h.root_pos.col(4) + static_cast<double>(i + 1) * v;
      f.root_rot[i] = h.root_rot[4];
      f.q.col(i) = h.q.col(4);
    }
    compute_body_positions(skeleton(), f);
    return f;
  }
};
struct MissingFutureFrames {
  const Skeleton& skeleton() const { return humanoid_skeleton(); }
  Index history_frames() const { return 5; }
  Trajectory generate(const TextCondition&, const Trajectory&, Rng&) { return {}; }
};
}  // namespace

static_assert(TrajectoryGenerator<ConstantVelocityGenerator>);
static_assert(!TrajectoryGenerator<MissingFutureFrames>, "a type without future_frames() is not a generator");

TEST(Generator, RolloutStitchesPrimitivesInTheWorldFrame) {
  ConstantVelocityGenerator g;
  const Trajectory hist = test::make_motion(8, 1.0, 0.0, 0.0);  // straight line, heading 0.4
  const Vec3 v = hist.root_pos.col(7) - hist.root_pos.col(6);
  Rng rng(1);
  const auto schedule = parse_text_schedule("0:wave hands,0.6:raise arms");
  const Trajectory out = rollout(g, schedule, hist, 40, rng);
  ASSERT_EQ(out.num_frames(), 40);
  for (Index i = 0; i < 40; ++i)
    EXPECT_LT((out.root_pos.col(i) - (hist.root_pos.col(7) + static_cast<double>(i + 1) * v)).norm(), 1e-9) << i;
  ASSERT_EQ(g.seen_texts.size(), 3u);  // 40 frames = 3 primitives of 15
  EXPECT_EQ(g.seen_texts[0], "wave hands");  // t = 0 s
  EXPECT_EQ(g.seen_texts[1], "wave hands");  // t = 0.5 s
  EXPECT_EQ(g.seen_texts[2], "raise arms");  // t = 1.0 s
}

TEST(Generator, TextScheduleParsing) {
  const auto s = parse_text_schedule("0:wave hands, 5:raise arms");
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[1].text, "raise arms");
  EXPECT_DOUBLE_EQ(s[1].start_s, 5.0);
  EXPECT_EQ(text_at(s, 4.9), "wave hands");
  EXPECT_EQ(text_at(s, 7.0), "raise arms");
  EXPECT_EQ(parse_text_schedule("punch")[0].text, "punch");
  EXPECT_THROW(parse_text_schedule("x:punch"), Error);
  EXPECT_THROW(parse_text_schedule("5:punch,1:kick"), Error);
  EXPECT_THROW(parse_text_schedule(""), Error);
}

TEST(Generator, CheckGeneratedRejectsBadOutput) {
  const Skeleton& skel = humanoid_skeleton();
  Trajectory t = Trajectory::zeros(skel, 15);
  EXPECT_NO_THROW(check_generated(skel, t, 15));
  EXPECT_THROW(check_generated(skel, t, 14), Error);
  t.q(0, 3) = NAN;
  EXPECT_THROW(check_generated(skel, t, 15), Error);
}
