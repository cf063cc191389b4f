// Arm-switch training data (motion/blend.hpp blend_parts_switched, tracking/arm_data.hpp), per-window
// segment labels (primitive_dataset.hpp) and the arm-following probe (tracking/arm_eval.hpp).
#include "test_support.hpp"

#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/motion/synthetic.hpp>
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
      const int k = Skeleton::dof_offset(b);
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
  const int k = Skeleton::dof_offset(skel.index_of("L_Shoulder"));
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
  }
  EXPECT_EQ(d.label_texts[1], std::vector<std::string>{"wave"});
  // a clip without segments: one label set, its texts
  LabelledTrajectory plain{"p", {"run"}, test::make_motion(40, 2.0, 0.0, 0.5), {}};
  const auto d2 = make_primitive_dataset(skel, {plain, c}, 5, 15, 5);
  EXPECT_EQ(d2.label_texts.size(), 3u);
  EXPECT_EQ(d2.label.front(), 0);
  EXPECT_EQ(d2.label_texts[0], std::vector<std::string>{"run"});
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
  const NearestMeanClassifier clf(s.summaries, s.labels, 2);
  const ArmFollowingReport r = evaluate_samples(s, prompts, clf);
  EXPECT_EQ(r.overall_accuracy(), 1.0);
  EXPECT_GT(r.diversity[0], 0.0);
  EXPECT_THROW(NearestMeanClassifier(s.summaries, s.labels, 3), Error);  // class 2 has no sample
}
