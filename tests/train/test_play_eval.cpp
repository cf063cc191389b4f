// play / eval-base on the tiny analytic simulator: the recorded clip reproduces the simulated
// body poses through forward kinematics, masks follow the schedule, outputs round-trip through
// their readers, and the H_norm table has the paper's shape and its closed-form extremes.
#include "tiny_sim.hpp"

#include <maskadapt/motion/bvh.hpp>
#include <maskadapt/humanoid/retarget.hpp>
#include <maskadapt/train/eval_base.hpp>
#include <maskadapt/train/play.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>

using namespace maskadapt;
using namespace maskadapt::train;
using maskadapt::testing::TinyWalkerSim;

namespace {

tasks::ResetSampler upright_jittered(const Skeleton& skel) {
  return [&skel](Rng& rng) {
    tasks::ResetSample r;
    r.pose = KinematicState::zero(skel);
    r.pose.root_pos.z() = TinyWalkerSim::kHeight;
    for (Index i = 0; i < r.pose.q.size(); ++i) r.pose.q[i] = rng.uniform(-0.3, 0.3);
    return r;
  };
}

/// A reference for eval-base: the visitation features of 20 random upright poses drawn from `reset`.
MatrixXf random_upright_reference(const Skeleton& skel, const tasks::ResetSampler& reset, std::uint64_t seed) {
  Rng rng(seed);
  MatrixXf ref;
  for (int k = 0; k < 20; ++k) {
    const VectorXf v = visitation_features(skel, forward_kinematics(skel, reset(rng).pose));
    if (k == 0) ref.resize(v.size(), 20);
    ref.col(k) = v;
  }
  return ref;
}

BaseTrainConfig play_config() {
  BaseTrainConfig c;  // the paper's formulation (struct defaults), not the cpu preset's walking recipe
  c.net.actor_hidden = {8};
  c.net.critic_hidden = {8};
  c.net.disc_hidden = {8};
  c.net.init_log_std = -1.0;
  return c;
}

struct Fixture {
  TinyWalkerSim sim;
  BasePolicy policy;
  explicit Fixture(std::size_t envs = 1) : sim(envs) {
    const Index d = observation_dim(sim.skeleton());
    Rng init(3);
    policy = make_base_policy(play_config(), {d, d + kNumParts, sim.skeleton().num_dofs(), 5 * d}, init);
  }
  FallCriteria fall() const { return FallCriteria::for_skeleton(sim.skeleton(), {"l_leg", "r_leg"}, "head", 0.8); }
};

std::filesystem::path play_temp(const std::string& name) { return std::filesystem::temp_directory_path() / name; }

}  // namespace

TEST(Play, ClipReproducesTheSimulatedBodyPosesAndMasksFollowTheSchedule) {
  Fixture f;
  PlayOptions opt;
  opt.seconds = 1.0;
  opt.masks = MaskSampler::scheduled("0:none,0.5:left_leg,right_arm");
  const PlayResult r = play_base_policy(f.sim, f.policy, upright_jittered(f.sim.skeleton()), opt,
                                        eval::make_rollout(f.sim.skeleton(), 30.0), f.fall());
  const int frames = static_cast<int>(std::llround(1.0 / f.sim.control_dt())) + 1;
  ASSERT_EQ(r.rollout.num_frames(), frames);
  ASSERT_EQ(r.clip.num_frames(), frames);
  ASSERT_EQ(r.root.cols(), frames);
  double worst = 0;
  for (int t = 0; t < frames; ++t) {
    const BodyStates b = forward_kinematics(f.sim.skeleton(), r.clip.frame(t));
    worst = std::max(worst, (b.pos - r.rollout.positions[static_cast<std::size_t>(t)]).cwiseAbs().maxCoeff());
    const double time = t * r.dt;
    const PartMask expected = time < 0.5 - 1e-9 ? PartMask::none() : PartMask::parse("left_leg,right_arm");
    EXPECT_EQ(r.rollout.masks[static_cast<std::size_t>(t)], expected) << "frame " << t;
  }
  EXPECT_LT(worst, 1e-9) << "FK of the recovered joint angles differs from the simulated body positions";
  // the policy moved the joints (the clip is not a frozen pose)
  EXPECT_GT((r.clip.q.col(frames - 1) - r.clip.q.col(0)).norm(), 1e-3);
}

