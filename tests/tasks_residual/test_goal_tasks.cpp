// Goal-driven tasks (tasks/location.hpp, heading.hpp, strike.hpp, goal_task.hpp): rewards, goal
// observations and success tests against hand-computed values; the tasks' trial bookkeeping on
// the tiny analytic simulator; the type-erased task is a value.
#include "../train/tiny_sim.hpp"
#include "residual_fixtures.hpp"  // (expect_error_naming)

#include <maskadapt/tasks/composition.hpp>
#include <maskadapt/tasks/goal_task.hpp>
#include <maskadapt/tasks/heading.hpp>
#include <maskadapt/tasks/location.hpp>
#include <maskadapt/tasks/strike.hpp>

#include <gtest/gtest.h>

#include <cmath>

using namespace maskadapt;
using maskadapt::testing::TinyWalkerSim;
using maskadapt::testing::stage2::expect_error_naming;

namespace {

Quat yaw(double a) { return Quat(Eigen::AngleAxisd(a, Vec3::UnitZ())); }

// A strike task's config on the tiny walker: its arms (bodies 2 and 3) are the strike bodies.
tasks::StrikeConfig tiny_strike_config() {
  tasks::StrikeConfig c;
  c.strike_bodies = {2, 3};
  return c;
}
// A box lying on its side (tilted 90°, well past the success angle).
const Quat kBoxOnItsSide(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY()));

// A simulator with one scene object whose state and contacts the test writes directly (for the
// strike task's bookkeeping without MuJoCo).
class TinySceneSim : public TinyWalkerSim {
 public:
  explicit TinySceneSim(std::size_t n) : TinyWalkerSim(n), boxes_(n), flags_(n, ContactFlags(6, 0)) {}
  std::size_t num_objects() const { return 1; }
  const RigidState& object_state(std::size_t e, std::size_t k) const {
    EXPECT_EQ(k, 0u);
    return boxes_.at(e);
  }
  void place_object(std::size_t e, std::size_t, const RigidState& s) { boxes_.at(e) = s; }
  const ContactFlags& object_contacts(std::size_t e, std::size_t) const { return flags_.at(e); }
  std::vector<RigidState> boxes_;
  std::vector<ContactFlags> flags_;
};
static_assert(SceneSimulator<TinySceneSim>);
static_assert(tasks::GoalTask<tasks::StrikeTask, TinySceneSim>);
static_assert(!tasks::GoalTask<tasks::StrikeTask, TinyWalkerSim>);  // strike needs scene objects
static_assert(tasks::GoalTask<tasks::LocationTask, TinyWalkerSim>);
static_assert(tasks::GoalTask<tasks::HeadingTask, TinyWalkerSim>);

}  // namespace

// ---- target location ----------------------------------------------------------------------------

TEST(LocationTask, RewardIsOneInsideTheRadiusAndTheVelocityTermOutside) {
  tasks::LocationConfig c;  // R 0.5 m, v* 1 m/s, k 4
  const Vec3 root(0, 0, 0.9), target(3, 4, 0);  // 5 m away along (0.6, 0.8)
  EXPECT_EQ(tasks::location_reward(Vec3(3.3, 4.0, 0.9), Vec3::Zero(), target, c), 1.0);  // 0.3 m: inside
  EXPECT_EQ(tasks::location_reward(Vec3(3.0, 4.49, 0.9), Vec3::Zero(), target, c), 1.0);
  EXPECT_NEAR(tasks::location_reward(root, Vec3(0.6, 0.8, 0.0), target, c), 1.0, 1e-12);  // v·d = v*
  EXPECT_NEAR(tasks::location_reward(root, Vec3::Zero(), target, c), std::exp(-4.0), 1e-12);  // standing: 0.018
  EXPECT_NEAR(tasks::location_reward(root, Vec3(-0.8, 0.6, 0.0), target, c), std::exp(-4.0), 1e-12);  // sideways
  EXPECT_NEAR(tasks::location_reward(root, Vec3(-0.6, -0.8, 5.0), target, c), std::exp(-4.0 * 4.0), 1e-12);  // away; z ignored
  EXPECT_NEAR(tasks::location_reward(root, Vec3(0.3, 0.4, 0.0), target, c), std::exp(-4.0 * 0.25), 1e-12);  // half speed
}

TEST(LocationTask, FacingShapingMixesTheHalfCosineOfTheTargetsBearingOutsideTheRadius) {
  tasks::LocationConfig c;  // R 0.5 m, v* 1 m/s, k 4
  const Vec3 root(0, 0, 0.9), target(3, 4, 0);  // 5 m away along (0.6, 0.8)
  // w = 0 is the paper's reward whatever the facing
  EXPECT_EQ(tasks::location_reward(root, yaw(2.0), Vec3(0.3, 0.4, 0), target, c),
            tasks::location_reward(root, Vec3(0.3, 0.4, 0), target, c));
  c.facing_weight = 0.3;
  const double bearing = std::atan2(0.8, 0.6);
  // facing the target, standing: 0.7·e^−4 + 0.3·1
  EXPECT_NEAR(tasks::location_reward(root, yaw(bearing), Vec3::Zero(), target, c), 0.7 * std::exp(-4.0) + 0.3, 1e-12);
  // facing away, walking toward it at v*: 0.7·1 + 0.3·0
  EXPECT_NEAR(tasks::location_reward(root, yaw(bearing + M_PI), Vec3(0.6, 0.8, 0), target, c), 0.7, 1e-12);
  // 90° off, standing: 0.7·e^−4 + 0.3·0.5 — the term still rises as the character turns toward it
  EXPECT_NEAR(tasks::location_reward(root, yaw(bearing + M_PI / 2), Vec3::Zero(), target, c), 0.7 * std::exp(-4.0) + 0.15, 1e-12);
  EXPECT_LT(tasks::location_reward(root, yaw(bearing + 2.0), Vec3::Zero(), target, c),
            tasks::location_reward(root, yaw(bearing + 1.0), Vec3::Zero(), target, c));
  // inside R: 1, as without shaping
  EXPECT_EQ(tasks::location_reward(Vec3(3.3, 4.0, 0.9), yaw(bearing + M_PI), Vec3::Zero(), target, c), 1.0);
  for (const double bad : {-0.1, 1.5, std::nan("")}) {
    c.facing_weight = bad;
    expect_error_naming([&] { c.validate(); }, "location.facing_weight", "facing_weight " + std::to_string(bad));
  }
}

