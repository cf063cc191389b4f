// The G1-like robot on MuJoCo: the generated model agrees with the description (mass, height,
// joints, forward kinematics — the G1's own and the generic Skeleton's), stands 10 s under PD at the nominal pose, and survives 10,000
// random-target control steps without a non-finite state or a MuJoCo instability warning.
#include <maskadapt/core/rng.hpp>
#include <maskadapt/g1/mjcf.hpp>
#include <maskadapt/g1/skeleton.hpp>
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>  // mujoco_detail::load_model_from_string/_file

#include "../build_paths.hpp"
#include "../skeleton_vs_mujoco.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>

using namespace maskadapt;
using namespace maskadapt::g1;

namespace {

const G1Description& D() { return g1_description(); }

mujoco_detail::ModelPtr load() { return mujoco_detail::load_model_from_string(g1_mjcf(D()), "g1.xml"); }

/// Places the robot: pelvis at `pos`/`rot`, hinges at `q`, at rest; refreshes kinematics.
void set_pose(const mjModel* m, mjData* d, const Vec3& pos, const Quat& rot, const VectorXd& q) {
  mj_resetData(m, d);
  for (int k = 0; k < 3; ++k) d->qpos[k] = pos[k];
  d->qpos[3] = rot.w(), d->qpos[4] = rot.x(), d->qpos[5] = rot.y(), d->qpos[6] = rot.z();
  for (int j = 0; j < kNumJoints; ++j) d->qpos[7 + j] = q[j];
  mj_forward(m, d);
}

void stand(const mjModel* m, mjData* d) {
  set_pose(m, d, Vec3(0, 0, D().nominal_root_height), Quat::Identity(), D().nominal_q);
  for (int j = 0; j < kNumJoints; ++j) d->ctrl[j] = D().nominal_q[j];
}

int instability_warnings(const mjData* d) {
  return d->warning[mjWARN_BADQACC].number + d->warning[mjWARN_BADQVEL].number + d->warning[mjWARN_BADQPOS].number +
         d->warning[mjWARN_BADCTRL].number + d->warning[mjWARN_CONTACTFULL].number +
         d->warning[mjWARN_CNSTRFULL].number + d->warning[mjWARN_INERTIA].number;
}

bool all_finite(const mjModel* m, const mjData* d) {
  for (int k = 0; k < m->nq; ++k)
    if (!std::isfinite(d->qpos[k])) return false;
  for (int k = 0; k < m->nv; ++k)
    if (!std::isfinite(d->qvel[k]) || !std::isfinite(d->qacc[k])) return false;
  return true;
}

}  // namespace

TEST(G1Mujoco, ModelSizesAndTotalMass) {
  auto m = load();
  EXPECT_EQ(m->nbody, kNumBodies + 1);  // + world
  EXPECT_EQ(m->njnt, kNumJoints + 1);   // + free root
  EXPECT_EQ(m->nq, 7 + kNumJoints);
  EXPECT_EQ(m->nv, 6 + kNumJoints);
  EXPECT_EQ(m->nu, kNumJoints);
  EXPECT_GE(m->nu, 23);
  EXPECT_LE(m->nu, 29);
  double mass = 0;
  for (int b = 0; b < m->nbody; ++b) mass += m->body_mass[b];
  std::cout << "MuJoCo total mass " << mass << " kg (description " << D().total_mass() << " kg)\n";
  EXPECT_NEAR(mass, D().total_mass(), 1e-9);
  for (int i = 0; i < kNumBodies; ++i) {
    const int b = mj_name2id(m.get(), mjOBJ_BODY, D().links[i].name.c_str());
    ASSERT_EQ(b, i + 1) << D().links[i].name;
    EXPECT_NEAR(m->body_mass[b], D().links[i].mass(), 1e-12) << D().links[i].name;
  }
  EXPECT_DOUBLE_EQ(m->opt.timestep, D().physics_dt);
  EXPECT_EQ(m->opt.integrator, mjINT_EULER);
}