TEST(Play, DeterministicRunsRepeatAndSampledRunsDependOnTheSeed) {
  auto run = [](bool det, std::uint64_t seed) {
    Fixture f;
    PlayOptions opt;
    opt.seconds = 0.5;
    opt.deterministic = det;
    opt.seed = seed;
    return play_base_policy(f.sim, f.policy, upright_jittered(f.sim.skeleton()), opt, eval::make_rollout(f.sim.skeleton()), f.fall()).clip.q;
  };
  EXPECT_EQ(run(true, 1), run(true, 1));
  EXPECT_EQ(run(false, 4), run(false, 4));
  EXPECT_NE(run(false, 4), run(false, 5));
}

TEST(Play, OutputsRoundTripThroughTheirReaders) {
  Fixture f;
  PlayOptions opt;
  opt.seconds = 0.5;
  opt.masks = MaskSampler::fixed(PartMask::parse("legs"));
  const PlayResult r = play_base_policy(f.sim, f.policy, upright_jittered(f.sim.skeleton()), opt, eval::make_rollout(f.sim.skeleton()), f.fall());
  // CSV: header + one row per frame, values as recorded
  const auto csv = play_temp("maskadapt_play_test.csv");
  write_root_xy_csv(csv.string(), r.root, r.dt);
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "t,x,y");
  int rows = 0;
  double t = 0, x = 0, y = 0;
  char c1, c2;
  while (in >> t >> c1 >> x >> c2 >> y) {
    EXPECT_NEAR(t, rows * r.dt, 1e-9);
    EXPECT_NEAR(x, r.root(0, rows), 1e-8);
    EXPECT_NEAR(y, r.root(1, rows), 1e-8);
    ++rows;
  }
  EXPECT_EQ(rows, r.root.cols());
  std::filesystem::remove(csv);
  // viewer rollout: frames, masks and contacts survive write → read
  const auto json = play_temp("maskadapt_play_test.json");
  eval::write_rollout(r.rollout, json.string());
  const eval::Rollout back = eval::read_rollout(json.string());
  ASSERT_EQ(back.num_frames(), r.rollout.num_frames());
  EXPECT_EQ(back.masks.back(), PartMask::parse("legs"));
  EXPECT_EQ(back.contacts.size(), r.rollout.contacts.size());
  std::filesystem::remove(json);
  // BVH: text → parser, same frame count and frame time
  const bvh::Motion m = bvh::parse(bvh::to_string(clip_to_bvh(r.clip, f.sim.skeleton())));
  EXPECT_EQ(m.frames.cols(), r.clip.num_frames());
  EXPECT_NEAR(m.frame_time, r.dt, 1e-9);
}

TEST(Play, RejectsAPolicyOfTheWrongSize) {
  Fixture f;
  BaseTrainConfig c = play_config();
  Rng init(1);
  const BasePolicy wrong = make_base_policy(c, {10, 15, 4, 50}, init);
  EXPECT_THROW(play_base_policy(f.sim, wrong, upright_jittered(f.sim.skeleton()), PlayOptions{}, eval::make_rollout(f.sim.skeleton()), f.fall()),
               Error);
}

TEST(EvalBase, MasksAreTheNullMaskAndEveryMaskOfOneOrTwoParts) {
  const auto masks = one_and_two_part_masks();
  ASSERT_EQ(masks.size(), 16u);
  EXPECT_TRUE(masks[0].empty());
  std::set<int> bits;
  for (auto m : masks) {
    EXPECT_LE(m.count(), 2);
    bits.insert(m.bits);
  }
  EXPECT_EQ(bits.size(), 16u);
}

