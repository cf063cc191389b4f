#pragma once
/// \file ik.hpp
/// Per-frame inverse kinematics of the G1-like robot over position and direction targets
/// (g1/retarget.hpp builds the targets from humanoid motion; docs/characters.md, "Retargeting
/// onto the G1").
///
/// Targets (world frame, `IkTargets`): the root pose, 5 end-effector points (the two soles —
/// the point of the sole under the ankle —, the two hand centres, the head centre) and 18 unit
/// directions (upper arms, forearms, thighs, shanks as bone vectors between joint centres; hands:
/// wrist → hand centre and the back-of-hand normal, which fixes the otherwise free wrist roll; the
/// torso link's up and forward axes; each ankle-roll link's forward and up axes). With the root
/// pose given, the 29 joint angles minimise, inside the joint limits (box constraints),
///     f(q) = ½ Σ_e w_e² |p_e(q) − p*_e|² + ½ Σ_k v_k² |d_k(q) − d*_k|²
///          + ½ λ_prev² |q − q_{t−1}|² + ½ λ_nom² |q − q_nominal|²
/// by projected Levenberg–Marquardt (Gauss–Newton with adaptive damping): at each iteration the
/// variables at a bound whose gradient pushes outward are held fixed, the damped normal equations
/// are solved for the others, the step is clamped to the box and accepted only if it lowers f.
/// Jacobians are analytic: ∂p/∂q_j = a_j × (p − o_j) for the hinge axes a_j (world) at link
/// origins o_j, ∂d/∂q_j = a_j × d for a link axis, (I − d dᵀ)/|v| · ∂v/∂q_j for a bone v.
/// Joint limits hold exactly by construction (every iterate is clamped to the box).
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/g1/description.hpp>

#include <Eigen/Cholesky>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace maskadapt::g1 {

/// End-effectors (points): index into IkTargets::pos.
enum Effector : int { kLeftFoot = 0, kRightFoot, kLeftHand, kRightHand, kHead, kNumEffectors };
/// Directions (unit vectors): index into IkTargets::dir.
enum Direction : int {
  kLeftUpperArm = 0, kRightUpperArm, kLeftForearm, kRightForearm, kLeftHandDir, kRightHandDir,
  kLeftHandBack, kRightHandBack, kLeftThigh, kRightThigh, kLeftShank, kRightShank, kTorsoUp, kTorsoForward,
  kLeftFootForward, kRightFootForward, kLeftFootUp, kRightFootUp, kNumDirections
};

inline const char* effector_name(int e) {
  static const char* n[kNumEffectors] = {"left foot", "right foot", "left hand", "right hand", "head"};
  return n[e];
}

/// What one frame's IK aims at (world frame, metres; directions unit length).
struct IkTargets {
  Vec3 root_pos = Vec3::Zero();
  Quat root_rot = Quat::Identity();
  std::array<Vec3, kNumEffectors> pos{};
  std::array<Vec3, kNumDirections> dir{};
};

/// Weights of the IK cost (see file comment): w_e in 1/m, v_k dimensionless, λ in 1/rad.
struct IkWeights {
  std::array<double, kNumEffectors> pos = {5.0, 5.0, 1.0, 1.0, 0.5};
  std::array<double, kNumDirections> dir = {0.3, 0.3, 0.3, 0.3,              // upper arms, forearms
                                            0.05, 0.05, 0.05, 0.05,          // hands, backs of the hands
                                            0.3, 0.3, 0.3, 0.3,              // thighs, shanks
                                            0.3, 0.3,                        // torso up, forward
                                            0.2, 0.2, 0.2, 0.2};             // feet forward, up
  double prev = 0.02;     ///< λ_prev: pull towards the previous frame (temporal smoothness)
  double nominal = 0.005; ///< λ_nom: pull towards the nominal pose (resolves the free wrist roll)
  int max_iterations = 100;
  double tolerance = 1e-10;  ///< stop when a step lowers f by less than tolerance·(1 + f)
};

struct IkResult {
  VectorXd q;           ///< (29) joint angles, inside the limits
  double cost = 0;      ///< f at q
  int iterations = 0;
  bool converged = false;
};

