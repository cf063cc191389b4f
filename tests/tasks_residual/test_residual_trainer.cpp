// The stage-2 trainer on the tiny analytic simulator: the frozen base stays bit-identical, the
// residual moves, and composition (ours, cml) and tracking runs produce finite statistics.
#include "../train/tiny_sim.hpp"

#include <maskadapt/train/residual_trainer.hpp>

#include <gtest/gtest.h>
#include "../blas_kernel.hpp"

#include <cstring>

using namespace maskadapt;
using namespace maskadapt::train;
using maskadapt::testing::TinyWalkerSim;

namespace {

tasks::ResetSampler upright(const Skeleton& skel) {
  return [&skel](Rng& rng) {
    tasks::ResetSample r;
    r.pose = KinematicState::zero(skel);
    r.pose.root_pos.z() = TinyWalkerSim::kHeight;
    for (Index i = 0; i < r.pose.q.size(); ++i) r.pose.q[i] = rng.uniform(-0.1, 0.1);
    return r;
  };
}

// A looping clip of the tiny walker: body `b`'s first hinge swings with amplitude `amp`.
MotionClip swing(const Skeleton& skel, std::vector<int> bodies, double amp, const std::string& name) {
  MotionClip c;
  c.name = name;
  c.loop = true;
  c.resize(61, skel.num_dofs());
  for (int t = 0; t < 61; ++t) {
    c.root_pos(2, t) = TinyWalkerSim::kHeight;
    for (std::size_t i = 0; i < bodies.size(); ++i)
      c.q(Skeleton::dof_offset(bodies[i]), t) = (i % 2 ? -amp : amp) * std::sin(2 * M_PI * t / 60.0);
  }
  return c;
}

ResidualTrainConfig tiny_config(const std::string& task, const std::string& method) {
  ResidualTrainConfig c;
  c.task = task;
  c.method = method;
  c.rl.env.num_envs = 4;
  c.rl.env.episode_seconds = 1.0;
  c.rl.env.termination_height = 0.8;
  c.rl.net.critic_hidden = {16};
  c.rl.net.disc_hidden = {16};
  c.rl.ppo.horizon = 8;
  c.rl.ppo.epochs = 2;
  c.rl.ppo.minibatch_size = 8;
  c.rl.ppo.actor_lr = 1e-3;
  c.rl.disc.batch_size = 8;
  c.rl.disc.replay_size = 64;
  c.rl.run.seed = 5;
  c.residual_hidden = {16};
  c.term_window_s = 0.2;
  return c;
}

rl::GaussianActor<float> tiny_base(const Skeleton& skel) {
  rl::ActorCriticConfig ac;
  ac.policy_input_dim = observation_dim(skel) + kNumParts;
  ac.critic_input_dim = observation_dim(skel);
  ac.action_dim = skel.num_dofs();
  ac.actor_hidden = {16, 16};
  ac.init_log_std = -1.0;
  Rng rng(1);
  return rl::GaussianActor<float>(ac, rng);
}

struct Data {
  Skeleton skel = maskadapt::testing::tiny_walker_skeleton();
  MotionLibrary base{skel}, added{skel};
  Data() {
    base.add(swing(skel, {4, 5}, 0.4, "legs_swing"));
    added.add(swing(skel, {2, 3}, 0.8, "arms_swing"));
  }
};

// A generator for the tiny walker: keeps the last history frame and swings the arms.
struct TinyGenerator {
  Skeleton skel = maskadapt::testing::tiny_walker_skeleton();
  const Skeleton& skeleton() const { return skel; }
  Index history_frames() const { return 1; }
  Index future_frames() const { return 4; }
  tracking::Trajectory generate(const tracking::TextCondition& c, const tracking::Trajectory& h, Rng&) const {
    tracking::Trajectory t = tracking::Trajectory::zeros(skel, 4);
    const double a = c.text == "raise arms" ? 0.6 : 0.3;
    for (Index i = 0; i < 4; ++i) {
      t.root_pos.col(i) = h.root_pos.col(0);
      t.root_rot[static_cast<std::size_t>(i)] = h.root_rot[0];
      t.q.col(i) = h.q.col(0);
      t.q(Skeleton::dof_offset(2), i) = a;
      t.q(Skeleton::dof_offset(3), i) = -a;
    }
    tracking::compute_body_positions(skel, t);
    return t;
  }
};

ResidualSetup composition_setup(const Data& d, const std::string& method, const std::vector<BodyPart>& obs_parts) {
  ResidualSetup s;
  const PartMask arms = PartMask::parse("arms"), legs = PartMask::parse("legs");
  if (method == "ours") {
    s.masks = {arms, legs};
    s.switch_rate = 1.0;
    auto set = std::make_shared<tasks::BlendedMotionSet>(d.base, d.added, s.masks);
    DiscriminatorSource src;
    src.name = "composition";
    src.conditioned = true;
    src.real = [set](Rng& r, Index B, MatrixXf& w, MatrixXf& c) { set->sample_real(r, B, w, c); };
    src.negative = [set](Rng& r, Index B, MatrixXf& w, MatrixXf& c) { set->sample_negative(r, B, w, c); };
    s.discriminators.push_back(src);
  } else {  // cml: fixed region = arms, one discriminator per group
    s.masks = {arms};
    const MotionLibrary* added = &d.added;
    const MotionLibrary* base = &d.base;
    DiscriminatorSource a{"arms", 0.5, tasks::window_rows(obs_parts, arms), false,
                          [added](Rng& r, Index B, MatrixXf& w, MatrixXf&) { w = added->sample_amp_windows(r, static_cast<int>(B)); }, {}};
    DiscriminatorSource b{"rest", 0.5, tasks::window_rows(obs_parts, ~arms), false,
                          [base](Rng& r, Index B, MatrixXf& w, MatrixXf&) { w = base->sample_amp_windows(r, static_cast<int>(B)); }, {}};
    s.discriminators = {a, b};
  }
  return s;
}

bool same_bits(const VectorXf& a, const VectorXf& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), sizeof(float) * static_cast<std::size_t>(a.size())) == 0;
}

}  // namespace