TEST(EvalBase, HNormReachesItsClosedFormExtremes) {
  Fixture f(3);
  EvalBaseOptions opt;
  opt.frames = 12;
  opt.episode_seconds = 0.2;
  // reference: 7 arbitrary frames of the right dimension
  const Index d = visitation_features(f.sim.skeleton(), f.sim.body_states(0)).size();
  const MatrixXf ref = MatrixXf::Random(d, 7);
  // a threshold larger than any distance, counting all_within: every generated frame counts for
  // every reference frame → uniform → 1
  opt.threshold = 1e6;
  opt.counting = eval::VisitCounting::all_within;
  const auto all = evaluate_visitation(f.sim, f.policy, upright_jittered(f.sim.skeleton()), PartMask::none(), ref, opt, f.fall());
  EXPECT_DOUBLE_EQ(all.h_norm, 1.0);
  EXPECT_DOUBLE_EQ(all.matched_fraction, 1.0);
  EXPECT_DOUBLE_EQ(all.visited_fraction, 1.0);
  // counting nearest: every frame still matches, but visits its nearest reference frame only; with
  // six of the seven frames moved 100 further away in every feature, column 0 takes every visit → 0
  opt.counting = eval::VisitCounting::nearest;
  MatrixXf one_near = ref;
  one_near.rightCols(6).array() += 100.f;
  const auto one = evaluate_visitation(f.sim, f.policy, upright_jittered(f.sim.skeleton()), PartMask::none(), one_near, opt, f.fall());
  EXPECT_DOUBLE_EQ(one.matched_fraction, 1.0);
  EXPECT_DOUBLE_EQ(one.visited_fraction, 1.0 / 7.0);
  EXPECT_EQ(one.h_norm, 0.0);
  opt.counting = eval::VisitCounting::all_within;
  // threshold 0 against frames far away: nothing matches → 0 by convention
  opt.threshold = 0.0;
  const auto none = evaluate_visitation(f.sim, f.policy, upright_jittered(f.sim.skeleton()), PartMask::none(), MatrixXf(ref.array() + 100.f), opt, f.fall());
  EXPECT_EQ(none.h_norm, 0.0);
  EXPECT_EQ(none.matched_fraction, 0.0);
  // episodes of 0.2 s over 12 steps of 1/30 s: every env ends at least one episode
  EXPECT_GE(all.episodes, 3);
  EXPECT_GE(all.fall_rate, 0.0);
  EXPECT_LE(all.fall_rate, 1.0);
  EXPECT_GT(all.mean_episode_length, 0.0);
  EXPECT_LE(all.mean_episode_length, 0.2 + 1e-9);
  EXPECT_TRUE(std::isfinite(all.mean_speed));
  EXPECT_GE(all.mean_speed, 0.0);
}

// The clips' mean speed is their summed horizontal root path over their summed duration: a 2-s
// clip at 1.5 m/s (with a vertical bob that must not count) and a 1-s clip standing still → 1 m/s.
TEST(EvalBase, ReferenceSpeedIsTheClipsHorizontalPathOverTheirDuration) {
  auto straight = [](int frames, double speed) {
    MotionClip c;
    c.name = "straight";
    c.fps = 30;
    c.resize(frames, humanoid_skeleton().num_dofs());
    for (int t = 0; t < frames; ++t) {
      c.root_pos.col(t) = Vec3(speed * t / 30.0, 0, 0.9 + 0.05 * std::sin(t));
      c.set_rot(t, Quat::Identity());
    }
    return c;
  };
  MotionLibrary lib(humanoid_skeleton());
  lib.add(straight(61, 1.5));
  lib.add(straight(31, 0.0));
  EXPECT_NEAR(reference_mean_speed(lib), 1.0, 1e-12);
}

