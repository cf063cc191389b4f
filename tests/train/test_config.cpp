#include <maskadapt/train/config.hpp>
#include <maskadapt/train/goal_recipe.hpp>

#include "../build_paths.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

using namespace maskadapt;
using namespace maskadapt::train;

namespace {
// Returns the Error's field (and checks that it names the file), or "" if nothing was thrown.
std::string error_field(const std::string& text, const std::string& file = "cfg.json") {
  try {
    config_from_string(text, file);
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, file) << e.what();
    return e.context().field;
  }
  return "";
}
}  // namespace

TEST(TrainConfig, PresetsCarryThePaperValues) {
  const auto p = paper_preset();
  EXPECT_EQ(p.net.actor_hidden, (std::vector<Index>{1024, 1024, 512}));
  EXPECT_EQ(p.net.critic_hidden, (std::vector<Index>{1024, 1024, 512}));
  EXPECT_DOUBLE_EQ(p.ppo.actor_lr, 1e-5);
  EXPECT_DOUBLE_EQ(p.ppo.critic_lr, 1e-4);
  EXPECT_DOUBLE_EQ(p.disc.lr, 1e-4);
  EXPECT_EQ(p.ppo.horizon, 32);
  EXPECT_DOUBLE_EQ(p.ppo.gamma, 0.99);
  EXPECT_DOUBLE_EQ(p.ppo.gae_lambda, 0.95);
  EXPECT_DOUBLE_EQ(p.ppo.clip, 0.2);
  EXPECT_DOUBLE_EQ(p.ppo.critic_weight, 5.0);
  EXPECT_DOUBLE_EQ(p.disc.gradient_penalty, 5.0);
  EXPECT_DOUBLE_EQ(p.mask.lambda_mi, 1.0);
  EXPECT_DOUBLE_EQ(p.mask.prob, 0.8);
  EXPECT_EQ(p.mask.max_parts, 3);
  EXPECT_EQ(p.env.num_envs, 4096);
  const auto c = cpu_preset();
  EXPECT_EQ(c.net.actor_hidden, (std::vector<Index>{256, 256}));
  EXPECT_EQ(c.env.num_envs, 32);
  EXPECT_NO_THROW(p.validate());
  EXPECT_NO_THROW(c.validate());
  EXPECT_THROW(preset("gpu"), Error);
}

// The cpu preset is the recipe that walked (docs/results.md, issue 14); the struct's defaults and
// the paper preset keep the paper's formulation; "custom" starts from the cpu values.
TEST(TrainConfig, CpuPresetIsTheWalkingRecipe) {
  const auto c = cpu_preset();
  EXPECT_DOUBLE_EQ(c.mask.lambda_mi, 0.3);
  EXPECT_EQ(c.mask.mi_gradient, "target_ema");
  EXPECT_DOUBLE_EQ(c.mask.mi_target_tau, 0.001);
  EXPECT_EQ(c.mask.warmup_samples, 3000000);
  EXPECT_EQ(c.mask.ramp_samples, 1000000);
  EXPECT_EQ(c.mask.hidden_value, "mean");
  EXPECT_EQ(c.net.action_offset, "mean_pose");
  EXPECT_EQ(c.net.action_scale, "half_range");
  EXPECT_EQ(c.ppo.actor_lr_schedule, "adaptive");
  EXPECT_EQ(c.run.iterations, 7800);
  const auto p = paper_preset();
  EXPECT_DOUBLE_EQ(p.mask.lambda_mi, 1.0);
  EXPECT_EQ(p.mask.warmup_samples, 0);
  EXPECT_EQ(p.mask.hidden_value, "zero");
  EXPECT_EQ(p.net.action_offset, "zero");
  EXPECT_EQ(p.ppo.actor_lr_schedule, "fixed");
  auto custom = config_from_string(R"({"preset": "custom"})");
  EXPECT_EQ(custom.preset, "custom");
  custom.preset = "cpu";
  EXPECT_EQ(to_json(custom), to_json(c));
}