TEST(LocationTask, PositionShapingAddsAsesDistanceKernelOutsideTheRadius) {
  tasks::LocationConfig c;  // R 0.5 m, v* 1 m/s, k 4, k_p 0.5
  c.facing_weight = 0.5;
  c.position_weight = 0.25;
  const double bearing = std::atan2(0.8, 0.6);
  const Vec3 target(3, 4, 0);
  // 5 m away, facing it, walking at v* toward it: 0.25·1 + 0.5·1 + 0.25·e^(−0.5·25)
  EXPECT_NEAR(tasks::location_reward(Vec3(0, 0, 0.9), yaw(bearing), Vec3(0.6, 0.8, 0), target, c),
              0.25 + 0.5 + 0.25 * std::exp(-12.5), 1e-12);
  // 1 m away (the root at (2.4, 3.2)), standing, facing away: 0.25·e^−4 + 0 + 0.25·e^−0.5
  EXPECT_NEAR(tasks::location_reward(Vec3(2.4, 3.2, 0.9), yaw(bearing + M_PI), Vec3::Zero(), target, c),
              0.25 * std::exp(-4.0) + 0.25 * std::exp(-0.5), 1e-12);
  // passing the target abeam at 1 m pays less than at 0.6 m, all else equal
  const Vec3 v(1.2, 0, 0);
  EXPECT_GT(tasks::location_reward(Vec3(3, 3.4, 0.9), yaw(0), v, target, c),
            tasks::location_reward(Vec3(3, 3.0, 0.9), yaw(0), v, target, c));
  // inside R: 1
  EXPECT_EQ(tasks::location_reward(Vec3(3.3, 4.0, 0.9), yaw(0), Vec3::Zero(), target, c), 1.0);
  // p = 0 leaves the facing-shaped reward unchanged
  tasks::LocationConfig f = c;
  f.position_weight = 0;
  EXPECT_NEAR(tasks::location_reward(Vec3(2.4, 3.2, 0.9), yaw(bearing + M_PI), Vec3::Zero(), target, f),
              0.5 * std::exp(-4.0), 1e-12);
  for (const double bad : {-0.1, 0.6, std::nan("")}) {  // (0.6 + the facing 0.5 > 1)
    c.position_weight = bad;
    expect_error_naming([&] { c.validate(); }, "location.position_weight", "position_weight " + std::to_string(bad));
  }
}

// The arrive shaping: the velocity term's target speed is v*·min(1, d/ρ), so slowing down near the
// target pays; beyond ρ, and with ρ = 0, the reward is unchanged.
TEST(LocationTask, ArriveShapingLowersTheTargetSpeedInsideRho) {
  tasks::LocationConfig c;  // R 0.5 m, v* 1 m/s, k 4
  c.facing_weight = 0.5;
  c.arrive_distance = 2.0;
  const Vec3 target(3, 0, 0);
  const Quat ahead = yaw(0);
  EXPECT_DOUBLE_EQ(c.target_speed(4.0), 1.0);
  EXPECT_DOUBLE_EQ(c.target_speed(1.0), 0.5);
  // 1 m away, facing it: at 0.5 m/s the velocity term is 1, at 1 m/s it is e^(−4·0.25)
  EXPECT_NEAR(tasks::location_reward(Vec3(2, 0, 0.9), ahead, Vec3(0.5, 0, 0), target, c), 0.5 + 0.5, 1e-12);
  EXPECT_NEAR(tasks::location_reward(Vec3(2, 0, 0.9), ahead, Vec3(1.0, 0, 0), target, c),
              0.5 * std::exp(-1.0) + 0.5, 1e-12);
  // 2.5 m away (beyond ρ): v* itself
  EXPECT_NEAR(tasks::location_reward(Vec3(0.5, 0, 0.9), ahead, Vec3(1.0, 0, 0), target, c), 1.0, 1e-12);
  // ρ = 0: the facing-shaped reward, v* everywhere
  tasks::LocationConfig off = c;
  off.arrive_distance = 0;
  EXPECT_NEAR(tasks::location_reward(Vec3(2, 0, 0.9), ahead, Vec3(1.0, 0, 0), target, off), 1.0, 1e-12);
  // the goal observation keeps showing v* (evaluation runs ρ = 0)
  VectorXf g(4);
  tasks::location_goal(Vec3(2, 0, 0.9), ahead, target, c, g);
  EXPECT_FLOAT_EQ(g[2], 1.0f);
  for (const double bad : {-0.5, 101.0, std::nan("")}) {
    c.arrive_distance = bad;
    expect_error_naming([&] { c.validate(); }, "location.arrive_distance", "arrive_distance " + std::to_string(bad));
  }
}