TEST(EvalBase, TableHasTheUpperTriangularShapeAndJsonMatchesTheRows) {
  Fixture f(2);
  EvalBaseOptions opt;
  opt.frames = 6;
  opt.threshold = 0.3;
  // reference: the visitation features of a few random upright poses
  const Skeleton& skel = f.sim.skeleton();
  auto reset = upright_jittered(skel);
  const MatrixXf ref = random_upright_reference(skel, reset, 9);
  const BaseEvaluation ev = evaluate_base_policy(f.sim, f.policy, reset, ref, opt, f.fall());
  ASSERT_EQ(ev.rows.size(), 16u);
  for (const auto& r : ev.rows) {
    EXPECT_GE(r.rsi.h_norm, 0.0);
    EXPECT_LE(r.rsi.h_norm, 1.0);
    EXPECT_GE(r.shared.h_norm, 0.0);
    EXPECT_LE(r.shared.h_norm, 1.0);
  }
  const nlohmann::json j = to_json(ev);
  ASSERT_EQ(j["table_rsi"].size(), 5u);
  for (int p = 0; p < 5; ++p)
    for (int q = 0; q < 5; ++q) {
      const auto& cell = j["table_rsi"][p][q];
      if (q < p) {
        EXPECT_TRUE(cell.is_null());
        continue;
      }
      const PartMask m = PartMask::of(static_cast<BodyPart>(p)) | PartMask::of(static_cast<BodyPart>(q));
      for (const auto& r : ev.rows)
        if (r.mask == m) {
          EXPECT_EQ(cell.get<double>(), r.rsi.h_norm);
        }
    }
  EXPECT_EQ(j["null_shared"].get<double>(), ev.rows[0].shared.h_norm);
  EXPECT_EQ(j["masks"].size(), 16u);
  const std::string table = format_hnorm_table(ev, false);
  EXPECT_NE(table.find("left_leg"), std::string::npos);
  EXPECT_EQ(std::count(table.begin(), table.end(), '\n'), 7);  // title, header, 5 rows
}

// `eval-base --masks`: a chosen subset evaluates each of its masks exactly as the whole table does
// (every mask draws the same seeds), in the order given, and the JSON tables mark the masks not
// evaluated as null.
TEST(EvalBase, ASubsetOfMasksGivesTheWholeTablesRowsForThoseMasks) {
  Fixture f(3);
  EvalBaseOptions opt;
  opt.frames = 40;
  opt.threshold = 0.3;
  opt.episode_seconds = 0.3;  // several episodes per env end within the 40 steps
  const Skeleton& skel = f.sim.skeleton();
  auto reset = upright_jittered(skel);
  const MatrixXf ref = random_upright_reference(skel, reset, 11);
  const BaseEvaluation whole = evaluate_base_policy(f.sim, f.policy, reset, ref, opt, f.fall());
  const PartMask legs = PartMask::parse("legs");
  opt.masks = {legs, PartMask::none()};
  const BaseEvaluation subset = evaluate_base_policy(f.sim, f.policy, reset, ref, opt, f.fall());
  ASSERT_EQ(subset.rows.size(), 2u);
  EXPECT_EQ(subset.rows[0].mask, legs);
  EXPECT_TRUE(subset.rows[1].mask.empty());
  auto same = [](double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; };
  long long episodes = 0;
  for (const auto& s : subset.rows) {
    const auto w = std::find_if(whole.rows.begin(), whole.rows.end(), [&](const MaskEvaluation& r) { return r.mask == s.mask; });
    ASSERT_NE(w, whole.rows.end());
    for (const auto& [a, b] : {std::pair{s.rsi, w->rsi}, std::pair{s.shared, w->shared}}) {
      EXPECT_EQ(a.h_norm, b.h_norm) << s.mask.to_string();
      EXPECT_TRUE(same(a.fall_rate, b.fall_rate)) << s.mask.to_string();
      EXPECT_TRUE(same(a.mean_speed, b.mean_speed)) << s.mask.to_string();
      EXPECT_EQ(a.episodes, b.episodes);
      EXPECT_EQ(a.falls, b.falls);
      episodes += a.episodes;
    }
  }
  EXPECT_GT(episodes, 0);  // (the comparison covers ended episodes, not only empty results)
  const nlohmann::json j = to_json(subset);
  EXPECT_EQ(j["masks"].size(), 2u);
  EXPECT_EQ(j["table_rsi"][3][4].get<double>(), subset.rows[0].rsi.h_norm);  // left_leg × right_leg
  EXPECT_TRUE(j["table_rsi"][0][0].is_null());                               // trunk: not evaluated
}