TEST(G1Mujoco, JointRangesAxesAndActuatorsMatchTheDescription) {
  auto m = load();
  for (int j = 0; j < kNumJoints; ++j) {
    const Link& l = D().links[j + 1];
    const int id = mj_name2id(m.get(), mjOBJ_JOINT, l.joint.c_str());
    ASSERT_EQ(id, j + 1) << l.joint;  // joint order = description order
    EXPECT_EQ(m->jnt_type[id], mjJNT_HINGE);
    EXPECT_EQ(m->jnt_qposadr[id], 7 + j);
    EXPECT_EQ(m->jnt_bodyid[id], j + 2);
    EXPECT_TRUE(m->jnt_limited[id]);
    EXPECT_DOUBLE_EQ(m->jnt_range[2 * id], l.lower) << l.joint;
    EXPECT_DOUBLE_EQ(m->jnt_range[2 * id + 1], l.upper) << l.joint;
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(m->jnt_axis[3 * id + k], l.axis[k], 1e-12) << l.joint;
    const int dof = m->jnt_dofadr[id];
    EXPECT_DOUBLE_EQ(m->dof_damping[dof], l.kd) << l.joint;
    EXPECT_DOUBLE_EQ(m->dof_armature[dof], l.armature) << l.joint;
    // Actuator j drives joint j: force = kp·(ctrl − q), clamped to ±effort.
    EXPECT_EQ(m->actuator_trnid[2 * j], id);
    EXPECT_DOUBLE_EQ(m->actuator_gainprm[mjNGAIN * j], l.kp);
    EXPECT_DOUBLE_EQ(m->actuator_biasprm[mjNBIAS * j + 1], -l.kp);
    EXPECT_DOUBLE_EQ(m->actuator_forcerange[2 * j + 1], l.effort);
    EXPECT_DOUBLE_EQ(m->actuator_ctrlrange[2 * j], l.lower);
  }
}

TEST(G1Mujoco, ForwardKinematicsMatchesMujoco) {
  auto m = load();
  mujoco_detail::DataPtr d(mj_makeData(m.get()));
  Rng r(18);
  double worst_pos = 0, worst_rot = 0;
  for (int trial = 0; trial < 50; ++trial) {
    const Vec3 pos(r.uniform(-1, 1), r.uniform(-1, 1), r.uniform(0.5, 1.2));
    const Quat rot = Quat(r.uniform(-1, 1), r.uniform(-1, 1), r.uniform(-1, 1), r.uniform(-1, 1)).normalized();
    VectorXd q(kNumJoints);
    for (int j = 0; j < kNumJoints; ++j) q[j] = r.uniform(D().links[j + 1].lower, D().links[j + 1].upper);
    set_pose(m.get(), d.get(), pos, rot, q);
    const LinkPoses p = forward_kinematics(D(), pos, rot, q);
    for (int i = 0; i < kNumBodies; ++i) {
      const Vec3 mp(d->xpos[3 * (i + 1)], d->xpos[3 * (i + 1) + 1], d->xpos[3 * (i + 1) + 2]);
      const mjtNum* w = d->xquat + 4 * (i + 1);
      const Quat mq(w[0], w[1], w[2], w[3]);
      worst_pos = std::max(worst_pos, (mp - p.pos[i]).norm());
      worst_rot = std::max(worst_rot, mq.angularDistance(p.rot[i]));
    }
  }
  std::cout << "worst link position error " << worst_pos << " m, rotation error " << worst_rot << " rad\n";
  EXPECT_LT(worst_pos, 1e-9);
  EXPECT_LT(worst_rot, 1e-9);
}

TEST(G1Mujoco, StandingHeightAndFeetOnTheFloor) {
  auto m = load();
  mujoco_detail::DataPtr d(mj_makeData(m.get()));
  stand(m.get(), d.get());
  const LinkPoses p = forward_kinematics(D(), Vec3(0, 0, D().nominal_root_height), Quat::Identity(), D().nominal_q);
  const int h = D().head_link;
  const Vec3 mj_head = Vec3(d->xpos[3 * (h + 1)], d->xpos[3 * (h + 1) + 1], d->xpos[3 * (h + 1) + 2]) +
                       Quat(d->xquat[4 * (h + 1)], d->xquat[4 * (h + 1) + 1], d->xquat[4 * (h + 1) + 2],
                            d->xquat[4 * (h + 1) + 3]) * D().head_centre;
  const double mj_top = mj_head.z() + D().head_radius;
  std::cout << "nominal pose: head top " << mj_top << " m (FK " << head_top_height(D(), p) << " m), pelvis "
            << D().nominal_root_height << " m\n";
  EXPECT_NEAR(mj_top, head_top_height(D(), p), 1e-9);
  EXPECT_NEAR(mj_top, 1.30, 0.03);  // 1.32 m straight, a little lower with bent knees
  // Soles touch z = 0: the lowest point of every geom is ≥ 0, the feet's lowest is 0.
  for (int g = 1; g < m->ngeom; ++g) {
    const int b = m->geom_bodyid[g];
    const std::string name = mj_id2name(m.get(), mjOBJ_BODY, b);
    double low = d->geom_xpos[3 * g + 2];
    if (m->geom_type[g] == mjGEOM_BOX) {
      for (int k = 0; k < 3; ++k) low -= std::abs(d->geom_xmat[9 * g + 6 + k]) * m->geom_size[3 * g + k];
    } else if (m->geom_type[g] == mjGEOM_CAPSULE) {
      low -= std::abs(d->geom_xmat[9 * g + 8]) * m->geom_size[3 * g + 1] + m->geom_size[3 * g];
    } else {
      low -= m->geom_size[3 * g];
    }
    if (name.find("ankle_roll") != std::string::npos) EXPECT_NEAR(low, 0.0, 1e-6) << name;
    else EXPECT_GT(low, 0.01) << name;
  }
}