/// The G1 side of the features (Pinocchio-style const model built once per description).
struct IkModel {
  struct Point {
    int link = 0;
    Vec3 local = Vec3::Zero();  ///< in the link frame
  };
  /// A direction: normalised (b − a) of two points, or (axis) the link-frame unit vector `b.local`
  /// of link b rotated to world.
  struct Dir {
    Point a, b;
    bool axis = false;
  };
  const G1Description* desc = nullptr;
  std::array<Point, kNumEffectors> eff{};
  std::array<Dir, kNumDirections> dir{};
  std::vector<std::vector<int>> chain;  ///< per link: itself and its ancestors, root excluded
  VectorXd lower, upper, nominal;       ///< (29)
};

inline IkModel make_ik_model(const G1Description& d) {
  d.validate();
  IkModel m;
  m.desc = &d;
  m.lower = d.joint_vector(&Link::lower);
  m.upper = d.joint_vector(&Link::upper);
  m.nominal = d.nominal_q;
  m.chain.resize(static_cast<std::size_t>(d.num_bodies()));
  for (int i = 1; i < d.num_bodies(); ++i)
    for (int k = i; k > 0; k = d.links[static_cast<std::size_t>(k)].parent) m.chain[static_cast<std::size_t>(i)].push_back(k);
  auto L = [&](const std::string& n) { return d.link_index(n); };
  auto geom_of = [&](int link, Geom::Type type) -> const Geom& {
    const auto& gs = d.links[static_cast<std::size_t>(link)].geoms;
    for (auto it = gs.rbegin(); it != gs.rend(); ++it)
      if (it->type == type) return *it;
    throw Error("G1 retargeting: link has no geom of the expected type", {{}, {}, d.links[static_cast<std::size_t>(link)].name});
  };
  for (int side = 0; side < 2; ++side) {
    const std::string s = side == 0 ? "left_" : "right_";
    const int foot = L(s + "ankle_roll_link"), hand = L(s + "wrist_yaw_link");
    const Geom& sole = geom_of(foot, Geom::Type::Box);
    m.eff[static_cast<std::size_t>(kLeftFoot + side)] = {foot, Vec3(0, 0, sole.a.z() - sole.b.z())};
    m.eff[static_cast<std::size_t>(kLeftHand + side)] = {hand, geom_of(hand, Geom::Type::Sphere).a};
    auto bone = [&](int k, const std::string& from, const std::string& to) {
      m.dir[static_cast<std::size_t>(k + side)] = {{L(s + from), Vec3::Zero()}, {L(s + to), Vec3::Zero()}, false};
    };
    auto axis = [&](int k, int link, const Vec3& u) { m.dir[static_cast<std::size_t>(k + side)] = {{link, u}, {link, u}, true}; };
    bone(kLeftUpperArm, "shoulder_pitch_link", "elbow_link");
    bone(kLeftForearm, "elbow_link", "wrist_roll_link");
    axis(kLeftHandDir, hand, Vec3::UnitX());
    axis(kLeftHandBack, hand, side == 0 ? Vec3::UnitY() : Vec3(-Vec3::UnitY()));
    bone(kLeftThigh, "hip_pitch_link", "knee_link");
    bone(kLeftShank, "knee_link", "ankle_pitch_link");
    axis(kLeftFootForward, foot, Vec3::UnitX());
    axis(kLeftFootUp, foot, Vec3::UnitZ());
  }
  m.eff[kHead] = {d.head_link, d.head_centre};
  const int torso = L("torso_link");
  m.dir[kTorsoUp] = {{torso, Vec3::UnitZ()}, {torso, Vec3::UnitZ()}, true};
  m.dir[kTorsoForward] = {{torso, Vec3::UnitX()}, {torso, Vec3::UnitX()}, true};
  return m;
}

/// The G1's effector points and directions for a pose (same order as IkTargets).
inline void g1_features(const IkModel& m, const LinkPoses& p, std::array<Vec3, kNumEffectors>& pos,
                        std::array<Vec3, kNumDirections>& dir) {
  auto world = [&](const IkModel::Point& pt) {
    const auto u = static_cast<std::size_t>(pt.link);
    return Vec3(p.pos[u] + p.rot[u] * pt.local);
  };
  for (int e = 0; e < kNumEffectors; ++e) pos[static_cast<std::size_t>(e)] = world(m.eff[static_cast<std::size_t>(e)]);
  for (int k = 0; k < kNumDirections; ++k) {
    const IkModel::Dir& dd = m.dir[static_cast<std::size_t>(k)];
    dir[static_cast<std::size_t>(k)] = dd.axis ? Vec3(p.rot[static_cast<std::size_t>(dd.b.link)] * dd.b.local)
                                               : Vec3((world(dd.b) - world(dd.a)).normalized());
  }
}

