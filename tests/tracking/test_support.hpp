#pragma once
// Small hand-made motions on the reference humanoid for the tracking tests.
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/tracking/builtin_generator.hpp>
#include <maskadapt/tracking/generator.hpp>
#include <maskadapt/tracking/primitive_dataset.hpp>

#include <cmath>

namespace maskadapt::tracking::test {

/// A generator small enough for unit tests: `width` hidden units in the VAE and the denoiser,
/// `latent` latent and text-embedding dimensions, 64 hashed text features.
inline BuiltinGeneratorConfig small_generator_config(Index width, Index latent) {
  BuiltinGeneratorConfig c;
  c.vae.hidden = {width};
  c.vae.latent = latent;
  c.denoiser.hidden = {width};
  c.denoiser.text_embed = latent;
  c.denoiser.text_features = 64;
  return c;
}

/// n frames at 30 Hz: the root walks forward at `speed` m/s while turning at `turn` rad/s and
/// bobbing; the shoulders swing with amplitude `arm` rad and the elbows follow.
inline Trajectory make_motion(Index n, double speed, double turn, double arm, double phase = 0.0) {
  const Skeleton& skel = humanoid_skeleton();
  Trajectory t = Trajectory::zeros(skel, n);
  const int ls = skel.index_of("L_Shoulder"), rs = skel.index_of("R_Shoulder");
  const int le = skel.index_of("L_Elbow"), re = skel.index_of("R_Elbow");
  const int lh = skel.index_of("L_Hip"), rh = skel.index_of("R_Hip");
  double x = 0.3, y = -0.2, yaw = 0.4;
  for (Index i = 0; i < n; ++i) {
    const double time = i / 30.0, w = 2.0 * 3.14159265 * 1.2 * time + phase;
    yaw += turn / 30.0;
    x += speed / 30.0 * std::cos(yaw);
    y += speed / 30.0 * std::sin(yaw);
    t.root_pos.col(i) = Vec3(x, y, 0.9 + 0.02 * std::sin(2 * w));
    t.root_rot[static_cast<std::size_t>(i)] = Quat(Eigen::AngleAxisd(yaw, Vec3::UnitZ())) *
                                              Quat(Eigen::AngleAxisd(0.05 * std::sin(w), Vec3::UnitX()));
    t.q(humanoid_skeleton().dof_offset(ls) + 0, i) = arm * std::sin(w);
    t.q(humanoid_skeleton().dof_offset(ls) + 1, i) = 0.5 * arm * std::cos(w);
    t.q(humanoid_skeleton().dof_offset(rs) + 0, i) = -arm * std::sin(w);
    t.q(humanoid_skeleton().dof_offset(rs) + 2, i) = 0.3 * arm * std::sin(w);
    t.q(humanoid_skeleton().dof_offset(le) + 2, i) = 0.5 + 0.4 * std::sin(w + 0.5);
    t.q(humanoid_skeleton().dof_offset(re) + 2, i) = -0.5 - 0.4 * std::sin(w + 0.5);
    t.q(humanoid_skeleton().dof_offset(lh) + 1, i) = 0.4 * std::sin(w);
    t.q(humanoid_skeleton().dof_offset(rh) + 1, i) = -0.4 * std::sin(w);
  }
  compute_body_positions(skel, t);
  return t;
}

inline std::vector<LabelledTrajectory> make_clips() {
  return {{"swing", {"wave hands", "swing arms"}, make_motion(90, 1.0, 0.2, 0.8), {}},
          {"raise", {"raise arms"}, make_motion(90, 0.3, -0.3, 1.4, 1.0), {}}};
}

}  // namespace maskadapt::tracking::test
