#pragma once
// A tiny analytic simulator for the trainer tests: a 6-body "walker" (root + head + two arms +
// two legs) whose joints track their PD targets with a first-order lag and whose root is an
// unstable inverted pendulum (tilt φ about y) balanced by the legs' y hinges:
//
//   q̇   = k_p · (q* − q)                 (every hinge)
//   φ̈   = (g / ℓ) · sin φ − k_b · u − c·φ̇,   u = mean of the two hips' y angles
//
// It falls (head below 0.5 m) within about a second under random targets and stays up under
// u ≈ −φ-feedback. It satisfies the Simulator concept and can save/restore an env's exact state,
// so resume bit-exactness can be tested without MuJoCo.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/motion/skeleton.hpp>
#include <maskadapt/sim/simulator.hpp>

#include <cmath>
#include <cstddef>
#include <vector>

namespace maskadapt::testing {

inline Skeleton tiny_walker_skeleton() {
  Skeleton s;
  s.names = {"root", "head", "l_arm", "r_arm", "l_leg", "r_leg"};
  s.parents = {-1, 0, 0, 0, 0, 0};
  s.parts = {BodyPart::Trunk, BodyPart::Trunk, BodyPart::LeftArm, BodyPart::RightArm, BodyPart::LeftLeg, BodyPart::RightLeg};
  s.offsets.resize(3, 6);
  s.offsets.col(0) << 0, 0, 0;
  s.offsets.col(1) << 0, 0, 0.6;
  s.offsets.col(2) << 0, 0.25, 0.45;
  s.offsets.col(3) << 0, -0.25, 0.45;
  s.offsets.col(4) << 0, 0.1, -0.1;
  s.offsets.col(5) << 0, -0.1, -0.1;
  s.set_xyz_hinges(Matrix3X::Constant(3, 6, -2.0), Matrix3X::Constant(3, 6, 2.0));
  s.validate();
  return s;
}

class TinyWalkerSim {
 public:
  static constexpr double kDt = 1.0 / 30.0;
  static constexpr double kHeight = 1.0;  // root height when upright (m)

  explicit TinyWalkerSim(std::size_t num_envs) : skel_(tiny_walker_skeleton()), envs_(num_envs) {
    for (std::size_t e = 0; e < num_envs; ++e) reset(e, KinematicState::zero(skel_));
  }

  std::size_t num_envs() const { return envs_.size(); }
  const Skeleton& skeleton() const { return skel_; }
  double control_dt() const { return kDt; }
  const StepStats& step_stats() const { return stats_; }

  void reset(std::size_t env, const KinematicState& pose) {
    Env& e = envs_.at(env);
    e.q = pose.q;
    e.qd = pose.qd.size() == pose.q.size() ? pose.qd : VectorXd::Zero(pose.q.size());
    // The pose's pitch (rotation about y) becomes the pendulum angle.
    const Mat3 R = pose.root_rot.normalized().toRotationMatrix();
    e.phi = std::atan2(R(0, 2), R(2, 2));
    e.phid = pose.root_ang_vel.y();
    e.x = pose.root_pos.x();
    e.y = pose.root_pos.y();
    e.vx = pose.root_lin_vel.x();
    refresh(e);
  }

  void step(const Eigen::Ref<const MatrixXf>& targets) {
    check_targets(targets, skel_.num_dofs(), static_cast<Index>(envs_.size()));
    ++stats_.control_steps;
    stats_.physics_reset.assign(envs_.size(), 0);
    for (std::size_t k = 0; k < envs_.size(); ++k) {
      Env& e = envs_[k];
      const VectorXd t = targets.col(static_cast<Index>(k)).cast<double>();
      e.qd = 8.0 * (t - e.q);
      e.q += kDt * e.qd;
      const double u = 0.5 * (e.q[skel_.dof_offset(4) + 1] + e.q[skel_.dof_offset(5) + 1]);
      const double phidd = 9.81 / kHeight * std::sin(e.phi) - 30.0 * u - 2.0 * e.phid;
      e.phid += kDt * phidd;
      e.phi += kDt * e.phid;
      e.phi = std::clamp(e.phi, -1.5, 1.5);
      e.vx = 0.5 * (e.qd[skel_.dof_offset(4)] - e.qd[skel_.dof_offset(5)]);
      e.x += kDt * e.vx;
      refresh(e);
    }
  }

  const BodyStates& body_states(std::size_t env) const { return envs_.at(env).bodies; }
  /// Per-body ground contact flags: a body whose origin is below 5 cm touches the ground.
  const ContactFlags& contacts(std::size_t env) const { return envs_.at(env).contacts; }

  std::vector<double> save_state(std::size_t env) const {
    const Env& e = envs_.at(env);
    std::vector<double> v(e.q.data(), e.q.data() + e.q.size());
    v.insert(v.end(), e.qd.data(), e.qd.data() + e.qd.size());
    v.insert(v.end(), {e.phi, e.phid, e.x, e.y, e.vx});
    return v;
  }
  void load_state(std::size_t env, const std::vector<double>& v) {
    Env& e = envs_.at(env);
    const Index n = skel_.num_dofs();
    require(static_cast<Index>(v.size()) == 2 * n + 5, "state has the wrong size", {{}, {}, "sim state"});
    e.q = Eigen::Map<const VectorXd>(v.data(), n);
    e.qd = Eigen::Map<const VectorXd>(v.data() + n, n);
    e.phi = v[2 * n];
    e.phid = v[2 * n + 1];
    e.x = v[2 * n + 2];
    e.y = v[2 * n + 3];
    e.vx = v[2 * n + 4];
    refresh(e);
  }

 private:
  struct Env {
    VectorXd q, qd;
    double phi = 0, phid = 0, x = 0, y = 0, vx = 0;
    BodyStates bodies;
    ContactFlags contacts;
  };

  void refresh(Env& e) const {
    KinematicState s;
    s.root_rot = Quat(Eigen::AngleAxisd(e.phi, Vec3::UnitY()));
    s.root_pos = Vec3(e.x, e.y, kHeight * std::cos(e.phi));
    s.root_lin_vel = Vec3(e.vx, 0, -kHeight * std::sin(e.phi) * e.phid);
    s.root_ang_vel = Vec3(0, e.phid, 0);
    s.q = e.q;
    s.qd = e.qd;
    forward_kinematics(skel_, s, e.bodies);
    e.contacts.assign(static_cast<std::size_t>(skel_.num_bodies()), 0);
    for (int b = 0; b < skel_.num_bodies(); ++b) e.contacts[static_cast<std::size_t>(b)] = e.bodies.pos(2, b) < 0.05 ? 1 : 0;
  }

  Skeleton skel_;
  std::vector<Env> envs_;
  StepStats stats_;
};

}  // namespace maskadapt::testing