namespace {
/// A 30-Hz clip on the tiny walker: root at (v·t, y0, 1 m) facing +x, all joints at zero.
MotionClip tiny_line(const Skeleton& skel, double v, double y0) {
  MotionClip c;
  c.name = v == 0 ? "tiny_stand" : "tiny_walk";
  c.fps = 30;
  c.resize(61, skel.num_dofs());
  for (int t = 0; t < c.num_frames(); ++t) {
    c.root_pos.col(t) = Vec3(v * t / 30.0, y0, TinyWalkerSim::kHeight);
    c.set_rot(t, Quat::Identity());
  }
  return c;
}
}  // namespace

// `eval-base --per-class`: a library of a standing clip (at y = 0) and a 1 m/s walk (at y = 5)
// has two classes, each with the 57 frames at t ≥ 4/30 s (1.9 s) and the clips' speed there
// (0 and 1 m/s); a class's resets come from its own clip only; the evaluation gives one row per
// (class, mask), without H_norm, with the same episode counts as evaluate_visitation from that
// class's sampler, and its table and JSON carry those rows.
TEST(EvalBase, PerClassStartsComeOnlyFromTheirClassAndReportTheClipsSpeed) {
  Fixture f(2);
  const Skeleton& skel = f.sim.skeleton();
  auto lib = std::make_shared<MotionLibrary>(skel);
  lib->add(tiny_line(skel, 0.0, 0.0));
  lib->add(tiny_line(skel, 1.0, 5.0));
  const std::vector<ClassStarts> classes = class_starts(*lib);
  ASSERT_EQ(classes.size(), 2u);
  EXPECT_EQ(classes[0].motion_class, MotionClass::stand);
  EXPECT_EQ(classes[1].motion_class, MotionClass::walk);
  for (const auto& cs : classes) {
    EXPECT_EQ(cs.starts.size(), 57u);
    EXPECT_NEAR(cs.seconds, 57 / 30.0, 1e-12);
    for (const ClipTime& ct : cs.starts) EXPECT_GE(ct.time, kEarliestResetTime - 1e-12);
  }
  EXPECT_NEAR(classes[0].mean_speed, 0.0, 1e-12);
  EXPECT_NEAR(classes[1].mean_speed, 1.0, 1e-9);
  EXPECT_NEAR(classes[1].mean_forward, 1.0, 1e-9);
  for (const auto& cs : classes) {
    const auto reset = class_reset_sampler(lib, std::make_shared<const ClassStarts>(cs));
    Rng rng(4);
    for (int k = 0; k < 50; ++k) {
      const tasks::ResetSample r = reset(rng);
      EXPECT_EQ(r.pose.root_pos.y(), cs.motion_class == MotionClass::stand ? 0.0 : 5.0);
      EXPECT_EQ(r.history.cols(), kAmpWindowFrames - 1);
    }
  }
  EXPECT_THROW((void)class_reset_sampler(lib, std::make_shared<const ClassStarts>()), Error);

  EvalBaseOptions opt;
  opt.frames = 30;
  opt.episode_seconds = 0.4;
  opt.masks = {PartMask::none(), PartMask::parse("legs")};
  const auto rows = evaluate_by_start_class(f.sim, f.policy, lib, opt, f.fall());
  ASSERT_EQ(rows.size(), 4u);  // 2 classes × 2 masks
  EXPECT_EQ(rows[0].motion_class, MotionClass::stand);
  EXPECT_EQ(rows[3].motion_class, MotionClass::walk);
  EXPECT_EQ(rows[3].mask, PartMask::parse("legs"));
  EXPECT_NEAR(rows[3].reference_speed, 1.0, 1e-9);
  for (const auto& r : rows) {
    EXPECT_TRUE(std::isnan(r.result.h_norm));
    EXPECT_GE(r.result.episodes, 2);  // 0.4-s episodes over 1 s: every env ends at least one
    EXPECT_TRUE(std::isfinite(r.result.mean_speed));
    EXPECT_LE(std::abs(r.result.mean_forward_speed), r.result.mean_speed + 1e-12);
  }
  // the walk's null-mask row is evaluate_visitation from the walk's sampler (same seed)
  EvalBaseOptions one = opt;
  one.entropy = false;
  const MatrixXf no_reference(3 * (skel.num_bodies() - 1), 0);
  const VisitationResult direct = evaluate_visitation(f.sim, f.policy, class_reset_sampler(lib, std::make_shared<const ClassStarts>(classes[1])),
                                                      PartMask::none(), no_reference, one, f.fall());
  EXPECT_EQ(direct.episodes, rows[2].result.episodes);
  EXPECT_EQ(direct.falls, rows[2].result.falls);
  EXPECT_EQ(direct.mean_speed, rows[2].result.mean_speed);
  const std::string table = format_class_table(rows);
  EXPECT_EQ(std::count(table.begin(), table.end(), '\n'), 6);  // header, 4 rows, footer
  EXPECT_NE(table.find("walk"), std::string::npos);
  const nlohmann::json j = to_json(rows);
  ASSERT_EQ(j.size(), 4u);
  EXPECT_EQ(j[3]["class"], "walk");
  EXPECT_EQ(j[3]["mask"], PartMask::parse("legs").to_string());
  EXPECT_EQ(j[2]["result"]["episodes"].get<long long>(), rows[2].result.episodes);
  EXPECT_TRUE(j[2]["result"]["h_norm"].is_null());
}

