// motion/motion_class.hpp: the root motion around a frame against closed forms (straight lines in
// every direction, a circle, a turn through ±π, the clip's ends), the class rules, bad input, and
// the real clips: the Bandai walks walk, its runs run, its walking turns turn, and the CMU
// navigation clip walks backwards where its README says.
#include <maskadapt/motion/motion_class.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/humanoid/retarget.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <numbers>

#include "test_util.hpp"

using namespace maskadapt;

namespace {
/// A 30-Hz clip of `frames` frames: root at xy(t) (m), heading yaw(t) (rad), height 0.9 m.
MotionClip class_test_path(int frames, const std::function<Eigen::Vector2d(double)>& xy, const std::function<double(double)>& yaw) {
  MotionClip c;
  c.name = "root_path";
  c.fps = 30;
  c.resize(frames, humanoid_skeleton().num_dofs());
  for (int f = 0; f < frames; ++f) {
    const double t = f / c.fps;
    c.root_pos.col(f) = Vec3(xy(t).x(), xy(t).y(), 0.9);
    c.set_rot(f, Quat(Eigen::AngleAxisd(yaw(t), Vec3::UnitZ())));
  }
  return c;
}

/// Straight at `speed` (m/s) in world direction `dir` (rad) while facing `facing` (rad).
MotionClip class_test_line(double speed, double dir, double facing) {
  return class_test_path(61, [=](double t) { return Eigen::Vector2d(speed * t * std::cos(dir), speed * t * std::sin(dir)); },
                   [=](double) { return facing; });
}
}  // namespace

// Forward, backward and sideways in the heading frame, whichever way the clip faces; the class
// follows: walk, backward, sideways, run, stand.
TEST(MotionClass, StraightLinesInTheHeadingFrame) {
  for (double facing : {0.0, 1.0, -2.5}) {
    const RootMotion fwd = root_motion_at(class_test_line(1.2, facing, facing), 30, 0.5);
    EXPECT_NEAR(fwd.forward, 1.2, 1e-9);
    EXPECT_NEAR(fwd.sideways, 0.0, 1e-9);
    EXPECT_NEAR(fwd.speed, 1.2, 1e-9);
    EXPECT_NEAR(fwd.yaw_rate, 0.0, 1e-12);
    EXPECT_EQ(classify_root_motion(fwd), MotionClass::walk);

    const RootMotion back = root_motion_at(class_test_line(0.9, facing + std::numbers::pi, facing), 30, 0.5);
    EXPECT_NEAR(back.forward, -0.9, 1e-9);
    EXPECT_EQ(classify_root_motion(back), MotionClass::backward);

    const RootMotion left = root_motion_at(class_test_line(0.8, facing + std::numbers::pi / 2, facing), 30, 0.5);
    EXPECT_NEAR(left.sideways, 0.8, 1e-9);
    EXPECT_NEAR(left.forward, 0.0, 1e-9);
    EXPECT_EQ(classify_root_motion(left), MotionClass::sideways);
    const RootMotion right = root_motion_at(class_test_line(0.8, facing - std::numbers::pi / 2, facing), 30, 0.5);
    EXPECT_NEAR(right.sideways, -0.8, 1e-9);
    EXPECT_EQ(classify_root_motion(right), MotionClass::sideways);

    EXPECT_EQ(classify_root_motion(root_motion_at(class_test_line(3.1, facing, facing), 30, 0.5)), MotionClass::run);
    EXPECT_EQ(classify_root_motion(root_motion_at(class_test_line(3.1, facing + std::numbers::pi, facing), 30, 0.5)), MotionClass::run);
    EXPECT_EQ(classify_root_motion(root_motion_at(class_test_line(0.1, facing, facing), 30, 0.5)), MotionClass::stand);
  }
}

// A walk on a circle (the root moves along its heading, which turns at ω): the yaw rate is ω
// exactly; over a window of T = 1 s the chord is 2R·sin(ωT/2) with R = v/ω, along the middle
// frame's heading, so forward = v·sin(ωT/2)/(ωT/2) and sideways = 0. The same turning through the
// ±π of atan2 keeps its rate.
TEST(MotionClass, ACircleTurnsAtItsRateAcrossPlusMinusPi) {
  const double v = 1.0, w = 0.8, R = v / w;
  for (double phase : {0.0, std::numbers::pi - 0.3}) {
    const MotionClip c = class_test_path(91, [=](double t) { return Eigen::Vector2d(R * std::sin(w * t + phase), -R * std::cos(w * t + phase)); },
                                   [=](double t) { return w * t + phase; });
    for (int f : {15, 45, 60, 75}) {
      const RootMotion m = root_motion_at(c, f, 0.5);
      EXPECT_NEAR(m.yaw_rate, w, 1e-9) << "phase " << phase << ", frame " << f;
      EXPECT_NEAR(m.forward, v * std::sin(w * 0.5) / (w * 0.5), 1e-9);
      EXPECT_NEAR(m.sideways, 0.0, 1e-9);
      EXPECT_EQ(classify_root_motion(m), MotionClass::turn);
    }
  }
  // turning the other way, slower than the threshold: a walk
  const MotionClip slow = class_test_path(61, [](double t) { return Eigen::Vector2d(t, 0.0); }, [](double t) { return -0.3 * t; });
  EXPECT_NEAR(root_motion_at(slow, 30, 0.5).yaw_rate, -0.3, 1e-9);
  EXPECT_EQ(classify_root_motion(root_motion_at(slow, 30, 0.5)), MotionClass::walk);
}

