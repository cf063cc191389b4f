// The stage-2 trainer on the tiny analytic simulator: the frozen base stays bit-identical, the
// residual moves, and composition (ours, cml) and tracking runs produce finite statistics; a base
// with normalised actions gets offset + scale ⊙ â as PD targets (training, scratch, evaluation)
// and resumes bit-exactly.
#include "residual_fixtures.hpp"

#include <maskadapt/train/goal_eval.hpp>
#include <maskadapt/train/motion_sources.hpp>
#include <maskadapt/train/residual_eval.hpp>
#include <maskadapt/train/residual_export.hpp>
#include <maskadapt/adapt/adaptnet_policy.hpp>
#include <maskadapt/tasks/heading.hpp>
#include <maskadapt/tasks/location.hpp>
#include <maskadapt/tasks/tracking_task.hpp>
#include <maskadapt/train/residual_trainer.hpp>

#include <gtest/gtest.h>
#include "../blas_kernel.hpp"

#include <cstring>
#include <limits>

using namespace maskadapt;
using namespace maskadapt::train;
using maskadapt::testing::TinyWalkerSim;

namespace {

using namespace maskadapt::testing::stage2;

// A checkpoint's bytes without its training wall time (provenance/train_seconds: never equal
// between two runs, and never read back into training).
std::vector<std::uint8_t> bytes_without_wall_time(Checkpoint c) {
  c.erase("provenance/train_seconds");
  return serialize_checkpoint(c);
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
      EXPECT_GT(st.disc_grad_penalty, 0.0) << method;  // the penalty is applied, and logged
      // the update's time split (fields, so that runs' `extra` maps stay comparable)
      EXPECT_GT(st.time_ppo, 0.0) << method;
      EXPECT_GT(st.time_disc_reward, 0.0) << method;
      EXPECT_LE(st.time_ppo + st.time_disc, st.time_update) << method;
      EXPECT_LE(st.time_disc_reward, st.time_disc) << method;
      EXPECT_EQ(st.time_disc_real_windows, 0.0) << method;
      EXPECT_EQ(st.extra.count("time_ppo"), 0u) << method;
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
  ResidualSetup<TinyWalkerSim> s;
  s.masks = {arms};
  const MotionLibrary* base = &d.base;
  s.discriminators.push_back({"imitation", 0.5, tasks::window_rows(parts, ~arms), false,
                              [base](Rng& r, Index B, MatrixXf& w, MatrixXf&) { w = base->sample_amp_windows(r, static_cast<int>(B)); }, {}});
  auto gen = std::make_shared<TinyGenerator>();
  tasks::TrackingTaskConfig t;
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
  s.goal = tasks::TrackingTask(sim.skeleton(), t, 4);
  ResidualTrainer<TinyWalkerSim> tr(sim, upright(sim.skeleton()), tiny_base(sim.skeleton()), s,
                                    tiny_config("tracking", "ours"), nullptr,
                                    FallCriteria::for_skeleton(sim.skeleton(), {"l_leg", "r_leg"}, "head", 0.8));
  EXPECT_EQ(tr.num_objectives(), 2);
  EXPECT_EQ(tr.policy().goal_dim(), tracking::goal_dim(sim.skeleton(), arms, 2));
  for (int i = 0; i < 3; ++i) tr.iterate();
  EXPECT_EQ(refills, 2);  // at construction and before iteration 3
  const double r = tr.last_goal_reward();
  EXPECT_TRUE(std::isfinite(r));
  EXPECT_GT(r, 0.0);
  EXPECT_LE(r, 1.0);
}


// Stage-2 resume: 2 iterations, checkpoint, a fresh trainer loads it and runs 2 more — the
// networks, optimiser moments and the next statistics equal those of 4 uninterrupted iterations,
// bit for bit (the tiny sim saves its state).
// (with the KL-adaptive actor learning rate of the cpu preset: the rate moves every minibatch and
// must come back from the checkpoint)
TEST(ResidualTrainer, ResumeContinuesBitExactly) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  for (const std::string task : {"composition", "tracking", "location", "heading"}) {
    Data d;
    const auto fall = [](const Skeleton& s) { return FallCriteria::for_skeleton(s, {"l_leg", "r_leg"}, "head", 0.8); };
    ResidualTrainConfig cfg = tiny_config(task, "ours");
    cfg.rl.ppo.actor_lr_schedule = "adaptive";
    auto make = [&](TinyWalkerSim& sim) {
      const auto parts = observation_parts(sim.skeleton());
      ResidualSetup<TinyWalkerSim> setup = task == "tracking" ? tracking_setup(d, sim) : composition_setup(d, "ours", parts);
      if (task == "location") {  // goals resampled every 3–5 steps: draws inside the resumed half
        tasks::LocationConfig lc;
        lc.schedule = {3, 5};
        lc.seed = 11;
        setup.goal = tasks::LocationTask(lc, 4);
      } else if (task == "heading") {
        tasks::HeadingConfig hc;
        hc.schedule = {3, 5};
        hc.success_window = 2;
        hc.seed = 12;
        setup.goal = tasks::HeadingTask(hc, 4);
      }
      return std::make_unique<ResidualTrainer<TinyWalkerSim>>(sim, upright(sim.skeleton()), tiny_base(sim.skeleton()),
                                                              std::move(setup), cfg, nullptr, fall(sim.skeleton()));
    };
    const auto run = run_and_resume(make);
    const auto& ref = run.straight_stats;
    const auto& straight = run.straight;
    const auto& resumed = run.resumed;
    EXPECT_EQ(resumed->iteration(), 4);
    for (int i = 2; i < 4; ++i) {
      const IterationStats& st = run.resumed_stats[static_cast<std::size_t>(i - 2)];
      EXPECT_EQ(st.iteration, ref[static_cast<std::size_t>(i)].iteration) << task;
      EXPECT_EQ(st.policy_loss, ref[static_cast<std::size_t>(i)].policy_loss) << task << " iteration " << i + 1;
      EXPECT_EQ(st.disc_loss, ref[static_cast<std::size_t>(i)].disc_loss) << task << " iteration " << i + 1;
      EXPECT_EQ(st.disc_reward, ref[static_cast<std::size_t>(i)].disc_reward) << task << " iteration " << i + 1;
      EXPECT_EQ(st.extra, ref[static_cast<std::size_t>(i)].extra) << task << " iteration " << i + 1;
      EXPECT_EQ(st.actor_lr, ref[static_cast<std::size_t>(i)].actor_lr) << task << " iteration " << i + 1;
    }
    EXPECT_NE(ref[1].actor_lr, cfg.rl.ppo.actor_lr) << task << ": the adaptive schedule never moved the rate";
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
    if (task == "location" || task == "heading") {  // goals were resampled (trials ended) after the resume
      ASSERT_TRUE(ref[3].extra.count("trials")) << task;
      EXPECT_GT(ref[3].extra.at("trials"), 0) << task;
      EXPECT_TRUE(ref[3].extra.count(task + "_reward")) << task;
      EXPECT_EQ(straight->num_objectives(), 2) << task;
    }
  }
}

// The residual's σ decay: at the start of iteration k every residual DoF's log σ is its initial
// value + min(1, k / N)·log(factor) (closed form; here factor 0.25 over N = 2 iterations, so the
// 3rd and 4th iterations run at a quarter of the initial σ), and a run resumed after 2 iterations
// continues the schedule bit for bit. A factor outside (0, 1], a
// negative count, or a decay on AdaptNet is refused naming residual_std_decay; the JSON keeps it.
TEST(ResidualTrainer, ResidualSigmaDecaysOnItsScheduleAndResumesBitExactly) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  Data d;
  ResidualTrainConfig cfg = tiny_config("tracking", "ours");
  cfg.residual_std = 0.4;
  cfg.residual_std_decay_factor = 0.25;
  cfg.residual_std_decay_iterations = 2;
  auto make = [&](TinyWalkerSim& sim) {
    return std::make_unique<ResidualTrainer<TinyWalkerSim>>(sim, upright(sim.skeleton()), tiny_base(sim.skeleton()),
                                                            tracking_setup(d, sim), cfg, nullptr,
                                                            FallCriteria::for_skeleton(sim.skeleton(), {"l_leg", "r_leg"}, "head", 0.8));
  };
  TinyWalkerSim probe(4);
  auto t = make(probe);
  const VectorXf initial = t->policy().residual().log_std.params();
  ASSERT_NEAR(std::exp(initial[0]), 0.4, 1e-6);
  for (int k = 0; k < 4; ++k) {
    (void)t->iterate();
    const double expected = std::log(0.4) + std::min(1.0, k / 2.0) * std::log(0.25);
    for (Index i = 0; i < initial.size(); ++i)
      EXPECT_NEAR(t->policy().residual().log_std.params()[i], expected, 1e-6) << "iteration " << k + 1 << " DoF " << i;
  }
  const auto run = run_and_resume(make);
  for (int i = 2; i < 4; ++i) {
    EXPECT_EQ(run.resumed_stats[static_cast<std::size_t>(i - 2)].policy_loss, run.straight_stats[static_cast<std::size_t>(i)].policy_loss)
        << "iteration " << i + 1;
    EXPECT_EQ(run.resumed_stats[static_cast<std::size_t>(i - 2)].extra, run.straight_stats[static_cast<std::size_t>(i)].extra);
  }
  EXPECT_TRUE(same_bits(run.resumed->policy().residual().log_std.params(), run.straight->policy().residual().log_std.params()));
  EXPECT_TRUE(same_bits(run.resumed->policy().residual().mean_net.params(), run.straight->policy().residual().mean_net.params()));

  const ResidualTrainConfig back = residual_config_from_json(to_json(cfg));
  EXPECT_EQ(back.residual_std_decay_factor, 0.25);
  EXPECT_EQ(back.residual_std_decay_iterations, 2);
  nlohmann::json old = to_json(cfg);
  old.erase("residual_std_decay");  // written before the decay existed: a fixed σ
  EXPECT_FALSE(residual_config_from_json(old).decays_std());
  const auto bad = [&](auto change, const std::string& what) {
    ResidualTrainConfig b = cfg;
    change(b);
    expect_error_naming([&] { b.validate(); }, "residual_std_decay", what);
  };
  bad([](ResidualTrainConfig& b) { b.residual_std_decay_factor = 1.5; }, "a factor above 1");
  bad([](ResidualTrainConfig& b) { b.residual_std_decay_factor = 0.0; }, "a factor of 0");
  bad([](ResidualTrainConfig& b) { b.residual_std_decay_factor = std::nan(""); }, "a NaN factor");
  bad([](ResidualTrainConfig& b) { b.residual_std_decay_iterations = -1; }, "a negative count");
  bad([](ResidualTrainConfig& b) { b.task = "location"; b.method = "adaptnet"; }, "a decay on AdaptNet");
  nlohmann::json three = to_json(cfg);
  three["residual_std_decay"] = {0.5, 2.5};
  expect_error_naming([&] { residual_config_from_json(three); }, "residual_std_decay", "a fractional count");
}