// The reach bonus: the step that first comes within R earns B more, closes the trial as a success
// and draws the next target at once (from the root, at a distance in [min, max]).
TEST(LocationTask, ReachBonusPaysOnceAndDrawsTheNextTarget) {
  TinyWalkerSim sim(1);
  tasks::LocationConfig c;
  c.reach_bonus = 10;
  tasks::LocationTask task(c, 1);
  task.new_episode(sim, 0);
  const Vec3 root = sim.body_states(0).pos.col(0);
  task.set_target(0, Vec3(root.x() + 0.3, root.y(), 0.0), 100);  // within R
  const tasks::GoalStep hit = task.after_step(sim, 0, tasks::EpisodeEnd::none);
  EXPECT_FLOAT_EQ(hit.reward, 1.0f + 10.0f);
  EXPECT_FALSE(hit.terminate);
  EXPECT_EQ(task.trials().trials, 1);
  EXPECT_EQ(task.trials().successes, 1);
  const double d = (task.target(0) - root).head<2>().norm();  // the next target, drawn at once
  EXPECT_GE(d, c.min_distance - 1e-9);
  EXPECT_LE(d, c.max_distance + 1e-9);
  const tasks::GoalStep next = task.after_step(sim, 0, tasks::EpisodeEnd::none);  // not there yet: no bonus
  EXPECT_LT(next.reward, 1.0f);
  EXPECT_EQ(task.trials().trials, 1);
  // without the bonus the trial stays open until its goal expires, and the reward is 1
  tasks::LocationTask plain(tasks::LocationConfig{}, 1);
  plain.new_episode(sim, 0);
  plain.set_target(0, Vec3(root.x() + 0.3, root.y(), 0.0), 100);
  EXPECT_EQ(plain.after_step(sim, 0, tasks::EpisodeEnd::none).reward, 1.0f);
  EXPECT_EQ(plain.trials().trials, 0);
  for (const double bad : {-1.0, 1001.0, std::nan("")}) {
    c.reach_bonus = bad;
    expect_error_naming([&] { c.validate(); }, "location.reach_bonus", "reach_bonus " + std::to_string(bad));
  }
}

TEST(LocationTask, GoalIsDirectionSpeedDistanceInTheHeadingFrame) {
  tasks::LocationConfig c;
  c.speed = 1.2;
  VectorXf g(4);
  // facing +y (yaw 90°): a target 2 m along +y is straight ahead, one along +x is to the right
  tasks::location_goal(Vec3(1, 1, 0.9), yaw(M_PI / 2), Vec3(1, 3, 0), c, g);
  EXPECT_NEAR(g[0], 1.0f, 1e-6f);
  EXPECT_NEAR(g[1], 0.0f, 1e-6f);
  EXPECT_FLOAT_EQ(g[2], 1.2f);
  EXPECT_NEAR(g[3], 2.0f, 1e-6f);
  tasks::location_goal(Vec3(1, 1, 0.9), yaw(M_PI / 2), Vec3(4, 1, 0), c, g);
  EXPECT_NEAR(g[0], 0.0f, 1e-6f);
  EXPECT_NEAR(g[1], -1.0f, 1e-6f);  // right = −left
  EXPECT_NEAR(g[3], 3.0f, 1e-6f);
  VectorXf wrong(3);
  EXPECT_THROW(tasks::location_goal(Vec3::Zero(), Quat::Identity(), Vec3(1, 0, 0), c, wrong), Error);
}

TEST(LocationTask, CharacterAtTheTargetGetsOneAndSucceeds) {
  TinyWalkerSim sim(2);
  tasks::LocationConfig c;
  tasks::LocationTask task(c, 2);
  task.new_episode(sim, 0);
  task.new_episode(sim, 1);
  const double d0 = (task.target(0) - sim.body_states(0).pos.col(0)).head<2>().norm();
  EXPECT_GE(d0, c.min_distance - 1e-9);
  EXPECT_LE(d0, c.max_distance + 1e-9);
  const Vec3 root = sim.body_states(0).pos.col(0);
  task.set_target(0, Vec3(root.x() + 0.2, root.y(), 0.0), 2);  // within R: reached
  task.set_target(1, Vec3(root.x() + 4.0, root.y(), 0.0), 2);  // 4 m away: not reached
  EXPECT_EQ(task.after_step(sim, 0, tasks::EpisodeEnd::none).reward, 1.0f);
  EXPECT_LT(task.after_step(sim, 1, tasks::EpisodeEnd::none).reward, 1.0f);
  EXPECT_EQ(task.trials().trials, 0);
  task.after_step(sim, 0, tasks::EpisodeEnd::none);  // second step: both goals expire, trials close
  task.after_step(sim, 1, tasks::EpisodeEnd::none);
  EXPECT_EQ(task.trials().trials, 2);
  EXPECT_EQ(task.trials().successes, 1);
  task.after_step(sim, 1, tasks::EpisodeEnd::terminated);  // env 1 fell before it reached its new target: a failure
  EXPECT_EQ(task.trials().trials, 3);
  EXPECT_EQ(task.trials().successes, 1);
  EXPECT_EQ(task.trials().censored, 0);
  // the time limit cut env 0's new trial short: censored, in neither count
  task.after_step(sim, 0, tasks::EpisodeEnd::time_limit);
  EXPECT_EQ(task.trials().trials, 3);
  EXPECT_EQ(task.trials().successes, 1);
  EXPECT_EQ(task.trials().censored, 1);
}

