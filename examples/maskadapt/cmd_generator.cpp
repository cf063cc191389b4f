// `maskadapt train-generator`, `maskadapt generate`, `maskadapt eval-generator` and
// `maskadapt map-prompt`: the built-in text-conditioned motion generator
// (tracking/builtin_generator.hpp; data: tracking/arm_data.hpp; probe: tracking/arm_eval.hpp;
// unseen words: tracking/lexicon.hpp, tracking/prompt_words.hpp).
#include "cli_checks.hpp"
#include "command_registry.hpp"

#include <maskadapt/eval/rollout_file.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/motion/bvh.hpp>
#include <maskadapt/humanoid/retarget.hpp>
#include <maskadapt/humanoid/synthetic.hpp>
#include <maskadapt/tracking/arm_data.hpp>
#include <maskadapt/tracking/arm_eval.hpp>
#include <maskadapt/tracking/builtin_generator.hpp>
#include <maskadapt/tracking/prompt_words.hpp>
#include <maskadapt/tracking/text_pool.hpp>

#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/train/base_policy.hpp>
#include <maskadapt/train/base_walks.hpp>
#include <maskadapt/train/config.hpp>
#include <maskadapt/train/motion_sources.hpp>
#include <maskadapt/train/play.hpp>
#ifdef MASKADAPT_HAS_MUJOCO
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>
#endif

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>