// The windowed tracking termination physically resets the env: its episode step counter goes
// back to 0 (and the pose to an RSI pose), not only the goal trajectory.
TEST(ResidualTrainer, TrackingTerminationResetsTheEnv) {
  Data d;
  TinyWalkerSim sim(4);
  const auto parts = observation_parts(sim.skeleton());
  tasks::TrackingTaskConfig t = tiny_tracking_config(d);
  t.term_threshold = 2.0;  // exp(−e) ≤ 1 < 2: fires as soon as the window is full
  t.term_window = 3;
  ResidualSetup<TinyWalkerSim> s = tracking_setup(d, sim, t);
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

// The reward scale k: the same pose against the same target earns exp(−k·e), so k = 0.5 gives the
// square root of the paper's reward (k = 1); k ≤ 0 is refused.
TEST(ResidualTrainer, TrackingRewardScaleShapesTheTasksReward) {
  Data d;
  TinyWalkerSim sim(2);
  tasks::TrackingTaskConfig t = tiny_tracking_config(d);
  tasks::TrackingTaskConfig half = t;
  half.reward_scale = 0.5;
  tasks::TrackingTask paper(sim.skeleton(), t, 2), scaled(sim.skeleton(), half, 2);
  paper.new_episode(sim, 0);
  scaled.new_episode(sim, 0);
  const float r1 = paper.after_step(sim, 0, tasks::EpisodeEnd::none).reward;
  const float rh = scaled.after_step(sim, 0, tasks::EpisodeEnd::none).reward;
  ASSERT_GT(r1, 0.0f);
  ASSERT_LT(r1, 0.999f);  // the pose is off its target, or the test proves nothing
  EXPECT_NEAR(rh, std::sqrt(r1), 1e-5);
  tasks::TrackingTaskConfig zero = t;
  zero.reward_scale = 0.0;
  expect_error_naming([&] { tasks::TrackingTask bad(sim.skeleton(), zero, 2); }, "tracking_reward_scale", "a zero reward scale");
}

// ---- bases with normalised actions (PD target = offset + scale ⊙ a) ---------------------------

namespace {

// The tiny walker, remembering every step's PD targets and the observations it was stepped from.
class RecordingSim : public TinyWalkerSim {
 public:
  using TinyWalkerSim::TinyWalkerSim;
  void step(const Eigen::Ref<const MatrixXf>& targets) {
    MatrixXf obs(observation_dim(skeleton()), targets.cols());
    for (Index e = 0; e < targets.cols(); ++e) compute_observation(skeleton(), body_states(static_cast<std::size_t>(e)), obs.col(e));
    before.push_back(obs);
    sent.push_back(targets);
    TinyWalkerSim::step(targets);
  }
  std::vector<MatrixXf> sent, before;  ///< per step: targets (num_dofs × N), observations (obs_dim × N)
};
static_assert(tasks::StateSavingSimulator<RecordingSim>);

// offset ≠ 0 and scale ≠ 1 on every DoF of the tiny walker (15 DoFs).
tasks::ActionSpace tiny_space(const Skeleton& skel) {
  tasks::ActionSpace s;
  const Index A = skel.num_dofs();
  s.offset.resize(A);
  s.scale.resize(A);
  for (Index i = 0; i < A; ++i) {
    s.offset[i] = 0.05f * static_cast<float>(i % 5) - 0.1f;
    s.scale[i] = 0.5f + 0.1f * static_cast<float>(i % 4);
  }
  return s;
}

FrozenBase normalised_base(const Skeleton& skel) { return {tiny_base(skel), tiny_space(skel)}; }


bool same_bits(const MatrixXf& a, const MatrixXf& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), sizeof(float) * static_cast<std::size_t>(a.size())) == 0;
}

// offset + scale ⊙ a, column by column (the expected PD targets).
MatrixXf mapped(const tasks::ActionSpace& s, const MatrixXf& a) {
  MatrixXf t(a.rows(), a.cols());
  for (Index j = 0; j < a.cols(); ++j)
    for (Index i = 0; i < a.rows(); ++i) t(i, j) = s.offset[i] + s.scale[i] * a(i, j);
  return t;
}

}  // namespace

// One iteration per method/task: every step the simulator receives exactly offset + scale ⊙ â of
// the rollout's composite actions â (a bare actor: the identity, â itself). Scratch takes the run
// config's action space (here half_range: 2 rad per unit on the tiny walker's ±2 rad joints).
TEST(ResidualTrainer, NormalisedBaseSendsOffsetPlusScaleOfTheCompositeToTheSimulator) {
  struct Case {
    std::string task, method;
    bool identity;
  };
  for (const Case& k : {Case{"composition", "ours", false}, Case{"composition", "cml", false}, Case{"composition", "scratch", false},
                        Case{"tracking", "ours", false}, Case{"tracking", "cml", false}, Case{"composition", "ours", true}}) {
    const std::string what = k.task + "/" + k.method + (k.identity ? "/identity" : "");
    Data d;
    RecordingSim sim(4);
    const auto parts = observation_parts(sim.skeleton());
    auto cfg = tiny_config(k.task, k.method);
    ResidualSetup<RecordingSim> setup = k.task == "tracking" ? tracking_setup(d, sim)
                                                             : composition_setup<RecordingSim>(d, k.method == "ours" ? "ours" : "cml", parts);
    FrozenBase base = normalised_base(sim.skeleton());
    if (k.method == "scratch") {
      setup.masks = {PartMask::all()};
      cfg.rl.net.action_scale = "half_range";
      EXPECT_THROW(scratch_base(cfg, observation_dim(sim.skeleton()), sim.skeleton().num_dofs()), Error);  // unresolved
      resolve_action_space(cfg.rl, sim.skeleton(), nullptr);
      base = scratch_base(cfg, observation_dim(sim.skeleton()), sim.skeleton().num_dofs());
      ASSERT_EQ(base.actions.offset.size(), 0);
      ASSERT_EQ(base.actions.scale.size(), sim.skeleton().num_dofs());
      EXPECT_TRUE((base.actions.scale.array() == 2.0f).all());
      base.actions.offset = tiny_space(sim.skeleton()).offset;  // (and an offset, to cover both)
    }
    std::unique_ptr<ResidualTrainer<RecordingSim>> tr =
        k.identity ? std::make_unique<ResidualTrainer<RecordingSim>>(sim, upright(sim.skeleton()), tiny_base(sim.skeleton()), setup, cfg,
                                                                     nullptr, tiny_fall(sim.skeleton()))
                   : std::make_unique<ResidualTrainer<RecordingSim>>(sim, upright(sim.skeleton()), base, setup, cfg, nullptr,
                                                                     tiny_fall(sim.skeleton()));
    EXPECT_EQ(tr->policy().actions().identity(), k.identity) << what;
    tr->iterate();
    const auto& buf = tr->rollout();
    ASSERT_EQ(static_cast<Index>(sim.sent.size()), cfg.rl.ppo.horizon) << what;
    for (Index t = 0; t < cfg.rl.ppo.horizon; ++t) {
      const MatrixXf a_hat = buf.actions.middleCols(buf.step_begin(t), 4);
      const MatrixXf expected = k.identity ? a_hat : mapped(tr->policy().actions(), a_hat);
      EXPECT_TRUE(same_bits(sim.sent[static_cast<std::size_t>(t)], expected)) << what << " step " << t;
    }
  }
}