TEST(TrainConfig, JsonRoundTripPreservesEveryField) {
  BaseTrainConfig c = paper_preset();
  c.run.seed = 1234567890123ULL;
  c.run.minutes = 2.5;
  c.env.motions = {"locomotion", "/tmp/x.bvh"};
  c.mask.enabled = false;
  c.mask.lambda_mi = 0.1;
  c.net.activation = "elu";
  c.ppo.minibatch_size = 77;
  c.disc.lsgan = true;
  c.disc.window_frames = 2;
  c.ppo.actor_lr_schedule = "adaptive";
  c.ppo.adaptive_lr.desired_kl = 0.02;
  c.ppo.adaptive_lr.max_lr = 3e-3;
  const auto j = to_json(c);
  const auto back = config_from_json(j);
  EXPECT_EQ(to_json(back), j);
  EXPECT_EQ(back.ppo.actor_lr_schedule, "adaptive");
  EXPECT_EQ(back.ppo.adaptive_lr.desired_kl, 0.02);
  EXPECT_EQ(back.ppo.adaptive_lr.max_lr, 3e-3);
  EXPECT_EQ(back.run.seed, c.run.seed);
  EXPECT_EQ(back.env.motions, c.env.motions);
  EXPECT_FALSE(back.mask.enabled);
  EXPECT_TRUE(back.disc.lsgan);
  EXPECT_EQ(back.disc.window_frames, 2);

  const auto path = (std::filesystem::temp_directory_path() / "maskadapt_cfg_roundtrip.json").string();
  save_config(c, path);
  EXPECT_EQ(to_json(load_config(path)), j);
  std::filesystem::remove(path);
}

TEST(TrainConfig, MissingFieldsComeFromTheNamedPreset) {
  const auto c = config_from_string(R"({"preset": "paper", "ppo": {"actor_lr": 3e-5}})");
  EXPECT_EQ(c.net.actor_hidden, (std::vector<Index>{1024, 1024, 512}));
  EXPECT_DOUBLE_EQ(c.ppo.actor_lr, 3e-5);
  EXPECT_DOUBLE_EQ(c.ppo.critic_lr, 1e-4);
  const auto d = config_from_string("{}");
  EXPECT_EQ(to_json(d), to_json(cpu_preset()));
}