TEST(ResidualTrainer, BaseStaysFrozenWhileTheResidualLearns) {
  for (const std::string method : {"ours", "cml"}) {
    Data d;
    TinyWalkerSim sim(4);
    const auto base = tiny_base(sim.skeleton());
    const auto parts = observation_parts(sim.skeleton());
    ResidualTrainer<TinyWalkerSim> tr(sim, upright(sim.skeleton()), base, composition_setup(d, method, parts),
                                      tiny_config("composition", method), nullptr,
                                      FallCriteria::for_skeleton(sim.skeleton(), {"l_leg", "r_leg"}, "head", 0.8));
    const VectorXf res0 = tr.policy().residual().mean_net.params();
    for (int i = 1; i <= 3; ++i) {
      const IterationStats st = tr.iterate();
      EXPECT_EQ(st.iteration, i);
      for (double v : {st.disc_reward, st.disc_real, st.disc_fake, st.policy_loss, st.value_loss, st.approx_kl})
        EXPECT_TRUE(std::isfinite(v)) << method;
    }
    EXPECT_EQ(tr.num_objectives(), method == "ours" ? 1 : 2);
    EXPECT_TRUE(same_bits(tr.policy().base().mean_net.params(), base.mean_net.params())) << method;
    EXPECT_TRUE(same_bits(tr.policy().base().log_std.params(), base.log_std.params())) << method;
    EXPECT_FALSE(same_bits(tr.policy().residual().mean_net.params(), res0)) << method;
    // checkpoint round trip of the networks
    Checkpoint ck;
    tr.save(ck);
    const auto cfg = residual_config_from_json(nlohmann::json::parse(ck.get_string("residual_config")));
    EXPECT_EQ(cfg.method, method);
    ResidualTrainer<TinyWalkerSim> again(sim, upright(sim.skeleton()), tiny_base(sim.skeleton()),
                                         composition_setup(d, method, parts), cfg, nullptr,
                                         FallCriteria::for_skeleton(sim.skeleton(), {"l_leg", "r_leg"}, "head", 0.8));
    again.load(ck);
    EXPECT_TRUE(same_bits(again.policy().residual().mean_net.params(), tr.policy().residual().mean_net.params()));
    EXPECT_EQ(again.iteration(), 3);
  }
}