// CML's divergence termination: the episode ends, the trial failed unless the target was reached,
// once the root is more than D farther from the target than when it was drawn; D = 0 never ends it.
TEST(LocationTask, DivergenceEndsTheEpisodeOnceTheTargetIsDFartherThanWhenDrawn) {
  TinyWalkerSim sim(1);
  auto put_root = [&](double x, double y) {
    KinematicState s = KinematicState::zero(sim.skeleton());
    s.root_pos = Vec3(x, y, s.root_pos.z());
    sim.reset(0, s);
  };
  tasks::LocationConfig c;
  c.divergence_distance = 2.0;
  tasks::LocationTask task(c, 1);
  put_root(0, 0);
  task.new_episode(sim, 0);
  const Vec3 t = task.target(0);
  const double d0 = std::hypot(t.x(), t.y());  // the distance when drawn, in [1, 5] m
  const Vec3 away = -Vec3(t.x(), t.y(), 0) / d0;  // from the target through the start
  put_root(1.9 * away.x(), 1.9 * away.y());        // d0 + 1.9: goes on
  EXPECT_FALSE(task.after_step(sim, 0, tasks::EpisodeEnd::none).terminate);
  put_root(2.1 * away.x(), 2.1 * away.y());        // d0 + 2.1: ends, a failed trial
  EXPECT_TRUE(task.after_step(sim, 0, tasks::EpisodeEnd::none).terminate);
  EXPECT_EQ(task.trials().trials, 1);
  EXPECT_EQ(task.trials().successes, 0);
  // reached first, then walked off: the episode still ends, the trial succeeded
  put_root(0, 0);
  task.new_episode(sim, 0);
  const Vec3 t2 = task.target(0);
  put_root(t2.x(), t2.y());
  EXPECT_FALSE(task.after_step(sim, 0, tasks::EpisodeEnd::none).terminate);
  const double d2 = std::hypot(t2.x(), t2.y());
  put_root(-t2.x() / d2 * 2.5, -t2.y() / d2 * 2.5);
  EXPECT_TRUE(task.after_step(sim, 0, tasks::EpisodeEnd::none).terminate);
  EXPECT_EQ(task.trials().trials, 2);
  EXPECT_EQ(task.trials().successes, 1);
  // the distance at the draw travels in the checkpoint
  put_root(0, 0);
  task.new_episode(sim, 0);
  Checkpoint ck;
  task.save(ck, "loc/");
  tasks::LocationTask back(c, 1);
  back.load(ck, "loc/");
  const Vec3 t3 = back.target(0);
  const double d3 = std::hypot(t3.x(), t3.y());
  put_root(-t3.x() / d3 * 2.1, -t3.y() / d3 * 2.1);
  EXPECT_TRUE(back.after_step(sim, 0, tasks::EpisodeEnd::none).terminate);
  // D = 0 (the paper's task): never
  tasks::LocationTask never(tasks::LocationConfig{}, 1);
  put_root(0, 0);
  never.new_episode(sim, 0);
  put_root(-40 * never.target(0).x(), -40 * never.target(0).y());
  EXPECT_FALSE(never.after_step(sim, 0, tasks::EpisodeEnd::none).terminate);
  tasks::LocationConfig bad;
  bad.divergence_distance = -1;
  expect_error_naming([&] { bad.validate(); }, "location.divergence_distance", "a negative D");
}

// ---- heading ---------------------------------------------------------------------------------------

TEST(HeadingTask, RewardMatchesTheClosedForm) {
  const Vec3 d(0, 1, 0);  // target direction +y
  // moving at s* along d and facing d: 0.7 + 0.3
  EXPECT_NEAR(tasks::heading_reward(Vec3(0, 1.2, 0), yaw(M_PI / 2), d, 1.2), 1.0, 1e-12);
  // standing still, facing away: 0.7·exp(−0.25·s*²)
  EXPECT_NEAR(tasks::heading_reward(Vec3::Zero(), yaw(-M_PI / 2), d, 1.2), 0.7 * std::exp(-0.25 * 1.44), 1e-12);
  // 1 m/s sideways, facing 45° off d: 0.7·exp(−0.25·(1 + 0.1)) + 0.3·cos 45°
  EXPECT_NEAR(tasks::heading_reward(Vec3(1, 0, 0.3), yaw(M_PI / 4), d, 1.0),
              0.7 * std::exp(-0.25 * 1.1) + 0.3 * std::sqrt(0.5), 1e-12);
  VectorXf g(3);
  tasks::heading_goal(yaw(M_PI / 2), d, 1.2, g);  // facing d: straight ahead
  EXPECT_NEAR(g[0], 1.0f, 1e-6f);
  EXPECT_NEAR(g[1], 0.0f, 1e-6f);
  EXPECT_FLOAT_EQ(g[2], 1.2f);
}

TEST(HeadingTask, SuccessIsTheMeanVelocityAlongTheDirectionWithinTolerance) {
  TinyWalkerSim sim(1);  // standing still: v_d = 0
  tasks::HeadingConfig c;
  c.success_window = 3;
  tasks::HeadingTask task(c, 1);
  task.set_goal(0, Vec3(1, 0, 0), 0.4, 3);  // |0.4 − 0| < 0.5: success once the window is full
  task.after_step(sim, 0, tasks::EpisodeEnd::none);
  EXPECT_FALSE(task.success(0));  // 1 of 3 steps
  task.after_step(sim, 0, tasks::EpisodeEnd::none);
  task.after_step(sim, 0, tasks::EpisodeEnd::none);  // goal expires: trial closes
  EXPECT_EQ(task.trials().trials, 1);
  EXPECT_EQ(task.trials().successes, 1);
  task.set_goal(0, Vec3(1, 0, 0), 0.6, 3);  // |0.6 − 0| ≥ 0.5: failure
  for (int i = 0; i < 3; ++i) task.after_step(sim, 0, tasks::EpisodeEnd::none);
  EXPECT_EQ(task.trials().trials, 2);
  EXPECT_EQ(task.trials().successes, 1);
  // a trial the time limit cuts short is censored (even one whose window already says success);
  // one a fall ends is tested as it stands
  task.set_goal(0, Vec3(1, 0, 0), 0.4, 10);
  for (int i = 0; i < 3; ++i) task.after_step(sim, 0, tasks::EpisodeEnd::none);
  task.after_step(sim, 0, tasks::EpisodeEnd::time_limit);
  EXPECT_EQ(task.trials().trials, 2);
  EXPECT_EQ(task.trials().censored, 1);
  task.set_goal(0, Vec3(1, 0, 0), 0.4, 10);
  for (int i = 0; i < 3; ++i) task.after_step(sim, 0, tasks::EpisodeEnd::none);
  task.after_step(sim, 0, tasks::EpisodeEnd::terminated);
  EXPECT_EQ(task.trials().trials, 3);
  EXPECT_EQ(task.trials().successes, 2);
  EXPECT_THROW(task.set_goal(0, Vec3(1, 1, 0), 1.0, 3), Error);  // not a unit vector
}

