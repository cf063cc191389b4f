#pragma once
/// \file text_pool.hpp
/// Labelled training clips for the generator and the arms-related text pool.
///
/// `labelled_from_clip` turns a MotionClip (humanoid skeleton) into a LabelledTrajectory: its
/// labels, else its description, else words derived from its name ("02_10_wash_self" →
/// "wash self"). `load_labelled_clips(dir)` imports every .bvh / .npz under a directory with the
/// motion importer (CMU clips are named like that, so their descriptions become the labels).
/// `arms_text_pool` keeps the distinct labels that mention the arms (arm, hand, wave, punch,
/// raise, lift, wash, rotate, swing, clap, reach, throw, sword, box, wipe, swim, jack, …), which is what partial
/// tracking samples its prompts from.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/motion/clip.hpp>
#include <maskadapt/humanoid/retarget.hpp>
#include <maskadapt/tracking/primitive_dataset.hpp>
#include <maskadapt/tracking/text_encoder.hpp>

#include <algorithm>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

namespace maskadapt::tracking {

/// "02_10_wash_self" → "wash self": drops leading numeric words, joins the rest with spaces.
inline std::string text_from_clip_name(const std::string& name) {
  std::string spaced = name;
  std::replace(spaced.begin(), spaced.end(), '_', ' ');
  std::string out;
  for (const auto& w : tokenize_words(spaced)) {
    if (out.empty() && std::all_of(w.begin(), w.end(), [](char c) { return c >= '0' && c <= '9'; })) continue;
    if (!out.empty()) out += ' ';
    out += w;
  }
  return out;
}

/// Converts a clip (30 Hz, humanoid skeleton) to a labelled trajectory (see file comment).
inline LabelledTrajectory labelled_from_clip(const MotionClip& c, const Skeleton& skel) {
  require(c.num_dofs() == skel.num_dofs(), "clip '" + c.name + "' does not match the skeleton", {{}, {}, c.name});
  require(std::abs(c.fps - 30.0) < 1e-6, "clip '" + c.name + "' must be at 30 Hz (got " + std::to_string(c.fps) + ")",
          {{}, {}, c.name});
  LabelledTrajectory l;
  l.name = c.name;
  for (const auto& s : c.labels)
    if (!tokenize_words(s).empty()) l.texts.push_back(s);
  if (l.texts.empty()) {
    const std::string t = text_from_clip_name(c.name);
    if (!t.empty()) l.texts.push_back(t);
  }
  l.motion = Trajectory::zeros(skel, c.num_frames(), c.fps);
  l.motion.root_pos = c.root_pos;
  for (int i = 0; i < c.num_frames(); ++i) l.motion.root_rot[static_cast<std::size_t>(i)] = c.rot(i);
  l.motion.q = c.q;
  compute_body_positions(skel, l.motion);
  return l;
}

/// Imports every .bvh and .npz file directly inside `dir` (sorted by name). Files that fail to
/// import are reported through `skipped` (path: reason) instead of aborting.
inline std::vector<LabelledTrajectory> load_labelled_clips(const std::string& dir, const Skeleton& skel,
                                                           std::vector<std::string>* skipped = nullptr) {
  require(std::filesystem::is_directory(dir), "not a directory", {dir, {}, {}});
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const auto ext = e.path().extension().string();
    if (e.is_regular_file() && (ext == ".bvh" || ext == ".npz")) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  std::vector<LabelledTrajectory> out;
  for (const auto& f : files) {
    try {
      MotionClip c = import_motion(f.string());
      c.name = f.stem().string();
      out.push_back(labelled_from_clip(c, skel));
    } catch (const Error& e) {
      if (skipped) skipped->push_back(f.string() + ": " + e.what());
    }
  }
  return out;
}

/// Words that make a label arms-related.
inline const std::vector<std::string>& arms_keywords() {
  static const std::vector<std::string> k = {"arm",  "arms",  "hand",  "hands", "wave",  "waving", "punch", "punching",
                                             "box",  "boxing", "raise", "lift", "wash",  "rotate", "swing", "clap",
                                             "reach", "throw", "sword", "swordplay", "expressive", "high",
                                             "wipe", "swim", "swimming", "jack", "jacks", "punches"};
  return k;
}

/// True when the text mentions an arms keyword and no leg word (leg, legs, kick, kicks).
inline bool is_arms_related(const std::string& text) {
  bool arms = false;
  for (const auto& w : tokenize_words(text)) {
    if (w == "leg" || w == "legs" || w == "kick" || w == "kicks") return false;
    if (std::find(arms_keywords().begin(), arms_keywords().end(), w) != arms_keywords().end()) arms = true;
  }
  return arms;
}

/// Distinct arms-related labels of the clips (sorted). Throws if none is found.
inline std::vector<std::string> arms_text_pool(const std::vector<LabelledTrajectory>& clips) {
  std::set<std::string> s;
  for (const auto& c : clips)
    for (const auto& t : c.texts)
      if (is_arms_related(t)) s.insert(t);
  require(!s.empty(), "no arms-related label among the training clips", {{}, {}, "labels"});
  return {s.begin(), s.end()};
}

/// A prompt drawn uniformly from a pool.
inline const std::string& sample_text(const std::vector<std::string>& pool, Rng& rng) {
  require(!pool.empty(), "empty text pool", {{}, {}, "pool"});
  return pool[static_cast<std::size_t>(rng.uniform_int(pool.size()))];
}

}  // namespace maskadapt::tracking
