#pragma once
/// \file arm_data.hpp
/// Training data in which the arms follow a command: the labelled arm motions of the shared data
/// (the "arm catalog") and walking clips whose arms switch to one of them.
///
/// `arm_catalog()` lists the arm behaviours with their prompt (the label partial tracking asks
/// for), their other descriptions and the files they come from, relative to the data directory
/// ($MASKADAPT_DATA_DIR): Bandai gestures (waving with the left, right or both hands) and
/// actions (punches), the `styles` clips (boxing, wipe, swim, jumping jacks), the CMU arm clips,
/// and the built-in synthetic arm circles (so the catalog is never empty). Labels come from the
/// file names and the folders' READMEs (motions/bandai/README.md, motions/styles/README.md,
/// motions/cmu/README.md).
///
/// `make_arm_switch_clips` builds, per class, walking clips (locomotion on the lower body and
/// trunk, root included) whose arms cross-fade (motion/blend.hpp `blend_parts_switched`, 0.3 s)
/// from the walk's own swing to the class's arm motion at a random time, and in half of them back
/// again. The segments are labelled (walk texts / class texts), so a primitive whose history
/// still swings the arms but whose future waves is labelled "wave right hand": the generator
/// learns to change the arms on command from a walking history.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/rng.hpp>
#include <maskadapt/mask/parts.hpp>
#include <maskadapt/motion/blend.hpp>
#include <maskadapt/humanoid/retarget.hpp>
#include <maskadapt/humanoid/synthetic.hpp>
#include <maskadapt/tracking/text_pool.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace maskadapt::tracking {

/// Files of one arm behaviour: every .bvh in `<data>/<folder>` whose name contains one of
/// `include`; folder "synthetic" names a built-in clip (synthetic_clip) instead.
struct ArmMotionSource {
  std::string folder;
  std::vector<std::string> include;
  /// The span of each file that shows the behaviour (s; default: the whole clip). With
  /// `ping_pong` the span is played forwards then backwards (without repeating its end frames), so
  /// that looping it (arm-switch blends loop their arm clip) stays continuous.
  double begin_s = 0.0, end_s = INFINITY;
  bool ping_pong = false;
};

/// Frames [round(begin_s·fps), round(end_s·fps)] of c (clamped to the clip), optionally followed by
/// the same frames backwards without the two end frames (see ArmMotionSource). Throws naming the
/// clip when the span holds fewer than 2 frames.
inline MotionClip clip_span(const MotionClip& c, double begin_s, double end_s, bool ping_pong) {
  const int n = c.num_frames();
  const int b = std::clamp(static_cast<int>(std::lround(begin_s * c.fps)), 0, std::max(0, n - 1));
  const int e = std::isfinite(end_s) ? std::clamp(static_cast<int>(std::lround(end_s * c.fps)), 0, n - 1) : n - 1;
  require(e - b + 1 >= 2, "the span " + std::to_string(begin_s) + "-" + std::to_string(end_s) + " s holds fewer than 2 frames",
          {{}, {}, c.name});
  const int m = e - b + 1, total = ping_pong ? 2 * m - 2 : m;
  MotionClip out = c;
  out.resize(total, c.num_dofs());
  for (int i = 0; i < total; ++i) {
    const int src = i < m ? b + i : e - (i - m + 1);  // backwards: e − 1, …, b + 1
    out.root_pos.col(i) = c.root_pos.col(src);
    out.root_rot.col(i) = c.root_rot.col(src);
    out.q.col(i) = c.q.col(src);
  }
  return out;
}

struct ArmMotionClass {
  std::string prompt;               ///< the label tracking asks for (first of texts)
  std::vector<std::string> texts;   ///< every description used in training (prompt first)
  std::vector<ArmMotionSource> sources;
};

