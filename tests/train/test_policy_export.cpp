// Policy-only exports (train/policy_export.hpp) of a stage-1 checkpoint made by the trainer on
// the tiny analytic simulator: small, only the actor's sections, the same actor bit for bit
// (load_base_policy and stage 2's load_base_actor read it), dims / kind / missing sections
// refused naming the section, provenance carried over.
#include "tiny_sim.hpp"
#include "trainer_test_helpers.hpp"

#include <maskadapt/train/base_trainer.hpp>
#include <maskadapt/train/policy_export.hpp>
#include <maskadapt/train/residual_trainer.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include <unistd.h>  // getpid: temp files per process

using namespace maskadapt;
using namespace maskadapt::train;
using maskadapt::testing::TinyWalkerSim;

namespace {

BaseTrainConfig export_config() { return maskadapt::testing::tiny_walker_config(); }

// A trainer on the tiny walker after two iterations (upright resets with small random joint
// angles; "real" discriminator windows of uniform noise: what they are does not matter here).
struct ExportRun {
  TinyWalkerSim sim;
  BaseTrainer<TinyWalkerSim> trainer;
  explicit ExportRun(const BaseTrainConfig& c)
      : sim(static_cast<std::size_t>(c.env.num_envs)),
        trainer(
            sim,
            [this](Rng& rng) {
              tasks::ResetSample r;
              r.pose = KinematicState::zero(sim.skeleton());
              for (Index i = 0; i < r.pose.q.size(); ++i) r.pose.q[i] = rng.uniform(-0.1, 0.1);
              return r;
            },
            [](Rng& rng, Eigen::Ref<MatrixXf> out) {
              for (Index j = 0; j < out.cols(); ++j)
                for (Index i = 0; i < out.rows(); ++i) out(i, j) = static_cast<float>(rng.uniform(-1.0, 1.0));
            },
            c, nullptr, FallCriteria::for_skeleton(sim.skeleton(), {"l_leg", "r_leg"}, "head", c.env.termination_height)) {
    for (int i = 0; i < 2; ++i) trainer.iterate();
  }
  Checkpoint checkpoint() const {
    Checkpoint c;
    trainer.save(c);
    c.set_source("runs/tiny/checkpoint.bin");
    return c;
  }
  PolicyDims dims() const { return trainer.dims(); }
};

Checkpoint exported(const Checkpoint& training, const std::string& note = "a note") {
  Checkpoint out;
  export_base_policy(training, out, {"/abs/runs/tiny/checkpoint.bin", "abc1234", note});
  return out;
}

std::filesystem::path export_temp(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("maskadapt_export_" + std::to_string(::getpid()) + "_" + name);
}

/// A fixed batch of 7 policy inputs (policy_input_dim × 7).
MatrixXf input_batch(Index rows) {
  Rng r(11);
  MatrixXf x(rows, 7);
  for (Index j = 0; j < x.cols(); ++j)
    for (Index i = 0; i < rows; ++i) x(i, j) = static_cast<float>(r.normal());
  return x;
}

MatrixXf actor_means(const rl::GaussianActor<float>& actor, const MatrixXf& x) {
  MatrixXf mu(actor.action_dim(), x.cols()), scratch;
  nn::InferenceWorkspace<float> ws;
  actor.mean(x, mu, ws, scratch);
  return mu;
}

bool bit_identical(const MatrixXf& a, const MatrixXf& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), static_cast<std::size_t>(a.size()) * sizeof(float)) == 0;
}

/// `f` throws a maskadapt::Error whose field is `section` and whose text names `file`.
void expect_refused(const std::function<void()>& f, const std::string& section, const std::string& file) {
  try {
    f();
    ADD_FAILURE() << "no error; expected one naming section '" << section << "'";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, section) << e.what();
    EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << "the message does not name " << file << ": " << e.what();
  }
}

}  // namespace