// disc.window_frames came after checkpoints that hold configs without it: those discriminators saw
// the whole 5-frame window, so an absent field means 5 whatever the preset says.
TEST(TrainConfig, AbsentDiscriminatorWindowMeansTheFiveFramesOfEarlierRuns) {
  for (const char* preset : {"cpu", "paper"}) {
    const auto c = config_from_string(std::string(R"({"preset": ")") + preset + R"(", "disc": {"lr": 2e-4}})");
    EXPECT_EQ(c.disc.window_frames, 5) << preset;
    EXPECT_EQ(config_from_string(std::string(R"({"preset": ")") + preset + R"("})").disc.window_frames, 5) << preset;
  }
  EXPECT_EQ(config_from_string(R"({"disc": {"window_frames": 2}})").disc.window_frames, 2);
}

TEST(TrainConfig, ErrorsNameTheFieldAndFile) {
  EXPECT_EQ(error_field(R"({"ppo": {"actor_lr": "fast"}})"), "ppo.actor_lr");
  EXPECT_EQ(error_field(R"({"ppo": {"actro_lr": 1e-5}})"), "ppo.actro_lr");  // unknown key
  EXPECT_EQ(error_field(R"({"bogus": 1})"), "bogus");
  EXPECT_EQ(error_field(R"({"env": {"num_envs": 0}})"), "env.num_envs");
  EXPECT_EQ(error_field(R"({"env": {"num_envs": 1.5}})"), "env.num_envs");
  EXPECT_EQ(error_field(R"({"env": {"num_envs": -3000000000}})"), "env.num_envs");
  EXPECT_EQ(error_field(R"({"env": {"motions": ["a", 3]}})"), "env.motions[1]");
  EXPECT_EQ(error_field(R"({"mask": {"prob": 1.5}})"), "mask.prob");
  EXPECT_EQ(error_field(R"({"mask": {"enabled": 1}})"), "mask.enabled");
  EXPECT_EQ(error_field(R"({"net": {"actor_hidden": [256, 0]}})"), "net.actor_hidden");
  EXPECT_EQ(error_field(R"({"net": {"activation": "gelu"}})"), "net.activation");
  EXPECT_EQ(error_field(R"({"preset": "gpu"})"), "preset");
  EXPECT_EQ(error_field(R"({"run": 5})"), "run");
  EXPECT_EQ(error_field(R"({"run": {"iterations": 0, "minutes": 0}})"), "run.iterations");
  EXPECT_EQ(error_field(R"({"ppo": {"actor_lr_schedule": "cosine"}})"), "ppo.actor_lr_schedule");
  EXPECT_EQ(error_field(R"({"ppo": {"adaptive_lr": {"factor": 1.0}}})"), "ppo.adaptive_lr.factor");
  EXPECT_EQ(error_field(R"({"ppo": {"adaptive_lr": {"min_lr": 1e-3, "max_lr": 1e-4}}})"), "ppo.adaptive_lr.max_lr");
  EXPECT_EQ(error_field(R"({"net": {"action_offset": "median"}})"), "net.action_offset");
  EXPECT_EQ(error_field(R"({"net": {"action_scale_rad": [1.0, -1.0]}})"), "net.action_scale_rad");
  EXPECT_EQ(error_field(R"({"disc": {"window_frames": 0}})"), "disc.window_frames");
  EXPECT_EQ(error_field(R"({"disc": {"window_frames": 6}})"), "disc.window_frames");
  EXPECT_EQ(error_field(R"({"ppo": {"horizon": 32}})"), "");  // valid: nothing thrown
}

// The masking curriculum's probability in closed form: 0 before the warm-up, a linear ramp, then p.
TEST(TrainConfig, MaskProbabilityFollowsTheWarmupAndRamp) {
  MaskConfig m;
  m.prob = 0.8;
  EXPECT_EQ(mask_prob_at(m, 0), 0.8);  // no curriculum: p from the start
  m.warmup_samples = 1000;
  EXPECT_EQ(mask_prob_at(m, 999), 0.0);
  EXPECT_EQ(mask_prob_at(m, 1000), 0.8);  // ramp 0: at once
  m.ramp_samples = 400;
  EXPECT_EQ(mask_prob_at(m, 1000), 0.0);
  EXPECT_DOUBLE_EQ(mask_prob_at(m, 1100), 0.2);
  EXPECT_DOUBLE_EQ(mask_prob_at(m, 1300), 0.6);
  EXPECT_EQ(mask_prob_at(m, 1400), 0.8);
  EXPECT_EQ(mask_prob_at(m, 1 << 30), 0.8);
  BaseTrainConfig c;
  c.mask = m;
  const auto back = config_from_json(to_json(c));
  EXPECT_EQ(back.mask.warmup_samples, 1000);
  EXPECT_EQ(back.mask.ramp_samples, 400);
  EXPECT_EQ(error_field(R"({"mask": {"warmup_samples": -1}})"), "mask.warmup_samples");
  EXPECT_EQ(error_field(R"({"mask": {"ramp_samples": 1.5}})"), "mask.ramp_samples");
  EXPECT_EQ(error_field(R"({"mask": {"hidden_value": "median"}})"), "mask.hidden_value");
  EXPECT_EQ(error_field(R"({"mask": {"mi_gradient": "frozen"}})"), "mask.mi_gradient");
  EXPECT_EQ(error_field(R"({"mask": {"mi_gradient": "target_frozen", "hidden_value": "mean"}})"), "");
  c.mask.hidden_value = "mean";
  EXPECT_EQ(config_from_json(to_json(c)).mask.hidden_value, "mean");
  EXPECT_EQ(error_field(R"({"mask": {"mi_gradient": "target_ema", "mi_target_tau": 0.05}})"), "");
  EXPECT_EQ(error_field(R"({"mask": {"mi_target_tau": 0}})"), "mask.mi_target_tau");
  EXPECT_EQ(error_field(R"({"mask": {"mi_target_tau": 1.5}})"), "mask.mi_target_tau");
  EXPECT_EQ(error_field(R"({"mask": {"mi_target_tau": "fast"}})"), "mask.mi_target_tau");
  c.mask.mi_gradient = "target_ema";
  c.mask.mi_target_tau = 0.03;
  EXPECT_EQ(config_from_json(to_json(c)).mask.mi_gradient, "target_ema");
  EXPECT_EQ(config_from_json(to_json(c)).mask.mi_target_tau, 0.03);
}

TEST(TrainConfig, SyntaxErrorsGiveTheLine) {
  try {
    config_from_string("{\n  \"ppo\": {\n    \"clip\": 0.2,,\n  }\n}", "bad.json");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, "bad.json");
    ASSERT_TRUE(e.context().line.has_value());
    EXPECT_EQ(*e.context().line, 3);
  }
  EXPECT_THROW(load_config("/nonexistent/dir/cfg.json"), Error);
}

TEST(TrainConfig, ShippedConfigsParse) {
  const std::filesystem::path dir = std::filesystem::path(maskadapt::build_paths::source_dir()) / "configs";
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().extension() != ".json") continue;
    SCOPED_TRACE(e.path().string());
    EXPECT_NO_THROW(load_config(e.path().string()));
    ++n;
  }
  EXPECT_GE(n, 2);
}

