// The models committed under models/ (models/README.md): each loads through the public API with
// its checksum verified, is a policy-only export of the reference humanoid's dims, says how it was
// trained, and its actor gives finite actions. CI never retrains them; this catches a model file
// that was replaced, truncated or written by an incompatible format.
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/mask/apply.hpp>
#include <maskadapt/motion/amp_window.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/policy_export.hpp>
#include <maskadapt/train/residual_export.hpp>
#include <maskadapt/train/stage2_policy.hpp>

#include "../build_paths.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

using namespace maskadapt;
using namespace maskadapt::train;

TEST(ShippedModels, AmpWalkBandaiLoadsWithItsDimsAndProvenance) {
  const std::string path = maskadapt::build_paths::source_dir() + "/models/amp_walk_bandai.bin";
  const Checkpoint c = load_checkpoint(path);
  ASSERT_TRUE(is_policy_export(c));
  const ModelDims d = check_policy_export(c, ModelDims{kObservationDim, policy_input_dim(kObservationDim), 63}, path);
  EXPECT_EQ(d.action_dim, 63);
  EXPECT_EQ(c.get_int("trainer/iteration"), 5400);
  EXPECT_EQ(c.get_int("trainer/samples"), 5400LL * 1024);
  const ExportProvenance p = export_provenance(c);
  EXPECT_NE(p.note.find("train-base --preset cpu --motions bandai-walk"), std::string::npos) << p.note;
  EXPECT_EQ(p.export_git_commit.size(), 7u);

  const LoadedBasePolicy base =
      load_base_policy(c, {kObservationDim, policy_input_dim(kObservationDim), 63, kObservationDim * kAmpWindowFrames}, path);
  EXPECT_TRUE(base.policy_only);
  EXPECT_EQ(base.config.env.motions, std::vector<std::string>{"bandai-walk"});
  EXPECT_EQ(base.config.net.action_offset, "mean_pose");
  EXPECT_EQ(base.policy.actions.offset.size(), 63);  // normalised actions: offset + scale ⊙ a
  EXPECT_EQ(base.policy.actions.scale.size(), 63);
  // the actor on its own normaliser's mean input (the average state, null mask): finite actions
  MatrixXf x = MatrixXf::Zero(policy_input_dim(kObservationDim), 1);
  x.topRows(kObservationDim) = base.policy.ac.actor.normalizer.mean().head(kObservationDim).cast<float>();
  MatrixXf mu(63, 1), scratch;
  nn::InferenceWorkspace<float> ws;
  base.policy.ac.actor.mean(x, mu, ws, scratch);
  EXPECT_TRUE(mu.allFinite());
}

// The mask-invariant base (issue 14): the same checks, plus what makes it one — it was trained with
// masking and the MI loss (target_ema), its actor hides masked parts at their mean, and its
// provenance records the AMP phase and the masked continuation.
TEST(ShippedModels, MaskMiWalkBandaiLoadsWithItsDimsAndProvenance) {
  const std::string path = maskadapt::build_paths::source_dir() + "/models/mask_mi_walk_bandai.bin";
  const Checkpoint c = load_checkpoint(path);
  ASSERT_TRUE(is_policy_export(c));
  check_policy_export(c, ModelDims{kObservationDim, policy_input_dim(kObservationDim), 63}, path);
  EXPECT_EQ(c.get_int("trainer/iteration"), 6900);
  EXPECT_EQ(c.get_int("trainer/samples"), 6900LL * 1024);
  const ExportProvenance p = export_provenance(c);
  EXPECT_NE(p.note.find("lambda_MI 0.3"), std::string::npos) << p.note;
  const LoadedBasePolicy base =
      load_base_policy(c, {kObservationDim, policy_input_dim(kObservationDim), 63, kObservationDim * kAmpWindowFrames}, path);
  EXPECT_TRUE(base.config.mask.enabled);
  EXPECT_EQ(base.config.mask.lambda_mi, 0.3);
  EXPECT_EQ(base.config.mask.mi_gradient, "target_ema");
  EXPECT_EQ(base.config.mask.mi_target_tau, 0.001);
  EXPECT_EQ(base.config.mask.hidden_value, "mean");
  EXPECT_EQ(base.policy.ac.actor.hidden_groups.size(), static_cast<std::size_t>(kObservationDim));
  // with both legs masked the actor's input differs from the unmasked one, and its actions are finite
  const PartMask legs = PartMask::parse("left_leg,right_leg");
  const MatrixXf obs = base.policy.ac.actor.normalizer.mean().head(kObservationDim).cast<float>();
  const PartElements parts(observation_parts(humanoid_skeleton()));
  const std::vector<PartMask> none_mask{PartMask::none()}, legs_mask{legs};
  const MatrixXf x_none = policy_input<float>(parts, obs, none_mask);
  const MatrixXf x_legs = policy_input<float>(parts, obs, legs_mask);
  MatrixXf mu_none(63, 1), mu_legs(63, 1), scratch;
  nn::InferenceWorkspace<float> ws;
  base.policy.ac.actor.mean(x_none, mu_none, ws, scratch);
  base.policy.ac.actor.mean(x_legs, mu_legs, ws, scratch);
  EXPECT_TRUE(mu_none.allFinite() && mu_legs.allFinite());
  EXPECT_NE(x_none, x_legs);
}


