// `maskadapt export CHECKPOINT --out FILE [--note TEXT]`: the policy-only model file of a
// training checkpoint — no replay buffer, optimiser, critic or discriminator:
//   - of a train-base checkpoint (train/policy_export.hpp): config, actor, normaliser, action
//     space, counters and provenance; play, eval-base and train-residual --base read it like the
//     training checkpoint;
//   - of a train-residual checkpoint (train/residual_export.hpp): the residual or AdaptNet policy
//     with its frozen base; play-residual and eval-residual read it like the checkpoint.
#include "command_registry.hpp"

#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/core/error.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/sim/mujoco/character.hpp>
#include <maskadapt/train/policy_export.hpp>
#include <maskadapt/train/residual_export.hpp>
#include <maskadapt/train/stage2_policy.hpp>

#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <system_error>
#include <utility>


namespace {

struct ExportArgs {
  std::string checkpoint, out, note;
};

std::string megabytes(const std::filesystem::path& p) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << static_cast<double>(std::filesystem::file_size(p)) / 1e6 << " MB";
  return s.str();
}

std::string duration_text(double seconds) {
  if (!std::isfinite(seconds)) return "unknown";
  std::ostringstream s;
  if (seconds < 60) {
    s << std::fixed << std::setprecision(1) << seconds << " s";
    return s.str();
  }
  const long long t = std::llround(seconds);
  s << t / 3600 << "h" << std::setw(2) << std::setfill('0') << (t / 60) % 60 << "m" << std::setw(2) << t % 60 << "s";
  return s.str();
}

/// Checks --out before the (large) input is read: its directory must exist, and it must not be
/// a directory or the input itself (that would replace the training state by the export).
void check_out_path(const std::string& in, const std::string& out) {
  using maskadapt::Error;
  namespace fs = std::filesystem;
  if (out.empty()) throw Error("must name the file to write", {{}, std::nullopt, "--out"});
  std::error_code ec;
  const fs::path dir = fs::path(out).parent_path();
  if (!dir.empty() && !fs::is_directory(dir, ec))
    throw Error("directory '" + dir.string() + "' does not exist (export does not create directories)", {out, std::nullopt, "--out"});
  if (fs::is_directory(out, ec)) throw Error("is a directory; give the path of the file to write", {out, std::nullopt, "--out"});
  if (fs::exists(out, ec) && fs::equivalent(in, out, ec))
    throw Error("is the input checkpoint; writing the export over it would lose the training state",
                {out, std::nullopt, "--out"});
}

void run_export(const ExportArgs& a) {
  using namespace maskadapt;
  using namespace maskadapt::train;
  namespace fs = std::filesystem;
  check_out_path(a.checkpoint, a.out);
  const Checkpoint training = load_checkpoint(a.checkpoint);
  ExportInfo info;
  std::error_code ec;
  const fs::path abs = fs::absolute(a.checkpoint, ec);
  info.exported_from = ec ? a.checkpoint : abs.lexically_normal().string();
  info.git_commit = maskadapt::cli::build_commit();
  info.note = a.note;
  Checkpoint model;
  const bool stage2 = training.contains("residual_config");
  // a stage-2 export: build the policy the evaluations will build from it, on the bundled
  // humanoid, before anything is written (every section's size is checked)
  // (returns the policy's input and action counts)
  auto stage2_dims = [](const Checkpoint& m) -> std::pair<Index, Index> {
    const ResidualTrainConfig c = check_residual_export(m);
    const Skeleton& skel = mujoco_character(c.rl.env.character, "env.character").skeleton;
    if (c.method == "adaptnet") {
      const auto p = stage2_policy_from_checkpoint<adapt::AdaptNetPolicy<float>>(m, skel);
      return {p.input_dim(), p.action_dim()};
    }
    const auto p = stage2_policy_from_checkpoint<adapt::ResidualPolicy<float>>(m, skel);
    return {p.input_dim(), p.action_dim()};
  };
  if (stage2) {
    export_residual_policy(training, model, info);
    (void)stage2_dims(model);
  } else {
    export_base_policy(training, model, info);
  }
  save_checkpoint(a.out, model);
  // Read back what was written: the file on disk is the one that must load.
  const Checkpoint written = load_checkpoint(a.out);
  const ExportProvenance p = export_provenance(written);
  auto counter = [&](const char* name) {
    return written.contains(name) ? std::to_string(written.get_int(name)) : std::string("unknown");
  };
  std::cout << "export: " << a.checkpoint << " (" << megabytes(a.checkpoint) << ") -> " << a.out << " ("
            << megabytes(a.out) << ", " << written.size() << " sections, policy only)\n"
            << "export: iteration " << counter("trainer/iteration") << ", samples " << counter("trainer/samples");
  if (stage2) {
    const auto [inputs, actions] = stage2_dims(written);
    std::cout << ", task " << written.get_string("model/task") << ", method " << written.get_string("model/method")
              << ", policy input " << inputs << ", actions " << actions << "\n";
  } else {
    const ModelDims d = check_policy_export(written);
    std::cout << ", obs " << d.obs_dim << ", policy input " << d.policy_input_dim << ", actions " << d.action_dim << "\n";
  }
  std::cout << "export: training wall time " << duration_text(p.train_seconds) << "\n"
            << "export: training history:\n";
  std::istringstream lines(p.history);
  for (std::string line; std::getline(lines, line);) std::cout << "  " << line << "\n";
  std::cout << "export: exported from " << p.exported_from << " by commit " << p.export_git_commit << "\n";
  if (!p.note.empty()) std::cout << "export: note: " << p.note << "\n";
}

const bool registered = maskadapt::cli::register_command([](CLI::App& app) {
  auto args = std::make_shared<ExportArgs>();
  CLI::App* c = app.add_subcommand(
      "export", "Write the policy-only model file of a training checkpoint: stage 1 (for play, eval-base, train-residual --base) or "
                "stage 2 (for play-residual, eval-residual)");
  c->add_option("checkpoint", args->checkpoint, "training checkpoint (train-base or train-residual output)")
      ->required()
      ->check(CLI::ExistingFile);
  c->add_option("--out", args->out, "model file to write (its directory must exist)")->required();
  c->add_option("--note", args->note, "free text stored with the model (provenance/note)");
  c->callback([args] { run_export(*args); });
});

}  // namespace