TEST(G1Mujoco, StandsTenSecondsUnderPd) {
  // At rest, and after small pushes (initial pelvis velocity, m/s): open-loop PD has a margin.
  auto m = load();
  mujoco_detail::DataPtr d(mj_makeData(m.get()));
  const double z0 = D().nominal_root_height;
  const int torso = D().head_link + 1, pelvis = 1;
  const int steps = static_cast<int>(std::lround(10.0 / m->opt.timestep));
  for (const Vec3& push : {Vec3(0, 0, 0), Vec3(0.1, 0, 0), Vec3(-0.1, 0, 0), Vec3(0, 0.2, 0)}) {
    stand(m.get(), d.get());
    for (int k = 0; k < 3; ++k) d->qvel[k] = push[k];
    double max_drift = 0, min_up = 1, max_xy = 0;
    int bad_contacts = 0;
    for (int s = 0; s < steps; ++s) {
      mj_step(m.get(), d.get());
      max_drift = std::max(max_drift, std::abs(d->xpos[3 * pelvis + 2] - z0));
      max_xy = std::max(max_xy, std::hypot(d->xpos[3 * pelvis], d->xpos[3 * pelvis + 1]));
      min_up = std::min(min_up, d->xmat[9 * torso + 8]);  // torso z-axis · world z
      for (int c = 0; c < d->ncon; ++c) {
        const int g = d->contact[c].geom1 == 0 ? d->contact[c].geom2 : d->contact[c].geom1;
        const std::string body = mj_id2name(m.get(), mjOBJ_BODY, m->geom_bodyid[g]);
        if (body.find("ankle_roll") == std::string::npos) ++bad_contacts;
      }
    }
    std::cout << "10 s standing, push (" << push.x() << ", " << push.y() << ") m/s: pelvis height drift " << max_drift
              << " m, horizontal drift " << max_xy << " m, min torso uprightness " << min_up << ", final pelvis z "
              << d->xpos[3 * pelvis + 2] << " m\n";
    EXPECT_TRUE(all_finite(m.get(), d.get()));
    EXPECT_EQ(instability_warnings(d.get()), 0);
    EXPECT_LT(max_drift, 0.03) << "metres";
    EXPECT_LT(max_xy, 0.06) << "metres";
    EXPECT_GT(min_up, std::cos(0.1));
    EXPECT_EQ(bad_contacts, 0) << "contacts of bodies other than the feet";
  }
}

TEST(G1Mujoco, SurvivesTenThousandRandomTargetSteps) {
  auto m = load();
  mujoco_detail::DataPtr d(mj_makeData(m.get()));
  stand(m.get(), d.get());
  Rng r(1818);
  const int control_steps = 10000, resample = 15;  // 30 Hz control: new targets every 0.5 s
  int falls = 0, fallen_for = 0, resets_by_mujoco = 0;
  double max_qacc = 0, max_qvel = 0;
  for (int t = 0; t < control_steps; ++t) {
    if (t % resample == 0)
      for (int j = 0; j < kNumJoints; ++j) d->ctrl[j] = r.uniform(D().links[j + 1].lower, D().links[j + 1].upper);
    for (int k = 0; k < D().substeps; ++k) {
      const double time = d->time;
      mj_step(m.get(), d.get());
      if (d->time < time) ++resets_by_mujoco;
      for (int v = 0; v < m->nv; ++v) {
        max_qacc = std::max(max_qacc, std::abs(d->qacc[v]));
        max_qvel = std::max(max_qvel, std::abs(d->qvel[v]));
      }
    }
    ASSERT_TRUE(all_finite(m.get(), d.get())) << "control step " << t;
    ASSERT_EQ(instability_warnings(d.get()), 0) << "control step " << t;
    // A fall (pelvis below 0.4 m) is allowed; after 1 s on the ground the robot is stood up again.
    if (d->qpos[2] < 0.4) {
      if (fallen_for++ == 0) ++falls;
      if (fallen_for >= 30) {
        stand(m.get(), d.get());
        fallen_for = 0;
      }
    } else {
      fallen_for = 0;
    }
  }
  std::cout << control_steps << " random-target control steps (" << control_steps * D().substeps
            << " physics steps): falls " << falls << ", max |qacc| " << max_qacc << ", max |qvel| " << max_qvel
            << ", MuJoCo resets " << resets_by_mujoco << "\n";
  EXPECT_EQ(resets_by_mujoco, 0);
  EXPECT_LT(max_qvel, 1e3);
}

