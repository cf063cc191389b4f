// MotionLibrary: interpolation and velocities against closed forms, looping with root offsets,
// weighted sampling, AMP windows = compute_observation, visitation features, part-wise blends,
// synthetic clips.
#include <maskadapt/motion/blend.hpp>
#include <maskadapt/motion/geometry.hpp>
#include <maskadapt/motion/library.hpp>
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/humanoid/synthetic.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>
#include <numbers>

using namespace maskadapt;

namespace {
constexpr double kPi = std::numbers::pi;

// Closed-form clip at 30 Hz: root moves at v along x and turns at w_yaw about z; the left knee
// bends as A sin(2π f t) about its y hinge; everything else is still.
constexpr double kV = 1.3, kYawRate = 0.4, kA = 0.5, kF = 1.0;
MotionClip closed_form_clip() {
  MotionClip c;
  c.name = "closed_form";
  c.fps = 30;
  c.resize(61, humanoid_skeleton().num_dofs());
  for (int t = 0; t < c.num_frames(); ++t) {
    const double time = t / c.fps;
    c.root_pos.col(t) = Vec3(kV * time, 0, 0.9);
    c.set_rot(t, Quat(Eigen::AngleAxisd(kYawRate * time, Vec3::UnitZ())));
    c.q(humanoid_skeleton().dof_offset(hb::LKnee) + 1, t) = kA * std::sin(2 * kPi * kF * time);
  }
  return c;
}
}  // namespace

// wrap_angle's fast path for angles already in (−π, π] returns what the remainder formula does,
// bit for bit, at the boundaries and across many turns.
TEST(Rotation, WrapAngleIsTheRemainderFormulaBitForBit) {
  auto reference = [](double a) {
    a = std::remainder(a, 2.0 * kPi);
    return a <= -kPi ? a + 2.0 * kPi : a;
  };
  std::vector<double> angles = {0.0, -0.0, 1e-300, kPi, -kPi, 2 * kPi, -2 * kPi, 3 * kPi, -3 * kPi, 1e6, -1e6};
  for (double a : {kPi, -kPi, 3 * kPi})
    for (double dir : {-1e9, 1e9}) angles.push_back(std::nextafter(a, dir));
  Rng rng(3);
  for (int k = 0; k < 10000; ++k) angles.push_back(rng.uniform(-25.0, 25.0));
  for (double a : angles) {
    const double got = wrap_angle(a), want = reference(a);
    EXPECT_EQ(0, std::memcmp(&got, &want, sizeof(double))) << std::hexfloat << a;
    EXPECT_TRUE(got > -kPi && got <= kPi) << std::hexfloat << a;
  }
}

TEST(MotionLibrary, InterpolationAndVelocitiesMatchClosedForms) {
  MotionLibrary lib(humanoid_skeleton());
  lib.add(closed_form_clip());
  const int knee = humanoid_skeleton().dof_offset(hb::LKnee) + 1;
  const double h = 1.0 / 30, w = 2 * kPi * kF;
  for (double t : {0.5 + 0.3 * h, 0.77, 1.2345, 1.5 + 0.5 * h}) {
    SCOPED_TRACE(t);
    const KinematicState s = lib.state(0, t);
    EXPECT_NEAR((s.root_pos - Vec3(kV * t, 0, 0.9)).norm(), 0, 1e-12);
    EXPECT_NEAR(s.root_rot.angularDistance(Quat(Eigen::AngleAxisd(kYawRate * t, Vec3::UnitZ()))), 0, 1e-12);
    // slerp of single-axis rotations = lerp of the angle: error ≤ A w² h² / 8
    EXPECT_NEAR(s.q[knee], kA * std::sin(w * t), kA * w * w * h * h / 8 + 1e-12);
    EXPECT_NEAR((s.root_lin_vel - Vec3(kV, 0, 0)).norm(), 0, 1e-9);
    EXPECT_NEAR((s.root_ang_vel - Vec3(0, 0, kYawRate)).norm(), 0, 1e-9);
    // central difference over ±h of the interpolated angle: error ≈ A w³ h² / 6 (+ interpolation)
    EXPECT_NEAR(s.qd[knee], kA * w * std::cos(w * t), kA * w * w * w * h * h / 6 + kA * w * w * h / 4);
    for (Index k = 0; k < s.qd.size(); ++k) {
      if (k != knee) {
        EXPECT_EQ(s.qd[k], 0.0);
      }
    }
  }
  // at the clip's ends the differences are one-sided and stay finite
  const KinematicState end = lib.state(0, lib.clip(0).duration());
  EXPECT_NEAR(end.root_lin_vel.x(), kV, 1e-9);
}