// The three Table 1 bases (models/README.md, docs/results.md): the same run continued to iteration
// 8,100 as AMP (mask probability 0), masking without MI and masking with MI; each says so in its
// config and provenance.
TEST(ShippedModels, Table1BasesLoadAsTheVariantsTheyClaimToBe) {
  struct Expected {
    const char* file;
    double mask_prob;
    double lambda_mi;
    const char* note;
    std::uint64_t seed;
  };
  for (const Expected& e : {Expected{"amp_s1.bin", 0.0, 0.0, "Table 1 AMP base", 1},
                            Expected{"mask_no_mi_s1.bin", 0.8, 0.0, "Table 1 masking without MI", 1},
                            Expected{"mask_mi03_s1.bin", 0.8, 0.3, "Table 1 masking with MI", 1},
                            Expected{"amp_s2.bin", 0.0, 0.0, "Table 1 AMP base, seed 2", 2},
                            Expected{"mask_no_mi_s2.bin", 0.8, 0.0, "Table 1 masking without MI, seed 2", 2},
                            Expected{"mask_mi1_s1.bin", 0.8, 1.0, "Table 1 masking with MI, lambda 1", 1}}) {
    const std::string path = maskadapt::build_paths::source_dir() + "/models/table1/" + e.file;
    const Checkpoint c = load_checkpoint(path);
    ASSERT_TRUE(is_policy_export(c)) << path;
    EXPECT_EQ(c.get_int("trainer/iteration"), 8100) << path;
    EXPECT_EQ(c.get_int("trainer/samples"), 8100LL * 1024) << path;
    EXPECT_NE(export_provenance(c).note.find(e.note), std::string::npos) << path;
    const LoadedBasePolicy base =
        load_base_policy(c, {kObservationDim, policy_input_dim(kObservationDim), 63, kObservationDim * kAmpWindowFrames}, path);
    EXPECT_EQ(base.config.env.motions, std::vector<std::string>{"bandai-walk"}) << path;
    EXPECT_EQ(base.config.mask.prob, e.mask_prob) << path;
    EXPECT_EQ(base.config.mask.lambda_mi, e.lambda_mi) << path;
    EXPECT_EQ(base.config.mask.hidden_value, "mean") << path;
    EXPECT_EQ(base.config.run.seed, e.seed) << path;
  }
}

// Bit-identical actor parameters: a stage-2 model's frozen base against the base model it names
// (loaded once by the caller, not once per stage-2 file).
bool same_base(const Checkpoint& stage2, const Checkpoint& base_model) {
  return stage2.section("base/actor/params").data == base_model.section("actor/params").data;
}