// Evaluation (residual_eval.hpp) on a normalised base: with Δa = 0 and w = 1 every frame's targets
// equal those of the base alone (its own offset + scale ⊙ a_base rollout, bit for bit); with a
// trained residual and w ≠ 1 they are offset + scale ⊙ (w·a_base + Δa) on the masked DoFs and
// exactly the base's targets on the others. Tracking evaluation maps its actions the same way.
TEST(ResidualEval, NormalisedBaseTargetsAreTheBasesOwnUntilTheResidualActsOnMaskedDofs) {
  Data d;
  const Skeleton& skel = d.skel;
  const tasks::ActionSpace space = tiny_space(skel);
  const auto parts = observation_parts(skel);
  const PartElements pe(parts);
  const PartMask arms = PartMask::parse("arms");
  adapt::ResidualConfig rc;
  rc.hidden = {16};
  rc.gain = adapt::GainMode::PerDof;
  Rng init(2);
  adapt::ResidualPolicy<float> pol(tiny_base(skel), observation_dim(skel), action_parts(skel), rc, init, space);
  CompositionEvalOptions opt;
  opt.frames = 12;

  // Δa = 0, w = 1: the base's own rollout
  RecordingSim sim_res(3), sim_base(3);
  (void)evaluate_composition(sim_res, pol, arms, d.base, d.added, upright(skel), tiny_fall(skel), opt);
  {
    tasks::ImitationTaskConfig tc;
    tc.fall = tiny_fall(skel);
    tc.episode_seconds = opt.episode_seconds;
    tc.masking = false;
    tc.actions = space;
    tasks::ImitationTask<RecordingSim> task(sim_base, upright(skel), tc, opt.seed);
    const std::vector<PartMask> masks(3, arms);
    MatrixXf in, mu, scratch;
    nn::InferenceWorkspace<float> ws;
    for (Index f = 0; f < opt.frames; ++f) {
      in = policy_input<float>(pe, task.observations(), masks);
      mu.resize(skel.num_dofs(), 3);
      pol.base().mean(in, mu, ws, scratch);
      task.step(mu);
    }
  }
  ASSERT_EQ(sim_res.sent.size(), sim_base.sent.size());
  for (std::size_t f = 0; f < sim_res.sent.size(); ++f) EXPECT_TRUE(same_bits(sim_res.sent[f], sim_base.sent[f])) << "frame " << f;

  // a trained residual, per-DoF gains ≠ 1: the first frame (same observations as the base's)
  Rng fill(4);
  for (Index i = 0; i < pol.residual().mean_net.params().size(); ++i)
    pol.residual().mean_net.params()[i] = static_cast<float>(fill.uniform(-0.5, 0.5));
  for (Index i = 0; i < pol.gain().params().size(); ++i) pol.gain().params()[i] = 0.7f + 0.05f * static_cast<float>(i);
  RecordingSim sim_trained(3);
  (void)evaluate_composition(sim_trained, pol, arms, d.base, d.added, upright(skel), tiny_fall(skel), opt);
  const MatrixXf& obs0 = sim_trained.before.front();
  ASSERT_TRUE(same_bits(obs0, sim_base.before.front()));
  const std::vector<PartMask> masks(3, arms);
  adapt::ResidualWorkspace<float> ws;
  MatrixXf x, delta, scratch;
  pol.build_input(pe, obs0, masks, MatrixXf(0, 3), x, ws);
  const MatrixXf a_base = x.middleRows(obs0.rows(), skel.num_dofs());
  nn::InferenceWorkspace<float> rws;
  delta.resize(skel.num_dofs(), 3);
  pol.residual().mean(x, delta, rws, scratch);
  const auto dof_parts = action_parts(skel);
  int masked_rows = 0;
  for (Index j = 0; j < 3; ++j)
    for (Index i = 0; i < skel.num_dofs(); ++i) {
      const float got = sim_trained.sent.front()(i, j), own = sim_base.sent.front()(i, j);
      if (arms.has(dof_parts[static_cast<std::size_t>(i)])) {
        ++masked_rows;
        EXPECT_EQ(got, space.offset[i] + space.scale[i] * (pol.gain().params()[i] * a_base(i, j) + delta(i, j))) << i;
        EXPECT_NE(got, own) << "masked DoF " << i << " kept the base's target";
      } else {
        EXPECT_EQ(got, own) << "unmasked DoF " << i << " moved";
      }
    }
  EXPECT_EQ(masked_rows, 3 * 6);  // two arms × 3 hinges per env

  // tracking evaluation: Δa = 0, w = 1 ⇒ every step's targets = offset + scale ⊙ a_base(s̄, m)
  adapt::ResidualConfig tc = rc;
  tc.goal_dim = tracking::goal_dim(skel, arms, 2);
  Rng init2(2);
  const adapt::ResidualPolicy<float> track(tiny_base(skel), observation_dim(skel), action_parts(skel), tc, init2, space);
  TinyGenerator gen;
  TrackingEvalOptions topt;
  topt.prompts = {"raise arms"};
  topt.repeats = 2;
  topt.seconds = 0.3;
  RecordingSim sim_track(2);
  (void)evaluate_tracking(sim_track, track, gen, arms, 2, d.base, tiny_fall(skel), topt);
  ASSERT_FALSE(sim_track.sent.empty());
  const std::vector<PartMask> tm(2, arms);
  for (std::size_t t = 0; t < sim_track.sent.size(); ++t) {
    MatrixXf in, mu(skel.num_dofs(), 2), sc;
    nn::InferenceWorkspace<float> bws;
    in = policy_input<float>(pe, sim_track.before[t], tm);
    track.base().mean(in, mu, bws, sc);
    EXPECT_TRUE(same_bits(sim_track.sent[t], mapped(space, mu))) << "tracking step " << t;
  }
}

// The per-frame visits eval-residual writes (`visits_adapted_vs_new`) are the counts H_norm(adapted | B)
// is computed from: one per frame of B in clip order (`clip_list_json` names them), with that
// normalised entropy; with a threshold wider than any distance every generated frame visits every
// frame of B once, so each count is envs × frames and H_norm is 1.
TEST(ResidualEval, PerFrameVisitsOfBAreTheCountsBehindItsHNorm) {
  Data d;
  const Skeleton& skel = d.skel;
  const PartMask arms = PartMask::parse("arms");
  adapt::ResidualConfig rc;
  rc.hidden = {16};
  Rng init(2);
  adapt::ResidualPolicy<float> pol(tiny_base(skel), observation_dim(skel), action_parts(skel), rc, init, tiny_space(skel));
  std::int64_t b_frames = 0;
  for (int c = 0; c < d.added.num_clips(); ++c) b_frames += d.added.clip(c).num_frames();
  const nlohmann::json clips = clip_list_json(d.added);
  ASSERT_EQ(clips.size(), 1u);
  EXPECT_EQ(clips[0]["name"], "arms_swing");
  EXPECT_EQ(clips[0]["frames"].get<std::int64_t>(), b_frames);

  CompositionEvalOptions opt;
  opt.frames = 20;
  for (const double threshold : {0.1, 1e3}) {
    opt.threshold_per_body = threshold;
    RecordingSim sim(3);
    const CompositionResult r = evaluate_composition(sim, pol, arms, d.base, d.added, upright(skel), tiny_fall(skel), opt);
    ASSERT_EQ(static_cast<std::int64_t>(r.visits_adapted.size()), b_frames) << threshold;
    EXPECT_DOUBLE_EQ(eval::normalized_entropy(r.visits_adapted), r.h_adapted) << threshold;
    EXPECT_EQ(to_json(r)["visits_adapted_vs_new"].get<std::vector<std::int64_t>>(), r.visits_adapted) << threshold;
    if (threshold > 1.0) {
      for (const std::int64_t v : r.visits_adapted) EXPECT_EQ(v, 3 * opt.frames);
      EXPECT_NEAR(r.h_adapted, 1.0, 1e-12);  // Σ p log p of a uniform p, rounded
    }
  }
}

// Identity bases are untouched: a bare actor and FrozenBase{actor, identity} train the same bits,
// and the checkpoint holds no action-space sections (it is the checkpoint of before).
TEST(ResidualTrainer, IdentityBaseWritesNoActionSpace) {
  Data d;
  std::vector<std::vector<std::uint8_t>> bytes;
  for (bool frozen : {false, true}) {
    TinyWalkerSim sim(4);
    const auto parts = observation_parts(sim.skeleton());
    std::unique_ptr<ResidualTrainer<TinyWalkerSim>> tr =
        frozen ? std::make_unique<ResidualTrainer<TinyWalkerSim>>(sim, upright(sim.skeleton()), FrozenBase{tiny_base(sim.skeleton()), {}},
                                                                  composition_setup(d, "ours", parts), tiny_config("composition", "ours"),
                                                                  nullptr, tiny_fall(sim.skeleton()))
               : std::make_unique<ResidualTrainer<TinyWalkerSim>>(sim, upright(sim.skeleton()), tiny_base(sim.skeleton()),
                                                                  composition_setup(d, "ours", parts), tiny_config("composition", "ours"),
                                                                  nullptr, tiny_fall(sim.skeleton()));
    tr->iterate();
    tr->iterate();
    Checkpoint ck;
    tr->save(ck);
    for (const auto& n : ck.names()) EXPECT_EQ(n.find("action_"), std::string::npos) << n;
    bytes.push_back(bytes_without_wall_time(ck));
  }
  EXPECT_TRUE(bytes[0] == bytes[1]);
}

// A normalised base resumes bit-exactly, and the resumed trainer gets its action space from the
// checkpoint: it is built like `train-residual --resume` builds it, on a placeholder identity base.
TEST(ResidualTrainer, NormalisedBaseResumesBitExactlyWithTheCheckpointsActionSpace) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  for (const std::string task : {"composition", "tracking"}) {
    Data d;
    auto make = [&](RecordingSim& sim, bool placeholder) {
      const auto parts = observation_parts(sim.skeleton());
      FrozenBase base = placeholder ? FrozenBase{tiny_base(sim.skeleton()), {}} : normalised_base(sim.skeleton());
      return std::make_unique<ResidualTrainer<RecordingSim>>(
          sim, upright(sim.skeleton()), std::move(base),
          task == "tracking" ? tracking_setup(d, sim) : composition_setup<RecordingSim>(d, "ours", parts), tiny_config(task, "ours"), nullptr,
          tiny_fall(sim.skeleton()));
    };
    RecordingSim sim_a(4), sim_b(4), sim_c(4);
    auto straight = make(sim_a, false);
    std::vector<IterationStats> ref;
    for (int i = 0; i < 4; ++i) ref.push_back(straight->iterate());
    auto first = make(sim_b, false);
    first->iterate();
    first->iterate();
    Checkpoint ck;
    first->save(ck);
    ASSERT_TRUE(ck.contains("base/actor/action_offset") && ck.contains("base/actor/action_scale"));
    auto resumed = make(sim_c, true);
    ASSERT_TRUE(resumed->policy().actions().identity());
    resumed->load(ck);
    EXPECT_TRUE(resumed->policy().actions().offset == tiny_space(sim_c.skeleton()).offset) << task;
    EXPECT_TRUE(resumed->policy().actions().scale == tiny_space(sim_c.skeleton()).scale) << task;
    for (int i = 2; i < 4; ++i) {
      const IterationStats st = resumed->iterate();
      const auto& r = ref[static_cast<std::size_t>(i)];
      EXPECT_EQ(st.policy_loss, r.policy_loss) << task << " iteration " << i + 1;
      EXPECT_EQ(st.disc_loss, r.disc_loss) << task << " iteration " << i + 1;
      EXPECT_EQ(st.disc_reward, r.disc_reward) << task << " iteration " << i + 1;
      EXPECT_EQ(st.extra, r.extra) << task << " iteration " << i + 1;
    }
    // the PD targets of the resumed half are those of the straight run's second half
    ASSERT_EQ(sim_c.sent.size() * 2, sim_a.sent.size());
    for (std::size_t t = 0; t < sim_c.sent.size(); ++t)
      EXPECT_TRUE(same_bits(sim_c.sent[t], sim_a.sent[t + sim_c.sent.size()])) << task << " step " << t;
    Checkpoint a, b;
    straight->save(a);
    resumed->save(b);
    EXPECT_TRUE(bytes_without_wall_time(a) == bytes_without_wall_time(b)) << task;
  }
}