TEST(MotionLibrary, BodyVelocitiesMatchFiniteDifferencesOfPositions) {
  MotionLibrary lib(humanoid_skeleton());
  lib.add(synthetic_walk());
  // the library differentiates over ±h = one frame; body velocities (FK of q̇) must agree with
  // the same central difference of body positions up to the curvature of the path (O(h²))
  const double h = 1.0 / 30;
  for (double t : {0.2, 0.41, 0.83}) {
    const BodyStates b = lib.body_states(0, t), b1 = lib.body_states(0, t - h), b2 = lib.body_states(0, t + h);
    for (int i = 0; i < b.num_bodies(); ++i) {
      const Vec3 fd = (b2.pos.col(i) - b1.pos.col(i)) / (2 * h);
      EXPECT_LT((b.lin_vel.col(i) - fd).norm(), 0.03 + 0.03 * fd.norm()) << t << " " << humanoid_skeleton().names[i];
    }
  }
}

TEST(MotionLibrary, LoopingAccumulatesTheRootOffset) {
  MotionLibrary lib(humanoid_skeleton());
  const MotionClip walk = synthetic_walk();
  lib.add(walk);
  const double P = walk.duration();
  const Vec3 travel = walk.root_pos.col(walk.num_frames() - 1) - walk.root_pos.col(0);
  ASSERT_GT(travel.x(), 0.5);
  for (double tau : {0.0, 0.2, 0.55}) {
    const KinematicState a = lib.state(0, tau), b = lib.state(0, tau + 2 * P);
    EXPECT_LT((b.q - a.q).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_NEAR(b.root_pos.x() - a.root_pos.x(), 2 * travel.x(), 1e-6);
    EXPECT_NEAR(b.root_pos.z(), a.root_pos.z(), 1e-12);
  }
  // continuous across the cycle boundary
  const KinematicState before = lib.state(0, P - 1e-6), after = lib.state(0, P + 1e-6);
  EXPECT_LT((before.root_pos - after.root_pos).norm(), 1e-4);
  EXPECT_LT((before.q - after.q).cwiseAbs().maxCoeff(), 1e-3);
}

TEST(MotionLibrary, WeightedAndUniformSampling) {
  MotionLibrary lib(humanoid_skeleton());
  lib.add(synthetic_walk(), 1.0);
  lib.add(synthetic_jump(), 3.0);
  Rng rng(7);
  int count[2] = {0, 0};
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    const ClipTime ct = lib.sample(rng);
    ++count[ct.clip];
    EXPECT_GE(ct.time, 0.0);
    EXPECT_LE(ct.time, lib.clip(ct.clip).duration());
  }
  EXPECT_NEAR(count[1] / double(n), 0.75, 0.03);
  count[0] = count[1] = 0;
  for (int i = 0; i < n; ++i) ++count[lib.sample(rng, false).clip];
  EXPECT_NEAR(count[1] / double(n), 0.5, 0.03);
  // same seed → same samples
  Rng r1(3), r2(3);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(lib.sample(r1).time, lib.sample(r2).time);
  EXPECT_THROW(lib.add(synthetic_walk(), 0.0), Error);
  MotionClip wrong = synthetic_walk();
  wrong.q.conservativeResize(10, Eigen::NoChange);
  EXPECT_THROW(lib.add(wrong), Error);
}

TEST(MotionLibrary, AmpWindowsAreObservationsOfFiveFrames) {
  MotionLibrary lib(humanoid_skeleton());
  lib.add(synthetic_kick());
  const Index d = observation_dim(humanoid_skeleton());
  ASSERT_EQ(d, kObservationDim);
  VectorXf win(lib.amp_window_dim());
  // A 30-fps clip's window shares the poses of neighbouring frames' central differences (7 poses
  // for 15): the same observations up to the rounding of the shared times. Inside the clip, at
  // its start (t − 4Δ − h clamped to 0) and at its end (t + h clamped), looping and not.
  MotionClip looping = synthetic_walk();
  ASSERT_TRUE(looping.loop);
  lib.add(looping);
  MotionClip once = synthetic_kick();
  once.loop = false;
  lib.add(once);
  ASSERT_EQ(lib.clip(0).fps, 30.0);
  for (int clip : {0, 1, 2})
    for (double t : {1.0, 4.0 / 30.0, 0.1371, lib.clip(clip).duration(), lib.clip(clip).duration() + 0.73}) {
      lib.amp_window(clip, t, win);
      for (int k = 0; k < kAmpWindowFrames; ++k) {
        const VectorXf o = compute_observation(humanoid_skeleton(), lib.body_states(clip, t - (4 - k) / 30.0));
        EXPECT_LT((win.segment(k * d, d) - o).cwiseAbs().maxCoeff(), 2e-5f) << "clip " << clip << " t " << t << " frame " << k;
      }
    }
  // other frame rates: every frame computed on its own, exactly as body_states gives it
  MotionClip fast = synthetic_kick();
  fast.fps = 60;
  const int c60 = lib.add(fast);
  lib.amp_window(c60, 0.5, win);
  for (int k = 0; k < kAmpWindowFrames; ++k)
    EXPECT_EQ(win.segment(k * d, d), compute_observation(humanoid_skeleton(), lib.body_states(c60, 0.5 - (4 - k) / 30.0)));
  Rng rng(1);
  const MatrixXf batch = lib.sample_amp_windows(rng, 8);
  EXPECT_EQ(batch.rows(), 5 * kObservationDim);
  EXPECT_EQ(batch.cols(), 8);
  EXPECT_TRUE(batch.allFinite());
  // reset states are finite and carry velocities
  const KinematicState s = lib.reset_state(rng);
  EXPECT_EQ(s.q.size(), humanoid_skeleton().num_dofs());
  EXPECT_TRUE(s.qd.allFinite());
}