// ---- strike ----------------------------------------------------------------------------------------

TEST(StrikeTask, ApproachShapingRewardsWalkingTowardAndFacingTheBoxUntilWithinReach) {
  tasks::StrikeConfig c;  // v* 1 m/s, reach 1 m
  c.strike_bodies = {2};
  const Vec3 root(0, 0, 0.9), box(3, 4, 0.6);  // 5 m away along (0.6, 0.8)
  const double bearing = std::atan2(0.8, 0.6);
  // facing the box and walking to it at v*: 0.5·1 + 0.5·1
  EXPECT_NEAR(tasks::strike_approach(root, yaw(bearing), Vec3(0.6, 0.8, 0), box, false, c), 1.0, 1e-12);
  // facing away, standing: 0.5·e^−4 + 0.5·0
  EXPECT_NEAR(tasks::strike_approach(root, yaw(bearing + M_PI), Vec3::Zero(), box, false, c), 0.5 * std::exp(-4.0), 1e-12);
  // 90° off, walking sideways at v* (d·v = 0): 0.5·e^−4 + 0.5·0.5
  EXPECT_NEAR(tasks::strike_approach(root, yaw(bearing + M_PI / 2), Vec3(-0.8, 0.6, 0), box, false, c),
              0.5 * std::exp(-4.0) + 0.25, 1e-12);
  // within reach (0.9 m, height ignored) or once tilted: 1 whatever the motion
  EXPECT_EQ(tasks::strike_approach(Vec3(3.0, 3.1, 0.2), yaw(bearing + M_PI), Vec3::Zero(), box, false, c), 1.0);
  EXPECT_EQ(tasks::strike_approach(root, yaw(bearing + M_PI), Vec3::Zero(), box, true, c), 1.0);
  // the mix: (1 − w)·tilt term + w·approach; w = 0 is the paper's reward
  const Quat tilt60(Eigen::AngleAxisd(M_PI / 3, Vec3::UnitX()));
  EXPECT_NEAR(tasks::strike_reward(tilt60, 0.2, c), 0.5, 1e-12);
  c.approach_weight = 0.4;
  EXPECT_NEAR(tasks::strike_reward(tilt60, 0.2, c), 0.6 * 0.5 + 0.4 * 0.2, 1e-12);
  EXPECT_NEAR(tasks::strike_reward(Quat::Identity(), 1.0, c), 0.4, 1e-12);  // upright box, character at it
  for (const double bad : {-0.5, 2.0, std::nan("")}) {
    c.approach_weight = bad;
    expect_error_naming([&] { c.validate(); }, "strike.approach_weight", "approach_weight " + std::to_string(bad));
  }
}

TEST(StrikeTask, BoxTiltedBy80DegreesSucceedsBy70DoesNot) {
  const auto tilt = [](double deg) { return Quat(Eigen::AngleAxisd(deg * M_PI / 180.0, Vec3::UnitX())); };
  EXPECT_NEAR(tasks::strike_reward(Quat::Identity()), 0.0, 1e-12);
  EXPECT_NEAR(tasks::strike_reward(tilt(90)), 1.0, 1e-12);
  EXPECT_NEAR(tasks::strike_reward(tilt(60)), 0.5, 1e-12);
  TinySceneSim sim(1);
  tasks::StrikeConfig c = tiny_strike_config();
  tasks::StrikeTask task(c, 1);
  for (double deg : {80.0, 70.0}) {
    task.new_episode(sim, 0);
    sim.flags_[0] = {0, 0, 0, 1, 0, 0};  // the right arm touches first
    sim.boxes_[0].rot = tilt(deg);
    const auto step = task.after_step(sim, 0, tasks::EpisodeEnd::none);
    EXPECT_NEAR(step.reward, 1.0 - std::cos(deg * M_PI / 180.0), 1e-6) << deg;
    EXPECT_EQ(task.success(0), deg == 80.0) << deg;
  }
}

TEST(StrikeTask, OnlyAStrikeWithTheHandsCounts) {
  TinySceneSim sim(1);
  tasks::StrikeConfig c = tiny_strike_config();
  tasks::StrikeTask task(c, 1);
  // a leg touches first, the box falls: no success; the trial closes as a failure when the episode ends
  task.new_episode(sim, 0);
  sim.flags_[0] = {0, 0, 0, 0, 1, 0};
  task.after_step(sim, 0, tasks::EpisodeEnd::none);
  EXPECT_EQ(task.first_contact(0), tasks::FirstContact::Foreign);
  sim.flags_[0] = {0, 0, 1, 0, 0, 0};
  sim.boxes_[0].rot = kBoxOnItsSide;
  task.after_step(sim, 0, tasks::EpisodeEnd::none);
  EXPECT_FALSE(task.success(0));
  task.after_step(sim, 0, tasks::EpisodeEnd::time_limit);  // (the trial is the episode: counted)
  EXPECT_EQ(task.trials().trials, 1);
  EXPECT_EQ(task.trials().successes, 0);
  // hand first (together with the trunk), then the fall: success
  task.new_episode(sim, 0);
  EXPECT_EQ(task.first_contact(0), tasks::FirstContact::None);
  sim.boxes_[0].rot = Quat::Identity();
  sim.flags_[0] = {1, 0, 1, 0, 0, 0};
  task.after_step(sim, 0, tasks::EpisodeEnd::none);
  EXPECT_EQ(task.first_contact(0), tasks::FirstContact::Strike);
  sim.flags_[0] = {0, 0, 0, 0, 0, 0};
  sim.boxes_[0].rot = kBoxOnItsSide;
  task.after_step(sim, 0, tasks::EpisodeEnd::none);
  EXPECT_TRUE(task.success(0));
  task.after_step(sim, 0, tasks::EpisodeEnd::terminated);
  EXPECT_EQ(task.trials().successes, 1);
  // with end_on_foreign_contact, a foreign first contact ends the episode at once
  c.end_on_foreign_contact = true;
  tasks::StrikeTask strict(c, 1);
  strict.new_episode(sim, 0);
  sim.flags_[0] = {0, 0, 0, 0, 0, 1};
  EXPECT_TRUE(strict.after_step(sim, 0, tasks::EpisodeEnd::none).terminate);
  EXPECT_EQ(strict.trials().trials, 1);
}