namespace {

using namespace maskadapt;
using namespace maskadapt::tracking;

/// The data directory (the folder holding motions/): --data, else $MASKADAPT_DATA_DIR, else the
/// checkout's ../shared/data.
std::string data_root(const std::string& flag) {
  if (!flag.empty()) return flag;
  if (const char* e = std::getenv("MASKADAPT_DATA_DIR"); e && *e) return e;
  return maskadapt::cli::source_dir() + "/../shared/data";
}

/// The shipped generator (models/README.md "text_generator.bin").
std::string shipped_generator() { return maskadapt::cli::source_dir() + "/models/text_generator.bin"; }

/// The shipped mask-invariant base (models/README.md "mask_mi_walk_bandai.bin").
std::string shipped_base() { return maskadapt::cli::source_dir() + "/models/mask_mi_walk_bandai.bin"; }

/// Walks of a base policy under the simulator — what partial tracking's generator is given when it
/// continues the simulated character: one rollout per seed of `seconds` (30 Hz, no mask, sampled
/// actions, RSI from the policy's own motion set; train::play_base_policy), labelled "walk forward",
/// "walk". A rollout in which the humanoid falls is refused naming the seed (`flag` names the
/// option that asked for it).
std::vector<MotionClip> base_rollout_walks(const std::string& checkpoint, const std::vector<std::uint64_t>& seeds,
                                           double seconds, const std::string& data_dir, const std::string& flag) {
#ifndef MASKADAPT_HAS_MUJOCO
  (void)checkpoint, (void)seeds, (void)seconds, (void)data_dir;
  throw Error("this build has no MuJoCo: rollouts of a base policy need the maskadapt::mujoco target", {{}, {}, flag});
#else
  using namespace maskadapt::train;
  require(std::filesystem::is_regular_file(checkpoint), "base policy not found", {checkpoint, std::nullopt, flag});
  try {
    const Checkpoint ck = load_checkpoint(checkpoint);
    const MujocoCharacter& character = mujoco_character(checkpoint_character(ck, checkpoint), checkpoint + " (env.character)");
    require(character.name == "humanoid", "the generator's histories need a base policy of the humanoid (got " + character.name + ")",
            {checkpoint, std::nullopt, flag});
    MujocoHumanoidSim sim(1, 1, character);
    const PolicyDims dims{observation_dim(sim.skeleton()), observation_dim(sim.skeleton()) + kNumParts,
                          sim.skeleton().num_dofs(), observation_dim(sim.skeleton()) * kAmpWindowFrames};
    const LoadedBasePolicy loaded = load_base_policy(ck, dims, checkpoint);
    auto lib = load_motion_library(loaded.config.env.motions, data_dir, character);
    return base_policy_walks(sim, loaded.policy, library_reset_sampler(lib),
                             character.fall_criteria(loaded.config.env.termination_height),
                             loaded.config.env.termination_height, seeds, seconds);
  } catch (const Error& e) {  // name the flag: a generator or a stage-2 file given as the base, a fall
    throw Error(std::string(e.what()) + " (is it a stage-1 base policy?)", {checkpoint, std::nullopt, flag});
  }
#endif
}

std::string machine_line() {
  std::ifstream f("/proc/cpuinfo");
  std::string line;
  int cores = 0;
  std::string model = "unknown CPU";
  while (std::getline(f, line)) {
    if (line.rfind("model name", 0) == 0 && model == "unknown CPU") model = line.substr(line.find(':') + 2);
    if (line.rfind("processor", 0) == 0) ++cores;
  }
  return model + ", " + std::to_string(cores) + " logical cores";
}

struct TrainOptions {
  std::string data, out, mix = "arms";
  double minutes = 0.0, arm_seconds = 120.0, guidance = -1.0, temperature = -1.0;  ///< < 0: the defaults (5, 1)
  double transition_fraction = 0.0;
  double ema = 0.0;                 ///< EMA decay of the denoiser's weights (0: off)
  long long select_every = 0;       ///< > 0: score every N diffusion iterations, keep the best
  long long select_samples = 20;    ///< samples per prompt of each score
  unsigned long long select_seed = 1001;
  long long iterations = 2000;
  long long vae_iterations = 0, diffusion_iterations = 0;  ///< > 0: this stage's count instead of --iterations
  long long batch = 64;
  unsigned long long seed = 1;
  int stride = 2;
  std::string walks = "bandai";  ///< the walks the arms are blended onto: bandai, or all (issue 42)
  bool standing_arm_clips = true;  ///< the catalog's clips as recorded join the corpus
  std::string base_walks;        ///< a base policy whose simulated walks join them ("" : none)
  long long base_walk_count = 8;
  double base_walk_seconds = 10.0;
};

struct GenerateOptions {
  std::string checkpoint, text = "raise arms", bvh, rollout, from = "walk", data, wordnet;
  double seconds = 5.0, guidance = -1.0, temperature = -1.0;  ///< < 0: not given (the checkpoint's)
  unsigned long long seed = 1;
};

struct MapPromptOptions {
  std::string checkpoint, data, wordnet;
  std::vector<std::string> prompts;
  bool paraphrases = false, heldout = false, vocabulary = false, labels = false;
};

/// The generator's training labels and a prompt mapper over them (WordNet from --wordnet, else
/// $MASKADAPT_WORDNET_DIR, else /usr/share/wordnet), installed into g. Says what it used.
TrainingLabels install_prompt_mapper(BuiltinGenerator& g, const std::string& data_flag, const std::string& wordnet_flag) {
  const Skeleton& skel = humanoid_skeleton();
  TrainingLabels labels = generator_training_labels(g, data_root(data_flag), skel);
  const std::filesystem::path wn = wordnet_flag.empty() ? default_wordnet_dir() : std::filesystem::path(wordnet_flag);
  if (!wordnet_flag.empty()) (void)WordNet::load(wn);  // a named folder must hold the dictionary: say which file is missing
  g.set_prompt_mapper(make_prompt_mapper(labels.sets, wn));
  std::cout << "vocabulary: " << g.prompt_mapper()->vocabulary().size() << " words of " << labels.sets.size()
            << " training label sets (" << labels.source << "); "
            << (g.prompt_mapper()->wordnet() ? "unseen words mapped through WordNet in " + wn.string()
                                             : "WordNet not found in " + wn.string() +
                                                   " (apt-get install wordnet-base): unseen words are dropped, not mapped")
            << "\n";
  return labels;
}

struct EvalOptions {
  std::string checkpoint, data, out, save, probe;  ///< probe empty: the library default (ArmProbeConfig{})
  bool per_source = false;  ///< issue 42: accuracy and arm/pelvis/speed figures per walking-history source
  std::string base;         ///< the base whose simulated walks are one source (default: the shipped base; "none": left out)
  std::vector<std::string> prompts, paraphrases;
  long long samples = 10;
  unsigned long long seed = 1;
  double guidance = -1.0, temperature = -1.0;  ///< < 0: the checkpoint's
};

void run_train(const TrainOptions& o) {
  const Skeleton& skel = humanoid_skeleton();
  const std::string root = data_root(o.data);
  Rng data_rng(o.seed + 1000);
  GeneratorCorpus corpus;
  if (o.mix == "legacy") {  // the data of the first version: CMU clips + synthetic clips, one label set per clip
    const std::string dir = root + "/motions/cmu";
    if (std::filesystem::is_directory(dir)) corpus.clips = load_labelled_clips(dir, skel, &corpus.skipped);
    corpus.num_real = static_cast<Index>(corpus.clips.size());
    for (const MotionClip& c : builtin_motion_set("synthetic", root)) corpus.clips.push_back(labelled_from_clip(c, skel));
    corpus.num_synthetic = 4;
  } else {
    ArmSwitchOptions ao;
    ao.active_seconds_per_class = o.arm_seconds;
    std::vector<WalkGroup> more;
    if (o.walks == "all") {
      std::vector<std::string> missing;
      more = other_walk_groups(root, &missing);
      for (const auto& m : missing) std::cerr << "--walks all: " << m << " not found, left out\n";
    }
    if (!o.base_walks.empty()) {  // rollout seeds 101+: eval-generator --per-source uses seeds 1 and 2
      std::vector<std::uint64_t> seeds;
      for (long long k = 0; k < o.base_walk_count; ++k) seeds.push_back(101 + static_cast<std::uint64_t>(k));
      more.push_back({"base rollouts", base_rollout_walks(o.base_walks, seeds, o.base_walk_seconds, root, "--base-walks")});
    }
    for (const auto& grp : more) std::cout << "walk group '" << grp.name << "': " << grp.clips.size() << " clip(s)\n";
    corpus = load_generator_corpus(root, skel, data_rng, ao, more, o.standing_arm_clips);
    if (corpus.arms.classes.size() <= 1)
      std::cerr << "no arm clips under " << root << "/motions (set --data or MASKADAPT_DATA_DIR): the arms pool is "
                << "the synthetic arm circles only\n";
  }
  for (const auto& s : corpus.skipped) std::cerr << "skipped " << s << "\n";
  const auto data = make_primitive_dataset(skel, corpus.clips, 5, 15, o.stride);
  const std::vector<std::string> pool = o.mix == "legacy" ? arms_text_pool(corpus.clips) : corpus.arms.prompts();
  std::cout << "data " << root << " (mix " << o.mix << "): clips: " << corpus.clips.size() << " (" << corpus.num_real
            << " real, " << corpus.num_synthetic << " synthetic, " << corpus.num_switch << " arm-switch blends onto "
            << corpus.walks.size() << " walks), windows: " << data.size() << " (H = 5, F = 15, stride " << o.stride
            << ")\narms text pool (" << pool.size() << "):";
  for (const auto& t : pool) std::cout << " '" << t << "'";
  std::cout << "\n";
  Rng rng(o.seed);
  BuiltinGeneratorConfig gc;
  if (o.guidance >= 0) gc.guidance = o.guidance;
  if (o.temperature > 0) gc.temperature = o.temperature;
  BuiltinGenerator g(skel, gc, rng);
  std::cout << "parameters: vae encoder " << g.vae().encoder().num_params() << ", decoder "
            << g.vae().decoder().num_params() << ", denoiser " << g.denoiser().network().num_params()
            << ", text projection " << g.denoiser().projection().num_params() << "\n";
  GeneratorTrainConfig tc;
  tc.vae_iterations = o.vae_iterations > 0 ? o.vae_iterations : o.iterations;
  tc.diffusion_iterations = o.diffusion_iterations > 0 ? o.diffusion_iterations : o.iterations;
  if (o.minutes > 0) {
    tc.max_seconds = 60.0 * o.minutes;
    tc.vae_iterations = tc.diffusion_iterations = 1'000'000'000;
  }
  tc.batch = o.batch;
  tc.transition_fraction = o.transition_fraction;
  std::cout << "transition windows: " << std::count(data.transition.begin(), data.transition.end(), 1) << " of "
            << data.size() << ", drawn for " << 100.0 * o.transition_fraction << " % of each diffusion batch\n";
  tc.log_every = std::max<Index>(1, std::min<Index>(200, tc.vae_iterations / 5));
  tc.ema_decay = o.ema;
  tc.select_every = o.select_every;
  // Selection (--select-every): the arm-following accuracy of eval-generator, but on its own draws —
  // a classifier fitted on other blended windows (seed 777, not eval-generator's 12345) and sample
  // seeds from --select-seed (default 1001+, disjoint from eval-generator's 1+) — so the figure that
  // eval-generator reports afterwards was not the one maximised.
  GeneratorScore score;
  std::unique_ptr<GeneratorEvalSet> select_set;
  std::vector<std::vector<Trajectory>> select_histories;  // per source, world frame, H frames each
  if (o.select_every > 0) {
    Rng select_rng(777);
    select_set = std::make_unique<GeneratorEvalSet>(make_generator_eval_set(root, skel, select_rng));
    if (o.walks == "all" || !o.base_walks.empty()) {
      // issue 42: every source the blends used, at other times than eval-generator's (1.5 s and 2.5 s)
      if (o.walks == "all")
        for (const auto& src : walking_history_sources(root, skel, 5, nullptr, {45, 75})) select_histories.push_back(src.histories);
      else
        select_histories.push_back(select_set->histories);
      if (!o.base_walks.empty()) {  // rollout seeds 201, 202
        std::vector<LabelledTrajectory> l;
        for (const auto& w : base_rollout_walks(o.base_walks, {201, 202}, 4.0, root, "--base-walks")) l.push_back(labelled_from_clip(w, skel));
        select_histories.push_back(walking_history_source("base rollouts", skel, l, {45, 75}).histories);
      }
    } else {
      select_histories.push_back(select_set->histories);
    }
    score = [&, samples = o.select_samples, seed = o.select_seed](const BuiltinGenerator& gen) {
      PromptEvalOptions po;
      po.samples = samples;
      po.seed = seed;
      double acc = 0;  // the mean over the sources
      for (const auto& h : select_histories)
        acc += evaluate_prompts(gen, select_set->prompts, h, select_set->classifier, po).overall_accuracy();
      return acc / static_cast<double>(select_histories.size());
    };
    std::cout << "selection: every " << o.select_every << " diffusion iterations, arm-following accuracy of "
              << o.select_samples << " samples per prompt (seeds " << o.select_seed << "+, classifier of draw 777), mean over "
              << select_histories.size() << " history source(s)\n";
  }
  const auto rep = train_generator(g, data, tc, rng, [](const std::string& s) { std::cout << s << std::endl; }, score);
  nlohmann::json snapshots = nlohmann::json::array();
  for (const auto& sn : rep.snapshots) snapshots.push_back({{"iteration", sn.iteration}, {"score", sn.score}});
  g.set_arms_pool(pool);
  g.set_provenance({{"command", cli::invocation()},
                    {"git_commit", cli::build_commit()},
                    {"trained", cli::provenance_line()},
                    {"machine", machine_line()},
                    {"seed", o.seed},
                    {"data_mix", o.mix},
                    {"walks", o.walks},
                    {"standing_arm_clips", o.standing_arm_clips},
                    {"base_walks", o.base_walks},
                    {"base_walk_count", o.base_walks.empty() ? 0 : o.base_walk_count},
                    {"base_walk_seconds", o.base_walk_seconds},
                    {"transition_fraction", o.transition_fraction},
                    {"data_dir", root},
                    {"clips", corpus.clips.size()},
                    {"windows", data.size()},
                    {"vae_iterations", rep.vae_iterations},
                    {"vae_seconds", rep.vae_seconds},
                    {"vae_recon", rep.vae_final.recon},
                    {"diffusion_iterations", rep.diffusion_iterations},
                    {"diffusion_seconds", rep.diffusion_seconds},
                    {"diffusion_x0_loss", rep.diffusion_final},
                    {"ema_decay", o.ema},
                    {"select_every", o.select_every},
                    {"select_samples", o.select_samples},
                    {"select_seed", o.select_seed},
                    {"selected_iteration", rep.selected_iteration},
                    {"snapshots", snapshots}});
  g.save(o.out);
  std::cout << "trained: vae " << rep.vae_iterations << " it in " << rep.vae_seconds << " s (recon " << rep.vae_final.recon
            << ", kl " << rep.vae_final.kl << "), diffusion " << rep.diffusion_iterations << " it in "
            << rep.diffusion_seconds << " s (x0 loss " << rep.diffusion_final << ")";
  if (o.select_every > 0)
    std::cout << "; kept the weights of iteration " << rep.selected_iteration << " of " << rep.snapshots.size()
              << " scored (" << rep.select_seconds << " s scoring)";
  std::cout << "\nwrote " << o.out << "\n";
}

/// `--from CLIP[:SECONDS]`: H frames of a clip ending at SECONDS (default 1 s; clamped to the
/// clip). CLIP is a .bvh/.npz file or a built-in clip name (walk, arms, kick, jump).
Trajectory history_from(const std::string& spec, const Skeleton& skel, Index H) {
  std::string name = spec;
  double at = 1.0;
  if (const auto c = spec.rfind(':'); c != std::string::npos && c + 1 < spec.size()) {
    const std::string num = spec.substr(c + 1);
    char* end = nullptr;
    const double v = std::strtod(num.c_str(), &end);
    if (end && *end == '\0') {
      require(std::isfinite(v) && v >= 0, "the time after ':' must be seconds ≥ 0", {{}, {}, "--from"});
      at = v;
      name = spec.substr(0, c);
    }
  }
  MotionClip clip;
  if (std::filesystem::exists(name)) {
    clip = import_motion(name);
  } else {
    try {
      clip = synthetic_clip(name);
    } catch (const Error&) {
      throw Error("'" + name + "' is neither a motion file nor a built-in clip (walk, arms, kick, jump)", {{}, {}, "--from"});
    }
  }
  const LabelledTrajectory l = labelled_from_clip(clip, skel);
  require(l.motion.num_frames() >= H, "clip '" + name + "' has fewer than " + std::to_string(H) + " frames", {{}, {}, "--from"});
  const Index last = std::clamp<Index>(static_cast<Index>(std::lround(at * 30.0)), H - 1, l.motion.num_frames() - 1);
  return l.motion.slice(last - H + 1, H);
}

void run_generate(const GenerateOptions& o) {
  const Skeleton& skel = humanoid_skeleton();
  const std::string path = o.checkpoint.empty() ? shipped_generator() : o.checkpoint;
  BuiltinGenerator g = BuiltinGenerator::load(path, skel);
  if (o.guidance >= 0) g.config().guidance = o.guidance;
  if (o.temperature > 0) g.config().temperature = o.temperature;
  require(o.seconds > 0 && o.seconds <= 600, "must be a number in (0, 600]", {{}, {}, "--seconds"});  // checked when parsed, too
  const auto schedule = parse_text_schedule(o.text);
  try {
    (void)install_prompt_mapper(g, o.data, o.wordnet);
  } catch (const Error& e) {  // no record of the training labels and no data to derive them from
    std::cout << "prompts featurised as given, unseen words not mapped: " << e.what() << "\n";
  }
  if (g.prompt_mapper())
    for (const auto& tt : schedule) {
      const PromptMapping m = g.prompt_mapper()->map(tt.text);  // throws for a prompt of unknown words only
      std::cout << "prompt " << m.describe();
      if (m.changed()) std::cout << "; conditioned on the training text '" << g.conditioning_text(tt.text) << "'";
      std::cout << "\n";
    }
  const Trajectory hist = history_from(o.from, skel, g.history_frames());
  Rng rng(o.seed);
  const Index n = static_cast<Index>(std::lround(o.seconds * 30.0));
  const Trajectory t = rollout(g, schedule, hist, n, rng);
  std::cout << "generated " << t.num_frames() << " frames (" << o.seconds << " s at 30 Hz) for '" << o.text << "' from "
            << o.from << " with " << path << "\n";
  if (!o.bvh.empty()) {
    MotionClip c;
    c.name = "generated";
    c.labels = {o.text};
    c.fps = 30.0;
    c.resize(static_cast<int>(t.num_frames()), skel.num_dofs());
    c.root_pos = t.root_pos;
    for (Index i = 0; i < t.num_frames(); ++i) c.set_rot(static_cast<int>(i), t.root_rot[static_cast<std::size_t>(i)]);
    c.q = t.q;
    bvh::write(o.bvh, clip_to_bvh(c, skel));
    std::cout << "wrote " << o.bvh << "\n";
  }
  if (!o.rollout.empty()) {  // the viewer's format: kinematic frames, the prompts as its text track
    eval::Rollout r = eval::make_rollout(humanoid_description(), t.fps);
    r.metadata.command = cli::invocation();
    r.metadata.checkpoint = path;
    r.metadata.seed = static_cast<std::int64_t>(o.seed);
    r.metadata.extra["from"] = o.from;
    r.metadata.extra["kind"] = "generated (kinematic, not simulated)";
    for (const auto& tt : schedule) r.texts.push_back({tt.start_s, tt.text});
    for (Index i = 0; i < t.num_frames(); ++i) eval::add_frame(r, forward_kinematics(skel, t.state(i)), PartMask::none());
    eval::write_rollout(r, o.rollout);
    std::cout << "wrote " << o.rollout << "\n";
  }
}

void print_paraphrase_table(const BuiltinGenerator& g, const TrainingLabels& labels, const std::vector<Paraphrase>& list,
                            const std::string& name);

void run_map_prompt(const MapPromptOptions& o) {
  const Skeleton& skel = humanoid_skeleton();
  const std::string path = o.checkpoint.empty() ? shipped_generator() : o.checkpoint;
  BuiltinGenerator g = BuiltinGenerator::load(path, skel);
  const TrainingLabels labels = install_prompt_mapper(g, o.data, o.wordnet);
  if (o.vocabulary) {
    std::cout << "vocabulary:";
    for (const auto& w : g.prompt_mapper()->vocabulary()) std::cout << " " << w;
    std::cout << "\n";
  }
  if (o.labels)
    for (const auto& set : labels.sets) {
      std::cout << "label set:";
      for (const auto& t : set) std::cout << " '" << t << "'";
      std::cout << "\n";
    }
  const auto label_of = [&](const PromptLanding& l) { return labels.sets[l.label_set].front(); };
  std::vector<std::string> refused;
  for (const auto& p : o.prompts) {
    try {
      const PromptLanding l = land_prompt(g, p, labels.sets);
      std::cout << "prompt " << l.mapping.describe() << "\n  lands on '" << label_of(l) << "' (nearest training text '"
                << l.nearest_text << "', cosine " << std::fixed << std::setprecision(3) << l.cosine << ")";
      if (l.mapping.changed())
        std::cout << "; conditioned on '" << l.conditioned_on << "' (word overlap " << l.lexical_score << ")";
      std::cout << "\n";
      std::cout.unsetf(std::ios::floatfield);
    } catch (const Error& e) {  // a prompt of unknown words only: say so, go on with the others
      std::cout << "prompt '" << p << "': " << e.what() << "\n";
      refused.push_back(p);
    }
  }
  if (o.paraphrases) print_paraphrase_table(g, labels, unseen_word_paraphrases(), "paraphrases");
  if (o.heldout) print_paraphrase_table(g, labels, heldout_paraphrases(), "held-out paraphrases");
  require(refused.empty(), std::to_string(refused.size()) + " prompt(s) have no known word and none maps onto one", {{}, {}, "prompts"});
}

/// The tables of docs/generator.md "Words it has not seen": each paraphrase of `list`, its mapping,
/// where it lands, and the share that lands on the label meant ("… <name> land on …").
void print_paraphrase_table(const BuiltinGenerator& g, const TrainingLabels& labels, const std::vector<Paraphrase>& list,
                            const std::string& name) {
  const auto label_of = [&](const PromptLanding& l) { return labels.sets[l.label_set].front(); };
  std::cout << "\n| paraphrase | mapped prompt | word overlap | lands on (nearest training text, cosine) | meant | correct |\n"
               "| --- | --- | --- | --- | --- | --- |\n";
  int correct = 0, total = 0;
  for (const auto& para : list) {
    std::string mapped, overlap = "—", landed, ok = "no";
    try {
      const PromptLanding l = land_prompt(g, para.text, labels.sets);
      mapped = l.mapping.changed() ? l.mapping.text : "(unchanged)";
      if (l.mapping.changed()) {
        std::ostringstream o;
        o << std::fixed << std::setprecision(3) << l.lexical_score;
        overlap = o.str();
      }
      std::ostringstream c;
      c << std::fixed << std::setprecision(3) << l.cosine;
      landed = label_of(l) + " ('" + l.nearest_text + "', " + c.str() + ")";
      if (same_behaviour(l.nearest_text, para.intended, labels.sets)) {
        ok = "yes";
        ++correct;
      }
    } catch (const Error&) {
      mapped = "error: no known word";
      landed = "—";
    }
    ++total;
    std::cout << "| " << para.text << " | " << mapped << " | " << overlap << " | " << landed << " | " << para.intended << " | " << ok
              << " |\n";
  }
  std::cout << "\n" << correct << " of " << total << " " << name << " land on the label meant ("
            << std::fixed << std::setprecision(1) << 100.0 * correct / total << " %)\n";
  std::cout.unsetf(std::ios::floatfield);
}

void print_report(const ArmFollowingReport& r, const std::string& title) {
  std::cout << title << "\n| prompt | accuracy | diversity (m) | predicted (count) |\n| --- | --- | --- | --- |\n";
  for (std::size_t p = 0; p < r.classes.size(); ++p) {
    std::cout << "| " << r.classes[p] << " | " << std::fixed << std::setprecision(2) << r.accuracy[p] << " | "
              << std::setprecision(3) << r.diversity[p] << " | ";
    bool first = true;
    for (Index c = 0; c < r.confusion.cols(); ++c)
      if (r.confusion(static_cast<Index>(p), c) > 0) {
        std::cout << (first ? "" : ", ") << r.classes[static_cast<std::size_t>(c)] << " " << r.confusion(static_cast<Index>(p), c);
        first = false;
      }
    std::cout << " |\n";
  }
  std::cout << "overall accuracy " << std::setprecision(3) << r.overall_accuracy() << "\nconfusion (rows: prompt, columns: predicted, same order):\n";
  for (Index p = 0; p < r.confusion.rows(); ++p) {
    for (Index c = 0; c < r.confusion.cols(); ++c) std::cout << std::setw(4) << r.confusion(p, c);
    std::cout << "   " << r.classes[static_cast<std::size_t>(p)] << "\n";
  }
  std::cout.unsetf(std::ios::floatfield);
}

std::string fmt(double v, int precision = 2) {
  if (!std::isfinite(v)) return "—";
  std::ostringstream o;
  o << std::fixed << std::setprecision(precision) << v;
  return o.str();
}

nlohmann::json stats_json(const ArmWindowStats& w) {
  return {{"wrist_max_m", w.wrist_max}, {"wrist_range_m", w.wrist_range}, {"wrist_freq_hz", w.wrist_freq},
          {"right_over_head_m", w.right_over_head}, {"left_over_head_m", w.left_over_head},
          {"pelvis_height_m", w.pelvis_height}, {"speed_mps", w.speed}};
}

/// Per prompt: median wrist height above the pelvis (max over the span), median range, median
/// frequency, and the shares of samples with the right / left wrist above the head.
void print_arm_stats(const std::vector<std::string>& prompts, const std::vector<std::vector<ArmWindowStats>>& per_prompt,
                     const std::vector<double>* accuracy, const std::string& title) {
  std::cout << title << "\n| prompt |" << (accuracy ? " accuracy |" : "")
            << " wrist max above pelvis, median (m) | ≥ 0.6 m | range (m) | frequency (Hz) | R wrist above head | L wrist above head | pelvis (m) | speed (m/s) |\n| --- |"
            << (accuracy ? " --- |" : "") << " --- | --- | --- | --- | --- | --- | --- | --- |\n";
  for (std::size_t p = 0; p < prompts.size(); ++p) {
    const auto& v = per_prompt[p];
    std::vector<double> mx, rg, fq, pv, sp;
    int high = 0, rh = 0, lh = 0;
    for (const auto& w : v) {
      mx.push_back(w.wrist_max), rg.push_back(w.wrist_range), fq.push_back(w.wrist_freq);
      pv.push_back(w.pelvis_height), sp.push_back(w.speed);
      high += w.wrist_max >= 0.6, rh += w.right_over_head > 0, lh += w.left_over_head > 0;
    }
    const double n = std::max<std::size_t>(1, v.size());
    std::cout << "| " << prompts[p] << " |" << (accuracy ? " " + fmt((*accuracy)[p]) + " |" : "") << " " << fmt(median_of(mx))
              << " | " << fmt(high / n) << " | " << fmt(median_of(rg)) << " | " << fmt(median_of(fq), 1) << " | " << fmt(rh / n)
              << " | " << fmt(lh / n) << " | " << fmt(median_of(pv)) << " | " << fmt(median_of(sp)) << " |\n";
  }
}

/// Issue 42: the probe from every walking-history source (the shared data's walks, the synthetic
/// walk, and the simulated walks of a base policy), with the arm, pelvis and speed figures beside
/// the real clips'.
nlohmann::json run_per_source(BuiltinGenerator& g, const GeneratorEvalSet& ev, const EvalOptions& o, const std::string& root) {
  const Skeleton& skel = g.skeleton();
  const Index H = g.history_frames();
  std::vector<std::string> missing;
  std::vector<WalkingHistorySource> sources = walking_history_sources(root, skel, H, &missing);
  for (const auto& m : missing) std::cout << "per-source: " << m << " not found, its source left out\n";
  std::string base = o.base.empty() ? shipped_base() : o.base;
  if (base != "none") {
    // seeds 1 and 2 (eval); train-generator --base-walks draws its rollouts from seeds 101+
    const auto walks = base_rollout_walks(base, {1, 2}, 4.0, root, "--base");
    std::vector<LabelledTrajectory> l;
    for (const auto& w : walks) l.push_back(labelled_from_clip(w, skel));
    sources.push_back(walking_history_source("base rollouts", skel, l, {60, 90}, H));
    std::cout << "per-source: base rollouts of " << base << " (seeds 1, 2; 4 s; histories ending at 2 s and 3 s)\n";
  }
  PromptEvalOptions po;
  po.samples = o.samples;
  po.seed = o.seed;
  nlohmann::json out = nlohmann::json::array();
  std::vector<SourceSummary> sums;
  for (const auto& src : sources) {
    std::vector<std::vector<ArmWindowStats>> stats;
    const ArmFollowingReport r = evaluate_prompts(g, ev.prompts, src.histories, ev.classifier, po, &stats);
    sums.push_back(summarise_source(src, r, stats));
    std::string refs;
    for (const auto& w : src.reference) refs += " pelvis " + fmt(w.pelvis_height) + " m, speed " + fmt(w.speed) + " m/s;";
    print_arm_stats(ev.prompts, stats, &r.accuracy, "## per source: " + src.name + " (history references:" + refs + ")");
    nlohmann::json sj = {{"source", src.name}, {"report", r.to_json()}};
    for (const auto& w : src.reference) sj["reference"].push_back(stats_json(w));
    for (const auto& pp : stats) {
      nlohmann::json a = nlohmann::json::array();
      for (const auto& w : pp) a.push_back(stats_json(w));
      sj["stats"].push_back(a);
    }
    out.push_back(sj);
  }
  std::vector<std::vector<ArmWindowStats>> held(ev.prompts.size()), raw(ev.prompts.size());
  for (std::size_t j = 0; j < ev.heldout.stats.size(); ++j) held[static_cast<std::size_t>(ev.heldout.labels[j])].push_back(ev.heldout.stats[j]);
  for (std::size_t j = 0; j < ev.raw.stats.size(); ++j) raw[static_cast<std::size_t>(ev.raw.labels[j])].push_back(ev.raw.stats[j]);
  print_arm_stats(ev.prompts, held, nullptr, "## real: held-out walks with the labelled arm motion blended on (2-s windows)");
  print_arm_stats(ev.prompts, raw, nullptr, "## real: the labelled arm clips as recorded (standing; 2-s windows)");
  std::cout << "## per source (issue 42 bars: accuracy ≥ 0.85; arms high ≥ 0.6 m above the pelvis in ≥ 80 % of samples; each "
               "wave's wrist(s) above the head; pelvis and speed within 10 % of the history's)\n"
               "| source | accuracy | arms high ≥ 0.6 m (median max, m) | wave R / L / both above head | pelvis ratio (farthest prompt) | speed ratio (farthest prompt) | bars |\n"
               "| --- | --- | --- | --- | --- | --- | --- |\n";
  for (const auto& s : sums)
    std::cout << "| " << s.source << " | " << fmt(s.accuracy, 3) << " | " << fmt(s.arms_high_share) << " (" << fmt(s.arms_high_median)
              << ") | " << fmt(s.wave_share[0]) << " / " << fmt(s.wave_share[1]) << " / " << fmt(s.wave_share[2]) << " | "
              << fmt(s.pelvis_ratio, 3) << " (" << s.pelvis_worst_prompt << " " << fmt(s.pelvis_worst, 3) << ") | "
              << fmt(s.speed_ratio, 3) << " (" << s.speed_worst_prompt << " " << fmt(s.speed_worst, 3) << ") | "
              << (s.meets_bars() ? "met" : "missed") << " |\n";
  for (std::size_t k = 0; k < sums.size(); ++k)
    out[k]["summary"] = {{"accuracy", sums[k].accuracy}, {"arms_high_share", sums[k].arms_high_share},
                         {"arms_high_median_m", sums[k].arms_high_median},
                         {"wave_share", {sums[k].wave_share[0], sums[k].wave_share[1], sums[k].wave_share[2]}},
                         {"pelvis_ratio", sums[k].pelvis_ratio}, {"pelvis_worst", sums[k].pelvis_worst},
                         {"speed_ratio", sums[k].speed_ratio}, {"speed_worst", sums[k].speed_worst},
                         {"meets_bars", sums[k].meets_bars()}};
  return out;
}

void run_eval(const EvalOptions& o) {
  const Skeleton& skel = humanoid_skeleton();
  const std::string path = o.checkpoint.empty() ? shipped_generator() : o.checkpoint;
  BuiltinGenerator g = BuiltinGenerator::load(path, skel);
  if (o.guidance >= 0) g.config().guidance = o.guidance;
  if (o.temperature > 0) g.config().temperature = o.temperature;
  const std::string root = data_root(o.data);
  Rng data_rng(12345);
  const GeneratorEvalSet ev = make_generator_eval_set(root, skel, data_rng,
                                                         o.probe.empty() ? ArmProbeConfig{} : parse_arm_probe(o.probe, "--probe"));
  std::vector<std::string> prompts = o.prompts.empty() ? ev.prompts : o.prompts;
  for (const auto& p : prompts)
    require(std::find(ev.prompts.begin(), ev.prompts.end(), p) != ev.prompts.end(),
            "'" + p + "' is not a class of the arm catalog found under " + root, {{}, {}, "--prompts"});
  require(prompts == ev.prompts, "--prompts must list every catalog class in catalog order (the classifier's classes)",
          {{}, {}, "--prompts"});
  std::cout << "generator " << path << " (guidance " << g.config().guidance << ", temperature " << g.config().temperature << "); classifier: " << ev.classifier.config().name() << " on 48 arm-feature statistics, " << ev.train.labels.size()
            << " labelled 2-s windows of walks with switched arms (seed 12345); " << ev.histories.size()
            << " walking histories\n";
  const ArmFollowingReport real_blend = evaluate_samples(ev.train, ev.prompts, ev.classifier);
  const ArmFollowingReport real_heldout = evaluate_samples(ev.heldout, ev.prompts, ev.classifier);
  const ArmFollowingReport real_raw = evaluate_samples(ev.raw, ev.prompts, ev.classifier);
  PromptEvalOptions po;
  po.samples = o.samples;
  po.seed = o.seed;
  const ArmFollowingReport gen = evaluate_prompts(g, ev.prompts, ev.histories, ev.classifier, po);
  print_report(gen, "## generated: " + std::to_string(o.samples) + " samples per prompt, from walking histories, frames 1-3 s after the prompt");
  // Switches: "0:walk,2:<prompt>", the 2-s window starting 0, 0.5 and 1 s after the switch.
  nlohmann::json sj = nlohmann::json::array();
  std::cout << "## switches \"0:walk,2:<prompt>\": accuracy of the 2-s window starting d s after the switch\n| d (s) | overall | per prompt |\n| --- | --- | --- |\n";
  for (const double d : {0.0, 0.5, 1.0}) {
    PromptEvalOptions so = po;
    so.before = "walk";
    so.before_s = 2.0;
    so.lead_s = d;
    const ArmFollowingReport r = evaluate_prompts(g, ev.prompts, ev.histories, ev.classifier, so);
    std::cout << "| " << d << " | " << std::setprecision(3) << r.overall_accuracy() << " |";
    for (std::size_t p = 0; p < r.classes.size(); ++p) std::cout << " " << std::setprecision(2) << r.accuracy[p];
    std::cout << " |\n";
    sj.push_back({{"delay_s", d}, {"report", r.to_json()}});
  }
  nlohmann::json per_source_json;
  if (o.per_source) per_source_json = run_per_source(g, ev, o, root);
  print_report(real_blend, "## real: walks with the labelled arm motion blended on (the classifier's training windows)");
  print_report(real_heldout, "## real: other walks with the labelled arm motion blended on (drawn after the training windows; not used to fit the classifier)");
  print_report(real_raw, "## real: the labelled arm clips as recorded (standing; not used to fit the classifier)");
  // Paraphrases: nearest prompt by cosine of the learned text embedding, and the classifier's
  // majority on generated motion.
  const std::vector<std::string> paras = o.paraphrases.empty() ? default_paraphrases() : o.paraphrases;
  std::cout << "## paraphrases\n| paraphrase | nearest prompt (embedding cosine) | generated motion classified as (of " << o.samples << ") |\n| --- | --- | --- |\n";
  nlohmann::json pj = nlohmann::json::array();
  for (const auto& para : paras) {
    const auto [best, cosine] = nearest_prompt(g, para, ev.prompts);
    std::vector<int> votes(ev.prompts.size(), 0);
    for (Index i = 0; i < o.samples; ++i) {
      Rng rng(o.seed + static_cast<std::uint64_t>(i));
      Trajectory t = rollout(g, parse_text_schedule(para), ev.histories[static_cast<std::size_t>(i) % ev.histories.size()], 90, rng);
      compute_body_positions(skel, t);
      ++votes[static_cast<std::size_t>(ev.classifier.predict(arm_summary(arm_features(skel, t, 30, 60))))];
    }
    const auto top = std::max_element(votes.begin(), votes.end()) - votes.begin();
    std::cout << "| " << para << " | " << ev.prompts[best] << " (" << std::setprecision(3) << cosine << ") | "
              << ev.prompts[static_cast<std::size_t>(top)] << " (" << votes[static_cast<std::size_t>(top)] << ") |\n";
    pj.push_back({{"paraphrase", para}, {"nearest_prompt", ev.prompts[best]}, {"cosine", cosine},
                  {"motion_majority", ev.prompts[static_cast<std::size_t>(top)]}, {"votes", votes}});
  }
  if (!o.out.empty()) {
    nlohmann::json j = {{"generator", path}, {"samples", o.samples}, {"seed", o.seed}, {"generated", gen.to_json()},
                        {"switches", sj}, {"probe", ev.classifier.config().name()}, {"real_blended", real_blend.to_json()},
                        {"real_heldout", real_heldout.to_json()}, {"real_raw", real_raw.to_json()}, {"paraphrases", pj},
                        {"per_source", per_source_json},
                        {"provenance", g.provenance()}};
    std::ofstream(o.out) << j.dump(2) << "\n";
    std::cout << "wrote " << o.out << "\n";
  }
  if (!o.save.empty()) {  // the same weights with the sampling settings just evaluated
    nlohmann::json p = g.provenance().is_object() ? g.provenance() : nlohmann::json::object();
    p["sampling"] = {{"guidance", g.config().guidance}, {"temperature", g.config().temperature},
                     {"set_by", cli::provenance_line()}, {"overall_accuracy", gen.overall_accuracy()}};
    g.set_provenance(p);
    g.save(o.save);
    std::cout << "wrote " << o.save << " (guidance " << g.config().guidance << ", temperature " << g.config().temperature << ")\n";
  }
}

const bool registered = maskadapt::cli::register_command([](CLI::App& app) {
  auto topt = std::make_shared<TrainOptions>();
  auto* train = app.add_subcommand("train-generator", "train the built-in text-conditioned motion generator (VAE + latent diffusion)");
  train->add_option("--data", topt->data, "data directory holding motions/ (default: $MASKADAPT_DATA_DIR, else ../shared/data)");
  train->add_option("--data-mix", topt->mix, "arms: CMU + arm catalog + Bandai walks + arm-switch blends (default); legacy: CMU + synthetic clips only (the first version, for comparison)")
      ->check(maskadapt::cli::one_of({"arms", "legacy"}));
  train->add_option("--arm-seconds", topt->arm_seconds, "seconds of switched arm motion per arm class in the blends (default 120)")
      ->check(maskadapt::cli::non_negative_real());
  using namespace maskadapt::cli;
  auto* minutes = train->add_option("--minutes", topt->minutes, "wall-clock budget, split between the VAE and the diffusion stage")
                      ->check(positive_real());
  train->add_option("--iterations", topt->iterations, "iterations per stage (default 2000)")
      ->excludes(minutes)
      ->transform(positive_integer());
  train->add_option("--vae-iterations", topt->vae_iterations, "iterations of the VAE stage (default: --iterations)")
      ->excludes(minutes)
      ->transform(positive_integer());
  train->add_option("--diffusion-iterations", topt->diffusion_iterations,
                    "iterations of the diffusion stage (default: --iterations); with --vae-iterations, a run's budget independent of the machine's load")
      ->excludes(minutes)
      ->transform(positive_integer());
  train->add_option("--batch", topt->batch, "batch size (default 64)")->transform(integer_in(1, 65536));
  train->add_option("--stride", topt->stride, "frames between training windows (default 2)")
      ->transform(positive_integer(std::numeric_limits<int>::max()));
  train->add_option("--transition-fraction", topt->transition_fraction,
                    "share of each diffusion batch drawn from the windows where the behaviour switches (default 0: uniform)")
      ->check(real_in(0, 1));
  train->add_option("--ema", topt->ema, "exponential moving average of the denoiser's weights, decay in [0, 1) (default 0: off, the last weights)")
      ->check(real_in(0, 1, false, true));
  train->add_option("--select-every", topt->select_every,
                    "score the diffusion stage every N iterations by arm-following accuracy on held-out draws and keep the best weights (needs the shared arm clips; default 0: off)")
      ->transform(non_negative_integer());
  train->add_option("--select-samples", topt->select_samples, "samples per prompt of each --select-every score (default 20)")
      ->transform(integer_in(2, 10000));
  train->add_option("--select-seed", topt->select_seed, "first sample seed of the --select-every scores (default 1001; eval-generator uses 1+)")
      ->transform(non_negative_integer());
  train->add_option("--walks", topt->walks,
                    "walks the arms are blended onto: bandai (the Bandai straight walks; default) or all (also the CMU walks, the styles walks and the synthetic walk, each source equally likely; issue 42)")
      ->check(maskadapt::cli::one_of({"bandai", "all"}));
  train->add_flag("--standing-arm-clips,!--no-standing-arm-clips", topt->standing_arm_clips,
                  "whether the arm catalog's clips as recorded (standing) join the corpus besides the blends (default: yes; issue 42: --no-standing-arm-clips)");
  train->add_option("--base-walks", topt->base_walks,
                    "a base policy (e.g. models/mask_mi_walk_bandai.bin) whose simulated walks join the walks the arms are blended onto, as one more source (rollout seeds 101+)");
  train->add_option("--base-walk-count", topt->base_walk_count, "rollouts of --base-walks (default 8)")->transform(integer_in(1, 1000));
  train->add_option("--base-walk-seconds", topt->base_walk_seconds, "seconds per rollout of --base-walks (default 10)")
      ->check(real_in(1, 600));
  train->add_option("--seed", topt->seed, "random seed")->transform(non_negative_integer());
  train->add_option("--guidance", topt->guidance, "classifier-free guidance weight stored with the model (default 5)")
      ->check(non_negative_real());
  train->add_option("--temperature", topt->temperature, "sampling temperature in (0, 1] stored with the model (default 1)")
      ->check(real_in(0, 1, true, false));
  train->add_option("--out", topt->out, "checkpoint to write")->required();
  train->callback([topt] { run_train(*topt); });

  auto gopt = std::make_shared<GenerateOptions>();
  auto* gen = app.add_subcommand("generate", "generate motion from text with a trained generator");
  gen->add_option("--checkpoint", gopt->checkpoint, "generator checkpoint (default: the shipped models/text_generator.bin)");
  gen->add_option("--from", gopt->from, "history: CLIP[:SECONDS], a .bvh/.npz file or a built-in clip (walk, arms, kick, jump); H frames ending at SECONDS (default walk:1)");
  gen->add_option("--text", gopt->text, "prompt, or a schedule \"0:wave hands,5:raise arms\"")
      ->check(parsed_by([](const std::string& t) { (void)parse_text_schedule(t); }, "TEXT"));
  gen->add_option("--seconds", gopt->seconds, "length (s)")->check(real_in(0, 600, true, false));
  gen->add_option("--guidance", gopt->guidance, "classifier-free guidance weight (default: the checkpoint's, 5)")
      ->check(non_negative_real());
  gen->add_option("--temperature", gopt->temperature, "sampling temperature in (0, 1] (default: the checkpoint's)")
      ->check(real_in(0, 1, true, false));
  gen->add_option("--seed", gopt->seed, "random seed")->transform(non_negative_integer());
  gen->add_option("--bvh", gopt->bvh, "write the motion as BVH");
  gen->add_option("--rollout", gopt->rollout, "write the motion as a rollout for the web viewer (tools/viewer), the prompts as its text track");
  gen->add_option("--data", gopt->data, "data directory holding motions/, to derive the training vocabulary of a checkpoint that does not record it (default: $MASKADAPT_DATA_DIR, else ../shared/data)");
  gen->add_option("--wordnet", gopt->wordnet, "WordNet dictionary folder for unseen words (default: $MASKADAPT_WORDNET_DIR, else /usr/share/wordnet)");
  gen->callback([gopt] { run_generate(*gopt); });

  auto mopt = std::make_shared<MapPromptOptions>();
  auto* mp = app.add_subcommand("map-prompt", "show how prompts' unseen words map onto the generator's training vocabulary (WordNet) and which training label each lands on");
  mp->add_option("prompts", mopt->prompts, "prompts to map");
  mp->add_option("--checkpoint", mopt->checkpoint, "generator checkpoint (default: the shipped models/text_generator.bin)");
  mp->add_option("--data", mopt->data, "data directory holding motions/, to derive the training labels of a checkpoint that does not record them (default: $MASKADAPT_DATA_DIR, else ../shared/data)");
  mp->add_option("--wordnet", mopt->wordnet, "WordNet dictionary folder (default: $MASKADAPT_WORDNET_DIR, else /usr/share/wordnet)");
  mp->add_flag("--paraphrases", mopt->paraphrases, "also the table of the built-in paraphrases (docs/generator.md): mapped prompt, landing label, % correct");
  mp->add_flag("--heldout", mopt->heldout, "also the table of the held-out paraphrases (docs/generator.md; never used to tune the mapping)");
  mp->add_flag("--vocabulary", mopt->vocabulary, "list the vocabulary");
  mp->add_flag("--labels", mopt->labels, "list the training label sets (a landing is correct when it falls in the set of the label meant)");
  mp->callback([mopt] { run_map_prompt(*mopt); });

  auto eopt = std::make_shared<EvalOptions>();
  auto* ev = app.add_subcommand("eval-generator", "does the generator follow its arms prompts? classifier accuracy, confusion, diversity, paraphrases (needs the shared data)");
  ev->add_option("--checkpoint", eopt->checkpoint, "generator checkpoint (default: the shipped models/text_generator.bin)");
  ev->add_option("--data", eopt->data, "data directory holding motions/ (default: $MASKADAPT_DATA_DIR, else ../shared/data)");
  ev->add_option("--samples", eopt->samples, "samples per prompt (default 10)")->transform(integer_in(2, 10000));
  ev->add_option("--seed", eopt->seed, "sample i uses seed + i")->transform(non_negative_integer());
  ev->add_option("--guidance", eopt->guidance, "classifier-free guidance weight (default: the checkpoint's)")
      ->check(non_negative_real());
  ev->add_option("--temperature", eopt->temperature, "sampling temperature in (0, 1] (default: the checkpoint's)")
      ->check(real_in(0, 1, true, false));
  ev->add_option("--probe", eopt->probe, "the classifier: nearest-mean, lda[:SHRINKAGE] or knn[:K] (default: knn, 1-nearest neighbour)")
      ->check(parsed_by([](const std::string& t) { (void)parse_arm_probe(t); }, "PROBE"));
  ev->add_option("--paraphrases", eopt->paraphrases, "prompts to map onto the pool (default: a built-in list)");
  ev->add_flag("--per-source", eopt->per_source,
               "also the probe from every walking-history source (Bandai, CMU and styles walks, the synthetic walk, rollouts of --base) with wrist height, pelvis height and speed beside the real clips' (issue 42)");
  ev->add_option("--base", eopt->base, "with --per-source: the base policy whose simulated walks are a history source (default: models/mask_mi_walk_bandai.bin; none: leave it out)");
  ev->add_option("--out", eopt->out, "write the figures as JSON");
  ev->add_option("--save", eopt->save, "write the checkpoint again with the evaluated --guidance/--temperature as its defaults");
  ev->callback([eopt] { run_eval(*eopt); });
});

}  // namespace