// The export holds exactly the actor's sections, the model/ and provenance/ records, and is a
// small fraction of the training checkpoint on disk (no replay buffer, no Adam moments).
TEST(PolicyExport, HoldsOnlyThePolicyAndIsMuchSmaller) {
  ExportRun run(export_config());
  const Checkpoint training = run.checkpoint();
  const Checkpoint model = exported(training);
  EXPECT_TRUE(is_policy_export(model));
  EXPECT_FALSE(is_policy_export(training));
  const std::vector<std::string> list = model.names();  // (names() returns a copy)
  const std::set<std::string> names(list.begin(), list.end());
  const std::set<std::string> expected = {
      "model/kind", "model/format_version", "model/obs_dim", "model/policy_input_dim", "model/action_dim", "config",
      "actor/params", "actor/log_std", "actor/norm/count", "actor/norm/mean", "actor/norm/m2", "trainer/iteration",
      "trainer/samples", "provenance/history", "provenance/train_seconds", "provenance/exported_from",
      "provenance/export_git_commit", "provenance/note"};
  EXPECT_EQ(names, expected);
  for (const auto& n : model.names())
    EXPECT_TRUE(n.rfind("replay/", 0) != 0 && n.find("adam") == std::string::npos && n.rfind("critic/", 0) != 0 &&
                n.rfind("disc/", 0) != 0 && n.rfind("task/", 0) != 0)
        << n;
  // the copied sections are byte-identical to the training checkpoint's
  for (const char* n : {"config", "actor/params", "actor/log_std", "actor/norm/count", "actor/norm/mean", "actor/norm/m2",
                        "trainer/iteration", "trainer/samples"}) {
    EXPECT_EQ(model.section(n).data, training.section(n).data) << n;
    EXPECT_EQ(model.section(n).shape, training.section(n).shape) << n;
  }
  EXPECT_EQ(model.get_int("trainer/iteration"), 2);
  EXPECT_EQ(model.get_int("trainer/samples"), run.trainer.samples());
  const ModelDims d = check_policy_export(model);
  EXPECT_EQ(d.obs_dim, run.dims().obs_dim);
  EXPECT_EQ(d.policy_input_dim, run.dims().policy_input_dim);
  EXPECT_EQ(d.action_dim, run.dims().action_dim);

  const auto tp = export_temp("training.bin"), mp = export_temp("model.bin");
  save_checkpoint(tp, training);
  save_checkpoint(mp, model);
  const auto ts = std::filesystem::file_size(tp), ms = std::filesystem::file_size(mp);
  std::cout << "[          ] training checkpoint " << ts << " bytes, export " << ms << " bytes (" << 100.0 * ms / ts
            << " %)\n";
  EXPECT_LT(ms * 10, ts);
  EXPECT_TRUE(is_policy_export(load_checkpoint(mp)));
  std::filesystem::remove(tp);
  std::filesystem::remove(mp);
}

// Mean actions for a fixed input batch: the export (through a file), the training checkpoint and
// the live trainer give the same bits; load_base_policy says policy_only for the export only;
// stage 2's load_base_actor reads the export unchanged and gives the same bits too.
TEST(PolicyExport, ActorIsBitIdenticalAndEveryLoaderReadsIt) {
  ExportRun run(export_config());
  const Checkpoint training = run.checkpoint();
  const auto mp = export_temp("model_bits.bin");
  save_checkpoint(mp, exported(training));
  const Checkpoint model = load_checkpoint(mp);
  std::filesystem::remove(mp);

  const LoadedBasePolicy from_training = load_base_policy(training, run.dims());
  const LoadedBasePolicy from_export = load_base_policy(model, run.dims());
  EXPECT_FALSE(from_training.policy_only);
  EXPECT_TRUE(from_export.policy_only);
  EXPECT_EQ(from_export.iteration, 2);
  EXPECT_EQ(to_json(from_export.config), to_json(from_training.config));

  const MatrixXf x = input_batch(run.dims().policy_input_dim);
  const MatrixXf live = actor_means(run.trainer.policy().ac.actor, x);
  EXPECT_TRUE(bit_identical(actor_means(from_training.policy.ac.actor, x), live));
  EXPECT_TRUE(bit_identical(actor_means(from_export.policy.ac.actor, x), live));
  EXPECT_EQ(from_export.policy.ac.actor.log_std.params(), run.trainer.policy().ac.actor.log_std.params());
  EXPECT_EQ(from_export.policy.actions.offset.size(), 0);  // identity action space: a is the PD target
  EXPECT_EQ(from_export.policy.actions.scale.size(), 0);

  const FrozenBase stage2 = load_base_actor(model, run.dims().obs_dim, run.dims().action_dim);
  EXPECT_TRUE(bit_identical(actor_means(stage2.actor, x), live));
  EXPECT_EQ(stage2.actor.log_std.params(), run.trainer.policy().ac.actor.log_std.params());
}