// A residual with the location task's 4 goal rows on the tiny base, and fall criteria that never
// trigger (every body may touch the ground, no height limit): the goal-evaluation tests below.
namespace {
adapt::ResidualPolicy<float> tiny_location_residual(const Skeleton& skel) {
  adapt::ResidualConfig rc;
  rc.hidden = {16};
  rc.goal_dim = 4;
  Rng init(2);
  return adapt::ResidualPolicy<float>(tiny_base(skel), observation_dim(skel), action_parts(skel), rc, init);
}
FallCriteria never_falls(const Skeleton& skel) {
  return FallCriteria::for_skeleton(skel, {"root", "head", "l_arm", "r_arm", "l_leg", "r_leg"}, "");
}
/// The goal-evaluation tests' setup: the tiny data, that residual, and falls that never trigger.
struct TinyGoalEval {
  Data d;
  const Skeleton& skel = d.skel;
  const adapt::ResidualPolicy<float> pol = tiny_location_residual(d.skel);
  const FallCriteria never = never_falls(d.skel);
};
}  // namespace

// Goal-task evaluation: a goal radius that covers the whole floor makes every trial a success, a
// 1 mm radius around targets metres away makes every trial a failure; at least min_trials end,
// the Wilson interval brackets the rate, and a step budget too small to end them is refused.
TEST(ResidualEval, GoalTaskSuccessRateCountsEndedTrials) {
  const TinyGoalEval g;
  const Skeleton& skel = g.skel;
  const adapt::ResidualPolicy<float>& pol = g.pol;
  GoalEvalOptions opt;
  opt.min_trials = 20;
  opt.episode_seconds = 1000.0;  // no truncation, and (below) no falls: every trial ends by its goal's expiry
  const FallCriteria& never = g.never;
  for (double radius : {1000.0, 0.001}) {
    TinyWalkerSim sim(4);
    tasks::LocationConfig lc;
    lc.radius = radius;
    lc.schedule = {5, 8};
    const GoalEvalResult r = evaluate_goal_task<TinyWalkerSim>(sim, pol, tasks::LocationTask(lc, 4), PartMask::parse("arms"),
                                                               upright(skel), never, opt);
    EXPECT_EQ(r.task, "location");
    EXPECT_GE(r.trials.trials, 20);
    EXPECT_LT(r.trials.trials, 20 + 4 * 2);  // it stops soon after: at most two trials per env in the last step
    EXPECT_EQ(r.trials.rate(), radius > 1 ? 1.0 : 0.0) << radius;
    EXPECT_LE(r.ci_low, r.trials.rate());
    EXPECT_GE(r.ci_high, r.trials.rate());
    EXPECT_LT(r.ci_high - r.ci_low, 0.2);
    if (radius > 1) {
      EXPECT_EQ(r.mean_reward, 1.0);
    }
  }
  TinyWalkerSim sim(4);
  opt.max_steps = 3;  // no 5-step goal can end
  EXPECT_THROW(evaluate_goal_task<TinyWalkerSim>(sim, pol, tasks::LocationTask(tasks::LocationConfig{}, 4), PartMask::parse("arms"),
                                                 upright(skel), tiny_fall(skel), opt),
               Error);
  tasks::HeadingConfig hc;  // a policy with 4 goal rows does not fit a 3-row task
  EXPECT_THROW(evaluate_goal_task<TinyWalkerSim>(sim, pol, tasks::HeadingTask(hc, 4), PartMask::parse("arms"), upright(skel),
                                                 tiny_fall(skel), GoalEvalOptions{}),
               Error);
}

// Trials the episode's time limit cuts short are censored, not counted: 30-step episodes (1 s at
// 30 Hz) and goals held 20 steps give each episode one trial that runs its course and one that the
// limit cuts after 10 steps. With a radius covering the floor both would be successes; only the
// first is counted, and the second appears in `censored` (one per ended episode).
TEST(ResidualEval, GoalTaskTrialsCutByTheTimeLimitAreCensored) {
  const TinyGoalEval g;
  const Skeleton& skel = g.skel;
  const adapt::ResidualPolicy<float>& pol = g.pol;
  GoalEvalOptions opt;
  opt.min_trials = 20;
  opt.episode_seconds = 1.0;
  const FallCriteria& never = g.never;
  TinyWalkerSim sim(4);
  tasks::LocationConfig lc;
  lc.radius = 1000.0;
  lc.schedule = {20, 20};
  const GoalEvalResult r = evaluate_goal_task<TinyWalkerSim>(sim, pol, tasks::LocationTask(lc, 4), PartMask::parse("arms"),
                                                             upright(skel), never, opt);
  EXPECT_GE(r.trials.trials, 20);
  EXPECT_EQ(r.trials.rate(), 1.0);
  EXPECT_GE(r.trials.censored, r.trials.trials - 4);  // one per env-episode, the last episodes' maybe not yet
  EXPECT_LE(r.trials.censored, r.trials.trials);
  EXPECT_EQ(r.steps % 30, 20) << "stops when the 20th counted trial (a goal's expiry at step 20 of an episode) ends";
}

// The composed motion beside the success rate: with a threshold wider than any distance every
// simulated frame is within it of every frame of B (matched 1, H_norm 1: uniform visits); with a
// zero threshold only frames exactly on a frame of B count, fewer than all; the success count and
// the steps do not depend on it; bad parts and thresholds are refused.
TEST(ResidualEval, GoalTaskMeasuresTheComposedMotionBesideSuccess) {
  const TinyGoalEval g;
  const Skeleton& skel = g.skel;
  const adapt::ResidualPolicy<float>& pol = g.pol;
  GoalEvalOptions opt;
  opt.min_trials = 12;
  opt.episode_seconds = 1000.0;
  const FallCriteria& never = g.never;
  tasks::LocationConfig lc;
  lc.schedule = {5, 8};
  const PartMask arms = PartMask::parse("arms");
  auto run = [&](std::optional<ComposedMotion> composed) {
    TinyWalkerSim sim(4);
    return evaluate_goal_task<TinyWalkerSim>(sim, pol, tasks::LocationTask(lc, 4), arms, upright(skel), never, opt, nullptr,
                                             composed);
  };
  const GoalEvalResult plain = run(std::nullopt);
  EXPECT_FALSE(plain.composed.has_value());
  for (const double threshold : {1e3, 0.0}) {
    const GoalEvalResult r = run(ComposedMotion{&g.d.added, arms, threshold});
    ASSERT_TRUE(r.composed.has_value()) << threshold;
    EXPECT_EQ(r.composed->parts, arms);
    EXPECT_EQ(r.composed->threshold_per_body, threshold);
    EXPECT_EQ(r.trials.successes, plain.trials.successes) << threshold;
    EXPECT_EQ(r.steps, plain.steps) << threshold;
    if (threshold > 1) {
      EXPECT_EQ(r.composed->matched, 1.0);
      EXPECT_NEAR(r.composed->h_norm, 1.0, 1e-12);
    } else {
      EXPECT_LT(r.composed->matched, 0.5);
      EXPECT_GE(r.composed->h_norm, 0.0);
      EXPECT_LE(r.composed->h_norm, 1.0);
    }
  }
  EXPECT_THROW(run(ComposedMotion{&g.d.added, PartMask::all(), 0.1}), Error);
  EXPECT_THROW(run(ComposedMotion{nullptr, arms, 0.1}), Error);
  EXPECT_THROW(run(ComposedMotion{&g.d.added, arms, std::nan("")}), Error);
}

// Tracking evaluation with --oracle-targets: the arms' PD targets are the target trajectory's own
// angles (the toy generator's "raise arms": the l_arm / r_arm x hinges at +0.6 / −0.6 rad, the
// rest of the arms at the walk's 0), whatever the policy says; the other DoFs stay the base's. The
// tiny walker's joints follow a target with the lag q ← q + Δt·8·(q* − q) from the walk's 0, so
// after step t each arm is 0.6·(1 − 8Δt)^(t+1) rad from its target, and the rotation error is the
// mean of that over the episode's steps (closed form). Without the oracle it is not.
TEST(ResidualEval, TrackingOracleDrivesTheDesignatedJointsWithTheTargetsAngles) {
  const Data d;
  const Skeleton& skel = d.skel;
  const PartMask arms = PartMask::parse("arms");
  adapt::ResidualConfig rc;
  rc.hidden = {16};
  rc.goal_dim = tracking::goal_dim(skel, arms, 2);
  Rng init(2);
  adapt::ResidualPolicy<float> pol(tiny_base(skel), observation_dim(skel), action_parts(skel), rc, init);
  Rng fill(5);  // a residual that moves the arms: the oracle must override it
  for (Index i = 0; i < pol.residual().mean_net.params().size(); ++i)
    pol.residual().mean_net.params()[i] = static_cast<float>(fill.uniform(-0.5, 0.5));
  TinyGenerator gen;
  TrackingEvalOptions opt;
  opt.prompts = {"raise arms"};
  opt.repeats = 2;
  opt.seconds = 0.3;  // 9 control steps
  opt.oracle_targets = true;
  RecordingSim sim(2);
  const TrackingEvaluation ev = evaluate_tracking(sim, pol, gen, arms, 2, d.base, never_falls(skel), opt);
  ASSERT_EQ(sim.sent.size(), 9u);
  const int la = skel.dof_offset(2), ra = skel.dof_offset(3);
  const PartElements pe(observation_parts(skel));
  const std::vector<PartMask> one_env(1, arms);
  double expected_rot = 0;
  for (std::size_t t = 0; t < sim.sent.size(); ++t) {
    for (Index e = 0; e < 2; ++e) {
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(sim.sent[t](la + k, e), k == 0 ? 0.6f : 0.0f) << "step " << t << " l_arm hinge " << k;
        EXPECT_EQ(sim.sent[t](ra + k, e), k == 0 ? -0.6f : 0.0f) << "step " << t << " r_arm hinge " << k;
      }
      // the other DoFs: the composite's, as without the oracle (Δa acts on the arms only)
      MatrixXf in = policy_input<float>(pe, MatrixXf(sim.before[t].col(e)), one_env), mu(skel.num_dofs(), 1), sc;
      nn::InferenceWorkspace<float> bws;
      pol.base().mean(in, mu, bws, sc);
      for (Index i = 0; i < skel.num_dofs(); ++i) {
        if (i >= la && i < ra + 3) continue;
        EXPECT_NEAR(sim.sent[t](i, e), mu(i, 0), 1e-5f) << "step " << t << " DoF " << i;
      }
    }
    expected_rot += 0.6 * std::pow(1.0 - 8.0 * TinyWalkerSim::kDt, static_cast<double>(t + 1)) / 9.0;
  }
  EXPECT_NEAR(ev.rotation_error, expected_rot, 1e-6);
  EXPECT_NEAR(ev.prompts.at(0).rotation_error, expected_rot, 1e-6);
  EXPECT_GT(ev.tracking_error, 0.0);

  opt.oracle_targets = false;
  RecordingSim plain(2);
  const TrackingEvaluation free = evaluate_tracking(plain, pol, gen, arms, 2, d.base, never_falls(skel), opt);
  EXPECT_GT(std::abs(free.rotation_error - expected_rot), 1e-3);
  EXPECT_NE(plain.sent.front()(la, 0), 0.6f);
}

