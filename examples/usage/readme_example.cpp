// The README's usage example: step the reference humanoid with a (random, untrained) Gaussian MLP
// policy that sees a masked observation. Built by CMake so the README never drifts from the API.
#include <maskadapt/humanoid/observation.hpp>
#include <maskadapt/mask/apply.hpp>
#include <maskadapt/nn/nn.hpp>
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>

#include <iostream>

int main() {
  using namespace maskadapt;
  ThreadPool pool(2);
  MujocoHumanoidSim sim(/*num_envs=*/4, pool);                  // 22 bodies, 63 PD-driven DoF, 30 Hz
  const Skeleton& skel = sim.skeleton();
  for (std::size_t e = 0; e < sim.num_envs(); ++e) sim.reset(e, humanoid_standing_pose());

  Rng rng(7);
  const PartElements parts(observation_parts(skel));            // every feature → its body part
  nn::Mlp<float> policy({.inputs = policy_input_dim(kObservationDim), .hidden = {256, 256},
                         .outputs = skel.num_dofs()}, rng);
  const VectorXf log_std = VectorXf::Constant(skel.num_dofs(), -2.f);
  const std::vector<PartMask> masks(sim.num_envs(), PartMask::parse("left_leg,right_leg"));

  MatrixXf obs(kObservationDim, sim.num_envs()), input(policy_input_dim(kObservationDim), sim.num_envs());
  MatrixXf mean(skel.num_dofs(), sim.num_envs()), action(skel.num_dofs(), sim.num_envs());
  nn::InferenceWorkspace<float> ws;
  for (int step = 0; step < 30; ++step) {                        // one second of control
    for (std::size_t e = 0; e < sim.num_envs(); ++e) compute_observation(skel, sim.body_states(e), obs.col(e));
    build_policy_input<float>(parts, obs, masks, input);         // [(1−m)⊙s ; m]
    policy.forward(input, mean, ws);                             // (63 × envs), no allocation
    nn::gaussian_sample<float>(mean, log_std, rng, action);
    sim.step(action);                                            // PD targets (rad)
  }
  std::cout << "pelvis height after 1 s: " << sim.body_states(0).pos(2, 0) << " m\n";
}