namespace detail {

/// Residuals r (rows: 3 per effector, 3 per direction, 29 prev, 29 nominal) and, if J is given,
/// their Jacobian (rows × 29). Returns f = ½|r|².
inline double ik_residual(const IkModel& m, const IkTargets& tg, const IkWeights& w, const VectorXd& q,
                          const VectorXd* q_prev, VectorXd& r, MatrixXd* J) {
  const G1Description& d = *m.desc;
  const int nj = kNumJoints;
  const int rows = 3 * kNumEffectors + 3 * kNumDirections + 2 * nj;
  r.setZero(rows);
  if (J) J->setZero(rows, nj);
  const LinkPoses p = forward_kinematics(d, tg.root_pos, tg.root_rot, q);
  // world hinge axes (a_k = R_k·axis_k: a hinge's axis is fixed under its own rotation)
  std::array<Vec3, kNumBodies> ax{};
  for (int k = 1; k < d.num_bodies(); ++k)
    ax[static_cast<std::size_t>(k)] = p.rot[static_cast<std::size_t>(k)] * d.links[static_cast<std::size_t>(k)].axis;
  auto world = [&](const IkModel::Point& pt) {
    const auto u = static_cast<std::size_t>(pt.link);
    return Vec3(p.pos[u] + p.rot[u] * pt.local);
  };
  // adds s·∂(point)/∂q to rows [row, row+3)
  auto point_jac = [&](const IkModel::Point& pt, const Vec3& x, int row, double s) {
    for (int k : m.chain[static_cast<std::size_t>(pt.link)]) {
      const auto u = static_cast<std::size_t>(k);
      J->block<3, 1>(row, k - 1) += s * ax[u].cross(x - p.pos[u]);
    }
  };
  int row = 0;
  for (int e = 0; e < kNumEffectors; ++e, row += 3) {
    const auto u = static_cast<std::size_t>(e);
    const Vec3 x = world(m.eff[u]);
    r.segment<3>(row) = w.pos[u] * (x - tg.pos[u]);
    if (J) point_jac(m.eff[u], x, row, w.pos[u]);
  }
  for (int k = 0; k < kNumDirections; ++k, row += 3) {
    const auto u = static_cast<std::size_t>(k);
    const IkModel::Dir& dd = m.dir[u];
    if (dd.axis) {
      const Vec3 a = p.rot[static_cast<std::size_t>(dd.b.link)] * dd.b.local;
      r.segment<3>(row) = w.dir[u] * (a - tg.dir[u]);
      if (J)
        for (int c : m.chain[static_cast<std::size_t>(dd.b.link)])
          J->block<3, 1>(row, c - 1) += w.dir[u] * ax[static_cast<std::size_t>(c)].cross(a);
    } else {
      const Vec3 xa = world(dd.a), xb = world(dd.b);
      const Vec3 v = xb - xa;
      const double n = v.norm();
      const Vec3 dv = v / n;
      r.segment<3>(row) = w.dir[u] * (dv - tg.dir[u]);
      if (J) {
        Eigen::Matrix<double, 3, kNumJoints> Jv = Eigen::Matrix<double, 3, kNumJoints>::Zero();
        for (int c : m.chain[static_cast<std::size_t>(dd.b.link)])
          Jv.col(c - 1) += ax[static_cast<std::size_t>(c)].cross(xb - p.pos[static_cast<std::size_t>(c)]);
        for (int c : m.chain[static_cast<std::size_t>(dd.a.link)])
          Jv.col(c - 1) -= ax[static_cast<std::size_t>(c)].cross(xa - p.pos[static_cast<std::size_t>(c)]);
        J->middleRows<3>(row) += (w.dir[u] / n) * (Mat3::Identity() - dv * dv.transpose()) * Jv;
      }
    }
  }
  if (q_prev) {
    r.segment(row, nj) = w.prev * (q - *q_prev);
    if (J) J->block(row, 0, nj, nj).diagonal().setConstant(w.prev);
  }
  row += nj;
  r.segment(row, nj) = w.nominal * (q - m.nominal);
  if (J) J->block(row, 0, nj, nj).diagonal().setConstant(w.nominal);
  return 0.5 * r.squaredNorm();
}

}  // namespace detail