// Per-part credit's groups: DoFs whose parts carry equal weights form one group, in order of
// first appearance; a part without its own weights takes the run's; a part with a weight count
// other than the run's objective count is refused naming it.
TEST(PartCredit, GroupsTheDofsByTheirWeights) {
  std::array<std::vector<double>, kNumParts> w{};
  w[static_cast<std::size_t>(BodyPart::LeftArm)] = {1, 0};
  w[static_cast<std::size_t>(BodyPart::RightArm)] = {1, 0};
  const std::vector<BodyPart> dofs = {BodyPart::Trunk, BodyPart::LeftArm, BodyPart::RightArm, BodyPart::LeftLeg, BodyPart::LeftArm};
  const PartCredit pc = make_part_credit(w, {0.1, 0.9}, dofs);
  EXPECT_EQ(pc.group_of_row, (std::vector<Index>{0, 1, 1, 0, 1}));
  ASSERT_EQ(pc.groups(), 2);
  EXPECT_EQ(pc.weights(0, 0), 0.1);
  EXPECT_EQ(pc.weights(0, 1), 0.9);
  EXPECT_EQ(pc.weights(1, 0), 1.0);
  EXPECT_EQ(pc.weights(1, 1), 0.0);
  w[static_cast<std::size_t>(BodyPart::LeftLeg)] = {1, 0, 0};
  try {
    (void)make_part_credit(w, {0.1, 0.9}, dofs);
    ADD_FAILURE() << "three weights for a two-objective run were accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("left_leg"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW((void)make_part_credit(w, {0.1, 0.9}, {BodyPart::Trunk}));  // (no left-leg DoF: not used)
}

// Per-part credit routes each objective to its parts' DoFs: a location residual that moves the
// arms and the legs, with per-DoF gains; with the arms credited with nothing (weights 0 0) their
// gains never move (their DoFs' policy gradient is exactly zero, so Adam leaves them), while the
// legs' do; without per-part credit the arms' gains move too. AdaptNet refuses per-part credit.
TEST(ResidualTrainer, PerPartCreditRoutesEachObjectiveToItsPartsDofs) {
  Data d;
  auto run = [&](bool credit) {
    ResidualTrainConfig cfg = tiny_config("location", "ours");
    cfg.gain = "per_dof";
    cfg.goal_parts = "lower_body";
    if (credit) {
      cfg.part_objective_weights[static_cast<std::size_t>(BodyPart::LeftArm)] = {0, 0};
      cfg.part_objective_weights[static_cast<std::size_t>(BodyPart::RightArm)] = {0, 0};
    }
    TinyWalkerSim sim(4);
    ResidualSetup<TinyWalkerSim> s;
    s.masks = {PartMask::parse("arms")};
    const MotionLibrary* base = &d.base;
    s.discriminators.push_back({"imitation", 0.5, {}, false,
                                [base](Rng& r, Index B, MatrixXf& w, MatrixXf&) { w = base->sample_amp_windows(r, static_cast<int>(B)); }, {}});
    tasks::LocationConfig lc;
    lc.schedule = {3, 5};
    s.goal = tasks::LocationTask(lc, 4);
    ResidualTrainer<TinyWalkerSim> tr(sim, upright(sim.skeleton()), tiny_base(sim.skeleton()), std::move(s), cfg, nullptr,
                                      tiny_fall(sim.skeleton()));
    EXPECT_EQ(tr.part_credit_groups(), credit ? 2 : 0);
    const VectorXf before = tr.policy().gain().params();
    for (int i = 0; i < 3; ++i) tr.iterate();
    return std::make_pair(before, VectorXf(tr.policy().gain().params()));
  };
  const auto [before_off, off] = run(false);
  const auto [before_on, on] = run(true);
  const auto dofs = action_parts(d.skel);
  int arms = 0, legs = 0;
  for (std::size_t i = 0; i < dofs.size(); ++i) {
    const Index r = static_cast<Index>(i);
    if (dofs[i] == BodyPart::LeftArm || dofs[i] == BodyPart::RightArm) {
      ++arms;
      EXPECT_EQ(on[r], before_on[r]) << "arm DoF " << i << " moved under zero credit";
      EXPECT_NE(off[r], before_off[r]) << "arm DoF " << i << " did not train without per-part credit";
    } else if (dofs[i] == BodyPart::LeftLeg || dofs[i] == BodyPart::RightLeg) {
      ++legs;
      EXPECT_NE(on[r], before_on[r]) << "leg DoF " << i << " did not train";
    }
  }
  EXPECT_GT(arms, 0);
  EXPECT_GT(legs, 0);
  ResidualTrainConfig a = tiny_config("location", "adaptnet");
  a.part_objective_weights[static_cast<std::size_t>(BodyPart::LeftArm)] = {1, 0};
  EXPECT_THROW(a.validate(), Error);
}

// AdaptNet through the same trainer (the policy is a template parameter): on a location goal
// with an imitation discriminator of the base motion, it trains (the adaptation moves, the frozen
// base does not) and resumes bit-exactly.
TEST(ResidualTrainer, AdaptNetTrainsOnAGoalTaskAndResumesBitExactly) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  Data d;
  ResidualTrainConfig cfg = tiny_config("location", "adaptnet");
  auto make = [&](TinyWalkerSim& sim) {
    ResidualSetup<TinyWalkerSim> s;
    s.masks = {PartMask::parse("arms")};
    const MotionLibrary* base = &d.base;
    s.discriminators.push_back({"imitation", 0.5, {}, false,
                                [base](Rng& r, Index B, MatrixXf& w, MatrixXf&) { w = base->sample_amp_windows(r, static_cast<int>(B)); }, {}});
    tasks::LocationConfig lc;
    lc.schedule = {3, 5};
    s.goal = tasks::LocationTask(lc, 4);
    return std::make_unique<ResidualTrainer<TinyWalkerSim, adapt::AdaptNetPolicy<float>>>(
        sim, upright(sim.skeleton()), tiny_base(sim.skeleton()), std::move(s), cfg, nullptr, tiny_fall(sim.skeleton()));
  };
  TinyWalkerSim sim_a(4), sim_b(4), sim_c(4);
  auto straight = make(sim_a);
  EXPECT_EQ(straight->policy().goal_dim(), 4);
  const VectorXf base0 = straight->policy().base().mean_net.params();
  Checkpoint before, after;
  straight->save(before);
  std::vector<IterationStats> ref;
  for (int i = 0; i < 4; ++i) ref.push_back(straight->iterate());
  EXPECT_TRUE(same_bits(straight->policy().base().mean_net.params(), base0));
  straight->save(after);
  EXPECT_FALSE(same_bits(before.get_vector<float>("adaptnet/embed"), after.get_vector<float>("adaptnet/embed")));  // it trained
  auto first = make(sim_b);
  first->iterate();
  first->iterate();
  Checkpoint ck;
  first->save(ck);
  auto resumed = make(sim_c);
  resumed->load(ck);
  for (int i = 2; i < 4; ++i) {
    const IterationStats st = resumed->iterate();
    EXPECT_EQ(st.policy_loss, ref[static_cast<std::size_t>(i)].policy_loss) << i;
    EXPECT_EQ(st.extra, ref[static_cast<std::size_t>(i)].extra) << i;
  }
  Checkpoint a, b;
  straight->save(a);
  resumed->save(b);
  EXPECT_TRUE(bytes_without_wall_time(a) == bytes_without_wall_time(b));
  EXPECT_THROW(tiny_config("composition", "adaptnet").validate(), Error);  // AdaptNet is for goal tasks
}

