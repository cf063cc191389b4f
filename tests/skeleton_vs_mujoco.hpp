#pragma once
// Checks a Skeleton against a MuJoCo model of the same character (tests/humanoid, tests/g1): the
// bodies are matched by name, body i's hinges are the joints MuJoCo declares inside that body,
// in order. expect_same_hinges checks axes and ranges; compare_with_mujoco places a kinematic
// state in MuJoCo (mj_forward) and returns the worst disagreement with forward_kinematics.
#include <maskadapt/motion/skeleton.hpp>

#include <mujoco/mujoco.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

namespace maskadapt::testing {

/// MuJoCo body id of every skeleton body, (num_bodies).
inline std::vector<int> mujoco_body_ids(const Skeleton& s, const mjModel* m) {
  std::vector<int> id(static_cast<std::size_t>(s.num_bodies()));
  for (int i = 0; i < s.num_bodies(); ++i) {
    id[static_cast<std::size_t>(i)] = mj_name2id(m, mjOBJ_BODY, s.names[static_cast<std::size_t>(i)].c_str());
    EXPECT_GT(id[static_cast<std::size_t>(i)], 0) << s.names[static_cast<std::size_t>(i)];
  }
  return id;
}

/// Every non-root body's MuJoCo joints are its hinges: same count, order, axes and ranges.
inline void expect_same_hinges(const Skeleton& s, const mjModel* m) {
  const std::vector<int> id = mujoco_body_ids(s, m);
  for (int i = 1; i < s.num_bodies(); ++i) {
    const int b = id[static_cast<std::size_t>(i)];
    ASSERT_EQ(m->body_jntnum[b], s.num_dofs_of(i)) << s.names[static_cast<std::size_t>(i)];
    for (int h = 0; h < s.num_dofs_of(i); ++h) {
      const int j = m->body_jntadr[b] + h, k = s.dof_offset(i) + h;
      EXPECT_EQ(m->jnt_type[j], mjJNT_HINGE);
      EXPECT_EQ(s.dof_body(k), i);
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(m->jnt_axis[3 * j + a], s.dof_axis(k)[a], 1e-12) << "hinge " << k;
      EXPECT_DOUBLE_EQ(m->jnt_range[2 * j], s.dof_lower(k)) << "hinge " << k;
      EXPECT_DOUBLE_EQ(m->jnt_range[2 * j + 1], s.dof_upper(k)) << "hinge " << k;
    }
  }
}

struct FkDifference {
  double pos = 0, rot = 0, lin_vel = 0, ang_vel = 0;  ///< worst over bodies: m, rad, m/s, rad/s
};

/// Places `st` in MuJoCo (root free joint: world linear, body-local angular velocity), runs
/// mj_forward and compares every body's xpos, xquat and velocity at its origin with
/// forward_kinematics(s, st).
inline FkDifference compare_with_mujoco(const Skeleton& s, const mjModel* m, mjData* d, const KinematicState& st) {
  const std::vector<int> id = mujoco_body_ids(s, m);
  mj_resetData(m, d);
  const int root = m->body_jntadr[id[0]];
  const int qa = m->jnt_qposadr[root], va = m->jnt_dofadr[root];
  const Quat R = st.root_rot.normalized();
  const Vec3 w_local = R.conjugate() * st.root_ang_vel;
  for (int a = 0; a < 3; ++a) {
    d->qpos[qa + a] = st.root_pos[a];
    d->qvel[va + a] = st.root_lin_vel[a];
    d->qvel[va + 3 + a] = w_local[a];
  }
  d->qpos[qa + 3] = R.w(), d->qpos[qa + 4] = R.x(), d->qpos[qa + 5] = R.y(), d->qpos[qa + 6] = R.z();
  for (int i = 1; i < s.num_bodies(); ++i)
    for (int h = 0; h < s.num_dofs_of(i); ++h) {
      const int j = m->body_jntadr[id[static_cast<std::size_t>(i)]] + h, k = s.dof_offset(i) + h;
      d->qpos[m->jnt_qposadr[j]] = st.q[k];
      d->qvel[m->jnt_dofadr[j]] = st.qd.size() ? st.qd[k] : 0.0;
    }
  mj_forward(m, d);
  const BodyStates b = forward_kinematics(s, st);
  FkDifference e;
  for (int i = 0; i < s.num_bodies(); ++i) {
    const int bi = id[static_cast<std::size_t>(i)];
    const Vec3 p(d->xpos[3 * bi], d->xpos[3 * bi + 1], d->xpos[3 * bi + 2]);
    const Quat q(d->xquat[4 * bi], d->xquat[4 * bi + 1], d->xquat[4 * bi + 2], d->xquat[4 * bi + 3]);
    mjtNum v[6];
    mj_objectVelocity(m, d, mjOBJ_XBODY, bi, v, 0);  // [angular; linear], world axes, at the body origin
    e.pos = std::max(e.pos, (p - b.pos.col(i)).norm());
    e.rot = std::max(e.rot, q.angularDistance(b.rot[static_cast<std::size_t>(i)]));
    if (st.qd.size()) {
      e.ang_vel = std::max(e.ang_vel, (Vec3(v[0], v[1], v[2]) - b.ang_vel.col(i)).norm());
      e.lin_vel = std::max(e.lin_vel, (Vec3(v[3], v[4], v[5]) - b.lin_vel.col(i)).norm());
    }
  }
  return e;
}

}  // namespace maskadapt::testing