// At the clip's ends the window is clamped to the clip: frame 0 averages over [0, 0.5 s].
TEST(MotionClass, TheWindowIsClampedAtTheClipsEnds) {
  // speed 1 m/s for 1 s, then 2.4 m/s: frame 0 sees only the first part, the last frame the second
  const MotionClip c = class_test_path(61, [](double t) { return Eigen::Vector2d(t < 1 ? t : 1 + 2.4 * (t - 1), 0.0); }, [](double) { return 0.0; });
  EXPECT_NEAR(root_motion_at(c, 0, 0.5).forward, 1.0, 1e-9);
  EXPECT_NEAR(root_motion_at(c, 60, 0.5).forward, 2.4, 1e-9);
  EXPECT_NEAR(root_motion_at(c, 30, 0.5).forward, 1.7, 1e-9);  // [0.5, 1.5] s: 0.5 m + 1.2 m
  const auto classes = classify_frames(c);
  ASSERT_EQ(classes.size(), 61u);
  EXPECT_EQ(classes.front(), MotionClass::walk);
  EXPECT_EQ(classes.back(), MotionClass::run);
}

TEST(MotionClass, BadInputIsNamed) {
  const MotionClip c = class_test_line(1.0, 0, 0);
  try {
    (void)root_motion_at(c, 61, 0.5);
    FAIL() << "frame 61 of 61 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("root_path"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("frame 61"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)root_motion_at(c, 0, 0.0), Error);
  EXPECT_THROW((void)root_motion_at(c, 0, std::nan("")), Error);
  MotionClip one = c;
  one.resize(1, c.num_dofs());
  EXPECT_THROW((void)root_motion_at(one, 0, 0.5), Error);
  EXPECT_EQ(to_string(MotionClass::backward), "backward");
}

namespace {
/// Share of the frames of `clip` in class `k`.
double class_share(const MotionClip& clip, MotionClass k, double from_s = 0, double to_s = 1e9) {
  const auto cl = classify_frames(clip);
  int n = 0, in = 0;
  for (int f = 0; f < clip.num_frames(); ++f) {
    const double t = f / clip.fps;
    if (t < from_s || t > to_s) continue;
    ++n;
    in += cl[static_cast<std::size_t>(f)] == k;
  }
  return n ? static_cast<double>(in) / n : 0.0;
}
}  // namespace

// The real clips (skips without the shared data): the humanoid's x axis is its facing direction
// (a walk's forward speed is positive), Bandai walks walk, runs run, walking turns turn, and CMU
// 09_12 walks backwards in its backward spans (README: ≈ 7.5–10 s and 11.5–16 s).
TEST(MotionClass, RealClipsFallInTheirClasses) {
  MASKADAPT_REQUIRE_MOTIONS(bandai, "bandai/locomotion");
  namespace fs = std::filesystem;
  const MotionClip walk = import_motion((fs::path(bandai) / "dataset-2_walk_normal_001.bvh").string());
  const MotionClip run = import_motion((fs::path(bandai) / "dataset-2_run_normal_001.bvh").string());
  const MotionClip turn = import_motion((fs::path(bandai) / "dataset-2_walk-turn-left_normal_001.bvh").string());
  EXPECT_GT(root_motion_at(walk, walk.num_frames() / 2, 0.5).forward, 0.8);
  EXPECT_GE(class_share(walk, MotionClass::walk), 0.8);
  EXPECT_GE(class_share(run, MotionClass::run), 0.6);
  EXPECT_GE(class_share(turn, MotionClass::turn), 0.3);
  MASKADAPT_REQUIRE_CMU(cmu);
  const MotionClip nav = import_motion((fs::path(cmu) / "09_12_navigate_walk.bvh").string());
  EXPECT_GE(class_share(nav, MotionClass::backward, 12.0, 15.5), 0.6);
  EXPECT_LE(class_share(nav, MotionClass::backward, 1.0, 6.0), 0.05);
}