// A policy-only export of a stage-2 run (train/residual_export.hpp) holds the policy and its
// frozen base and nothing the training alone needs; the policy read back from it acts bit for
// bit as the one read from the checkpoint (ours and AdaptNet); bad files are refused naming the
// section; the run's history travels with it.
TEST(ResidualExport, ActsAsTheCheckpointAndHoldsOnlyThePolicy) {
  Data d;
  TinyWalkerSim sim_r(4), sim_a(4);
  const Skeleton& skel = sim_r.skeleton();
  // (the CLI copies the base's architecture into the run's config; loading needs it)
  auto config = [](const std::string& task, const std::string& method) {
    ResidualTrainConfig c = tiny_config(task, method);
    c.rl.net.actor_hidden = {16, 16};
    return c;
  };
  ResidualTrainer<TinyWalkerSim> ours(sim_r, upright(skel), tiny_base(skel), composition_setup(d, "ours", observation_parts(skel)),
                                      config("composition", "ours"), nullptr, tiny_fall(skel));
  ResidualSetup<TinyWalkerSim> goal_setup;
  goal_setup.masks = {PartMask::parse("arms")};
  tasks::LocationConfig lc;
  lc.schedule = {3, 5};
  goal_setup.goal = tasks::LocationTask(lc, 4);
  ResidualTrainer<TinyWalkerSim, adapt::AdaptNetPolicy<float>> adaptnet(sim_a, upright(skel), tiny_base(skel), std::move(goal_setup),
                                                                       config("location", "adaptnet"), nullptr, tiny_fall(skel));
  ours.add_provenance("chunk 1 (test)");
  for (int i = 0; i < 2; ++i) {
    ours.iterate();
    adaptnet.iterate();
  }
  ExportInfo info;
  info.exported_from = "runs/x/checkpoint.bin";
  info.git_commit = "abc1234";
  info.note = "unit test";
  Rng rng(3);
  MatrixXf x;

  auto check = [&](const Checkpoint& training, auto build, const std::string& method) {
    Checkpoint model;
    export_residual_policy(training, model, info);
    EXPECT_TRUE(is_residual_export(model)) << method;
    EXPECT_EQ(model.get_string("model/method"), method);
    EXPECT_EQ(check_residual_export(model).method, method);
    for (const std::string& name : model.names()) {  // only the policy, its base, the config and the records
      const bool kept = name.rfind("residual", 0) == 0 || name.rfind("adaptnet/", 0) == 0 || name.rfind("base/actor/", 0) == 0 ||
                        name.rfind("model/", 0) == 0 || name.rfind("provenance/", 0) == 0 || name.rfind("trainer/", 0) == 0 ||
                        name == "config";
      EXPECT_TRUE(kept) << method << ": " << name;
      if (name.rfind("residual", 0) == 0 || name.rfind("adaptnet/", 0) == 0 || name.rfind("base/actor/", 0) == 0 || name == "config") {
        EXPECT_TRUE(model.section(name).data == training.section(name).data) << method << ": " << name;
      }
    }
    for (const char* gone : {"critic/params", "popart/mean", "disc/0/params", "state/rng"})
      EXPECT_FALSE(model.contains(gone)) << method << ": " << gone;
    EXPECT_LT(serialize_checkpoint(model).size(), serialize_checkpoint(training).size());
    EXPECT_EQ(model.get_int("trainer/iteration"), 2);
    // the policies built from the checkpoint and from the export: identical mean actions
    const auto from_ckpt = build(training);
    const auto from_model = build(model);
    x.resize(from_ckpt.input_dim(), 6);
    for (Index i = 0; i < x.size(); ++i) x.data()[i] = static_cast<float>(rng.uniform(-1.0, 1.0));
    const std::vector<PartMask> masks(6, PartMask::parse("arms"));
    MatrixXf mu_c, mu_m;
    typename Stage2Types<std::decay_t<decltype(from_ckpt)>>::Workspace ws;
    from_ckpt.mean(x, masks, mu_c, ws);
    from_model.mean(x, masks, mu_m, ws);
    EXPECT_TRUE(mu_c.size() == mu_m.size() &&
                std::memcmp(mu_c.data(), mu_m.data(), sizeof(float) * static_cast<std::size_t>(mu_c.size())) == 0)
        << method;
    EXPECT_GT(mu_c.cwiseAbs().maxCoeff(), 0.0f);
    // refusals, each naming the section
    auto refused = [&](const Checkpoint& c, const std::string& section, auto fn) {
      try {
        fn(c);
        ADD_FAILURE() << method << ": accepted a file without a valid " << section;
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(section), std::string::npos) << e.what();
      }
    };
    auto do_export = [&](const Checkpoint& c) {
      Checkpoint o;
      export_residual_policy(c, o, info);
    };
    auto do_check = [&](const Checkpoint& c) { (void)check_residual_export(c); };
    refused(model, "model/kind", do_export);  // an export of an export
    Checkpoint no_config = training;
    no_config.erase("residual_config");
    refused(no_config, "residual_config", do_export);  // a stage-1 checkpoint has none
    const char* policy_section = method == "adaptnet" ? "adaptnet/embed" : "residual/params";
    Checkpoint no_policy = training;
    no_policy.erase(policy_section);
    refused(no_policy, policy_section, do_export);
    Checkpoint missing = model;
    missing.erase("base/actor/params");
    refused(missing, "base/actor/params", do_check);
    Checkpoint other_method = model;
    other_method.put_string("model/method", method == "adaptnet" ? "ours" : "adaptnet");
    refused(other_method, "model/method", do_check);
    Checkpoint base_kind = model;
    base_kind.put_string("model/kind", kPolicyExportKind);
    refused(base_kind, "model/kind", do_check);
    return model;
  };
  Checkpoint ours_ck, adaptnet_ck;
  ours.save(ours_ck);
  adaptnet.save(adaptnet_ck);
  const Checkpoint ours_model =
      check(ours_ck, [&](const Checkpoint& c) { return stage2_policy_from_checkpoint<adapt::ResidualPolicy<float>>(c, skel); }, "ours");
  (void)check(adaptnet_ck, [&](const Checkpoint& c) { return stage2_policy_from_checkpoint<adapt::AdaptNetPolicy<float>>(c, skel); },
              "adaptnet");
  // the run's history and training time travel with it, with the export's own records
  const ExportProvenance p = export_provenance(ours_model);
  EXPECT_EQ(p.history, "chunk 1 (test)\n");
  EXPECT_GT(p.train_seconds, 0.0);
  EXPECT_EQ(p.train_seconds, ours.train_seconds());
  EXPECT_EQ(p.exported_from, "runs/x/checkpoint.bin");
  EXPECT_EQ(p.export_git_commit, "abc1234");
  EXPECT_EQ(p.note, "unit test");
}

TEST(ResidualConfig, KeepsTheResidualSigmaThroughJsonAndIntoTheNetwork) {
  ResidualTrainConfig c;
  c.residual_std = 0.25;
  const auto back = residual_config_from_json(to_json(c));
  EXPECT_EQ(back.residual_std, 0.25);
  EXPECT_EQ(residual_net_config(back, maskadapt::testing::tiny_walker_skeleton()).init_std, 0.25);
  // a config written before the field existed: the base's σ (0)
  nlohmann::json old = to_json(c);
  old.erase("residual_std");
  EXPECT_EQ(residual_config_from_json(old).residual_std, 0.0);
  c.residual_std = -1;
  try {
    c.validate();
    ADD_FAILURE() << "a negative residual_std was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("residual_std"), std::string::npos) << e.what();
  }
}

TEST(ResidualConfig, ParsesPerPartSigmaItemsAndKeepsThemThroughJsonAndIntoTheNetwork) {
  const auto s = parse_part_std({"arms=0.15", "left_leg,right_leg=0.05"}, "--part-std");
  EXPECT_EQ(s[static_cast<std::size_t>(BodyPart::LeftArm)], 0.15);
  EXPECT_EQ(s[static_cast<std::size_t>(BodyPart::RightArm)], 0.15);
  EXPECT_EQ(s[static_cast<std::size_t>(BodyPart::LeftLeg)], 0.05);
  EXPECT_EQ(s[static_cast<std::size_t>(BodyPart::RightLeg)], 0.05);
  EXPECT_EQ(s[static_cast<std::size_t>(BodyPart::Trunk)], 0.0);  // not given: residual_std
  ResidualTrainConfig c;
  c.residual_part_std = s;
  const nlohmann::json j = to_json(c);
  EXPECT_EQ(j.at("residual_part_std").size(), 4u);  // the parts set only
  EXPECT_EQ(j.at("residual_part_std").at("left_arm"), 0.15);
  const auto back = residual_config_from_json(j);
  EXPECT_EQ(back.residual_part_std, s);
  EXPECT_EQ(residual_net_config(back, maskadapt::testing::tiny_walker_skeleton()).part_std, s);
  nlohmann::json old = j;
  old.erase("residual_part_std");  // written before the field existed: every part at residual_std
  EXPECT_EQ(residual_config_from_json(old).residual_part_std, (std::array<double, kNumParts>{}));
  nlohmann::json unknown = j;
  unknown["residual_part_std"]["tail"] = 0.1;
  expect_error_naming([&] { (void)residual_config_from_json(unknown); }, "residual_part_std", "an unknown part");
  // bad items are refused naming the flag
  for (const std::vector<std::string>& bad :
       {std::vector<std::string>{"arms"}, {"arms="}, {"=0.1"}, {"arms=x"}, {"arms=0.1x"}, {"arms=-0.1"}, {"arms=0"},
        {"arms=nan"}, {"arms=11"}, {"hands=0.1"}, {"arms=0.1", "left_arm=0.2"}}) {
    expect_error_naming([&] { (void)parse_part_std(bad, "--part-std"); }, "--part-std", "a bad --part-std item");
  }
}

TEST(ResidualConfig, ParsesPerPartObjectiveWeightItemsAndRefusesBadOnesNamingTheFlag) {
  const auto w = parse_part_weights({"arms=1,0", "lower_body=0.1,0.9"}, "--part-objective-weights");
  EXPECT_EQ(w[static_cast<std::size_t>(BodyPart::LeftArm)], (std::vector<double>{1.0, 0.0}));
  EXPECT_EQ(w[static_cast<std::size_t>(BodyPart::RightArm)], (std::vector<double>{1.0, 0.0}));
  EXPECT_EQ(w[static_cast<std::size_t>(BodyPart::LeftLeg)], (std::vector<double>{0.1, 0.9}));
  EXPECT_EQ(w[static_cast<std::size_t>(BodyPart::RightLeg)], (std::vector<double>{0.1, 0.9}));
  EXPECT_TRUE(w[static_cast<std::size_t>(BodyPart::Trunk)].empty());  // not given: the run's objective weights
  EXPECT_EQ(part_weights_from_json(part_weights_to_json(w)), w);
  for (const std::vector<std::string>& bad :
       {std::vector<std::string>{"arms"}, {"arms="}, {"=1,0"}, {"arms=1,"}, {",1"}, {"arms=1,x"}, {"arms=1,0x"},
        {"arms=-1,0"}, {"arms=inf,0"}, {"arms=nan,1"}, {"tail=1,0"}, {"arms=1,0", "lower_body=1"},
        {"arms=1,0", "left_arm=0,1"}}) {
    expect_error_naming([&] { (void)parse_part_weights(bad, "--part-objective-weights"); }, "--part-objective-weights",
                        "a bad --part-objective-weights item");
  }
}

