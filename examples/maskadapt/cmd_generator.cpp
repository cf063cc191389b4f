// `maskadapt train-generator` and `maskadapt generate`: the built-in text-conditioned motion
// generator (tracking/builtin_generator.hpp).
#include "cli_checks.hpp"
#include "command_registry.hpp"

#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/motion/bvh.hpp>
#include <maskadapt/motion/retarget.hpp>
#include <maskadapt/motion/synthetic.hpp>
#include <maskadapt/tracking/builtin_generator.hpp>
#include <maskadapt/tracking/text_pool.hpp>

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>

namespace {

using namespace maskadapt;
using namespace maskadapt::tracking;

std::string default_data_dir() {
  if (const char* e = std::getenv("MASKADAPT_DATA_DIR")) return std::string(e) + "/motions/cmu";
  return std::string(MASKADAPT_SOURCE_DIR) + "/../shared/data/motions/cmu";
}

struct TrainOptions {
  std::string data, out;
  double minutes = 0.0;
  long long iterations = 2000;
  long long batch = 64;
  unsigned long long seed = 1;
  int stride = 2;
};

struct GenerateOptions {
  std::string checkpoint, text = "raise arms", bvh;
  double seconds = 5.0, guidance = -1.0;  ///< guidance < 0: not given (the checkpoint's)
  unsigned long long seed = 1;
};

void run_train(const TrainOptions& o) {
  const Skeleton& skel = humanoid_skeleton();
  const std::string dir = o.data.empty() ? default_data_dir() : o.data;
  std::vector<std::string> skipped;
  // Real clips from the data directory when it exists, plus the built-in synthetic clips (walk,
  // rotate arms, kick, jump) with their labels, so a fresh machine can train too.
  std::vector<LabelledTrajectory> clips;
  if (std::filesystem::is_directory(dir)) clips = load_labelled_clips(dir, skel, &skipped);
  else std::cerr << "no clip directory at " << dir << "; training on the built-in synthetic clips only\n";
  for (const auto& s : skipped) std::cerr << "skipped " << s << "\n";
  for (const MotionClip& c : builtin_motion_set("synthetic")) clips.push_back(labelled_from_clip(c, skel));
  require(!clips.empty(), "no motion clips found", {dir, {}, "--data"});
  const auto data = make_primitive_dataset(skel, clips, 5, 15, o.stride);
  std::cout << "clips: " << clips.size() << ", windows: " << data.size() << " (H = 5, F = 15, stride " << o.stride
            << ")\narms text pool:";
  for (const auto& t : arms_text_pool(clips)) std::cout << " '" << t << "'";
  std::cout << "\n";
  Rng rng(o.seed);
  BuiltinGenerator g(skel, BuiltinGeneratorConfig{}, rng);
  std::cout << "parameters: vae encoder " << g.vae().encoder().num_params() << ", decoder "
            << g.vae().decoder().num_params() << ", denoiser " << g.denoiser().network().num_params()
            << ", text projection " << g.denoiser().projection().num_params() << "\n";
  GeneratorTrainConfig tc;
  tc.vae_iterations = tc.diffusion_iterations = o.iterations;
  if (o.minutes > 0) {
    tc.max_seconds = 60.0 * o.minutes;
    tc.vae_iterations = tc.diffusion_iterations = 1'000'000'000;
  }
  tc.batch = o.batch;
  tc.log_every = std::max<Index>(1, std::min<Index>(200, tc.vae_iterations / 5));
  const auto rep = train_generator(g, data, tc, rng, [](const std::string& s) { std::cout << s << std::endl; });
  g.save(o.out);
  std::cout << "trained: vae " << rep.vae_iterations << " it in " << rep.vae_seconds << " s (recon " << rep.vae_final.recon
            << ", kl " << rep.vae_final.kl << "), diffusion " << rep.diffusion_iterations << " it in "
            << rep.diffusion_seconds << " s (x0 loss " << rep.diffusion_final << ")\nwrote " << o.out << "\n";
}

void run_generate(const GenerateOptions& o) {
  const Skeleton& skel = humanoid_skeleton();
  BuiltinGenerator g = BuiltinGenerator::load(o.checkpoint, skel);
  if (o.guidance >= 0) g.config().guidance = o.guidance;
  require(o.seconds > 0 && o.seconds <= 600, "must be a number in (0, 600]", {{}, {}, "--seconds"});  // checked when parsed, too
  const auto schedule = parse_text_schedule(o.text);
  // History: the standing pose held for H frames.
  Trajectory hist = Trajectory::zeros(skel, g.history_frames());
  const KinematicState stand = humanoid_standing_pose();
  for (Index i = 0; i < hist.num_frames(); ++i) {
    hist.root_pos.col(i) = stand.root_pos;
    hist.root_rot[static_cast<std::size_t>(i)] = stand.root_rot;
    hist.q.col(i) = stand.q;
  }
  compute_body_positions(skel, hist);
  Rng rng(o.seed);
  const Index n = static_cast<Index>(std::lround(o.seconds * 30.0));
  const Trajectory t = rollout(g, schedule, hist, n, rng);
  std::cout << "generated " << t.num_frames() << " frames (" << o.seconds << " s at 30 Hz) for '" << o.text << "'\n";
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
}

const bool registered = maskadapt::cli::register_command([](CLI::App& app) {
  auto topt = std::make_shared<TrainOptions>();
  auto* train = app.add_subcommand("train-generator", "train the built-in text-conditioned motion generator (VAE + latent diffusion)");
  train->add_option("--data", topt->data, "directory of labelled .bvh/.npz clips (default: $MASKADAPT_DATA_DIR/motions/cmu)");
  using namespace maskadapt::cli;
  auto* minutes = train->add_option("--minutes", topt->minutes, "wall-clock budget, split between the VAE and the diffusion stage")
                      ->check(positive_real());
  train->add_option("--iterations", topt->iterations, "iterations per stage (default 2000)")
      ->excludes(minutes)
      ->transform(positive_integer());
  train->add_option("--batch", topt->batch, "batch size (default 64)")->transform(integer_in(1, 65536));
  train->add_option("--stride", topt->stride, "frames between training windows (default 2)")
      ->transform(positive_integer(std::numeric_limits<int>::max()));
  train->add_option("--seed", topt->seed, "random seed")->transform(non_negative_integer());
  train->add_option("--out", topt->out, "checkpoint to write")->required();
  train->callback([topt] { run_train(*topt); });

  auto gopt = std::make_shared<GenerateOptions>();
  auto* gen = app.add_subcommand("generate", "generate motion from text with a trained generator");
  gen->add_option("--checkpoint", gopt->checkpoint, "generator checkpoint (from train-generator)")->required();
  gen->add_option("--text", gopt->text, "prompt, or a schedule \"0:wave hands,5:raise arms\"")
      ->check(parsed_by([](const std::string& t) { (void)parse_text_schedule(t); }, "TEXT"));
  gen->add_option("--seconds", gopt->seconds, "length (s)")->check(real_in(0, 600, true, false));
  gen->add_option("--guidance", gopt->guidance, "classifier-free guidance weight (default: the checkpoint's, 5)")
      ->check(non_negative_real());
  gen->add_option("--seed", gopt->seed, "random seed")->transform(non_negative_integer());
  gen->add_option("--bvh", gopt->bvh, "write the motion as BVH");
  gen->callback([gopt] { run_generate(*gopt); });
});

}  // namespace
