#pragma once
/// \file residual_export.hpp
/// A policy-only model file of a stage-2 (train-residual) run: the residual or AdaptNet policy
/// with its frozen base, without the critic, PopArt, the discriminators and their replay
/// buffers, the optimiser moments and the RNG/task/simulator states (a goal-task checkpoint of
/// the cpu preset: ~123 MB; its export: a few MB). Written by `maskadapt export` when given a
/// train-residual checkpoint; play-residual and eval-residual read it as they read the
/// checkpoint (stage2_policy_from_checkpoint needs only the sections kept here).
///
/// Sections of a residual export (format version 1; a checkpoint file, core/checkpoint.hpp):
///   model/kind                 bytes  "maskadapt.residual_policy" (kResidualExportKind)
///   model/format_version       int64  1 (kResidualExportVersion)
///   model/task, model/method   bytes  copied from the run's config, for a reader that only lists
///   residual_config            bytes  the ResidualTrainConfig JSON (task, method, masks, widths, base config)
///   config                     bytes  its BaseTrainConfig part, as the checkpoint has it
///   residual/*                 the residual policy (ours, cml, scratch): params, log_std, gain, norm/*
///   adaptnet/*                 the AdaptNet policy: encoder, goal_net, embed, ia, log_std, norm/*
///   base/actor/*               the frozen base: params, log_std, norm/*, hidden_groups, action space
///   trainer/iteration, trainer/samples   int64
///   provenance/history, provenance/train_seconds   copied (kUnknownProvenance / NaN when absent)
///   provenance/exported_from, provenance/export_git_commit, provenance/note   as for a base export
///
/// An export cannot be resumed (it has no optimiser, critic or discriminator); train-residual
/// --resume refuses it, naming model/kind.
#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/train/policy_export.hpp>
#include <maskadapt/train/residual_config.hpp>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <string>

namespace maskadapt::train {

inline constexpr const char* kResidualExportKind = "maskadapt.residual_policy";
inline constexpr std::int64_t kResidualExportVersion = 1;

/// True when `c` is a policy-only export of a stage-2 run (model/kind = kResidualExportKind).
inline bool is_residual_export(const Checkpoint& c) {
  if (!c.contains("model/kind") || c.section("model/kind").dtype != DType::Bytes) return false;
  return c.get_string("model/kind") == kResidualExportKind;
}

namespace detail {
/// The policy sections a stage-2 run of `method` must have (the rest of its policy is optional:
/// AdaptNet's goal_net and ia exist only for some configurations, the base's action space only
/// when it is not the identity).
inline std::vector<const char*> required_stage2_sections(const std::string& method) {
  std::vector<const char*> s{"base/actor/params", "base/actor/log_std", "base/actor/norm/count", "base/actor/norm/mean",
                             "base/actor/norm/m2"};
  if (method == "adaptnet")
    for (const char* n : {"adaptnet/encoder", "adaptnet/embed", "adaptnet/log_std", "adaptnet/norm/count"}) s.push_back(n);
  else
    for (const char* n : {"residual/params", "residual/log_std", "residual/gain", "residual/norm/count"}) s.push_back(n);
  return s;
}
inline bool is_stage2_policy_section(const std::string& name) {
  for (const char* prefix : {"residual/", "adaptnet/", "base/actor/"})
    if (name.rfind(prefix, 0) == 0) return true;
  return false;
}
/// The run's config, parsed; throws naming the file and the section when it is not one.
inline ResidualTrainConfig stage2_config_of(const Checkpoint& c, const std::string& file) {
  require(c.contains("residual_config"), "missing section: not a stage-2 (train-residual) checkpoint or export",
          {file, std::nullopt, "residual_config"});
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(c.get_string("residual_config"));
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("not valid JSON: ") + e.what(), {file, std::nullopt, "residual_config"});
  }
  return residual_config_from_json(j, file + " (residual_config)");
}
}  // namespace detail

/// Verifies a residual export: kind, format version, the config, the task/method records against
/// it, and the policy sections its method needs. Returns the run's config. The networks' sizes
/// are checked when the policy is built from it (stage2_policy_from_checkpoint names any section
/// of another size). `file` labels errors ("": c.source()).
inline ResidualTrainConfig check_residual_export(const Checkpoint& c, std::string file = {}) {
  if (file.empty()) file = c.source();
  detail::require_export_kind(c, file, kResidualExportKind, kResidualExportVersion, "stage-2");
  const ResidualTrainConfig cfg = detail::stage2_config_of(c, file);
  require(c.get_string("model/task") == cfg.task, "is '" + c.get_string("model/task") + "', the run's config says '" + cfg.task + "'",
          {file, std::nullopt, "model/task"});
  require(c.get_string("model/method") == cfg.method,
          "is '" + c.get_string("model/method") + "', the run's config says '" + cfg.method + "'", {file, std::nullopt, "model/method"});
  for (const char* name : detail::required_stage2_sections(cfg.method))
    require(c.contains(name), "missing section: the " + cfg.method + " policy needs it", {file, std::nullopt, name});
  return cfg;
}

/// Writes into `out` (cleared first) the policy-only export of the train-residual checkpoint
/// `training`: the sections of the file comment, copied byte for byte under the same names, plus
/// the model/ and provenance/ records. Refuses (maskadapt::Error naming the file and the section)
/// a file that already is an export and one that is not a stage-2 checkpoint or lacks a section
/// its method needs. The result is checked with check_residual_export.
inline void export_residual_policy(const Checkpoint& training, Checkpoint& out, const ExportInfo& info) {
  const std::string file = !training.source().empty() ? training.source() : info.exported_from;
  require(!training.contains("model/kind"), "already a policy-only model file; nothing to export",
          {file, std::nullopt, "model/kind"});
  const ResidualTrainConfig cfg = detail::stage2_config_of(training, file);
  for (const char* name : detail::required_stage2_sections(cfg.method))
    require(training.contains(name), "missing section: not a complete " + cfg.method + " checkpoint", {file, std::nullopt, name});

  Checkpoint e = detail::start_export(file, kResidualExportKind, kResidualExportVersion);
  e.put_string("model/task", cfg.task);
  e.put_string("model/method", cfg.method);
  auto copy = [&](const std::string& name) { detail::copy_section(training, e, name); };
  for (const char* name : {"residual_config", "config"})
    if (training.contains(name)) copy(name);
  for (const std::string& name : training.names())
    if (detail::is_stage2_policy_section(name)) copy(name);
  detail::put_export_records(training, e, info);
  (void)check_residual_export(e, file);
  out = std::move(e);
}

}  // namespace maskadapt::train