/// The arm behaviours of the shared data (see file comment). Not taken: the Bandai `bye` clips
/// (which hand waves is not documented), kicks (legs), and clips without arm content.
inline const std::vector<ArmMotionClass>& arm_catalog() {
  static const std::vector<ArmMotionClass> c = {
      {"wave right hand", {"wave right hand", "wave with the right hand", "right hand waves"},
       {{"motions/bandai/gestures", {"_wave-right-hand_"}}}},
      {"wave left hand", {"wave left hand", "wave with the left hand", "left hand waves"},
       {{"motions/bandai/gestures", {"_wave-left-hand_"}}}},
      {"wave both hands", {"wave both hands", "wave with both hands", "wave hands"},
       {{"motions/bandai/gestures", {"_wave-both-hands_"}}}},
      {"punch", {"punch", "box", "boxing", "throw punches"},
       {{"motions/bandai/actions", {"_punch_"}}, {"motions/styles", {"box-"}}, {"motions/cmu", {"02_05_punch"}}}},
      {"wipe", {"wipe", "wipe in circles"}, {{"motions/styles", {"wipe"}}}},
      {"swim", {"swim", "swimming strokes"}, {{"motions/styles", {"swim"}}}},
      {"jumping jack arms", {"jumping jack arms", "jumping jacks", "swing arms overhead"},
       {{"motions/styles", {"jumping-jack"}}}},
      // 05_12 holds its arms high only from 9.4 to 10.8 s (a wrist 0.5-0.9 m above the pelvis; before
      // that both hang at pelvis height while the upper body rotates): that span, played to and fro.
      {"arms high", {"arms high", "raise arms", "raise both arms"}, {{"motions/cmu", {"05_12_arms_high"}, 9.4, 10.8, true}}},
      {"lift arm", {"lift arm"}, {{"motions/cmu", {"02_06_lift_arm"}}}},
      {"swordplay", {"swordplay", "sword fight"}, {{"motions/cmu", {"02_07_swordplay"}}}},
      {"wash self", {"wash self"}, {{"motions/cmu", {"02_10_wash_self"}}}},
      {"expressive arms", {"expressive arms"}, {{"motions/cmu", {"05_02_expressive_arms"}}}},
      {"rotate arms", {"rotate arms", "arm circles"}, {{"synthetic", {"arms"}}}},
  };
  return c;
}

/// The clips of one class found under `data_dir` (empty when its files are absent), labelled with
/// the class's texts, at 30 Hz on the humanoid.
inline std::vector<MotionClip> load_arm_class(const ArmMotionClass& cls, const std::string& data_dir) {
  namespace fs = std::filesystem;
  std::vector<MotionClip> out;
  for (const auto& src : cls.sources) {
    if (src.folder == "synthetic") {
      for (const auto& n : src.include) out.push_back(synthetic_clip(n));
      continue;
    }
    const fs::path dir = fs::path(data_dir) / src.folder;
    if (data_dir.empty() || !fs::is_directory(dir)) continue;
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(dir)) {
      if (e.path().extension() != ".bvh") continue;
      const std::string f = e.path().filename().string();
      for (const auto& s : src.include)
        if (f.find(s) != std::string::npos) {
          files.push_back(e.path());
          break;
        }
    }
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
      MotionClip c = import_motion(f.string());
      c.name = f.stem().string();
      if (src.begin_s > 0 || std::isfinite(src.end_s) || src.ping_pong) c = clip_span(c, src.begin_s, src.end_s, src.ping_pong);
      out.push_back(std::move(c));
    }
  }
  for (auto& c : out) c.labels = cls.texts;
  return out;
}

/// The catalog's classes with at least one clip under data_dir, and their clips (same order).
struct ArmData {
  std::vector<ArmMotionClass> classes;
  std::vector<std::vector<MotionClip>> clips;  ///< (classes) clips of each class
  /// The prompts (class order): the arms pool of a generator trained on these data.
  std::vector<std::string> prompts() const {
    std::vector<std::string> p;
    for (const auto& c : classes) p.push_back(c.prompt);
    return p;
  }
};

/// Loads the catalog from data_dir. The synthetic class is always present, so with an empty or
/// missing data_dir only "rotate arms" results (callers that need the real classes check).
inline ArmData load_arm_data(const std::string& data_dir) {
  ArmData d;
  for (const auto& cls : arm_catalog()) {
    auto clips = load_arm_class(cls, data_dir);
    if (clips.empty()) continue;
    d.classes.push_back(cls);
    d.clips.push_back(std::move(clips));
  }
  return d;
}

struct ArmSwitchOptions {
  double active_seconds_per_class = 120.0;  ///< total seconds of arm motion per class (fade included)
  double min_on_s = 0.7, max_on_s = 2.5;    ///< switch time after the walk clip's start (s)
  double min_hold_s = 2.0, max_hold_s = 4.0; ///< length of the switched segment when it switches back (s)
  double back_probability = 0.5;            ///< chance that the arms return to the walk's swing
  double fade_s = 0.3;                      ///< cross-fade (s)
  /// Relative probability of each walk (the `walks` given to make_arm_switch_clips); empty: every
  /// walk equally likely (drawn as before the weights existed, so older runs are reproduced).
  std::vector<double> walk_weights;
};