TEST(ResidualConfig, KeepsTheLocationDistanceDivergenceAndPositionWeightAndRefusesThemElsewhere) {
  ResidualTrainConfig c;
  c.task = "location";
  c.location_min_distance = 0.5;
  c.location_max_distance = 2.0;
  c.location_divergence = 3.0;
  c.location_position_weight = 0.25;
  const auto back = residual_config_from_json(to_json(c));
  EXPECT_EQ(back.location_position_weight, 0.25);
  EXPECT_EQ(back.location_min_distance, 0.5);
  EXPECT_EQ(back.location_max_distance, 2.0);
  EXPECT_EQ(back.location_divergence, 3.0);
  nlohmann::json old = to_json(c);  // written before the fields existed: 1–5 m, never
  old.erase("location_distance");
  old.erase("location_divergence");
  old.erase("location_position_weight");
  const auto o = residual_config_from_json(old);
  EXPECT_EQ(o.location_position_weight, 0.0);
  EXPECT_EQ(o.location_min_distance, 1.0);
  EXPECT_EQ(o.location_max_distance, 5.0);
  EXPECT_EQ(o.location_divergence, 0.0);
  auto bad = [&](auto edit, const char* field) {
    ResidualTrainConfig b = c;
    edit(b);
    expect_error_naming([&] { b.validate(); }, field, field);
  };
  bad([](ResidualTrainConfig& b) { b.location_min_distance = 0; }, "location_distance");
  bad([](ResidualTrainConfig& b) { b.location_max_distance = 0.4; }, "location_distance");
  bad([](ResidualTrainConfig& b) { b.location_max_distance = std::nan(""); }, "location_distance");
  bad([](ResidualTrainConfig& b) { b.location_divergence = -1; }, "location_divergence");
  bad([](ResidualTrainConfig& b) { b.location_facing_weight = 0.5; b.location_position_weight = 0.6; },
      "location_position_weight");
  bad([](ResidualTrainConfig& b) {
    b.task = "heading";
    b.location_position_weight = 0;
    b.location_min_distance = 1;
    b.location_max_distance = 5;
  }, "location_divergence");
  bad([](ResidualTrainConfig& b) { b.task = "heading"; b.location_position_weight = 0; b.location_divergence = 0; },
      "location_distance");
  bad([](ResidualTrainConfig& b) {
    b.task = "heading";
    b.location_min_distance = 1;
    b.location_max_distance = 5;
    b.location_divergence = 0;
  }, "location_position_weight");
}

TEST(ResidualConfig, KeepsTheTrackingRewardScaleAndRefusesItElsewhere) {
  ResidualTrainConfig c;
  c.task = "tracking";
  c.tracking_reward_scale = 0.25;
  EXPECT_EQ(residual_config_from_json(to_json(c)).tracking_reward_scale, 0.25);
  nlohmann::json old = to_json(c);  // written before the field existed: the paper's reward
  old.erase("tracking_reward_scale");
  EXPECT_EQ(residual_config_from_json(old).tracking_reward_scale, 1.0);
  for (const double k : {0.0, -1.0, 101.0, std::nan("")}) {
    ResidualTrainConfig b = c;
    b.tracking_reward_scale = k;
    expect_error_naming([&] { b.validate(); }, "tracking_reward_scale", "a bad reward scale");
  }
  ResidualTrainConfig loc = c;
  loc.task = "location";
  expect_error_naming([&] { loc.validate(); }, "tracking_reward_scale", "the scale on another task");
}

TEST(ResidualConfig, KeepsTheLocationArriveDistanceAndReachBonusAndRefusesThemElsewhere) {
  ResidualTrainConfig c;
  c.task = "location";
  c.location_arrive_distance = 1.5;
  c.location_reach_bonus = 10;
  const auto back = residual_config_from_json(to_json(c));
  EXPECT_EQ(back.location_arrive_distance, 1.5);
  EXPECT_EQ(back.location_reach_bonus, 10.0);
  nlohmann::json old = to_json(c);  // written before the fields existed: both off
  old.erase("location_arrive_distance");
  old.erase("location_reach_bonus");
  const auto o = residual_config_from_json(old);
  EXPECT_EQ(o.location_arrive_distance, 0.0);
  EXPECT_EQ(o.location_reach_bonus, 0.0);
  auto bad = [&](auto edit, const char* field) {
    ResidualTrainConfig b = c;
    edit(b);
    expect_error_naming([&] { b.validate(); }, field, field);
  };
  bad([](ResidualTrainConfig& b) { b.location_arrive_distance = -1; }, "location_arrive_distance");
  bad([](ResidualTrainConfig& b) { b.location_arrive_distance = std::nan(""); }, "location_arrive_distance");
  bad([](ResidualTrainConfig& b) { b.location_reach_bonus = -1; }, "location_reach_bonus");
  bad([](ResidualTrainConfig& b) { b.location_reach_bonus = std::numeric_limits<double>::infinity(); },
      "location_reach_bonus");
  bad([](ResidualTrainConfig& b) { b.task = "heading"; b.location_reach_bonus = 0; }, "location_arrive_distance");
  bad([](ResidualTrainConfig& b) { b.task = "strike"; b.location_arrive_distance = 0; }, "location_reach_bonus");
}

TEST(ResidualConfig, KeepsTheStrikeTrainingOptionsAndRefusesThemElsewhere) {
  ResidualTrainConfig c;
  c.task = "strike";
  c.strike_min_distance = 0.5;
  c.strike_max_distance = 2.0;
  c.strike_end_on_foreign_contact = true;
  c.strike_next_box_steps = 15;
  c.validate();
  const auto back = residual_config_from_json(to_json(c));
  EXPECT_EQ(back.strike_min_distance, 0.5);
  EXPECT_EQ(back.strike_max_distance, 2.0);
  EXPECT_TRUE(back.strike_end_on_foreign_contact);
  EXPECT_EQ(back.strike_next_box_steps, 15);
  nlohmann::json old = to_json(c);  // written before the fields existed: the paper's setting
  old.erase("strike_distance");
  old.erase("strike_end_on_foreign_contact");
  old.erase("strike_next_box_steps");
  const auto o = residual_config_from_json(old);
  EXPECT_EQ(o.strike_min_distance, 1.0);
  EXPECT_EQ(o.strike_max_distance, 3.0);
  EXPECT_FALSE(o.strike_end_on_foreign_contact);
  EXPECT_EQ(o.strike_next_box_steps, 0);
  nlohmann::json three = to_json(c);
  three["strike_distance"] = {1.0, 2.0, 3.0};
  expect_error_naming([&] { residual_config_from_json(three); }, "strike_distance", "three distances");
  auto bad = [&](auto edit, const char* field) {
    ResidualTrainConfig b = c;
    edit(b);
    expect_error_naming([&] { b.validate(); }, field, field);
  };
  bad([](ResidualTrainConfig& b) { b.strike_min_distance = 0; }, "strike_distance");
  bad([](ResidualTrainConfig& b) { b.strike_min_distance = 2.5; }, "strike_distance");  // above max
  bad([](ResidualTrainConfig& b) { b.strike_max_distance = std::nan(""); }, "strike_distance");
  bad([](ResidualTrainConfig& b) { b.strike_next_box_steps = -1; }, "strike_next_box_steps");
  bad([](ResidualTrainConfig& b) { b.strike_next_box_steps = 100001; }, "strike_next_box_steps");
  bad([](ResidualTrainConfig& b) { b.task = "location"; b.strike_min_distance = 1; b.strike_max_distance = 3;
                                   b.strike_next_box_steps = 0; b.strike_end_on_foreign_contact = false;
                                   b.strike_min_distance = 0.5; }, "strike_distance");
  bad([](ResidualTrainConfig& b) { b.task = "heading"; b.strike_min_distance = 1; b.strike_max_distance = 3;
                                   b.strike_next_box_steps = 0; }, "strike_end_on_foreign_contact");
  bad([](ResidualTrainConfig& b) { b.task = "location"; b.strike_min_distance = 1; b.strike_max_distance = 3;
                                   b.strike_end_on_foreign_contact = false; }, "strike_next_box_steps");
}

TEST(ResidualConfig, KeepsTheBlendResetShareThroughJsonAndRejectsBadValues) {
  ResidualTrainConfig c;
  c.blend_resets = 0.5;
  EXPECT_EQ(residual_config_from_json(to_json(c)).blend_resets, 0.5);
  nlohmann::json old = to_json(c);
  old.erase("blend_resets");  // written before the field existed: every reset from A
  EXPECT_EQ(residual_config_from_json(old).blend_resets, 0.0);
  for (const double bad : {-0.1, 1.5, std::nan("")}) {
    c.blend_resets = bad;
    try {
      c.validate();
      ADD_FAILURE() << "blend_resets " << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("blend_resets"), std::string::npos) << e.what();
    }
  }
  c.blend_resets = 0.5;
  c.task = "location";
  EXPECT_THROW(c.validate(), Error);  // (blends exist for composition only)
}