// The goal tasks' rewards per preset (train/goal_recipe.hpp): the recipe weighs the goal 0.9 and the
// discriminators 0.1 together, with the facing term on location and, on strike only, the approach,
// a new box 15 steps after a tilt and the end of an episode at a foreign first contact;
// the paper's formulation is ours' composition 1, every other discriminator 0.5 and the goal 0.5,
// with no shaping. One weight per objective: the discriminators, then the goal.
TEST(GoalRecipe, PresetsGiveTheRecipeOrThePapersGoalRewards) {
  const GoalRewards loc = goal_rewards("cpu", "location", "ours", true);
  EXPECT_EQ(loc.objective_weights, (std::vector<double>{0.1, 0.9}));
  EXPECT_EQ(loc.location_facing_weight, 0.5);
  EXPECT_EQ(loc.strike_approach_weight, 0.0);
  const GoalRewards strike_cml = goal_rewards("cpu", "strike", "cml", true);
  EXPECT_EQ(strike_cml.objective_weights, (std::vector<double>{0.05, 0.05, 0.9}));
  EXPECT_EQ(strike_cml.location_facing_weight, 0.0);
  EXPECT_EQ(strike_cml.strike_approach_weight, 0.4);
  EXPECT_TRUE(strike_cml.strike_end_on_foreign_contact);
  EXPECT_EQ(strike_cml.strike_next_box_steps, 15);
  EXPECT_FALSE(loc.strike_end_on_foreign_contact);
  EXPECT_EQ(loc.strike_next_box_steps, 0);
  const GoalRewards heading_adaptnet = goal_rewards("cpu", "heading", "adaptnet", false);  // imitating A only
  EXPECT_EQ(heading_adaptnet.objective_weights, (std::vector<double>{0.1, 0.9}));
  EXPECT_EQ(heading_adaptnet.location_facing_weight + heading_adaptnet.strike_approach_weight, 0.0);

  EXPECT_EQ(goal_rewards("paper", "location", "ours", true).objective_weights, (std::vector<double>{1.0, 0.5}));
  EXPECT_EQ(goal_rewards("paper", "heading", "ours", false).objective_weights, (std::vector<double>{0.5, 0.5}));
  const GoalRewards paper_cml = goal_rewards("paper", "strike", "cml", true);
  EXPECT_EQ(paper_cml.objective_weights, (std::vector<double>{0.5, 0.5, 0.5}));
  EXPECT_EQ(paper_cml.strike_approach_weight, 0.0);
  EXPECT_FALSE(paper_cml.strike_end_on_foreign_contact);
  EXPECT_EQ(paper_cml.strike_next_box_steps, 0);
  EXPECT_EQ(goal_rewards("paper", "location", "ours", true).location_facing_weight, 0.0);

  const TrackingRecipe tracking = tracking_recipe("cpu");  // partial tracking: the goal weight and σ 0.5 on the designated parts
  EXPECT_EQ(tracking.objective_weights, (std::vector<double>{0.1, 0.9}));
  EXPECT_EQ(tracking.designated_std, 0.5);
  EXPECT_EQ(tracking.reward_scale, 2.0);  // exp(−2·Σ angle²), ended where the paper's exp(−Σ angle²) < 0.05 ends it:
  EXPECT_NEAR(-std::log(tracking.term_threshold) / tracking.reward_scale, -std::log(0.05), 1e-12);
  EXPECT_EQ(tracking_recipe("paper").reward_scale, 1.0);
  EXPECT_EQ(tracking_recipe("paper").term_threshold, 0.05);
  EXPECT_TRUE(tracking_recipe("paper").objective_weights.empty());  // the paper's 0.5 / 0.5
  EXPECT_EQ(tracking_recipe("paper").designated_std, 0.0);            // the base's σ
  try {
    (void)tracking_recipe("gpu");
    ADD_FAILURE() << "an unknown preset was accepted for tracking";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "--preset");
  }

  EXPECT_EQ(goal_task_discriminators("ours", true), 1u);
  EXPECT_EQ(goal_task_discriminators("adaptnet", true), 2u);
  EXPECT_EQ(goal_task_discriminators("cml", false), 1u);
  try {
    (void)goal_rewards("gpu", "location", "ours", true);
    ADD_FAILURE() << "an unknown preset was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "--preset");
  }
  try {
    (void)goal_rewards("cpu", "composition", "ours", true);
    ADD_FAILURE() << "a task that is not a goal task was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "--task");
  }
}