// Shorter windows (a discriminator that sees F < 5 frames, BaseTrainConfig::disc.window_frames):
// the window of F frames ending at t is the last F frames of the 5-frame one, bit for bit, on a
// 30-fps clip (shared poses) and at other rates; a batch drawn from the same seed is the last F
// frames of the 5-frame batch; sizes other than 1–5 frames are refused.
TEST(MotionLibrary, ShorterAmpWindowsAreTheLastFramesOfTheFiveFrameWindow) {
  MotionLibrary lib(humanoid_skeleton());
  lib.add(synthetic_walk());
  MotionClip once = synthetic_kick();
  once.loop = false;
  lib.add(once);
  MotionClip fast = synthetic_kick();
  fast.fps = 60;
  lib.add(fast);
  const Index d = kObservationDim;
  VectorXf five(lib.amp_window_dim());
  for (int frames = 1; frames <= kAmpWindowFrames; ++frames) {
    VectorXf w(lib.amp_window_dim(frames));
    ASSERT_EQ(w.size(), frames * d);
    for (int clip : {0, 1, 2})
      for (double t : {1.0, 0.1371, 2.0 / 30.0, lib.clip(clip).duration() + 0.2}) {
        lib.amp_window(clip, t, five);
        lib.amp_window(clip, t, w);
        EXPECT_EQ(w, five.tail(frames * d)) << frames << " frames, clip " << clip << " t " << t;
      }
    Rng a(7), b(7);
    const MatrixXf batch5 = lib.sample_amp_windows(a, 6);
    MatrixXf batch(frames * d, 6);
    lib.sample_amp_windows(b, batch);
    EXPECT_EQ(batch, batch5.bottomRows(frames * d));
  }
  EXPECT_THROW(lib.amp_window_dim(0), Error);
  EXPECT_THROW(lib.amp_window_dim(kAmpWindowFrames + 1), Error);
  VectorXf odd(2 * d + 1), six(6 * d);
  EXPECT_THROW(lib.amp_window(0, 1.0, odd), Error);
  EXPECT_THROW(lib.amp_window(0, 1.0, six), Error);
  Rng rng(1);
  MatrixXf bad(6 * d, 2);
  EXPECT_THROW(lib.sample_amp_windows(rng, bad), Error);
}

TEST(MotionLibrary, VisitationFeaturesSelectPartsAndIgnoreHeading) {
  const Skeleton& s = humanoid_skeleton();
  KinematicState st = synthetic_walk().frame(5);
  const BodyStates b = forward_kinematics(s, st);
  const VectorXf all = visitation_features(s, b);
  EXPECT_EQ(all.size(), 3 * 21);
  const VectorXf arm = visitation_features(s, b, PartMask::of(BodyPart::LeftArm));
  EXPECT_EQ(arm.size(), 3 * 4);  // L_Thorax, L_Shoulder, L_Elbow, L_Wrist
  EXPECT_EQ(arm.segment<3>(9), all.segment<3>(3 * (hb::LWrist - 1)));
  // turning and moving the whole body leaves the features unchanged
  st.root_rot = Quat(Eigen::AngleAxisd(1.1, Vec3::UnitZ())) * st.root_rot;
  st.root_pos += Vec3(3, -4, 0);
  const VectorXf turned = visitation_features(s, forward_kinematics(s, st));
  EXPECT_LT((turned - all).cwiseAbs().maxCoeff(), 1e-5);
}