namespace {
// The count of one named outcome in `o` (-1 if absent).
long long outcome(const tasks::TrialOutcomes& o, const std::string& name) {
  for (const auto& [n, k] : o)
    if (n == name) return k;
  return -1;
}
}  // namespace

TEST(StrikeTask, TrialOutcomesCountEachEndedTrialOnceInOrderOfPrecedence) {
  TinySceneSim sim(1);
  tasks::StrikeConfig c = tiny_strike_config();
  tasks::StrikeTask task(c, 1);
  // one trial per case: (first contact flags, box tilted, how the episode ends)
  struct Case { ContactFlags flags; bool tilt; tasks::EpisodeEnd end; const char* outcome; };
  const Case cases[] = {
      {{0, 0, 1, 0, 0, 0}, true, tasks::EpisodeEnd::time_limit, "struck"},
      {{0, 0, 0, 0, 1, 0}, true, tasks::EpisodeEnd::time_limit, "tilted_other_first"},
      {{0, 0, 0, 0, 1, 0}, true, tasks::EpisodeEnd::terminated, "tilted_other_first"},  // (the tilt first)
      {{0, 0, 1, 0, 0, 0}, false, tasks::EpisodeEnd::terminated, "fell"},
      {{0, 0, 0, 1, 0, 0}, false, tasks::EpisodeEnd::time_limit, "hands_no_tilt"},
      {{1, 0, 0, 0, 0, 0}, false, tasks::EpisodeEnd::time_limit, "other_no_tilt"},
      {{0, 0, 0, 0, 0, 0}, false, tasks::EpisodeEnd::time_limit, "untouched"},
      {{0, 0, 0, 0, 0, 0}, false, tasks::EpisodeEnd::time_limit, "untouched"},
  };
  for (const Case& k : cases) {
    task.new_episode(sim, 0);
    sim.flags_[0] = k.flags;
    sim.boxes_[0].rot = k.tilt ? kBoxOnItsSide : Quat::Identity();
    task.after_step(sim, 0, tasks::EpisodeEnd::none);
    task.after_step(sim, 0, k.end);
  }
  const tasks::TrialOutcomes o = task.trial_outcomes();
  ASSERT_EQ(o.size(), 6u);
  EXPECT_EQ(outcome(o, "struck"), 1);
  EXPECT_EQ(outcome(o, "tilted_other_first"), 2);
  EXPECT_EQ(outcome(o, "fell"), 1);
  EXPECT_EQ(outcome(o, "hands_no_tilt"), 1);
  EXPECT_EQ(outcome(o, "other_no_tilt"), 1);
  EXPECT_EQ(outcome(o, "untouched"), 2);
  long long sum = 0;
  for (const auto& [n, k] : o) sum += k;
  EXPECT_EQ(sum, task.trials().trials);
  EXPECT_EQ(task.trials().successes, 1);
  // the type-erased task reports them; a task without outcomes reports none
  tasks::AnyGoalTask<TinySceneSim> any = task;
  EXPECT_EQ(any.trial_outcomes(), o);
  any.clear_trials();
  EXPECT_EQ(outcome(any.trial_outcomes(), "untouched"), 0);
  EXPECT_TRUE(tasks::AnyGoalTask<TinyWalkerSim>(tasks::LocationTask(tasks::LocationConfig{}, 1)).trial_outcomes().empty());
  // a trial ended by end_on_foreign_contact is other_no_tilt
  c.end_on_foreign_contact = true;
  tasks::StrikeTask strict(c, 1);
  strict.new_episode(sim, 0);
  sim.boxes_[0].rot = Quat::Identity();
  sim.flags_[0] = {0, 0, 0, 0, 0, 1};
  EXPECT_TRUE(strict.after_step(sim, 0, tasks::EpisodeEnd::none).terminate);
  EXPECT_EQ(outcome(strict.trial_outcomes(), "other_no_tilt"), 1);
}

namespace {
// The least an `advance_goal` needs of an imitation task: which envs ended, and a restart.
struct TinyImitation {
  TinySceneSim& s;
  std::vector<std::uint8_t> term = {0}, trunc = {0};
  int restarts = 0;
  const std::vector<std::uint8_t>& terminated() const { return term; }
  const std::vector<std::uint8_t>& truncated() const { return trunc; }
  TinySceneSim& sim() { return s; }
  void restart_env(Index) { ++restarts; }
};
}  // namespace

