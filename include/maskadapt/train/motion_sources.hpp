#pragma once
/// \file motion_sources.hpp
/// Glue between the motion library and the trainer: build a MotionLibrary from the config's
/// `env.motions` list, and derive the task's reset sampler (reference state initialisation with
/// the 4 preceding reference frames as discriminator history) and the discriminator's real
/// window sampler from it.
#include <maskadapt/core/error.hpp>
#include <maskadapt/motion/library.hpp>
#include <maskadapt/humanoid/synthetic.hpp>
#include <maskadapt/sim/mujoco/character.hpp>
#include <maskadapt/tasks/composition.hpp>
#include <maskadapt/tasks/imitation.hpp>
#include <maskadapt/train/base_trainer.hpp>
#include <maskadapt/train/library_reset.hpp>

#include <algorithm>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace maskadapt::train {

/// Adds every source to a library on the reference humanoid. A source is a built-in set name
/// (`locomotion`, `synthetic`, `walk`, `arms`, `kick`, `jump`, or a real set of the data
/// directory: `bandai-locomotion`, `bandai-walk`, `bandai-walk-straight`, `bandai-turn`,
/// `bandai-run`, `bandai-gestures`, `bandai-actions`, `styles`, `cmu-131` — motion_set_specs()),
/// a directory (all .bvh/.npz files in it, sorted) or one clip file. Throws naming the source
/// when nothing can be loaded.
///
/// On another character (`character`, sim/mujoco/character.hpp) the library holds that
/// character's clips: every humanoid clip the sources name goes through
/// `character.from_humanoid` (the G1: retargeted, 0.2 s per 6-s clip), and a file in the
/// character's own format (`character.read_own_clip`; the G1's: `maskadapt motion import
/// --character g1`) is taken as it is.
inline std::shared_ptr<MotionLibrary> load_motion_library(const std::vector<std::string>& sources,
                                                          const std::string& data_dir = motion_data_dir(),
                                                          const MujocoCharacter& character = mujoco_character("humanoid")) {
  auto lib = std::make_shared<MotionLibrary>(character.skeleton);
  auto add = [&](MotionClip c) { lib->add(character.from_humanoid ? character.from_humanoid(c) : std::move(c)); };
  auto add_file = [&](const std::string& path) {
    std::optional<MotionClip> own = character.read_own_clip ? character.read_own_clip(path) : std::nullopt;
    if (own) lib->add(std::move(*own));
    else add(import_motion(path));
  };
  for (const auto& src : sources) {
    namespace fs = std::filesystem;
    if (fs::is_directory(src)) {
      std::vector<fs::path> files;
      for (const auto& e : fs::directory_iterator(src))
        if (e.path().extension() == ".bvh" || e.path().extension() == ".npz") files.push_back(e.path());
      std::sort(files.begin(), files.end());
      require(!files.empty(), "no .bvh or .npz clips in directory", {src, std::nullopt, "env.motions"});
      for (const auto& f : files) add_file(f.string());
    } else if (fs::is_regular_file(src)) {
      add_file(src);
    } else {
      for (auto& c : builtin_motion_set(src, data_dir)) add(std::move(c));
    }
  }
  require(lib->num_clips() > 0, "no motion clips loaded", {{}, std::nullopt, "env.motions"});
  return lib;
}

// (reset_sample_at and library_reset_sampler: train/library_reset.hpp)

/// RSI for composition: a share `from_blends` of the resets (a Bernoulli draw per reset) starts
/// from the part-wise blends — a mask of the set drawn uniformly, then a (clip, time) of its blend
/// library, so the adapted parts start in a pose of B and the rest in one of A — and the others
/// from A as library_reset_sampler(base). Lets the residual practise B's parts from B's own
/// poses (a kick mid-swing) rather than only from A's. `from_blends` = 0 is exactly
/// library_reset_sampler(base) (no extra draw). Note: the blend's mask is drawn here, apart from
/// the env's episode mask; with a one-mask set they are the same.
inline tasks::ResetSampler blended_reset_sampler(std::shared_ptr<const MotionLibrary> base,
                                                 std::shared_ptr<const tasks::BlendedMotionSet> blends,
                                                 double from_blends) {
  require(std::isfinite(from_blends) && from_blends >= 0 && from_blends <= 1, "must be in [0, 1]",
          {{}, std::nullopt, "blend_resets"});
  tasks::ResetSampler from_a = library_reset_sampler(base);
  if (from_blends == 0) return from_a;
  require(blends != nullptr, "resets from blends need the blended motion set", {{}, std::nullopt, "blend_resets"});
  std::vector<tasks::ResetSampler> from_blend;
  for (std::size_t k = 0; k < blends->masks().size(); ++k)
    from_blend.push_back(library_reset_sampler(std::shared_ptr<const MotionLibrary>(blends, &blends->library(k))));
  return [from_a, from_blend, from_blends](Rng& rng) {
    if (!rng.bernoulli(from_blends)) return from_a(rng);
    return from_blend[static_cast<std::size_t>(rng.uniform_int(from_blend.size()))](rng);
  };
}

/// Real discriminator windows from the library (same layout as the task's windows), computed on
/// `pool` when one is given (bit-identical for any pool size; the trainer's env pool is idle then).
inline RealWindowSampler library_window_sampler(std::shared_ptr<const MotionLibrary> lib, ThreadPool* pool = nullptr) {
  return [lib, pool](Rng& rng, Eigen::Ref<MatrixXf> out) {
    lib->sample_amp_windows(rng, out, pool);
  };
}

}  // namespace maskadapt::train