// The Table 2 policies (issue 15, models/table2/): a new motion composed onto one part of the
// Table 1 MI base by ours and by the CML-style baseline, two seeds per cell (eight for (b), three for
// the cut kick) — case (a) the kick on the legs, the same with B cut down to the kick and half the
// resets from its blends (`--blend-resets 0.5`), and (c) the sneaky walk on the legs (the residual
// explores with the base's σ), (b) the swim on the arms (with σ 0.15, `--residual-std 0.15`). Each is
// what its name says, on that base, with the σ and reset share it was trained with.
TEST(ShippedModels, Table2PoliciesAreTheCellsTheyClaimToBe) {
  struct Case {
    const char *file, *motion, *mask;
    double residual_std;  // 0: the base's σ
    int seeds;            // s1 … s<seeds>
    double blend_resets = 0.0;
  };
  const Skeleton& skel = humanoid_skeleton();
  const Checkpoint base = load_checkpoint(maskadapt::build_paths::source_dir() + "/models/table1/mask_mi03_s1.bin");
  for (const Case& k : {Case{"kick", "kick.bvh", "lower_body", 0.0, 2}, Case{"kick_cut", "kick_cut.npz", "lower_body", 0.0, 3, 0.5},
                        Case{"swim", "swim", "arms", 0.15, 8}, Case{"sneak", "SNEAKY", "lower_body", 0.0, 2}})
    for (const char* method : {"ours", "cml"})
      for (int seed = 1; seed <= k.seeds; ++seed) {
        const std::string path = maskadapt::build_paths::source_dir() + "/models/table2/" + k.file + "_" + method + "_s" +
                                 std::to_string(seed) + ".bin";
        const Checkpoint c = load_checkpoint(path);
        const ResidualTrainConfig cfg = check_residual_export(c, path);
        EXPECT_EQ(cfg.task, "composition") << path;
        EXPECT_EQ(cfg.method, method) << path;
        EXPECT_EQ(cfg.masks, std::vector<std::string>{k.mask}) << path;
        ASSERT_EQ(cfg.new_motions.size(), 1u) << path;
        EXPECT_NE(cfg.new_motions[0].find(k.motion), std::string::npos) << path;
        EXPECT_EQ(cfg.rl.run.seed, static_cast<std::uint64_t>(seed)) << path;
        EXPECT_EQ(c.get_int("trainer/iteration"), 1000) << path;
        EXPECT_EQ(cfg.residual_std, k.residual_std) << path;
        EXPECT_EQ(cfg.blend_resets, k.blend_resets) << path;
        EXPECT_TRUE(same_base(c, base)) << path;
        const auto pol = stage2_policy_from_checkpoint<adapt::ResidualPolicy<float>>(c, skel);
        // The residual explores with the σ it was trained with: the asked one, else the base's.
        VectorXf want(pol.residual().log_std.params().size());
        if (k.residual_std > 0) want.setConstant(float(std::log(k.residual_std)));
        else base.copy_to<float>("actor/log_std", want);
        EXPECT_EQ(pol.residual().log_std.params(), want) << path;
        MatrixXf x = MatrixXf::Zero(pol.input_dim(), 1), mu;
        adapt::ResidualWorkspace<float> ws;
        pol.mean(x, std::vector<PartMask>{PartMask::parse(k.mask)}, mu, ws);
        EXPECT_TRUE(mu.allFinite()) << path;
      }
}

// The Table 3 policies (issue 16, models/table3/): each is the stage-2 export of the cell it is
// named after — its task, its method, 1,500 iterations, a frozen base that is bit for bit the
// shipped walking base's actor — and builds on the reference humanoid with finite mean actions.
TEST(ShippedModels, Table3PoliciesAreTheCellsTheyClaimToBeOnTheShippedBase) {
  const Skeleton& skel = humanoid_skeleton();
  const Checkpoint walker = load_checkpoint(maskadapt::build_paths::source_dir() + "/models/mask_mi_walk_bandai.bin");
  for (const char* task : {"location", "heading", "strike"})
    for (const char* method : {"ours", "cml", "adaptnet"}) {
      const std::string path = maskadapt::build_paths::source_dir() + "/models/table3/" + task + "_" + method + ".bin";
      const Checkpoint c = load_checkpoint(path);
      ASSERT_TRUE(is_residual_export(c)) << path;
      const ResidualTrainConfig cfg = check_residual_export(c, path);
      EXPECT_EQ(cfg.task, task) << path;
      EXPECT_EQ(cfg.method, method) << path;
      EXPECT_EQ(cfg.goal_parts, std::string(task) == "heading" ? "" : "lower_body") << path;
      EXPECT_EQ(c.get_int("trainer/iteration"), 1500) << path;
      EXPECT_NE(export_provenance(c).note.find(std::string("Table 3 cell ") + task + "/" + method), std::string::npos) << path;
      EXPECT_TRUE(same_base(c, walker))
          << path << ": the frozen base is not models/mask_mi_walk_bandai.bin's actor";
      auto mean_actions = [&]<class Policy>() {
        const Policy pol = stage2_policy_from_checkpoint<Policy>(c, skel);
        MatrixXf x = MatrixXf::Zero(pol.input_dim(), 1), mu;
        typename Stage2Types<Policy>::Workspace ws;
        const std::vector<PartMask> masks{PartMask::parse(cfg.masks.front())};
        pol.mean(x, masks, mu, ws);
        return mu;
      };
      const MatrixXf mu = std::string(method) == "adaptnet" ? mean_actions.template operator()<adapt::AdaptNetPolicy<float>>()
                                                            : mean_actions.template operator()<adapt::ResidualPolicy<float>>();
      EXPECT_EQ(mu.rows(), 63) << path;
      EXPECT_TRUE(mu.allFinite()) << path;
    }
}

