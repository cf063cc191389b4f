#pragma once
/// \file foot_lock.hpp
/// Stance detection and foot contact cleanup on the G1 IK targets of a whole clip (step 4 of
/// g1/retarget.hpp; docs/characters.md, "Retargeting onto the G1"): stance phases of each source
/// sole are detected (low and slow), the foot's constant stance tilt is removed, its ground level
/// becomes z = 0, and in stance the sole target is held flat on the floor at the phase's mean
/// position (blended in and out over a few frames).
#include <maskadapt/core/types.hpp>
#include <maskadapt/g1/ik.hpp>

#include <algorithm>
#include <array>
#include <cstddef>
#include <vector>

namespace maskadapt::g1 {

namespace detail {
/// Foot contact cleanup on the per-frame targets (G1RetargetOptions::lock_feet, whose
/// lock_height, lock_speed and lock_blend are the parameters of the same names). For each foot,
/// frames whose sole target is within `lock_height` of the foot's low level (the 5th percentile
/// of its height over the clip) and moves horizontally slower than `lock_speed` form stance
/// phases. Inside a phase the sole target is held on the floor (z = 0) at the phase's mean
/// horizontal position, and the foot's up/forward direction targets are made level (up = +z,
/// forward projected on the floor); over `lock_blend` frames before and after a phase the targets
/// blend linearly from the source's to the held ones. `stance` (T × 2, out): 1 inside a phase.
/// Returns the number of (frame, foot) in stance. The source soles are often not flat on z = 0
/// in stance (the humanoid's feet from Bandai captures stand 15–23° toe-down, the sole point
/// under the ankle ≈ 7 cm up; CMU's 8–11° toe-up), hence the tilt removal below and the per-foot
/// ground level: after the tilt removal the 5th percentile of the foot's sole height becomes z = 0
/// in every frame, so a swing foot keeps the source's clearance above its own stance level.
/// Before holding, each foot's constant tilt in stance is removed from every frame: with the
/// foot frame R = [forward, up × forward, up] of the targets and ū the mean of Rᵀ·ẑ over the stance
/// frames, every frame's foot becomes R·C with C·ẑ = ū (minimal rotation), and its sole target
/// moves accordingly (`sole`: the scaled sole point in the foot frame); so a foot that the source
/// holds 20° toe-down in every stance is level in stance and keeps its motion relative to that.
inline long long lock_feet(std::vector<IkTargets>& tg, double fps, double lock_height, double lock_speed,
                           int lock_blend, std::vector<std::array<char, 2>>& stance_out,
                           const Vec3& sole = Vec3::Zero()) {
  const int T = static_cast<int>(tg.size());
  long long held = 0;
  stance_out.assign(static_cast<std::size_t>(T), {0, 0});
  if (T < 1) return held;
  const int feet[2] = {kLeftFoot, kRightFoot};
  const int fwd_dir[2] = {kLeftFootForward, kRightFootForward}, up_dir[2] = {kLeftFootUp, kRightFootUp};
  for (int side = 0; side < 2; ++side) {
    const auto uf = static_cast<std::size_t>(feet[side]);
    std::vector<Vec3> P(static_cast<std::size_t>(T));
    std::vector<double> z(static_cast<std::size_t>(T));
    for (int t = 0; t < T; ++t) {
      P[static_cast<std::size_t>(t)] = tg[static_cast<std::size_t>(t)].pos[uf];
      z[static_cast<std::size_t>(t)] = P[static_cast<std::size_t>(t)].z();
    }
    const auto k5 = static_cast<std::ptrdiff_t>(0.05 * (T - 1));
    std::nth_element(z.begin(), z.begin() + k5, z.end());
    const double z_low = z[static_cast<std::size_t>(k5)];
    std::vector<char> stance(static_cast<std::size_t>(T), 0);
    for (int t = 0; t < T; ++t) {
      const int a = std::max(t - 1, 0), b = std::min(t + 1, T - 1);
      const double v =
          b > a ? (P[static_cast<std::size_t>(b)] - P[static_cast<std::size_t>(a)]).head<2>().norm() * fps / (b - a) : 0.0;
      stance[static_cast<std::size_t>(t)] = P[static_cast<std::size_t>(t)].z() < z_low + lock_height && v < lock_speed;
    }
    // remove the foot's mean stance tilt from every frame
    auto foot_frame = [&](const IkTargets& g) {
      const Vec3 up = g.dir[static_cast<std::size_t>(up_dir[side])].normalized();
      Vec3 fw = g.dir[static_cast<std::size_t>(fwd_dir[side])];
      fw = (fw - up * up.dot(fw)).normalized();
      Mat3 R;
      R << fw, up.cross(fw), up;
      return R;
    };
    Vec3 ubar = Vec3::Zero();
    int ns = 0;
    for (int t = 0; t < T; ++t)
      if (stance[static_cast<std::size_t>(t)]) ubar += foot_frame(tg[static_cast<std::size_t>(t)]).transpose() * Vec3::UnitZ(), ++ns;
    if (ns > 0 && ubar.norm() > 1e-9) {
      const Mat3 C = Quat::FromTwoVectors(Vec3::UnitZ(), ubar.normalized()).toRotationMatrix();
      for (int t = 0; t < T; ++t) {
        IkTargets& g = tg[static_cast<std::size_t>(t)];
        const Mat3 R = foot_frame(g);
        g.dir[static_cast<std::size_t>(fwd_dir[side])] = R * C * Vec3::UnitX();
        g.dir[static_cast<std::size_t>(up_dir[side])] = R * C * Vec3::UnitZ();
        g.pos[uf] += R * (C * sole - sole);
        P[static_cast<std::size_t>(t)] = g.pos[uf];
      }
    }
    // the foot's ground level (5th percentile of its corrected height) becomes z = 0
    for (int t = 0; t < T; ++t) z[static_cast<std::size_t>(t)] = P[static_cast<std::size_t>(t)].z();
    std::nth_element(z.begin(), z.begin() + k5, z.end());
    const double level = z[static_cast<std::size_t>(k5)];
    for (int t = 0; t < T; ++t) {
      tg[static_cast<std::size_t>(t)].pos[uf].z() -= level;
      P[static_cast<std::size_t>(t)].z() -= level;
    }
    std::vector<double> w(static_cast<std::size_t>(T), 0.0);  // weight of the held target
    std::vector<Vec3> anchor(static_cast<std::size_t>(T), Vec3::Zero());
    for (int a = 0; a < T;) {
      if (!stance[static_cast<std::size_t>(a)]) {
        ++a;
        continue;
      }
      int b = a;
      while (b + 1 < T && stance[static_cast<std::size_t>(b + 1)]) ++b;
      Vec3 mean = Vec3::Zero();
      for (int t = a; t <= b; ++t) mean += P[static_cast<std::size_t>(t)];
      mean /= (b - a + 1);
      mean.z() = 0.0;
      for (int t = a; t <= b; ++t) stance_out[static_cast<std::size_t>(t)][static_cast<std::size_t>(side)] = 1;
      const int n = std::max(lock_blend, 0);
      for (int t = std::max(a - n, 0); t <= std::min(b + n, T - 1); ++t) {
        const double d = t < a ? a - t : t > b ? t - b : 0;
        const double wt = 1.0 - d / (n + 1);
        const auto u = static_cast<std::size_t>(t);
        if (wt > w[u]) {
          w[u] = wt;
          anchor[u] = mean;
        }
      }
      held += b - a + 1;
      a = b + 1;
    }
    for (int t = 0; t < T; ++t) {
      const auto u = static_cast<std::size_t>(t);
      if (w[u] <= 0) continue;
      IkTargets& g = tg[u];
      g.pos[uf] = (1 - w[u]) * g.pos[uf] + w[u] * anchor[u];
      Vec3& up = g.dir[static_cast<std::size_t>(up_dir[side])];
      Vec3& fw = g.dir[static_cast<std::size_t>(fwd_dir[side])];
      Vec3 level(fw.x(), fw.y(), 0.0);
      if (level.norm() < 1e-6) level = g.root_rot * Vec3::UnitX(), level.z() = 0;
      if (level.norm() > 1e-6) fw = ((1 - w[u]) * fw + w[u] * level.normalized()).normalized();
      up = ((1 - w[u]) * up + w[u] * Vec3::UnitZ()).normalized();
    }
  }
  return held;
}
}  // namespace detail

}  // namespace maskadapt::g1
