// The models committed under models/ (models/README.md): each loads through the public API with
// its checksum verified, is a policy-only export of the reference humanoid's dims, says how it was
// trained, and its actor gives finite actions. CI never retrains them; this catches a model file
// that was replaced, truncated or written by an incompatible format.
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/mask/apply.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/policy_export.hpp>

#include <gtest/gtest.h>

#include <string>

using namespace maskadapt;
using namespace maskadapt::train;

TEST(ShippedModels, AmpWalkBandaiLoadsWithItsDimsAndProvenance) {
  const std::string path = MASKADAPT_SOURCE_DIR "/models/amp_walk_bandai.bin";
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