TEST(ResidualTrainer, TrackingRunConsumesGoalsAndRewardsTheDesignatedParts) {
  Data d;
  TinyWalkerSim sim(4);
  const auto parts = observation_parts(sim.skeleton());
  const PartMask arms = PartMask::parse("arms");
  ResidualSetup s;
  s.masks = {arms};
  const MotionLibrary* base = &d.base;
  s.discriminators.push_back({"imitation", 0.5, tasks::window_rows(parts, ~arms), false,
                              [base](Rng& r, Index B, MatrixXf& w, MatrixXf&) { w = base->sample_amp_windows(r, static_cast<int>(B)); }, {}});
  auto gen = std::make_shared<TinyGenerator>();
  TrackingSource t;
  t.designated = arms;
  t.goal_steps = 2;
  t.sample_every = 2;
  t.term_window = 6;
  t.term_threshold = 0.05;
  int refills = 0;
  t.refill = [gen, base, &refills](Rng& r, tracking::GoalBuffer& b) {
    ++refills;
    b.refill(*gen, {"raise arms", "wave hands"},
             [base](Rng&) { return tracking::trajectory_from_library(*base, 0, 0.0, 1); }, 4, 40, r);
  };
  s.tracking = t;
  ResidualTrainer<TinyWalkerSim> tr(sim, upright(sim.skeleton()), tiny_base(sim.skeleton()), s,
                                    tiny_config("tracking", "ours"), nullptr,
                                    FallCriteria::for_skeleton(sim.skeleton(), {"l_leg", "r_leg"}, "head", 0.8));
  EXPECT_EQ(tr.num_objectives(), 2);
  EXPECT_EQ(tr.policy().goal_dim(), tracking::goal_dim(sim.skeleton(), arms, 2));
  for (int i = 0; i < 3; ++i) tr.iterate();
  EXPECT_EQ(refills, 2);  // at construction and before iteration 3
  const double r = tr.last_tracking_reward();
  EXPECT_TRUE(std::isfinite(r));
  EXPECT_GT(r, 0.0);
  EXPECT_LE(r, 1.0);
}

namespace {

ResidualSetup tracking_setup(const Data& d, const std::vector<BodyPart>& parts) {
  const PartMask arms = PartMask::parse("arms");
  ResidualSetup s;
  s.masks = {arms};
  const MotionLibrary* base = &d.base;
  s.discriminators.push_back({"imitation", 0.5, tasks::window_rows(parts, ~arms), false,
                              [base](Rng& r, Index B, MatrixXf& w, MatrixXf&) { w = base->sample_amp_windows(r, static_cast<int>(B)); }, {}});
  auto gen = std::make_shared<TinyGenerator>();
  TrackingSource t;
  t.designated = arms;
  t.goal_steps = 2;
  t.sample_every = 3;  // a refill happens inside the resumed half
  t.term_window = 4;
  t.term_threshold = 0.5;  // high: the windowed termination fires during these few iterations
  t.refill = [gen, base](Rng& r, tracking::GoalBuffer& b) {
    b.refill(*gen, {"raise arms", "wave hands"},
             [base](Rng& rr) { return tracking::trajectory_from_library(*base, 0, rr.uniform(0.0, 1.0), 1); }, 3, 40, r);
  };
  s.tracking = t;
  return s;
}

}  // namespace

