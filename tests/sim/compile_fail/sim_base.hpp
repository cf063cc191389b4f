// Shared pieces of the compile-fail cases: a simulator-like type with every member but those a
// case leaves out (selected by macros).
#include <maskadapt/sim/simulator.hpp>

struct Sim {
  std::size_t num_envs() const { return 1; }
  const maskadapt::Skeleton& skeleton() const { return skel; }
  double control_dt() const { return 1.0 / 30.0; }
  void reset(std::size_t, const maskadapt::KinematicState&) {}
  void step(const Eigen::Ref<const maskadapt::MatrixXf>&) {}
#ifdef BODY_STATES_BY_VALUE
  maskadapt::BodyStates body_states(std::size_t) const { return states; }
#else
  const maskadapt::BodyStates& body_states(std::size_t) const { return states; }
#endif
#ifndef MISSING_CONTACTS
  const maskadapt::ContactFlags& contacts(std::size_t) const { return flags; }
#endif
  const maskadapt::StepStats& step_stats() const { return stats; }
  maskadapt::Skeleton skel;
  maskadapt::BodyStates states;
  maskadapt::ContactFlags flags;
  maskadapt::StepStats stats;
};

template <maskadapt::Simulator S>
void use(S&) {}

inline void check() {
  Sim s;
  use(s);  // must fail to compile when a requirement is missing
}