// Issue 39's recipe run (models/recipe/location_face05w19_s2.bin): ours on the location task with
// the facing term 0.5 and objective weights 0.1 / 0.9, seed 2, taken at 6,000 iterations, on the
// shipped walking base; its mean actions are finite on the reference humanoid.
TEST(ShippedModels, RecipeLocationPolicyIsTheRunItClaimsToBe) {
  const Skeleton& skel = humanoid_skeleton();
  const Checkpoint walker = load_checkpoint(maskadapt::build_paths::source_dir() + "/models/mask_mi_walk_bandai.bin");
  const std::string path = maskadapt::build_paths::source_dir() + "/models/recipe/location_face05w19_s2.bin";
  const Checkpoint c = load_checkpoint(path);
  ASSERT_TRUE(is_residual_export(c)) << path;
  const ResidualTrainConfig cfg = check_residual_export(c, path);
  EXPECT_EQ(cfg.task, "location");
  EXPECT_EQ(cfg.method, "ours");
  EXPECT_EQ(cfg.goal_parts, "lower_body");
  EXPECT_EQ(cfg.location_facing_weight, 0.5);
  EXPECT_EQ(cfg.objective_weights, (std::vector<double>{0.1, 0.9}));
  EXPECT_EQ(cfg.rl.run.seed, 2u);
  EXPECT_EQ(c.get_int("trainer/iteration"), 6000);
  EXPECT_TRUE(same_base(c, walker)) << path << ": the frozen base is not models/mask_mi_walk_bandai.bin's actor";
  const auto pol = stage2_policy_from_checkpoint<adapt::ResidualPolicy<float>>(c, skel);
  MatrixXf x = MatrixXf::Zero(pol.input_dim(), 1), mu;
  Stage2Types<adapt::ResidualPolicy<float>>::Workspace ws;
  pol.mean(x, std::vector<PartMask>{PartMask::parse(cfg.masks.front())}, mu, ws);
  EXPECT_EQ(mu.rows(), 63);
  EXPECT_TRUE(mu.allFinite());
}

// Round 5 of issue 39's recipe (models/recipe/strike_foreign_next15_s{1,2}.bin): ours on strike with
// the approach term, a new box 15 steps after each tilt and the foreign-contact end, seeds 1 and 2,
// taken at 3,000 iterations on the shipped walking base; mean actions finite with the arms masked.
TEST(ShippedModels, RecipeStrikePoliciesAreTheRunsTheyClaimToBe) {
  const Skeleton& skel = humanoid_skeleton();
  const Checkpoint walker = load_checkpoint(maskadapt::build_paths::source_dir() + "/models/mask_mi_walk_bandai.bin");
  for (const int seed : {1, 2}) {
    const std::string path =
        maskadapt::build_paths::source_dir() + "/models/recipe/strike_foreign_next15_s" + std::to_string(seed) + ".bin";
    const Checkpoint c = load_checkpoint(path);
    ASSERT_TRUE(is_residual_export(c)) << path;
    const ResidualTrainConfig cfg = check_residual_export(c, path);
    EXPECT_EQ(cfg.task, "strike") << path;
    EXPECT_EQ(cfg.method, "ours") << path;
    EXPECT_EQ(cfg.masks.front(), "arms") << path;
    EXPECT_EQ(cfg.goal_parts, "lower_body") << path;
    EXPECT_EQ(cfg.strike_approach_weight, 0.4) << path;
    EXPECT_EQ(cfg.strike_next_box_steps, 15) << path;
    EXPECT_TRUE(cfg.strike_end_on_foreign_contact) << path;
    EXPECT_EQ(cfg.objective_weights, (std::vector<double>{0.1, 0.9})) << path;
    EXPECT_EQ(cfg.rl.run.seed, static_cast<std::uint64_t>(seed)) << path;
    EXPECT_EQ(c.get_int("trainer/iteration"), 3000) << path;
    EXPECT_TRUE(same_base(c, walker)) << path << ": the frozen base is not models/mask_mi_walk_bandai.bin's actor";
    const auto pol = stage2_policy_from_checkpoint<adapt::ResidualPolicy<float>>(c, skel);
    MatrixXf x = MatrixXf::Zero(pol.input_dim(), 1), mu;
    Stage2Types<adapt::ResidualPolicy<float>>::Workspace ws;
    pol.mean(x, std::vector<PartMask>{PartMask::parse(cfg.masks.front())}, mu, ws);
    EXPECT_EQ(mu.rows(), 63) << path;
    EXPECT_TRUE(mu.allFinite()) << path;
  }
}