// RSI from the part-wise blends (train/motion_sources.hpp): share 0 is exactly RSI from A (no
// extra draw); share 1 puts B's joint angles on the adapted parts (lower body: the kick) and A's
// on the rest and the root, at the time the stream draws.
TEST(Composition, ResetsFromBlendsTakeBsPoseOnTheAdaptedParts) {
  const Skeleton& skel = humanoid_skeleton();
  auto a = std::make_shared<MotionLibrary>(skel), b = std::make_shared<MotionLibrary>(skel);
  a->add(synthetic_walk());
  b->add(synthetic_kick());
  const PartMask lower = PartMask::parse("lower_body");
  auto blends = std::make_shared<const tasks::BlendedMotionSet>(*a, *b, std::vector<PartMask>{lower});
  const tasks::ResetSampler from_a = library_reset_sampler(a);
  const tasks::ResetSampler none = blended_reset_sampler(a, blends, 0.0);
  Rng r1(9), r2(9);
  for (int k = 0; k < 20; ++k) {
    const tasks::ResetSample x = from_a(r1), y = none(r2);
    EXPECT_EQ(x.pose.q, y.pose.q);
    EXPECT_EQ(x.pose.root_pos, y.pose.root_pos);
    EXPECT_EQ(x.history, y.history);
  }
  const tasks::ResetSampler all = blended_reset_sampler(a, blends, 1.0);
  Rng rng(10);
  int lower_differs = 0;
  for (int k = 0; k < 40; ++k) {
    Rng probe = rng;  // the time this reset draws: after its Bernoulli and mask draws
    (void)probe.bernoulli(1.0);
    (void)probe.uniform_int(1);
    const ClipTime ct = blends->library(0).sample(probe, true, (kAmpWindowFrames - 1) * kAmpFrameDt);
    const tasks::ResetSample r = all(rng);
    const KinematicState in_a = a->state(0, ct.time), in_b = b->state(0, ct.time);
    EXPECT_EQ(r.pose.root_pos, in_a.root_pos);
    bool differs = false;
    for (int body = 1; body < skel.num_bodies(); ++body) {
      const int o = skel.dof_offset(body), n = skel.num_dofs_of(body);
      const bool adapted = lower.has(skel.parts[static_cast<std::size_t>(body)]);
      if (n == 0 || (adapted && ct.time + 1e-9 >= b->clip(0).duration())) continue;  // (B looped: not compared)
      const VectorXd want = adapted ? in_b.q.segment(o, n) : in_a.q.segment(o, n);
      EXPECT_LT((r.pose.q.segment(o, n) - want).cwiseAbs().maxCoeff(), 1e-9) << "body " << body << " at " << ct.time;
      if (adapted) differs = differs || (r.pose.q.segment(o, n) - in_a.q.segment(o, n)).cwiseAbs().maxCoeff() > 1e-3;
    }
    lower_differs += differs;
  }
  EXPECT_GT(lower_differs, 20) << "the resets' legs are the walk's, not the kick's";
  EXPECT_THROW(blended_reset_sampler(a, blends, 1.5), Error);
  EXPECT_THROW(blended_reset_sampler(a, nullptr, 0.5), Error);
}

TEST(ResidualConfig, KeepsTheTrackingPromptsThroughJson) {
  ResidualTrainConfig c;
  c.task = "tracking";
  c.texts = {"wave right hand", "punch"};
  const auto back = residual_config_from_json(to_json(c));
  EXPECT_EQ(back.texts, c.texts);
  // a config written before the prompts were recorded: none (the generator's arms pool is used)
  nlohmann::json old = to_json(c);
  old.erase("texts");
  EXPECT_TRUE(residual_config_from_json(old).texts.empty());
  old["texts"] = 3;
  EXPECT_THROW(residual_config_from_json(old, "run.bin"), Error);
}

// Held exploration noise (ResidualTrainConfig::noise_hold_steps = k): within one episode and one
// mask every env's deviation a − μ̂ is a single draw kept for k steps, then drawn afresh; the
// recorded log-probability is the masked Gaussian density of the held action under that step's
// own mean (computed here by hand); and a run resumed in the middle of a hold continues bit-exactly.
TEST(ResidualTrainer, HeldNoiseKeepsOneDeviationForKStepsAndResumesMidHold) {
  MASKADAPT_REQUIRE_REQUESTED_BLAS_CORE();
  Data d;
  const auto fall = [](const Skeleton& s) { return FallCriteria::for_skeleton(s, {"l_leg", "r_leg"}, "head", 0.8); };
  constexpr int k = 3;
  ResidualTrainConfig cfg = tiny_config("location", "ours");
  cfg.noise_hold_steps = k;
  auto make = [&](TinyWalkerSim& sim) {
    ResidualSetup<TinyWalkerSim> setup = composition_setup(d, "ours", observation_parts(sim.skeleton()));
    tasks::LocationConfig lc;
    lc.schedule = {3, 5};
    lc.seed = 11;
    setup.goal = tasks::LocationTask(lc, 4);
    return std::make_unique<ResidualTrainer<TinyWalkerSim>>(sim, upright(sim.skeleton()), tiny_base(sim.skeleton()),
                                                            std::move(setup), cfg, nullptr, fall(sim.skeleton()));
  };
  TinyWalkerSim sim(4);
  auto run = make(sim);
  // the policy that collects the first rollout: its residual output is exactly 0, so its mean is
  // the base's whatever the input normaliser learns while collecting
  const adapt::ResidualPolicy<float> collecting = run->policy();
  run->iterate();  // (every counter starts at 0: the first step of each env draws)
  const auto& buf = run->rollout();
  const Index N = 4, H = cfg.rl.ppo.horizon, A = collecting.action_dim();
  MatrixXf mu;
  adapt::ResidualWorkspace<float> ws;
  collecting.mean(buf.policy_input, buf.masks, mu, ws);
  MatrixXf log_std;
  collecting.log_std(buf.masks, log_std);
  const double half_log_2pi = 0.5 * std::log(2.0 * M_PI);
  int fresh_after_k = 0, held = 0;
  for (Index e = 0; e < N; ++e) {
    VectorXf start_dev;
    int run_length = 0;
    for (Index t = 0; t < H; ++t) {
      const Index c = t * N + e;
      const VectorXf dev = buf.actions.col(c) - mu.col(c);
      // log-probability: Σ over the masked DoFs of the Gaussian log-density, by hand
      const VectorXf sel = adapt::dof_selector<float>(collecting.dof_parts(), buf.masks[static_cast<std::size_t>(c)]);
      double lp = 0;
      for (Index i = 0; i < A; ++i)
        if (sel[i] != 0) {
          const double z = dev[i] / std::exp(static_cast<double>(log_std(i, c)));
          lp += -0.5 * z * z - log_std(i, c) - half_log_2pi;
        }
      EXPECT_NEAR(buf.log_probs[c], lp, 1e-3 * (1 + std::abs(lp))) << "env " << e << " step " << t;
      const bool boundary = t == 0 || buf.terminated[static_cast<std::size_t>(c - N)] || buf.truncated[static_cast<std::size_t>(c - N)] ||
                            buf.masks[static_cast<std::size_t>(c)].bits != buf.masks[static_cast<std::size_t>(c - N)].bits;
      if (boundary || run_length == k) {
        if (!boundary) {  // the hold ran out: a fresh draw, not the old deviation
          EXPECT_GT((dev - start_dev).norm(), 1e-3) << "env " << e << " step " << t;
          ++fresh_after_k;
        }
        start_dev = dev;
        run_length = 1;
      } else {
        EXPECT_LT((dev - start_dev).norm(), 1e-4) << "env " << e << " step " << t << ": the deviation was not held";
        ++run_length;
        ++held;
      }
    }
  }
  EXPECT_GT(fresh_after_k, 0) << "no hold ran out inside the rollout; the test would not see a redraw";
  EXPECT_GT(held, 0);

  // resumed after 2 iterations of 8 steps: 16 = 5·3 + 1, every env mid-hold unless an episode ended
  auto resumed_run = run_and_resume(make);
  ASSERT_TRUE(resumed_run.at_split.contains("state/noise_hold/deviation"));
  for (int i = 2; i < 4; ++i) {
    const IterationStats& st = resumed_run.resumed_stats[static_cast<std::size_t>(i - 2)];
    EXPECT_EQ(st.policy_loss, resumed_run.straight_stats[static_cast<std::size_t>(i)].policy_loss) << "iteration " << i + 1;
    EXPECT_EQ(st.extra, resumed_run.straight_stats[static_cast<std::size_t>(i)].extra) << "iteration " << i + 1;
  }
  EXPECT_TRUE(same_bits(VectorXf(resumed_run.resumed->policy().residual().mean_net.params()),
                        VectorXf(resumed_run.straight->policy().residual().mean_net.params())));

  // a checkpoint without the held noise is refused by a run that holds noise, naming the section
  Checkpoint ck = resumed_run.at_split;
  ck.erase("state/noise_hold/deviation");
  TinyWalkerSim sim_d(4);
  auto broken = make(sim_d);
  expect_error_naming([&] { broken->load(ck); }, "noise_hold", "a checkpoint without state/noise_hold/deviation");
}

TEST(ResidualConfig, KeepsTheNoiseHoldAndObjectiveWeightsThroughJsonAndRejectsBadValues) {
  ResidualTrainConfig c = tiny_config("location", "ours");
  c.noise_hold_steps = 6;
  c.objective_weights = {0.2, 0.8};
  const ResidualTrainConfig back = residual_config_from_json(to_json(c));
  EXPECT_EQ(back.noise_hold_steps, 6);
  EXPECT_EQ(back.objective_weights, (std::vector<double>{0.2, 0.8}));
  nlohmann::json old = to_json(c);
  old.erase("noise_hold_steps");  // a checkpoint from before the option: fresh noise every step
  EXPECT_EQ(residual_config_from_json(old).noise_hold_steps, 1);
  for (const int bad : {0, -3}) {
    ResidualTrainConfig b = c;
    b.noise_hold_steps = bad;
    expect_error_naming([&] { b.validate(); }, "noise_hold_steps", "noise_hold_steps " + std::to_string(bad));
  }
  ResidualTrainConfig f = c;  // the facing shaping: kept, absent = the paper's reward, location only
  f.location_facing_weight = 0.3;
  EXPECT_EQ(residual_config_from_json(to_json(f)).location_facing_weight, 0.3);
  EXPECT_EQ(residual_config_from_json(old).location_facing_weight, 0.0);
  f.location_facing_weight = 1.2;
  EXPECT_THROW(f.validate(), Error);
  f.location_facing_weight = 0.3;
  f.task = "heading";
  expect_error_naming([&] { f.validate(); }, "location_facing_weight", "a facing weight on the heading task");
  ResidualTrainConfig sa = c;  // the strike's approach shaping: kept, absent = the paper's, strike only
  sa.task = "strike";
  sa.strike_approach_weight = 0.4;
  EXPECT_EQ(residual_config_from_json(to_json(sa)).strike_approach_weight, 0.4);
  EXPECT_EQ(residual_config_from_json(old).strike_approach_weight, 0.0);
  sa.task = "location";
  EXPECT_THROW(sa.validate(), Error);
  ResidualTrainConfig w = c;
  w.objective_weights = {0.5, -1.0};
  EXPECT_THROW(w.validate(), Error);
  w.objective_weights = {0.5, std::nan("")};
  EXPECT_THROW(w.validate(), Error);
}