/// Walking clips whose arms switch to each class's motion (see file comment). `walks`: world-frame
/// walking clips (30 Hz) with their labels; the result holds segments labelled walk texts / class
/// texts. Deterministic given rng.
inline std::vector<LabelledTrajectory> make_arm_switch_clips(const std::vector<MotionClip>& walks, const ArmData& arms,
                                                             const Skeleton& skel, Rng& rng,
                                                             const ArmSwitchOptions& opt = {}) {
  require(!walks.empty(), "no walking clips to blend the arm motions onto", {{}, {}, "walks"});
  require(opt.active_seconds_per_class > 0 && opt.min_on_s >= 0 && opt.max_on_s >= opt.min_on_s &&
              opt.min_hold_s > 0 && opt.max_hold_s >= opt.min_hold_s && opt.fade_s >= 0,
          "bad arm switch options", {{}, {}, "ArmSwitchOptions"});
  require(opt.walk_weights.empty() || (opt.walk_weights.size() == walks.size() &&
                                       std::all_of(opt.walk_weights.begin(), opt.walk_weights.end(),
                                                   [](double w) { return std::isfinite(w) && w >= 0; }) &&
                                       std::any_of(opt.walk_weights.begin(), opt.walk_weights.end(), [](double w) { return w > 0; })),
          "walk weights: one finite weight ≥ 0 per walk, not all 0", {{}, {}, "walk_weights"});
  const PartMask arms_mask = PartMask::parse("arms", "arms");
  std::vector<LabelledTrajectory> out;
  for (std::size_t c = 0; c < arms.classes.size(); ++c) {
    double active = 0.0;
    int k = 0;
    while (active < opt.active_seconds_per_class) {
      const MotionClip& w = walks[opt.walk_weights.empty() ? static_cast<std::size_t>(rng.uniform_int(walks.size()))
                                                           : draw_weighted(opt.walk_weights, rng)];
      const auto& pool = arms.clips[c];
      const MotionClip& b = pool[static_cast<std::size_t>(rng.uniform_int(pool.size()))];
      const double dur = w.duration();
      const double on = std::min(opt.min_on_s + rng.uniform() * (opt.max_on_s - opt.min_on_s), 0.5 * dur);
      double off = INFINITY;
      if (rng.uniform() < opt.back_probability) off = on + opt.min_hold_s + rng.uniform() * (opt.max_hold_s - opt.min_hold_s);
      if (off > dur - 0.5) off = INFINITY;  // too late to show the return
      BlendOptions bo;
      bo.b_offset = rng.uniform() * std::max(0.0, b.duration() - 1.0) - on;  // b at a random phase when it starts
      bo.loop_b = true;
      MotionClip m = blend_parts_switched(w, b, arms_mask, skel, PartSwitch{on, off, opt.fade_s}, bo);
      m.name = w.name + "+" + arms.classes[c].prompt + "#" + std::to_string(k++);
      LabelledTrajectory l = labelled_from_clip(m, skel);
      const auto walk_texts = l.texts;
      const Index on_f = static_cast<Index>(std::lround(on * w.fps));
      l.segments.push_back({0, walk_texts});
      l.segments.push_back({on_f, arms.classes[c].texts});
      if (std::isfinite(off)) l.segments.push_back({static_cast<Index>(std::lround(off * w.fps)), walk_texts});
      l.texts = arms.classes[c].texts;
      active += (std::isfinite(off) ? off : dur) - on;
      out.push_back(std::move(l));
    }
  }
  return out;
}

/// Everything `train-generator` trains on (see docs/generator.md "Training data").
struct GeneratorCorpus {
  std::vector<LabelledTrajectory> clips;  ///< real clips, synthetic clips and the arm-switch clips
  ArmData arms;                           ///< the arm classes found (their prompts: the arms pool)
  std::vector<MotionClip> walks;          ///< the walking clips the arms were blended onto
  Index num_real = 0, num_synthetic = 0, num_switch = 0;  ///< clips of each kind in `clips`
  std::vector<std::string> skipped;       ///< files that failed to import (path: reason)
};

/// True when a CMU file name belongs to one of the catalog's classes (loaded there instead).
inline bool in_arm_catalog(const std::string& stem) {
  for (const auto& c : arm_catalog())
    for (const auto& s : c.sources)
      if (s.folder == "motions/cmu")
        for (const auto& n : s.include)
          if (stem.find(n) != std::string::npos) return true;
  return false;
}

/// A named group of walking clips (one source of walking histories).
struct WalkGroup {
  std::string name;
  std::vector<MotionClip> clips;  ///< 30 Hz, humanoid, labelled "walk forward", "walk"
};