TEST(G1Mujoco, CommittedAssetLoads) {
  auto m = mujoco_detail::load_model_from_file(maskadapt::build_paths::source_dir() + "/assets/g1.xml");
  EXPECT_EQ(m->nu, kNumJoints);
  EXPECT_EQ(m->nbody, kNumBodies + 1);
}

TEST(G1Mujoco, GenericSkeletonMatchesTheDescription) {
  const Skeleton& s = g1_skeleton();
  ASSERT_EQ(s.num_bodies(), kNumBodies);
  ASSERT_EQ(s.num_dofs(), kNumJoints);
  for (int i = 1; i < kNumBodies; ++i) {
    const Link& l = D().links[static_cast<std::size_t>(i)];
    EXPECT_EQ(s.names[static_cast<std::size_t>(i)], l.name);
    EXPECT_EQ(s.parents[static_cast<std::size_t>(i)], l.parent);
    EXPECT_EQ(s.parts[static_cast<std::size_t>(i)], l.part) << l.name;
    ASSERT_EQ(s.num_dofs_of(i), 1) << l.name;
    EXPECT_EQ(s.dof_offset(i), i - 1) << l.name;  // DoF k = joint k (motor order)
    EXPECT_EQ(s.dof_axis(i - 1), l.axis) << l.name;
    EXPECT_EQ(s.dof_lower(i - 1), l.lower);
    EXPECT_EQ(s.dof_upper(i - 1), l.upper);
  }
  EXPECT_FALSE(s.has_xyz_layout());
  EXPECT_THROW(s.require_xyz_layout("test"), Error);
  const auto m = mujoco_detail::load_model_from_file(maskadapt::build_paths::source_dir() + "/assets/g1.xml");
  maskadapt::testing::expect_same_hinges(s, m.get());
}

TEST(G1Mujoco, GenericForwardKinematicsMatchesG1FkAndMujoco) {
  // The generic Skeleton FK on the G1 (one hinge per link, arbitrary axes) against the G1's own
  // FK (same products, ~1e-15) and MuJoCo's xpos/xquat and body velocities on assets/g1.xml.
  const auto m = mujoco_detail::load_model_from_file(maskadapt::build_paths::source_dir() + "/assets/g1.xml");
  mujoco_detail::DataPtr d(mj_makeData(m.get()));
  const Skeleton& s = g1_skeleton();
  Rng r(181);
  double own_pos = 0, own_rot = 0;
  maskadapt::testing::FkDifference worst;
  for (int trial = 0; trial < 20; ++trial) {
    KinematicState st = KinematicState::zero(s);
    st.root_pos = Vec3(r.uniform(-1, 1), r.uniform(-1, 1), r.uniform(0.5, 1.2));
    st.root_rot = Quat(r.normal(), r.normal(), r.normal(), r.normal()).normalized();
    st.root_lin_vel = Vec3(r.normal(), r.normal(), r.normal());
    st.root_ang_vel = Vec3(r.normal(), r.normal(), r.normal());
    for (int k = 0; k < s.num_dofs(); ++k) {
      st.q[k] = r.uniform(s.dof_lower(k), s.dof_upper(k));
      st.qd[k] = r.normal(0, 2);
    }
    const BodyStates b = maskadapt::forward_kinematics(s, st);
    const LinkPoses p = g1::forward_kinematics(D(), st.root_pos, st.root_rot, st.q);
    for (int i = 0; i < kNumBodies; ++i) {
      own_pos = std::max(own_pos, (b.pos.col(i) - p.pos[static_cast<std::size_t>(i)]).norm());
      own_rot = std::max(own_rot, b.rot[static_cast<std::size_t>(i)].angularDistance(p.rot[static_cast<std::size_t>(i)]));
    }
    const auto e = maskadapt::testing::compare_with_mujoco(s, m.get(), d.get(), st);
    worst.pos = std::max(worst.pos, e.pos);
    worst.rot = std::max(worst.rot, e.rot);
    worst.lin_vel = std::max(worst.lin_vel, e.lin_vel);
    worst.ang_vel = std::max(worst.ang_vel, e.ang_vel);
  }
  std::cout << "generic FK vs G1 FK: " << own_pos << " m, " << own_rot << " rad; vs MuJoCo: " << worst.pos << " m, "
            << worst.rot << " rad, " << worst.lin_vel << " m/s, " << worst.ang_vel << " rad/s\n";
  EXPECT_LT(own_pos, 1e-9);
  EXPECT_LT(own_rot, 1e-9);
  EXPECT_LT(worst.pos, 1e-6);
  EXPECT_LT(worst.rot, 1e-6);
  EXPECT_LT(worst.lin_vel, 1e-6);
  EXPECT_LT(worst.ang_vel, 1e-6);
}