// The Table 4 policies (issue 15, models/table4/): partial tracking with the arms designated and the
// shipped text generator — ours and the CML-style baseline on the shipped walking base (seeds 1 and
// 2), from scratch without a base (seed 1) — each the stage-2 export of the cell it is named after,
// trained with the stage-2 recipe (issue 39: the goal weighted 0.9, σ 0.5 on the arms).
TEST(ShippedModels, Table4TrackingPoliciesAreTheCellsTheyClaimToBe) {
  const Skeleton& skel = humanoid_skeleton();
  const Checkpoint walker = load_checkpoint(maskadapt::build_paths::source_dir() + "/models/mask_mi_walk_bandai.bin");
  struct Cell {
    std::string method;
    int seed;
    long long iterations;  // 3.07 M samples; CML-style seed 2 and scratch 1.54 M (models/README.md)
  };
  const std::vector<Cell> cells = {{"ours", 1, 3000}, {"ours", 2, 3000}, {"cml", 1, 3000}, {"cml", 2, 1500}, {"scratch", 1, 1500}};
  for (const auto& [method, seed, iterations] : cells) {
    const std::string path = maskadapt::build_paths::source_dir() + "/models/table4/tracking_" + method + "_s" +
                             std::to_string(seed) + ".bin";
    const Checkpoint c = load_checkpoint(path);
    ASSERT_TRUE(is_residual_export(c)) << path;
    const ResidualTrainConfig cfg = check_residual_export(c, path);
    EXPECT_EQ(cfg.task, "tracking") << path;
    EXPECT_EQ(cfg.method, method) << path;
    EXPECT_EQ(cfg.designated, "arms") << path;
    EXPECT_EQ(cfg.generator, "models/text_generator.bin") << path;
    EXPECT_EQ(cfg.rl.run.seed, static_cast<std::uint64_t>(seed)) << path;
    EXPECT_EQ(c.get_int("trainer/iteration"), iterations) << path;
    EXPECT_EQ(cfg.objective_weights, (std::vector<double>{0.1, 0.9})) << path;
    if (method != "scratch") {
      EXPECT_TRUE(same_base(c, walker))
          << path << ": the frozen base is not models/mask_mi_walk_bandai.bin's actor";
    }
    const auto pol = stage2_policy_from_checkpoint<adapt::ResidualPolicy<float>>(c, skel);
    MatrixXf x = MatrixXf::Zero(pol.input_dim(), 1), mu;
    adapt::ResidualWorkspace<float> ws;
    pol.mean(x, std::vector<PartMask>{method == "scratch" ? PartMask::all() : PartMask::parse("arms")}, mu, ws);
    EXPECT_EQ(mu.rows(), 63) << path;
    EXPECT_TRUE(mu.allFinite()) << path;
    // σ 0.5 on every arm DoF (from --residual-std 0.5 in the A/B runs, the preset's --part-std arms=0.5 in the others)
    const auto parts = action_parts(skel);
    int arm_dofs = 0;
    for (std::size_t i = 0; i < parts.size(); ++i) {
      if (!PartMask::parse("arms").has(parts[i])) continue;
      ++arm_dofs;
      EXPECT_NEAR(std::exp(pol.residual().log_std.params()[static_cast<Index>(i)]), 0.5, 1e-6) << path << " DoF " << i;
    }
    EXPECT_EQ(arm_dofs, 24) << path;
  }
}