TEST(StrikeTask, NextBoxClosesTheTrialKStepsAfterTheTiltAndPlacesANewBoxWithoutAReset) {
  TinySceneSim sim(1);
  tasks::StrikeConfig c = tiny_strike_config();
  c.next_box_steps = 3;
  tasks::AnyGoalTask<TinySceneSim> goal = tasks::StrikeTask(c, 1);
  TinyImitation im{sim};
  goal.new_episode(sim, 0);
  const Vec3 first_box = sim.boxes_[0].pos;
  sim.flags_[0] = {0, 0, 1, 0, 0, 0};  // the left arm strikes ...
  tasks::advance_goal(goal, im, 0);
  sim.flags_[0] = {0, 0, 0, 0, 0, 0};
  sim.boxes_[0].rot = kBoxOnItsSide;  // ... and the box falls
  for (int k = 1; k <= 2; ++k) {  // steps 1 and 2 after the tilt: the trial goes on
    tasks::advance_goal(goal, im, 0);
    EXPECT_EQ(goal.trials().trials, 0) << k;
    EXPECT_EQ(sim.boxes_[0].pos, first_box) << k;
  }
  const tasks::GoalOutcome o = tasks::advance_goal(goal, im, 0);  // step 3: closed, a new box
  EXPECT_FALSE(o.terminated);
  EXPECT_FALSE(o.truncated);
  EXPECT_EQ(im.restarts, 0);  // the env goes on
  EXPECT_EQ(goal.trials().trials, 1);
  EXPECT_EQ(goal.trials().successes, 1);
  EXPECT_NE(sim.boxes_[0].pos, first_box);
  EXPECT_NEAR(tasks::box_uprightness(sim.boxes_[0].rot), 1.0, 1e-12);
  EXPECT_EQ(goal.as<tasks::StrikeTask>()->first_contact(0), tasks::FirstContact::None);
  EXPECT_FALSE(goal.as<tasks::StrikeTask>()->success(0));
  // k = 0 (the paper's): a tilted box stays until the episode ends
  c.next_box_steps = 0;
  tasks::StrikeTask one(c, 1);
  one.new_episode(sim, 0);
  sim.flags_[0] = {0, 0, 1, 0, 0, 0};
  sim.boxes_[0].rot = kBoxOnItsSide;
  for (int k = 0; k < 50; ++k) EXPECT_FALSE(one.after_step(sim, 0, tasks::EpisodeEnd::none).next_goal);
  EXPECT_EQ(one.trials().trials, 0);
  c.next_box_steps = -1;
  expect_error_naming([&] { c.validate(); }, "strike.next_box_steps", "a negative count");
}

TEST(StrikeTask, SaveAndLoadKeepTheStepsSinceTheTilt) {
  TinySceneSim sim(1);
  tasks::StrikeConfig c = tiny_strike_config();
  c.next_box_steps = 4;
  tasks::StrikeTask a(c, 1), b(c, 1), old(c, 1);
  a.new_episode(sim, 0);
  sim.flags_[0] = {0, 0, 1, 0, 0, 0};
  sim.boxes_[0].rot = kBoxOnItsSide;
  a.after_step(sim, 0, tasks::EpisodeEnd::none);  // tilted: 1 step counted
  a.after_step(sim, 0, tasks::EpisodeEnd::none);  // 2
  Checkpoint ck;
  a.save(ck, "g/");
  b.load(ck, "g/");
  EXPECT_FALSE(b.after_step(sim, 0, tasks::EpisodeEnd::none).next_goal);  // 3
  EXPECT_TRUE(b.after_step(sim, 0, tasks::EpisodeEnd::none).next_goal);   // 4: as a would
  EXPECT_FALSE(a.after_step(sim, 0, tasks::EpisodeEnd::none).next_goal);
  EXPECT_TRUE(a.after_step(sim, 0, tasks::EpisodeEnd::none).next_goal);
  // a checkpoint written before next_box_steps existed has no count: it starts from 0
  Checkpoint before = ck;
  before.erase("g/since_tilt");
  old.load(before, "g/");
  for (int k = 1; k < 4; ++k) EXPECT_FALSE(old.after_step(sim, 0, tasks::EpisodeEnd::none).next_goal) << k;
  EXPECT_TRUE(old.after_step(sim, 0, tasks::EpisodeEnd::none).next_goal);
  // a count out of range is refused, naming the section
  Checkpoint bad = ck;
  bad.put("g/since_tilt", VectorX<std::int64_t>::Constant(1, -3));
  expect_error_naming([&] { old.load(bad, "g/"); }, "g/since_tilt", "a negative count");
}

TEST(StrikeTask, PlacesTheBoxUprightAtRestWithinTheDistanceRange) {
  TinySceneSim sim(3);
  tasks::StrikeConfig c = tiny_strike_config();
  c.min_distance = 1.5;
  c.max_distance = 2.5;
  c.box_half_height = 0.6;
  tasks::StrikeTask task(c, 3);
  for (Index e = 0; e < 3; ++e) {
    task.new_episode(sim, e);
    const RigidState& b = sim.boxes_[static_cast<std::size_t>(e)];
    const double d = (b.pos - sim.body_states(static_cast<std::size_t>(e)).pos.col(0)).head<2>().norm();
    EXPECT_GE(d, 1.5 - 1e-9);
    EXPECT_LE(d, 2.5 + 1e-9);
    EXPECT_DOUBLE_EQ(b.pos.z(), 0.6);
    EXPECT_NEAR(tasks::box_uprightness(b.rot), 1.0, 1e-12);
    EXPECT_EQ(b.lin_vel, Vec3::Zero());
  }
}

TEST(StrikeTask, GoalIsTheBoxStateInTheHeadingFrame) {
  RigidState box;
  box.pos = Vec3(1, 3, 0.6);
  box.rot = yaw(M_PI / 2);  // box turned like the root: identity in the heading frame
  box.lin_vel = Vec3(0, 2, 0);
  box.ang_vel = Vec3(0, 0, 0.5);
  VectorXf g(15);
  tasks::strike_goal(Vec3(1, 1, 0.9), yaw(M_PI / 2), box, g);  // root facing +y, box 2 m ahead
  VectorXf want(15);
  want << 2, 0, -0.3, 1, 0, 0, 0, 1, 0, 2, 0, 0, 0, 0, 0.5;
  EXPECT_TRUE(g.isApprox(want, 1e-6f)) << g.transpose();
}

TEST(StrikeTask, BodiesByNameNamesTheMissingOne) {
  const Skeleton s = maskadapt::testing::tiny_walker_skeleton();
  EXPECT_EQ(tasks::bodies_by_name(s, {"l_arm", "r_arm"}), (std::vector<int>{2, 3}));
  try {
    tasks::bodies_by_name(s, {"L_Wrist"});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("L_Wrist"), std::string::npos);
  }
}

// ---- shared ----------------------------------------------------------------------------------------