/// The walking sources of the shared data other than the Bandai walks (issue 42): the CMU walks
/// 02_01 and 07_01, the styles walk and female walk (one group each; absent files are left out),
/// and the built-in synthetic walk. Absent files are named in `missing`.
inline std::vector<WalkGroup> other_walk_groups(const std::string& data_dir, std::vector<std::string>* missing = nullptr) {
  namespace fs = std::filesystem;
  std::vector<WalkGroup> out;
  const std::pair<const char*, const char*> files[] = {{"cmu 02_01", "motions/cmu/02_01_walk.bvh"},
                                                       {"cmu 07_01", "motions/cmu/07_01_walk.bvh"},
                                                       {"styles walk", "motions/styles/walk.bvh"},
                                                       {"styles female-walk", "motions/styles/female-walk.bvh"}};
  for (const auto& [name, rel] : files) {
    const fs::path f = fs::path(data_dir) / rel;
    if (data_dir.empty() || !fs::is_regular_file(f)) {
      if (missing) missing->push_back(f.string());
      continue;
    }
    MotionClip c = import_motion(f.string());
    c.name = f.stem().string();
    c.labels = {"walk forward", "walk"};
    out.push_back({name, {std::move(c)}});
  }
  MotionClip w = synthetic_walk();
  w.labels = {"walk forward", "walk"};
  out.push_back({"synthetic walk", {std::move(w)}});
  return out;
}

/// Loads the corpus from data_dir (the folder holding motions/): the CMU clips (labels from file
/// names; the arm ones through the catalog), the arm catalog's clips, the Bandai straight walks
/// (`bandai-walk-straight`; the synthetic walk when absent) and the arm-switch clips made from
/// them, plus the built-in synthetic clips. `arm_switch.active_seconds_per_class` = 0 makes no
/// switch clips.
///
/// `more_walks` (issue 42): further groups of walks (other_walk_groups, rollouts of a base policy)
/// that the arms are blended onto as well. Each group — the Bandai walks being one — then gives the
/// walk of a blend with equal probability (a clip uniformly within its group; this replaces
/// `arm_switch.walk_weights`), and the groups' clips join the corpus as plain walks (the synthetic
/// walk is there already).
///
/// `standing_arm_clips` = false leaves the catalog's clips as recorded (standing, mostly) out of
/// the corpus: their arm motions then come only through the arm-switch blends, on walks (issue 42:
/// as recorded they teach a prompt such as "swim" to stop walking).
inline GeneratorCorpus load_generator_corpus(const std::string& data_dir, const Skeleton& skel, Rng& rng,
                                             const ArmSwitchOptions& arm_switch = {},
                                             const std::vector<WalkGroup>& more_walks = {},
                                             bool standing_arm_clips = true) {
  namespace fs = std::filesystem;
  GeneratorCorpus g;
  const fs::path cmu = fs::path(data_dir) / "motions" / "cmu";
  if (!data_dir.empty() && fs::is_directory(cmu))
    for (auto& c : load_labelled_clips(cmu.string(), skel, &g.skipped))
      if (!in_arm_catalog(c.name)) g.clips.push_back(std::move(c));
  g.arms = load_arm_data(data_dir);
  if (standing_arm_clips)
    for (const auto& cls : g.arms.clips)
      for (const auto& c : cls)
        if (c.name.rfind("synthetic_", 0) != 0) g.clips.push_back(labelled_from_clip(c, skel));
  if (const MotionSetSpec* spec = find_motion_set("bandai-walk-straight");
      spec && !data_dir.empty() && fs::is_directory(fs::path(data_dir) / spec->folder)) {
    g.walks = load_motion_set(*spec, data_dir);
    for (const auto& w : g.walks) g.clips.push_back(labelled_from_clip(w, skel));
  }
  g.num_real = static_cast<Index>(g.clips.size());
  for (const MotionClip& c : builtin_motion_set("synthetic", data_dir)) g.clips.push_back(labelled_from_clip(c, skel));
  g.num_synthetic = static_cast<Index>(g.clips.size()) - g.num_real;
  if (g.walks.empty()) g.walks.push_back(synthetic_walk());
  ArmSwitchOptions ao = arm_switch;
  if (!more_walks.empty()) {
    const std::size_t groups = 1 + more_walks.size();
    ao.walk_weights.assign(g.walks.size(), 1.0 / (static_cast<double>(groups) * static_cast<double>(g.walks.size())));
    for (const auto& grp : more_walks) {
      require(!grp.clips.empty(), "walk group '" + grp.name + "' holds no clip", {{}, {}, "walks"});
      for (const auto& c : grp.clips) {
        g.walks.push_back(c);
        ao.walk_weights.push_back(1.0 / (static_cast<double>(groups) * static_cast<double>(grp.clips.size())));
        if (c.name.rfind("synthetic_", 0) != 0) {
          g.clips.insert(g.clips.begin() + g.num_real, labelled_from_clip(c, skel));
          ++g.num_real;
        }
      }
    }
  }
  if (arm_switch.active_seconds_per_class > 0) {
    auto sw = make_arm_switch_clips(g.walks, g.arms, skel, rng, ao);
    g.num_switch = static_cast<Index>(sw.size());
    for (auto& c : sw) g.clips.push_back(std::move(c));
  }
  return g;
}

}  // namespace maskadapt::tracking
