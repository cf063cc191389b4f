#pragma once
/// \file point_mass_chain.hpp
/// A tiny analytic simulator that satisfies maskadapt::Simulator without any physics engine,
/// proving the concept is generic (tests/train may include it too).
///
/// Any skeleton; every hinge is an ideal first-order servo: q̇ = kp · (target − q), integrated
/// exactly over the control step: q(t + dt) = target + (q − target)·e^{−kp·dt}. The root glides
/// at its reset velocity (no gravity). Body states are the library's forward kinematics of that
/// state; a body is in contact when its origin is below `contact_height`.
#include <maskadapt/sim/simulator.hpp>

#include <cmath>
#include <vector>

namespace maskadapt::testing {

class PointMassChainSim {
 public:
  PointMassChainSim(Skeleton skeleton, std::size_t num_envs, double kp = 10.0, double dt = 1.0 / 30.0)
      : skel_(std::move(skeleton)), kp_(kp), dt_(dt), envs_(num_envs) {
    skel_.validate();
    stats_.physics_reset.assign(num_envs, 0);
    for (std::size_t e = 0; e < num_envs; ++e) reset(e, KinematicState::zero(skel_));
  }

  std::size_t num_envs() const { return envs_.size(); }
  const Skeleton& skeleton() const { return skel_; }
  double control_dt() const { return dt_; }
  const BodyStates& body_states(std::size_t e) const { return envs_.at(e).states; }
  const ContactFlags& contacts(std::size_t e) const { return envs_.at(e).contacts; }
  const StepStats& step_stats() const { return stats_; }

  void reset(std::size_t e, const KinematicState& pose) {
    check_pose(skel_, pose);
    Env& env = envs_.at(e);
    env.state = pose;
    if (env.state.qd.size() == 0) env.state.qd = VectorXd::Zero(skel_.num_dofs());
    refresh(env);
  }

  void step(const Eigen::Ref<const MatrixXf>& targets) {
    check_targets(targets, skel_.num_dofs(), static_cast<Index>(envs_.size()));
    const double decay = std::exp(-kp_ * dt_);
    for (std::size_t e = 0; e < envs_.size(); ++e) {
      KinematicState& s = envs_[e].state;
      const VectorXd target = targets.col(static_cast<Index>(e)).cast<double>();
      const VectorXd err = (s.q - target) * decay;
      s.q = target + err;
      s.qd = -kp_ * err;
      s.root_pos += dt_ * s.root_lin_vel;
      const Vec3 w = s.root_ang_vel * dt_;
      if (w.norm() > 0) s.root_rot = (Quat(Eigen::AngleAxisd(w.norm(), w.normalized())) * s.root_rot).normalized();
      refresh(envs_[e]);
    }
    ++stats_.control_steps;
  }

  double contact_height = 0.05;  ///< m

 private:
  struct Env {
    KinematicState state;
    BodyStates states;
    ContactFlags contacts;
  };
  void refresh(Env& env) const {
    forward_kinematics(skel_, env.state, env.states);
    env.contacts.assign(static_cast<std::size_t>(skel_.num_bodies()), 0);
    for (int i = 0; i < skel_.num_bodies(); ++i)
      env.contacts[static_cast<std::size_t>(i)] = env.states.pos(2, i) < contact_height ? 1 : 0;
  }

  Skeleton skel_;
  double kp_, dt_;
  std::vector<Env> envs_;
  StepStats stats_;
};

static_assert(Simulator<PointMassChainSim>);

}  // namespace maskadapt::testing
