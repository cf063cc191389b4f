// `maskadapt train-residual` (stage 2: composition or partial tracking on top of a frozen base)
// and `maskadapt play-residual` (mask / text schedules, BVH export). Residual playback lives here
// as its own subcommand so the trainer engineer's `play` stays untouched.
#include "command_registry.hpp"

#include <maskadapt/core/checkpoint.hpp>
#include <maskadapt/motion/bvh.hpp>
#include <maskadapt/motion/retarget.hpp>
#include <maskadapt/tracking/builtin_generator.hpp>
#include <maskadapt/tracking/text_pool.hpp>
#include <maskadapt/train/motion_sources.hpp>
#include <maskadapt/train/residual_trainer.hpp>
#include <maskadapt/train/run_loop.hpp>

#ifdef MASKADAPT_HAS_MUJOCO
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>
#endif

#include <fstream>
#include <iostream>
#include <memory>

namespace {

using namespace maskadapt;
using namespace maskadapt::train;

struct Args {
  std::string task = "composition", method = "ours", base, out = "runs/residual", preset, generator, gain = "scalar";
  std::vector<std::string> new_motion, masks, motions, texts;
  std::string designated = "arms";
  int envs = -1, threads = -1;
  long long iterations = -1, seed = -1;
  double minutes = -1, switch_rate = -1;
  std::vector<Index> hidden;
};

std::string data_dir() { return motion_data_dir(MASKADAPT_SOURCE_DIR "/../shared/data"); }

/// Builds the reward sources of a run (shared by training and nothing else).
ResidualSetup make_setup(const ResidualTrainConfig& c, const std::shared_ptr<MotionLibrary>& base_lib,
                         const std::shared_ptr<MotionLibrary>& new_lib, const std::vector<BodyPart>& obs_parts) {
  ResidualSetup s;
  s.masks = tasks::parse_mask_set(c.masks, "--masks");
  s.switch_rate = c.switch_rate;
  s.negative_fraction = c.negative_fraction;
  auto from = [](std::shared_ptr<MotionLibrary> lib) {
    return [lib](Rng& r, Index B, MatrixXf& w, MatrixXf&) { w = lib->sample_amp_windows(r, static_cast<int>(B)); };
  };
  const std::vector<double> w = c.objective_weights;
  if (c.task == "tracking") {
    const PartMask d = PartMask::parse(c.designated, "--designated");
    s.masks = {d};
    s.discriminators.push_back({"imitation", w.size() > 0 ? w[0] : 0.5, tasks::window_rows(obs_parts, ~d), false, from(base_lib), {}});
    return s;
  }
  if (c.method == "ours") {
    auto set = std::make_shared<tasks::BlendedMotionSet>(*base_lib, *new_lib, s.masks);
    DiscriminatorSource src{"composition", 1.0, {}, true,
                            [set](Rng& r, Index B, MatrixXf& x, MatrixXf& m) { set->sample_real(r, B, x, m); },
                            [set](Rng& r, Index B, MatrixXf& x, MatrixXf& m) { set->sample_negative(r, B, x, m); }};
    s.discriminators.push_back(src);
  } else {  // cml / scratch: fixed region = the first mask; one discriminator per group
    const PartMask region = c.method == "scratch" ? PartMask::all() : s.masks.front();
    const PartMask adapted = s.masks.front();
    s.masks = {region};
    s.switch_rate = 0;
    s.discriminators.push_back({"adapted", w.size() > 0 ? w[0] : 0.5, tasks::window_rows(obs_parts, adapted), false, from(new_lib), {}});
    s.discriminators.push_back({"rest", w.size() > 1 ? w[1] : 0.5, tasks::window_rows(obs_parts, ~adapted), false, from(base_lib), {}});
  }
  return s;
}

void run_train_residual(const Args& a) {
#ifndef MASKADAPT_HAS_MUJOCO
  (void)a;
  throw Error("this build has no MuJoCo; train-residual needs the maskadapt::mujoco target", {{}, std::nullopt, "train-residual"});
#else
  ResidualTrainConfig c;
  c.rl = a.preset.empty() ? cpu_preset() : preset(a.preset, "--preset");
  c.task = a.task;
  c.method = a.method;
  c.base_checkpoint = a.base;
  c.gain = a.gain;
  c.designated = a.designated;
  c.generator = a.generator;
  if (!a.new_motion.empty()) c.new_motions = a.new_motion;
  if (!a.masks.empty()) c.masks = a.masks;
  if (!a.motions.empty()) c.rl.env.motions = a.motions;
  if (a.envs > 0) c.rl.env.num_envs = a.envs;
  if (a.threads >= 0) c.rl.run.threads = a.threads;
  if (a.iterations >= 0) c.rl.run.iterations = a.iterations;
  if (a.minutes >= 0) c.rl.run.minutes = a.minutes;
  if (a.minutes > 0 && a.iterations < 0) c.rl.run.iterations = 0;
  if (a.seed >= 0) c.rl.run.seed = static_cast<std::uint64_t>(a.seed);
  if (a.switch_rate >= 0) c.switch_rate = a.switch_rate;
  if (!a.hidden.empty()) c.residual_hidden = a.hidden;
  c.rl.run.out_dir = a.out;
  c.validate();
  const bool scratch = c.method == "scratch";
  require(scratch || !a.base.empty(), "a base checkpoint is needed (or --method scratch)", {{}, {}, "--base"});
  require(c.task == "tracking" || !c.new_motions.empty(), "composition needs --new-motion", {{}, {}, "--new-motion"});

  auto base_lib = load_motion_library(c.rl.env.motions, data_dir());
  std::shared_ptr<MotionLibrary> new_lib = c.task == "composition" ? load_motion_library(c.new_motions, data_dir()) : base_lib;
  ThreadPool pool(static_cast<std::size_t>(c.rl.run.threads));
  MujocoHumanoidSim sim(static_cast<std::size_t>(c.rl.env.num_envs), pool);
  const Index obs_dim = observation_dim(sim.skeleton()), A = sim.skeleton().num_dofs();
  rl::GaussianActor<float> base;
  if (scratch) {  // from scratch: a zero base, every DoF residual
    rl::ActorCriticConfig ac;
    ac.policy_input_dim = obs_dim + kNumParts;
    ac.critic_input_dim = obs_dim;
    ac.action_dim = A;
    ac.actor_hidden = {8};
    Rng r(0);
    base = rl::GaussianActor<float>(ac, r);
    base.mean_net.params().setZero();
    c.masks = {"all"};
  } else {
    base = load_base_actor(load_checkpoint(a.base), obs_dim, A);
  }
  ResidualSetup setup = make_setup(c, base_lib, new_lib, observation_parts(sim.skeleton()));
  if (c.task == "tracking") {
    require(!c.generator.empty(), "tracking needs --generator (train one with `maskadapt train-generator`)", {{}, {}, "--generator"});
    auto gen = std::make_shared<tracking::BuiltinGenerator>(tracking::BuiltinGenerator::load(c.generator, sim.skeleton()));
    std::vector<std::string> pool_texts = a.texts;
    if (pool_texts.empty()) pool_texts = {"raise arms", "wave hands", "punch", "wash self"};
    TrackingSource t;
    t.designated = PartMask::parse(c.designated, "--designated");
    t.goal_steps = c.goal_steps;
    t.weight = c.objective_weights.size() > 1 ? c.objective_weights[1] : 0.5;
    t.sample_every = c.sample_every;
    t.term_window = std::max<Index>(1, std::llround(c.term_window_s / sim.control_dt()));
    t.term_threshold = c.term_threshold;
    const Index frames = std::llround(c.rl.env.episode_seconds / sim.control_dt()) + c.goal_steps + 1;
    const int n = c.goal_trajectories;
    t.refill = [gen, base_lib, pool_texts, frames, n](Rng& r, tracking::GoalBuffer& b) {
      b.refill(*gen, pool_texts, [&](Rng& rr) {
        const ClipTime ct = base_lib->sample(rr);
        return tracking::trajectory_from_library(*base_lib, ct.clip, ct.time, gen->history_frames());
      }, n, frames, r);
    };
    setup.tracking = t;
  }
  std::cout << "train-residual: task " << c.task << ", method " << c.method << ", masks";
  for (const auto& m : setup.masks) std::cout << " " << m.to_string();
  std::cout << ", " << setup.discriminators.size() << " discriminator(s), out " << c.rl.run.out_dir << "\n";
  ResidualTrainer<MujocoHumanoidSim> trainer(sim, library_reset_sampler(base_lib), base, std::move(setup), c, &pool);
  std::filesystem::create_directories(c.rl.run.out_dir);
  std::ofstream(c.rl.run.out_dir + "/residual_config.json") << to_json(c).dump(2) << "\n";
  run_training(trainer);
  std::cout << "train-residual: done, " << trainer.iteration() << " iterations; checkpoint " << c.rl.run.out_dir
            << "/checkpoint.bin";
  if (c.task == "tracking") std::cout << "; last tracking reward " << trainer.last_tracking_reward();
  std::cout << "\n";
#endif
}

struct PlayArgs {
  std::string checkpoint, mask_schedule = "0:lower_body", text, bvh, generator;
  double seconds = 10.0;
  long long seed = 1;
};

void run_play(const PlayArgs& a) {
#ifndef MASKADAPT_HAS_MUJOCO
  (void)a;
  throw Error("this build has no MuJoCo; play-residual needs the maskadapt::mujoco target", {{}, std::nullopt, "play-residual"});
#else
  const Checkpoint ck = load_checkpoint(a.checkpoint);
  const ResidualTrainConfig c = residual_config_from_json(nlohmann::json::parse(ck.get_string("residual_config")), a.checkpoint);
  MujocoHumanoidSim sim(1);
  const Skeleton& skel = sim.skeleton();
  const Index obs_dim = observation_dim(skel), A = skel.num_dofs();
  adapt::ResidualConfig rc;
  rc.hidden = c.residual_hidden;
  rc.activation = residual_activation(c.rl.net.activation);
  rc.gain = adapt::gain_mode_from_name(c.gain);
  const PartMask designated = PartMask::parse(c.designated);
  if (c.task == "tracking") rc.goal_dim = tracking::goal_dim(skel, designated, c.goal_steps);
  rl::ActorCriticConfig ac;
  ac.policy_input_dim = obs_dim + kNumParts;
  ac.critic_input_dim = obs_dim;
  ac.action_dim = A;
  ac.actor_hidden = c.method == "scratch" ? std::vector<Index>{8} : c.rl.net.actor_hidden;
  ac.activation = rc.activation;
  Rng init(0);
  adapt::ResidualPolicy<float> pol(rl::GaussianActor<float>(ac, init), obs_dim, action_parts(skel), rc, init);
  pol.load(ck, true);
  const auto schedule = MaskSampler::scheduled(c.task == "tracking" ? "0:" + c.designated : a.mask_schedule);
  auto lib = load_motion_library(c.rl.env.motions, data_dir());
  Rng rng(static_cast<std::uint64_t>(a.seed));
  sim.reset(0, lib->state(0, 4 * kAmpFrameDt));
  const PartElements pe(observation_parts(skel));
  const auto bodies = tracking::designated_bodies(skel, designated);
  std::unique_ptr<tracking::BuiltinGenerator> gen;
  tracking::Trajectory targets;
  const Index steps = std::llround(a.seconds / sim.control_dt());
  if (c.task == "tracking") {
    require(!a.generator.empty() || !c.generator.empty(), "tracking playback needs a generator", {{}, {}, "--generator"});
    gen = std::make_unique<tracking::BuiltinGenerator>(tracking::BuiltinGenerator::load(a.generator.empty() ? c.generator : a.generator, skel));
    const auto texts = tracking::parse_text_schedule(a.text.empty() ? "0:raise arms" : a.text);
    targets = tracking::rollout(*gen, texts, tracking::trajectory_from_library(*lib, 0, 0.0, gen->history_frames()),
                                steps + c.goal_steps + 1, rng);
  }
  MotionClip out;
  out.name = "play_residual";
  out.resize(static_cast<int>(steps), A);
  MatrixXf obs(obs_dim, 1), x, mu, goals(rc.goal_dim, 1);
  adapt::ResidualWorkspace<float> ws;
  double track_err = 0;
  for (Index t = 0; t < steps; ++t) {
    const double time = static_cast<double>(t) * sim.control_dt();
    const std::vector<PartMask> m{schedule.sample(rng, time)};
    compute_observation(skel, sim.body_states(0), obs.col(0));
    if (rc.goal_dim > 0) tracking::extract_goals(skel, bodies, targets, t, c.goal_steps, goals.col(0));
    pol.build_input(pe, obs, m, goals, x, ws);
    pol.mean(x, m, mu, ws);
    sim.step(mu);
    const BodyStates& b = sim.body_states(0);
    out.root_pos.col(static_cast<int>(t)) = b.pos.col(0);
    out.set_rot(static_cast<int>(t), b.rot[0]);
    out.q.col(static_cast<int>(t)) = sim.joint_angles(0);
    if (c.task == "tracking") track_err += tracking::position_error(bodies, targets, t + 1, b);
  }
  std::cout << "play-residual: " << steps << " steps, final root height " << sim.body_states(0).pos(2, 0) << " m";
  if (c.task == "tracking") std::cout << ", mean tracking error " << track_err / static_cast<double>(steps) << " m";
  std::cout << "\n";
  if (!a.bvh.empty()) {
    bvh::write(a.bvh, clip_to_bvh(out, skel));
    std::cout << "wrote " << a.bvh << "\n";
  }
#endif
}

const bool registered = maskadapt::cli::register_command([](CLI::App& app) {
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand("train-residual", "Train a residual policy on a frozen base (stage 2)");
  c->add_option("--task", a->task, "composition | tracking");
  c->add_option("--method", a->method, "ours | cml | scratch");
  c->add_option("--base", a->base, "stage-1 checkpoint (train-base output)");
  c->add_option("--new-motion", a->new_motion, "new motion set B: builtin name | DIR | FILE ...");
  c->add_option("--motions", a->motions, "base motion set A (default: the preset's env.motions)");
  c->add_option("--masks", a->masks, "training mask set, e.g. lower_body arms (cml: the first is the fixed region)");
  c->add_option("--switch-rate", a->switch_rate, "mid-episode mask switches per second");
  c->add_option("--designated", a->designated, "tracking: parts that follow the generated trajectory");
  c->add_option("--generator", a->generator, "tracking: generator checkpoint (train-generator output)");
  c->add_option("--texts", a->texts, "tracking: text pool");
  c->add_option("--gain", a->gain, "fixed | scalar | per_dof");
  c->add_option("--hidden", a->hidden, "residual hidden sizes");
  c->add_option("--preset", a->preset, "cpu | paper");
  c->add_option("--envs", a->envs, "parallel envs");
  c->add_option("--threads", a->threads, "simulation threads (0 = all cores)");
  c->add_option("--iterations", a->iterations, "iteration budget");
  c->add_option("--minutes", a->minutes, "wall-clock budget");
  c->add_option("--seed", a->seed, "master seed");
  c->add_option("--out", a->out, "output directory");
  c->callback([a] { run_train_residual(*a); });

  auto p = std::make_shared<PlayArgs>();
  CLI::App* q = app.add_subcommand("play-residual", "Run a residual checkpoint with a mask or text schedule, export BVH");
  q->add_option("checkpoint", p->checkpoint, "train-residual checkpoint")->required();
  q->add_option("--mask-schedule", p->mask_schedule, "e.g. \"0:lower_body,5:upper_body\"");
  q->add_option("--text", p->text, "tracking: e.g. \"0:wave hands,5:raise arms\"");
  q->add_option("--generator", p->generator, "tracking: generator checkpoint (default: the one trained with)");
  q->add_option("--seconds", p->seconds, "length");
  q->add_option("--bvh", p->bvh, "write the motion as BVH");
  q->add_option("--seed", p->seed, "seed");
  q->callback([p] { run_play(*p); });
});

}  // namespace