// Rising seconds (issue 41's jump measure): the clips' median root height and their share of whole
// seconds whose highest root point clears it by 0.1 m, on a 61-frame 30-Hz clip (two whole
// seconds; the partial third is left out) that rises to 1.05 m in frames 40–45 only → 0.5; in the
// simulator the share is 1 for a height far below the root, 0 far above it, and not measured
// (NaN) without one.
TEST(EvalBase, RisingSecondsOfTheClipsAndOfThePolicy) {
  MotionLibrary lib(humanoid_skeleton());
  MotionClip c;
  c.name = "rise";
  c.fps = 30;
  c.resize(61, humanoid_skeleton().num_dofs());
  for (int t = 0; t < 61; ++t) c.root_pos.col(t) = Vec3(0, 0, t >= 40 && t <= 45 ? 1.05 : 0.9);
  lib.add(c);
  EXPECT_DOUBLE_EQ(clips_median_root_height(lib), 0.9);
  EXPECT_DOUBLE_EQ(clips_rise_fraction(lib, 0.9, 0.1), 0.5);
  EXPECT_DOUBLE_EQ(clips_rise_fraction(lib, 0.96, 0.1), 0.0);  // 1.05 < 1.06
  EXPECT_DOUBLE_EQ(clips_rise_fraction(lib, 0.0, 0.1), 1.0);

  Fixture f(2);
  EvalBaseOptions opt;
  opt.frames = 70;  // two whole seconds per env at 30 Hz, and no episode ends (no fall, 10-s limit)
  opt.episode_seconds = 10;
  const FallCriteria never = FallCriteria::for_skeleton(f.sim.skeleton(), {"l_leg", "r_leg"}, "head", -100.0);
  const auto reset = upright_jittered(f.sim.skeleton());
  const MatrixXf ref = random_upright_reference(f.sim.skeleton(), reset, 5);
  const auto none = evaluate_visitation(f.sim, f.policy, reset, PartMask::none(), ref, opt, never);
  EXPECT_TRUE(std::isnan(none.rise_fraction));
  EXPECT_EQ(none.episodes, 0);
  opt.rise_height = -10;
  EXPECT_EQ(evaluate_visitation(f.sim, f.policy, reset, PartMask::none(), ref, opt, never).rise_fraction, 1.0);
  opt.rise_height = 10;
  EXPECT_EQ(evaluate_visitation(f.sim, f.policy, reset, PartMask::none(), ref, opt, never).rise_fraction, 0.0);
}