TEST(GoalTask, WilsonIntervalMatchesTheClosedForm) {
  tasks::TrialCounter t;
  for (int i = 0; i < 100; ++i) t.add(i % 2 == 0);
  const auto [lo, hi] = t.wilson95();
  // p = 0.5, n = 100, z = 1.96: centre 0.5, half-width 1.96·sqrt(0.0025 + 0.000096)/1.038416
  const double half = 1.96 * std::sqrt(0.0025 + 1.96 * 1.96 / 40000.0) / (1 + 1.96 * 1.96 / 100.0);
  EXPECT_NEAR(lo, 0.5 - half, 1e-12);
  EXPECT_NEAR(hi, 0.5 + half, 1e-12);
  EXPECT_NEAR(half, 0.0962, 1e-4);
  tasks::TrialCounter all;
  for (int i = 0; i < 10; ++i) all.add(true);
  EXPECT_DOUBLE_EQ(all.wilson95().second, 1.0);
  EXPECT_LT(all.wilson95().first, 1.0);
}

TEST(GoalTask, AnyGoalTaskIsAValue) {
  TinyWalkerSim sim(1);
  tasks::AnyGoalTask<TinyWalkerSim> a = tasks::LocationTask(tasks::LocationConfig{}, 1);
  a.new_episode(sim, 0);
  tasks::AnyGoalTask<TinyWalkerSim> b = a;  // a deep copy
  const Vec3 ta = a.as<tasks::LocationTask>()->target(0);
  EXPECT_EQ(b.as<tasks::LocationTask>()->target(0), ta);
  b.new_episode(sim, 0);  // draws a new target in b only
  EXPECT_EQ(a.as<tasks::LocationTask>()->target(0), ta);
  EXPECT_NE(b.as<tasks::LocationTask>()->target(0), ta);
  EXPECT_EQ(a.as<tasks::HeadingTask>(), nullptr);
  EXPECT_EQ(a.goal_dim(), 4);
  EXPECT_EQ(tasks::AnyGoalTask<TinyWalkerSim>().goal_dim(), 0);
  EXPECT_THROW(tasks::AnyGoalTask<TinyWalkerSim>().name(), Error);
}

TEST(GoalTask, SaveAndLoadRestoreGoalsAndStreams) {
  TinyWalkerSim sim(2);
  tasks::HeadingConfig c;
  c.schedule = {2, 2};
  tasks::HeadingTask a(c, 2), b(c, 2);
  for (Index e = 0; e < 2; ++e) a.new_episode(sim, e);
  a.after_step(sim, 0, tasks::EpisodeEnd::none);
  Checkpoint ck;
  a.save(ck, "g/");
  b.load(ck, "g/");
  for (int i = 0; i < 5; ++i)
    for (Index e = 0; e < 2; ++e) {
      EXPECT_EQ(a.after_step(sim, e, tasks::EpisodeEnd::none).reward, b.after_step(sim, e, tasks::EpisodeEnd::none).reward);
      EXPECT_EQ(a.direction(e), b.direction(e));
      EXPECT_EQ(a.speed(e), b.speed(e));
    }
  tasks::HeadingTask wrong(c, 3);  // another env count: refused, naming the section
  EXPECT_THROW(wrong.load(ck, "g/"), Error);
}

// ---- distributed runs: a rank's envs draw the streams of their global indices --------------

// A task built for envs [2, 4) of a run (first_env = 2) draws, for its envs 0 and 1, what a task
// of all 4 envs draws for envs 2 and 3 (train/distributed.hpp): location targets, heading
// directions, episode masks.
TEST(GoalTasks, FirstEnvGivesARanksEnvsTheirOneProcessStreams) {
  TinyWalkerSim all(4), part(2);
  for (std::size_t e = 0; e < 4; ++e) all.reset(e, KinematicState::zero(all.skeleton()));
  for (std::size_t e = 0; e < 2; ++e) part.reset(e, KinematicState::zero(part.skeleton()));
  tasks::LocationConfig lc;
  lc.seed = 3;
  tasks::LocationTask loc_all(lc, 4);
  lc.first_env = 2;
  tasks::LocationTask loc_part(lc, 2);
  tasks::HeadingConfig hc;
  hc.seed = 4;
  tasks::HeadingTask head_all(hc, 4);
  hc.first_env = 2;
  tasks::HeadingTask head_part(hc, 2);
  for (int episode = 0; episode < 3; ++episode) {
    for (Index e = 0; e < 4; ++e) {
      loc_all.new_episode(all, e);
      head_all.new_episode(all, e);
    }
    for (Index e = 0; e < 2; ++e) {
      loc_part.new_episode(part, e);
      head_part.new_episode(part, e);
    }
    for (Index e = 0; e < 2; ++e) {
      EXPECT_EQ(loc_part.target(e), loc_all.target(e + 2)) << "episode " << episode;
      EXPECT_EQ(head_part.direction(e), head_all.direction(e + 2)) << "episode " << episode;
      EXPECT_EQ(head_part.speed(e), head_all.speed(e + 2)) << "episode " << episode;
    }
    EXPECT_NE(loc_part.target(0), loc_all.target(0));  // (another env's stream differs)
  }
  const std::vector<PartMask> set = {PartMask::parse("arms"), PartMask::parse("legs"), PartMask::parse("trunk")};
  tasks::EpisodeMasks masks_all(set, 4, 0.0, 1.0 / 30, 9), masks_part(set, 2, 0.0, 1.0 / 30, 9, 2);
  for (int episode = 0; episode < 8; ++episode) {
    for (Index e = 0; e < 2; ++e) EXPECT_EQ(masks_part.masks()[e].bits, masks_all.masks()[e + 2].bits) << "episode " << episode;
    for (Index e = 0; e < 4; ++e) masks_all.new_episode(e);
    for (Index e = 0; e < 2; ++e) masks_part.new_episode(e);
  }
  EXPECT_THROW(tasks::env_streams(1, 0, 2, -1), Error);
}
