// The README's usage example: load the shipped mask-invariant base policy (models/, a policy-only
// export) and let it drive the reference humanoid on MuJoCo for 10 s with both legs masked (or another part mask), from a
// frame of the built-in synthetic walk. Built by CMake and run by ctest, so the README never drifts
// from the API. Usage: readme_example [MODEL] [MASK]   (MASK e.g. none, arms, left_leg,right_leg)
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/mask/apply.hpp>
#include <maskadapt/motion/library.hpp>
#include <maskadapt/humanoid/synthetic.hpp>
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>
#include <maskadapt/train/base_policy.hpp>

#include <iostream>
#include <string>

namespace maskadapt::example {
std::string models_dir();  // this checkout's models/ (defined in a file examples/CMakeLists.txt generates)
}

int main(int argc, char** argv) try {
  using namespace maskadapt;
  const std::string model = argc > 1 ? argv[1] : example::models_dir() + "/mask_mi_walk_bandai.bin";
  const PartMask mask = PartMask::parse(argc > 2 ? argv[2] : "left_leg,right_leg", "MASK");

  ThreadPool pool(2);
  MujocoHumanoidSim sim(/*num_envs=*/4, pool);                     // 22 bodies, 63 PD-driven DoF, 30 Hz
  const Skeleton& skel = sim.skeleton();
  const Index obs_dim = observation_dim(skel);
  const train::LoadedBasePolicy base = train::load_base_policy(    // checks kind, dims and checksum
      load_checkpoint(model), {obs_dim, policy_input_dim(obs_dim), skel.num_dofs(), obs_dim * kAmpWindowFrames}, model);
  const auto& actor = base.policy.ac.actor;                        // π(a | [s̄ ; m]) with its normaliser
  const tasks::ActionSpace& actions = base.policy.actions;         // PD target = offset + scale ⊙ a

  MotionLibrary walk(skel);                                        // start mid-stride: a frame of the
  walk.add(synthetic_walk());                                      // built-in walk, with its velocities
  const KinematicState start = walk.state(0, 0.1);                 // (not the Bandai walks it learned
                                                                   //  from: some phases make it fall)
  for (std::size_t e = 0; e < sim.num_envs(); ++e) sim.reset(e, start);

  const PartElements parts(observation_parts(skel));               // every feature → its body part
  const std::vector<PartMask> masks(sim.num_envs(), mask);
  MatrixXf obs(obs_dim, sim.num_envs()), input(policy_input_dim(obs_dim), sim.num_envs());
  MatrixXf mean(skel.num_dofs(), sim.num_envs()), targets(skel.num_dofs(), sim.num_envs()), scratch;
  nn::InferenceWorkspace<float> ws;
  const Vec3 from = sim.body_states(0).pos.col(0);
  double lowest_head = 1e9;
  for (int step = 0; step < 300; ++step) {                         // ten seconds of control
    for (std::size_t e = 0; e < sim.num_envs(); ++e) compute_observation(skel, sim.body_states(e), obs.col(e));
    build_policy_input<float>(parts, obs, masks, input);           // [(1−m)⊙s ; m]
    actor.mean(input, mean, ws, scratch);                          // deterministic actions (63 × envs)
    actions.to_targets(mean, targets);                             // radians
    sim.step(targets);
    lowest_head = std::min(lowest_head, sim.body_states(0).pos(2, skel.index_of("Head")));
  }
  const Vec3 to = sim.body_states(0).pos.col(0);
  std::cout << "model " << model << " (" << base.iteration << " iterations), mask " << mask.to_string() << ": walked "
            << (to - from).head<2>().norm() << " m in 10 s; lowest head height " << lowest_head << " m\n";
  return 0;
} catch (const maskadapt::Error& e) {
  std::cerr << "readme_example: " << e.what() << "\n";
  return 1;
}