// Normalised actions: the action space travels with the export and loads back identically,
// through load_base_policy and through stage 2's load_base_actor.
TEST(PolicyExport, CarriesTheActionSpace) {
  auto cfg = export_config();
  cfg.net.action_offset = "mid_range";
  cfg.net.action_scale = "half_range";
  resolve_action_space(cfg, TinyWalkerSim(1).skeleton(), nullptr);
  ExportRun run(cfg);
  const Checkpoint model = exported(run.checkpoint());
  ASSERT_TRUE(model.contains("actor/action_offset"));
  ASSERT_TRUE(model.contains("actor/action_scale"));
  const LoadedBasePolicy loaded = load_base_policy(model, run.dims());
  EXPECT_TRUE(loaded.policy.actions.offset == run.trainer.policy().actions.offset);
  EXPECT_TRUE(loaded.policy.actions.scale == run.trainer.policy().actions.scale);
  const MatrixXf x = input_batch(run.dims().policy_input_dim);
  EXPECT_TRUE(bit_identical(actor_means(loaded.policy.ac.actor, x), actor_means(run.trainer.policy().ac.actor, x)));
  const FrozenBase stage2 = load_base_actor(model, run.dims().obs_dim, run.dims().action_dim);
  EXPECT_TRUE(stage2.actions.offset == run.trainer.policy().actions.offset);
  EXPECT_TRUE(stage2.actions.scale == run.trainer.policy().actions.scale);
}

// What export refuses, each with an Error naming the file and the section: a stage-2
// checkpoint, a file that already is an export, a checkpoint without config or actor, an actor
// that does not fit its config's architecture, or malformed actor sections.
TEST(PolicyExport, RefusesWhatIsNotAStageOneCheckpoint) {
  ExportRun run(export_config());
  const Checkpoint training = run.checkpoint();
  const std::string file = "runs/tiny/checkpoint.bin";
  Checkpoint out;
  auto export_of = [&](const Checkpoint& c) { return [&out, c] { export_base_policy(c, out, {"x", "y", ""}); }; };

  Checkpoint stage2 = training;
  stage2.put_string("residual_config", "{}");
  expect_refused(export_of(stage2), "residual_config", file);
  Checkpoint again = exported(training);
  again.set_source(file);
  expect_refused(export_of(again), "model/kind", file);
  for (const char* missing : {"config", "actor/params", "actor/log_std", "actor/norm/mean", "actor/norm/m2", "actor/norm/count"}) {
    Checkpoint c = training;
    c.erase(missing);
    expect_refused(export_of(c), missing, file);
  }
  Checkpoint other_net = training;  // the config describes another actor than the one stored
  auto cfg = export_config();
  cfg.net.actor_hidden = {16, 8};
  other_net.put_string("config", to_json(cfg).dump());
  expect_refused(export_of(other_net), "actor/params", file);
  Checkpoint short_m2 = training;
  short_m2.put("actor/norm/m2", VectorXd::Zero(3));
  expect_refused(export_of(short_m2), "actor/norm/m2", file);
  Checkpoint bad_scale = training;
  bad_scale.put("actor/action_scale", VectorXf::Ones(run.dims().action_dim + 1));
  expect_refused(export_of(bad_scale), "actor/action_scale", file);
  Checkpoint f64_log_std = training;
  f64_log_std.put("actor/log_std", VectorXd::Zero(run.dims().action_dim));  // f64 where f32 belongs
  expect_refused(export_of(f64_log_std), "actor/log_std", file);
  Checkpoint empty;
  empty.set_source(file);
  expect_refused(export_of(empty), "config", file);
}