/// Box-constrained IK for one frame (projected Levenberg–Marquardt, see file comment).
/// `q_init` (29): start (clamped to the limits); `q_prev` (29, optional): the previous frame.
inline IkResult solve_ik(const IkModel& m, const IkTargets& tg, const IkWeights& w, const VectorXd& q_init,
                         const VectorXd* q_prev = nullptr) {
  const int nj = kNumJoints;
  require(q_init.size() == nj, "G1 IK: q_init needs 29 entries", {{}, {}, "q_init"});
  require(!q_prev || q_prev->size() == nj, "G1 IK: q_prev needs 29 entries", {{}, {}, "q_prev"});
  require(q_init.allFinite(), "G1 IK: q_init is not finite", {{}, {}, "q_init"});
  require(tg.root_pos.allFinite() && tg.root_rot.coeffs().allFinite(), "G1 IK: root target is not finite",
          {{}, {}, "root"});
  for (int e = 0; e < kNumEffectors; ++e)
    require(tg.pos[static_cast<std::size_t>(e)].allFinite(), std::string("G1 IK: target of the ") + effector_name(e) + " is not finite",
            {{}, {}, "pos"});
  for (int k = 0; k < kNumDirections; ++k)
    require(tg.dir[static_cast<std::size_t>(k)].allFinite(), "G1 IK: direction target " + std::to_string(k) + " is not finite",
            {{}, {}, "dir"});
  IkResult res;
  VectorXd q = q_init.cwiseMax(m.lower).cwiseMin(m.upper);
  VectorXd r, r_new;
  MatrixXd J;
  double f = detail::ik_residual(m, tg, w, q, q_prev, r, &J);
  double mu = 1e-4;
  for (int it = 0; it < w.max_iterations; ++it) {
    res.iterations = it + 1;
    const VectorXd g = J.transpose() * r;
    const MatrixXd H = J.transpose() * J;
    // free variables: not pinned at a bound by a gradient pointing out of the box
    std::vector<int> fr;
    for (int j = 0; j < nj; ++j) {
      const bool at_lo = q[j] <= m.lower[j] + 1e-12 && g[j] > 0;
      const bool at_hi = q[j] >= m.upper[j] - 1e-12 && g[j] < 0;
      if (!at_lo && !at_hi) fr.push_back(j);
    }
    double gmax = 0;
    for (int j : fr) gmax = std::max(gmax, std::abs(g[j]));
    if (fr.empty() || gmax < 1e-12) {
      res.converged = true;
      break;
    }
    const int nf = static_cast<int>(fr.size());
    MatrixXd Hf(nf, nf);
    VectorXd gf(nf);
    for (int a = 0; a < nf; ++a) {
      gf[a] = g[fr[static_cast<std::size_t>(a)]];
      for (int b = 0; b < nf; ++b) Hf(a, b) = H(fr[static_cast<std::size_t>(a)], fr[static_cast<std::size_t>(b)]);
    }
    bool accepted = false;
    double f_new = f;
    VectorXd q_new;
    for (int tries = 0; tries < 12 && !accepted; ++tries) {
      MatrixXd A = Hf;
      A.diagonal() += mu * (Hf.diagonal().array() + 1e-9).matrix();
      const VectorXd step = A.ldlt().solve(-gf);
      q_new = q;
      for (int a = 0; a < nf; ++a) q_new[fr[static_cast<std::size_t>(a)]] += step[a];
      q_new = q_new.cwiseMax(m.lower).cwiseMin(m.upper);
      f_new = detail::ik_residual(m, tg, w, q_new, q_prev, r_new, nullptr);
      if (std::isfinite(f_new) && f_new < f) {
        accepted = true;
        mu = std::max(mu / 3.0, 1e-9);
      } else {
        mu *= 8.0;
      }
    }
    if (!accepted) {
      res.converged = true;  // no descent step left at this damping: a (constrained) minimum
      break;
    }
    const double gain = f - f_new;
    q = q_new;
    f = detail::ik_residual(m, tg, w, q, q_prev, r, &J);
    if (gain < w.tolerance * (1.0 + f)) {
      res.converged = true;
      break;
    }
  }
  res.q = q;
  res.cost = f;
  return res;
}

}  // namespace maskadapt::g1