// Stage-2 resume: 2 iterations, checkpoint, a fresh trainer loads it and runs 2 more — the
// networks, optimiser moments and the next statistics equal those of 4 uninterrupted iterations,
// bit for bit (the tiny sim saves its state).
TEST(ResidualTrainer, ResumeContinuesBitExactly) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  for (const std::string task : {"composition", "tracking"}) {
    Data d;
    const auto fall = [](const Skeleton& s) { return FallCriteria::for_skeleton(s, {"l_leg", "r_leg"}, "head", 0.8); };
    auto make = [&](TinyWalkerSim& sim) {
      const auto parts = observation_parts(sim.skeleton());
      return std::make_unique<ResidualTrainer<TinyWalkerSim>>(
          sim, upright(sim.skeleton()), tiny_base(sim.skeleton()),
          task == "tracking" ? tracking_setup(d, parts) : composition_setup(d, "ours", parts), tiny_config(task, "ours"),
          nullptr, fall(sim.skeleton()));
    };
    TinyWalkerSim sim_a(4), sim_b(4);
    auto straight = make(sim_a);
    std::vector<IterationStats> ref;
    for (int i = 0; i < 4; ++i) ref.push_back(straight->iterate());

    auto first = make(sim_b);
    first->iterate();
    first->iterate();
    Checkpoint ck;
    first->save(ck);
    TinyWalkerSim sim_c(4);
    auto resumed = make(sim_c);
    resumed->load(ck);
    EXPECT_EQ(resumed->iteration(), 2);
    for (int i = 2; i < 4; ++i) {
      const IterationStats st = resumed->iterate();
      EXPECT_EQ(st.iteration, ref[static_cast<std::size_t>(i)].iteration) << task;
      EXPECT_EQ(st.policy_loss, ref[static_cast<std::size_t>(i)].policy_loss) << task << " iteration " << i + 1;
      EXPECT_EQ(st.disc_loss, ref[static_cast<std::size_t>(i)].disc_loss) << task << " iteration " << i + 1;
      EXPECT_EQ(st.disc_reward, ref[static_cast<std::size_t>(i)].disc_reward) << task << " iteration " << i + 1;
      EXPECT_EQ(st.extra, ref[static_cast<std::size_t>(i)].extra) << task << " iteration " << i + 1;
    }
    EXPECT_TRUE(same_bits(resumed->policy().residual().mean_net.params(), straight->policy().residual().mean_net.params())) << task;
    EXPECT_TRUE(same_bits(resumed->policy().gain().params(), straight->policy().gain().params())) << task;
    Checkpoint a, b;
    straight->save(a);
    resumed->save(b);
    for (const std::string sec : {"critic/params", "disc/0/params", "state/actor/0", "state/critic", "state/disc/0/block"})
      EXPECT_TRUE(same_bits(a.get_vector<float>(sec), b.get_vector<float>(sec))) << task << " " << sec;
    if (task == "tracking") {
      double terminations = 0;
      for (const auto& st : ref) terminations += st.extra.at("tracking_terminations");
      EXPECT_GT(terminations, 0) << "the windowed termination never fired; the test would not cover its reset";
    }
  }
}

// The windowed tracking termination physically resets the env: its episode step counter goes
// back to 0 (and the pose to an RSI pose), not only the goal trajectory.
TEST(ResidualTrainer, TrackingTerminationResetsTheEnv) {
  Data d;
  TinyWalkerSim sim(4);
  const auto parts = observation_parts(sim.skeleton());
  ResidualSetup s = tracking_setup(d, parts);
  s.tracking->term_threshold = 2.0;  // exp(−e) ≤ 1 < 2: fires as soon as the window is full
  s.tracking->term_window = 3;
  auto cfg = tiny_config("tracking", "ours");
  cfg.rl.env.episode_seconds = 100.0;  // no truncation
  cfg.rl.env.early_termination = false;  // no falls
  ResidualTrainer<TinyWalkerSim> tr(sim, upright(sim.skeleton()), tiny_base(sim.skeleton()), s, cfg, nullptr,
                                    FallCriteria::for_skeleton(sim.skeleton(), {"l_leg", "r_leg"}, "head", 0.8));
  const IterationStats st = tr.iterate();  // horizon 8: every env ends at steps 3 and 6
  EXPECT_EQ(st.extra.at("tracking_terminations"), 4 * 2);
  for (long long steps : tr.task().episode_steps()) EXPECT_EQ(steps, 2);  // 8 − 6 steps since the last reset
  EXPECT_TRUE(st.extra.count("tracking_reward"));
}