TEST(Blend, TakesBsJointsExactlyOnMaskedPartsAndAsElsewhere) {
  const Skeleton& s = humanoid_skeleton();
  const MotionClip a = synthetic_walk(), b = synthetic_arm_circles();
  const PartMask mask = PartMask::of(BodyPart::LeftArm) | PartMask::of(BodyPart::RightArm);
  const MotionClip m = blend_parts(a, b, mask, s);
  ASSERT_EQ(m.num_frames(), a.num_frames());
  EXPECT_EQ(m.root_pos, a.root_pos);
  EXPECT_EQ(m.root_rot, a.root_rot);
  for (int t = 0; t < m.num_frames(); ++t)
    for (int body = 1; body < s.num_bodies(); ++body) {
      const int k = humanoid_skeleton().dof_offset(body);
      const Vec3 expect = mask.has(s.parts[body]) ? Vec3(b.q.col(t).segment<3>(k)) : Vec3(a.q.col(t).segment<3>(k));
      EXPECT_EQ(Vec3(m.q.col(t).segment<3>(k)), expect) << t << " " << s.names[body];
    }
  // B shorter than A loops: the jump (not looping, 2.3 s) under a long A with loop_b
  MotionClip longer = synthetic_walk();
  longer = blend_parts(longer, synthetic_arm_circles(), mask, s, {.b_offset = 0.5});
  const int k = humanoid_skeleton().dof_offset(hb::LShoulder);
  const MotionClip arms = synthetic_arm_circles();
  // A frame 3 ↔ B time 0.1 + 0.5 = 0.6 s = B frame 18
  EXPECT_EQ(Vec3(longer.q.col(3).segment<3>(k)), Vec3(arms.q.col(18).segment<3>(k)));
}

TEST(Synthetic, ClipsAreGroundedValidAndLoop) {
  const auto& d = humanoid_description();
  for (const char* n : {"walk", "arms", "kick", "jump"}) {
    SCOPED_TRACE(n);
    const MotionClip c = synthetic_clip(n);
    c.validate(d.skeleton);
    EXPECT_FALSE(c.labels.empty());
    double zmin = 1e9;
    for (int t = 0; t < c.num_frames(); ++t) {
      const BodyStates b = forward_kinematics(d.skeleton, c.frame(t));
      for (int f : d.foot_bodies()) zmin = std::min(zmin, geometry::lowest_point(d, b, f));
    }
    EXPECT_NEAR(zmin, 0.0, 1e-9);
    if (c.loop) {
      EXPECT_LT((c.q.col(0) - c.q.col(c.num_frames() - 1)).cwiseAbs().maxCoeff(), 1e-6);
    }
  }
  EXPECT_THROW(synthetic_clip("moonwalk"), Error);
  const auto set = builtin_motion_set("synthetic");
  EXPECT_EQ(set.size(), 4u);
  const auto loco = builtin_motion_set("locomotion", "/nonexistent");
  ASSERT_EQ(loco.size(), 1u);
  EXPECT_EQ(loco[0].name, "synthetic_walk");
}

// slice_seconds (motion import --from/--to): the frames nearest the two times, both included,
// exactly as in the clip; errors name the field.
TEST(MotionClip, SliceSecondsKeepsTheFramesOfTheRange) {
  const MotionClip c = synthetic_walk(0.9, /*period=*/2.0);
  ASSERT_GT(c.duration(), 1.6);
  const MotionClip cut = slice_seconds(c, 0.5, 1.5);
  ASSERT_EQ(cut.num_frames(), 31);  // frames 15 … 45 at 30 fps
  EXPECT_EQ(cut.q, c.q.middleCols(15, 31));
  EXPECT_EQ(cut.root_pos, c.root_pos.middleCols(15, 31));
  EXPECT_EQ(cut.root_rot, c.root_rot.middleCols(15, 31));
  EXPECT_FALSE(cut.loop);
  EXPECT_EQ(slice_seconds(c, 0.51, -1).num_frames(), c.num_frames() - 15);  // to the last frame
  auto field_of = [&](double from, double to) {
    try {
      (void)slice_seconds(c, from, to, "--from", "--to");
    } catch (const Error& e) {
      return e.context().field;
    }
    return std::string("accepted");
  };
  EXPECT_EQ(field_of(-0.1, 1.0), "--from");
  EXPECT_EQ(field_of(std::nan(""), 1.0), "--from");
  EXPECT_EQ(field_of(c.duration() + 1, -1), "--from");
  EXPECT_EQ(field_of(0.5, c.duration() + 1), "--to");
  EXPECT_EQ(field_of(0.5, 0.5), "--to");   // one frame
  EXPECT_EQ(field_of(1.0, 0.5), "--to");   // backwards
}