// What loading an export refuses: another kind, another format version, recorded dims that do
// not match the sections, a simulator of other sizes, and missing actor sections.
TEST(PolicyExport, LoadingChecksKindVersionAndDims) {
  ExportRun run(export_config());
  const std::string file = "models/tiny.bin";
  Checkpoint model = exported(run.checkpoint());
  model.set_source(file);
  EXPECT_NO_THROW(load_base_policy(model, run.dims()));
  auto load = [&run](const Checkpoint& c) { return [&run, c] { (void)load_base_policy(c, run.dims()); }; };

  Checkpoint kind = model;
  kind.put_string("model/kind", "maskadapt.residual_policy");
  EXPECT_FALSE(is_policy_export(kind));
  expect_refused(load(kind), "model/kind", file);
  Checkpoint version = model;
  version.put_int("model/format_version", 2);
  expect_refused(load(version), "model/format_version", file);
  for (const char* dim : {"model/obs_dim", "model/policy_input_dim", "model/action_dim"}) {
    Checkpoint c = model;
    c.put_int(dim, c.get_int(dim) + 1);
    expect_refused(load(c), dim, file);
    Checkpoint gone = model;
    gone.erase(dim);
    expect_refused(load(gone), dim, file);
  }
  for (const char* missing : {"config", "actor/params", "actor/log_std", "actor/norm/mean", "model/format_version"}) {
    Checkpoint c = model;
    c.erase(missing);
    expect_refused(load(c), missing, file);
  }
  // a simulator with other sizes than the model was exported for
  PolicyDims wider = run.dims();
  wider.obs_dim += 1;
  wider.policy_input_dim += 1;
  expect_refused([&] { (void)load_base_policy(model, wider); }, "model/obs_dim", file);
  PolicyDims fewer_actions = run.dims();
  fewer_actions.action_dim -= 1;
  expect_refused([&] { (void)load_base_policy(model, fewer_actions); }, "model/action_dim", file);
}

// provenance/history and the training wall time are copied (the older name trainer/wall_seconds
// is read too); a checkpoint without them gets the "unknown" text and NaN; exported_from, the
// commit and the note are stored; all of it survives a file round trip.
TEST(PolicyExport, ProvenanceRoundTrips) {
  ExportRun run(export_config());
  Checkpoint training = run.checkpoint();
  const std::string history =
      "2026-12-01T10:00:00Z git 1111111: maskadapt train-base --preset cpu\n"
      "2026-12-01T12:00:00Z git 2222222: maskadapt train-base --resume runs/base/checkpoint.bin\n";
  training.put_string("provenance/history", history);
  training.put_double("provenance/train_seconds", 7261.5);
  const auto mp = export_temp("provenance.bin");
  save_checkpoint(mp, exported(training, "walk, 2 h, masks on"));
  const ExportProvenance p = export_provenance(load_checkpoint(mp));
  std::filesystem::remove(mp);
  EXPECT_EQ(p.history, history);
  EXPECT_EQ(p.train_seconds, 7261.5);
  EXPECT_EQ(p.exported_from, "/abs/runs/tiny/checkpoint.bin");
  EXPECT_EQ(p.export_git_commit, "abc1234");
  EXPECT_EQ(p.note, "walk, 2 h, masks on");

  Checkpoint old = training;  // written before the trainer kept these records
  old.erase("provenance/history");
  old.erase("provenance/train_seconds");
  const ExportProvenance unknown = export_provenance(exported(old, ""));
  EXPECT_EQ(unknown.history, kUnknownProvenance);
  EXPECT_TRUE(std::isnan(unknown.train_seconds));
  EXPECT_EQ(unknown.note, "");

  Checkpoint legacy = old;
  legacy.put_double("trainer/wall_seconds", 12.0);
  const Checkpoint from_legacy = exported(legacy);
  EXPECT_EQ(from_legacy.get_double("provenance/train_seconds"), 12.0);
  EXPECT_FALSE(from_legacy.contains("trainer/wall_seconds"));
}
