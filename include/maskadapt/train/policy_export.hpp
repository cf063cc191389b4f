#pragma once
/// \file policy_export.hpp
/// A policy-only model file ("export") of a stage-1 base policy: only what running the actor
/// needs, without the replay buffer, the optimiser states, the critic, the discriminator and the
/// RNG/task/simulator states of a training checkpoint (cpu preset: ~0.7 MB instead of ~107 MB).
/// Written by `maskadapt export`; read by load_base_policy (train/base_policy.hpp) and, because
/// the actor's sections keep the names save_policy gives them, by stage 2's load_base_actor
/// (train/residual_trainer.hpp) unchanged.
///
/// Sections of an export (format version 1; a checkpoint file, core/checkpoint.hpp):
///   model/kind                 bytes  "maskadapt.base_policy" (kPolicyExportKind)
///   model/format_version       int64  1 (kPolicyExportVersion)
///   model/obs_dim              int64  full observation s (humanoid 328)
///   model/policy_input_dim     int64  actor input [s̄ ; m] = obs_dim + kNumParts (humanoid 333)
///   model/action_dim           int64  actions = PD targets (humanoid 63)
///   config                     bytes  the BaseTrainConfig JSON of the training run (architecture)
///   actor/params               f32    (Σ_l out_l·(in_l + 1)) mean network, MlpSpec layout
///   actor/log_std              f32    (action_dim)
///   actor/norm/count           f64    scalar; actor/norm/mean, actor/norm/m2 f64 (policy_input_dim)
///   actor/action_offset, actor/action_scale   f32 (action_dim), only when the run had them
///   trainer/iteration, trainer/samples        int64, when the training checkpoint had them
///   provenance/history         bytes  one line per training chunk (date, git commit, command line),
///                                     copied, or kUnknownProvenance where the checkpoint has none (older
///                                     than that record, or an empty one)
///   provenance/train_seconds   f64    training wall time (s), copied (also read from the older name
///                                     trainer/wall_seconds); NaN = unknown, also when not recorded
///   provenance/exported_from   bytes  path of the training checkpoint
///   provenance/export_git_commit bytes commit of the binary that exported (the CLI: cli::build_commit())
///   provenance/note            bytes  free text (`--note`), may be empty
///
/// The dims are checked against the sections' sizes and the config's architecture when
/// exporting and when loading (check_policy_export), and against the simulator's when a policy
/// is loaded for it; every failure is a maskadapt::Error naming the file and the section.
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/nn/mlp.hpp>
#include <maskadapt/train/config.hpp>

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace maskadapt::train {

inline constexpr const char* kPolicyExportKind = "maskadapt.base_policy";
inline constexpr std::int64_t kPolicyExportVersion = 1;
/// provenance/history of an export made from a checkpoint without that record (written before
/// the trainer kept it, or with an empty one).
inline constexpr const char* kUnknownProvenance = "unknown (checkpoint predates provenance records)";

/// What `export_base_policy` records about the export itself.
struct ExportInfo {
  std::string exported_from;           ///< path of the training checkpoint (also labels errors)
  std::string git_commit = "unknown";  ///< commit of the exporting binary (the CLI: cli::build_commit())
  std::string note;                    ///< free text, may be empty
};

/// Training wall time (s, f64 scalar) as BaseTrainer::save records it; an export keeps the name.
inline constexpr const char* kTrainSecondsSection = "provenance/train_seconds";
/// The name first planned for it (issue 14): read as well, never written.
inline constexpr const char* kLegacyTrainSecondsSection = "trainer/wall_seconds";

/// The training wall time a checkpoint or an export records (NaN: unknown or not recorded).
inline double training_seconds_of(const Checkpoint& c) {
  for (const char* name : {kTrainSecondsSection, kLegacyTrainSecondsSection})
    if (c.contains(name)) return c.get_double(name);
  return std::numeric_limits<double>::quiet_NaN();
}

/// The actor's sizes (humanoid: 328, 333, 63).
struct ModelDims {
  Index obs_dim = 0;           ///< full observation s
  Index policy_input_dim = 0;  ///< [s̄ ; m] = obs_dim + kNumParts
  Index action_dim = 0;        ///< PD targets
  bool operator==(const ModelDims&) const = default;
};

/// Provenance of an export, as stored (see the file comment).
struct ExportProvenance {
  std::string history;                                        ///< one line per training chunk
  double train_seconds = std::numeric_limits<double>::quiet_NaN();  ///< training wall time (s); NaN = unknown
  std::string exported_from, export_git_commit, note;
};

/// True when `c` is a policy-only export of a base policy (model/kind = kPolicyExportKind).
inline bool is_policy_export(const Checkpoint& c) {
  if (!c.contains("model/kind") || c.section("model/kind").dtype != DType::Bytes) return false;
  return c.get_string("model/kind") == kPolicyExportKind;
}

namespace detail {
inline std::string dims_text(const std::vector<Index>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::to_string(v[i]);
  return s + "]";
}
/// Element count of section `name` after checking its dtype; throws naming file and section.
inline Index numel_of(const Checkpoint& c, const std::string& name, DType want, const std::string& file) {
  if (!c.contains(name)) throw Error("missing section", {file, std::nullopt, name});
  const CheckpointSection& s = c.section(name);
  if (s.dtype != want)
    throw Error(std::string("dtype mismatch: expected ") + dtype_name(want) + ", found " + dtype_name(s.dtype),
                {file, std::nullopt, name});
  return static_cast<Index>(s.numel());
}
/// Checks model/kind and model/format_version of an export of kind `kind` ("a `what` export").
inline void require_export_kind(const Checkpoint& c, const std::string& file, const char* kind, std::int64_t version,
                                const char* what) {
  const std::string found = c.contains("model/kind") ? c.get_string("model/kind") : std::string();
  require(found == kind,
          c.contains("model/kind") ? std::string("not a ") + what + " export: kind '" + found + "', expected '" + kind + "'"
                                   : std::string("missing section: not a policy-only export"),
          {file, std::nullopt, "model/kind"});
  const std::int64_t v = c.get_int("model/format_version");
  require(v == version,
          "unsupported export format version " + std::to_string(v) + " (this build reads version " + std::to_string(version) + ")",
          {file, std::nullopt, "model/format_version"});
}
/// A new export of kind `kind` (model/kind, model/format_version), labelled `file` for errors.
inline Checkpoint start_export(const std::string& file, const char* kind, std::int64_t version) {
  Checkpoint e;
  e.set_source(file);
  e.put_string("model/kind", kind);
  e.put_int("model/format_version", version);
  return e;
}
/// Copies section `name` of `from` into `to` byte for byte, under the same name.
inline void copy_section(const Checkpoint& from, Checkpoint& to, const std::string& name) {
  const CheckpointSection& s = from.section(name);
  to.put_raw(name, s.dtype, s.shape, s.data.data(), s.data.size());
}
/// Writes an export's counters (copied from `training` when it has them) and its provenance
/// records (the run's history and training time, copied; the export's own from `info`).
inline void put_export_records(const Checkpoint& training, Checkpoint& e, const ExportInfo& info) {
  for (const char* name : {"trainer/iteration", "trainer/samples"})
    if (training.contains(name)) e.put_int(name, training.get_int(name));  // (int64 scalars, type-checked)
  const std::string history = training.contains("provenance/history") ? training.get_string("provenance/history") : "";
  e.put_string("provenance/history", history.empty() ? std::string(kUnknownProvenance) : history);
  e.put_double(kTrainSecondsSection, training_seconds_of(training));
  e.put_string("provenance/exported_from", info.exported_from);
  e.put_string("provenance/export_git_commit", info.git_commit);
  e.put_string("provenance/note", info.note);
}
}  // namespace detail

/// The actor's sizes read off the actor sections of `c` (a training checkpoint or an export),
/// checked against each other and against the architecture `cfg` describes (net.actor_hidden):
/// action_dim = |actor/log_std|, policy_input_dim = |actor/norm/mean| = |actor/norm/m2|,
/// obs_dim = policy_input_dim − kNumParts, |actor/params| = MlpSpec{…}.num_params(),
/// |actor/action_offset| = |actor/action_scale| = action_dim when present.
inline ModelDims actor_dims_of(const Checkpoint& c, const BaseTrainConfig& cfg, const std::string& file) {
  using detail::numel_of;
  ModelDims d;
  d.action_dim = numel_of(c, "actor/log_std", DType::Float32, file);
  require(d.action_dim > 0, "the actor has no actions", {file, std::nullopt, "actor/log_std"});
  d.policy_input_dim = numel_of(c, "actor/norm/mean", DType::Float64, file);
  require(d.policy_input_dim > kNumParts,
          "the actor's input has " + std::to_string(d.policy_input_dim) + " rows; a base policy's input is [s̄ ; m] with " +
              std::to_string(kNumParts) + " mask bits after the observation",
          {file, std::nullopt, "actor/norm/mean"});
  d.obs_dim = d.policy_input_dim - kNumParts;
  const Index m2 = numel_of(c, "actor/norm/m2", DType::Float64, file);
  require(m2 == d.policy_input_dim,
          "has " + std::to_string(m2) + " entries, actor/norm/mean " + std::to_string(d.policy_input_dim),
          {file, std::nullopt, "actor/norm/m2"});
  require(numel_of(c, "actor/norm/count", DType::Float64, file) == 1, "must be a scalar",
          {file, std::nullopt, "actor/norm/count"});
  const nn::MlpSpec spec{d.policy_input_dim, cfg.net.actor_hidden, d.action_dim};
  const Index params = numel_of(c, "actor/params", DType::Float32, file);
  require(params == spec.num_params(),
          "has " + std::to_string(params) + " parameters; the config's architecture (net.actor_hidden " +
              detail::dims_text(cfg.net.actor_hidden) + ", " + std::to_string(d.policy_input_dim) + " inputs, " +
              std::to_string(d.action_dim) + " actions) has " + std::to_string(spec.num_params()),
          {file, std::nullopt, "actor/params"});
  for (const char* name : {"actor/action_offset", "actor/action_scale"})
    if (c.contains(name)) {
      const Index n = numel_of(c, name, DType::Float32, file);
      require(n == d.action_dim, "has " + std::to_string(n) + " entries, the actor " + std::to_string(d.action_dim) + " actions",
              {file, std::nullopt, name});
    }
  return d;
}

/// Verifies an export: kind, format version, the recorded dims against the actor sections and
/// the config's architecture, and (when given) against the dims of the simulator it is loaded
/// for. Returns the dims. `file` labels errors ("": c.source()).
inline ModelDims check_policy_export(const Checkpoint& c, const std::optional<ModelDims>& expected = std::nullopt,
                                     std::string file = {}) {
  if (file.empty()) file = c.source();
  detail::require_export_kind(c, file, kPolicyExportKind, kPolicyExportVersion, "base-policy");
  const BaseTrainConfig cfg = config_from_string(c.get_string("config"), file + " (config)");
  const ModelDims sections = actor_dims_of(c, cfg, file);
  const ModelDims recorded{c.get_int("model/obs_dim"), c.get_int("model/policy_input_dim"), c.get_int("model/action_dim")};
  auto same = [&](Index rec, Index actual, const char* name, const std::string& how) {
    require(rec == actual, "is " + std::to_string(rec) + ", but the actor's sections give " + std::to_string(actual) + " (" + how + ")",
            {file, std::nullopt, name});
  };
  const std::string rows = std::to_string(sections.policy_input_dim);
  same(recorded.obs_dim, sections.obs_dim, "model/obs_dim",
       "actor/norm/mean: " + rows + " input rows - " + std::to_string(kNumParts) + " mask bits");
  same(recorded.policy_input_dim, sections.policy_input_dim, "model/policy_input_dim", "actor/norm/mean: " + rows + " input rows");
  same(recorded.action_dim, sections.action_dim, "model/action_dim", "actor/log_std: one entry per action");
  if (expected) {
    auto fits = [&](Index rec, Index want, const char* name, const char* what) {
      require(rec == want,
              "this model was exported for " + std::to_string(rec) + " " + what + "; the simulator it is loaded for has " +
                  std::to_string(want),
              {file, std::nullopt, name});
    };
    fits(recorded.obs_dim, expected->obs_dim, "model/obs_dim", "observation rows");
    fits(recorded.policy_input_dim, expected->policy_input_dim, "model/policy_input_dim", "policy input rows");
    fits(recorded.action_dim, expected->action_dim, "model/action_dim", "actions");
  }
  return recorded;
}

/// Writes into `out` (cleared first) the policy-only export of the stage-1 training checkpoint
/// `training`: the sections listed in the file comment, copied byte for byte under the same
/// names, plus the model/ and provenance/ records. Refuses (maskadapt::Error naming the file and
/// the section) a stage-2 checkpoint (residual_config), a file that already is an export
/// (model/kind), one that is not a stage-1 checkpoint (no config or actor/params), and one whose
/// actor does not match its config's architecture. The result is checked with check_policy_export.
inline void export_base_policy(const Checkpoint& training, Checkpoint& out, const ExportInfo& info) {
  const std::string file = !training.source().empty() ? training.source() : info.exported_from;
  require(!training.contains("residual_config"),
          "a stage-2 (train-residual) checkpoint; export the stage-1 checkpoint it was trained on (its --base) instead",
          {file, std::nullopt, "residual_config"});
  require(!training.contains("model/kind"), "already a policy-only model file; nothing to export",
          {file, std::nullopt, "model/kind"});
  for (const char* name : {"config", "actor/params"})
    require(training.contains(name), "missing section: not a stage-1 training checkpoint (train-base output)",
            {file, std::nullopt, name});
  const BaseTrainConfig cfg = config_from_string(training.get_string("config"), file + " (config)");
  const ModelDims d = actor_dims_of(training, cfg, file);

  Checkpoint e = detail::start_export(file, kPolicyExportKind, kPolicyExportVersion);
  e.put_int("model/obs_dim", d.obs_dim);
  e.put_int("model/policy_input_dim", d.policy_input_dim);
  e.put_int("model/action_dim", d.action_dim);
  auto copy = [&](const std::string& name) { detail::copy_section(training, e, name); };
  for (const char* name : {"config", "actor/params", "actor/log_std", "actor/norm/count", "actor/norm/mean", "actor/norm/m2"})
    copy(name);
  for (const char* name : {"actor/action_offset", "actor/action_scale", "actor/hidden_groups"})
    if (training.contains(name)) copy(name);
  detail::put_export_records(training, e, info);
  (void)check_policy_export(e, std::nullopt, file);
  out = std::move(e);
}

/// The provenance records of an export (absent ones: kUnknownProvenance / NaN / "").
inline ExportProvenance export_provenance(const Checkpoint& c) {
  ExportProvenance p;
  auto text = [&](const char* name, std::string fallback) { return c.contains(name) ? c.get_string(name) : fallback; };
  p.history = text("provenance/history", kUnknownProvenance);
  p.train_seconds = training_seconds_of(c);
  p.exported_from = text("provenance/exported_from", "");
  p.export_git_commit = text("provenance/export_git_commit", "unknown");
  p.note = text("provenance/note", "");
  return p;
}

}  // namespace maskadapt::train
