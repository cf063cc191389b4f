// One source of truth: the library's forward kinematics equals MuJoCo's on the generated model.
#include <maskadapt/core/rng.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/sim/mujoco/humanoid_sim.hpp>

#include "../build_paths.hpp"
#include "../skeleton_vs_mujoco.hpp"

#include <gtest/gtest.h>

#include <iostream>

using namespace maskadapt;

namespace {
KinematicState random_state(Rng& r, bool with_velocity) {
  const Skeleton& s = humanoid_skeleton();
  KinematicState st = KinematicState::zero(s);
  st.root_pos = Vec3(r.uniform(-2, 2), r.uniform(-2, 2), r.uniform(0.8, 1.5));
  st.root_rot = Quat(r.normal(), r.normal(), r.normal(), r.normal()).normalized();
  for (int k = 0; k < s.num_dofs(); ++k) st.q[k] = r.uniform(s.dof_lower(k), s.dof_upper(k));
  if (with_velocity) {
    for (Index k = 0; k < st.qd.size(); ++k) st.qd[k] = r.normal(0, 2);
    st.root_lin_vel = Vec3(r.normal(), r.normal(), r.normal());
    st.root_ang_vel = Vec3(r.normal(), r.normal(), r.normal());
  }
  return st;
}
}  // namespace

TEST(MujocoKinematics, BodyPosesMatchLibraryForwardKinematics) {
  MujocoHumanoidSim sim(1);
  Rng r(21);
  double worst_pos = 0, worst_rot = 0;
  for (int trial = 0; trial < 50; ++trial) {
    const KinematicState st = random_state(r, false);
    sim.reset(0, st);
    const BodyStates lib = forward_kinematics(sim.skeleton(), st);
    const BodyStates& mj = sim.body_states(0);
    for (int i = 0; i < 22; ++i) {
      worst_pos = std::max(worst_pos, (lib.pos.col(i) - mj.pos.col(i)).norm());
      worst_rot = std::max(worst_rot, lib.rot[i].angularDistance(mj.rot[i]));
    }
  }
  std::cout << "worst body position error " << worst_pos << " m, rotation error " << worst_rot << " rad\n";
  EXPECT_LT(worst_pos, 1e-5) << "metres";
  EXPECT_LT(worst_rot, 1e-5) << "radians";
}

TEST(MujocoKinematics, BodyVelocitiesMatchLibrary) {
  // Exercises the free joint's body-local angular velocity conversion and mj_objectVelocity.
  MujocoHumanoidSim sim(1);
  Rng r(22);
  for (int trial = 0; trial < 20; ++trial) {
    const KinematicState st = random_state(r, true);
    sim.reset(0, st);
    const BodyStates lib = forward_kinematics(sim.skeleton(), st);
    const BodyStates& mj = sim.body_states(0);
    for (int i = 0; i < 22; ++i) {
      ASSERT_LT((lib.lin_vel.col(i) - mj.lin_vel.col(i)).norm(), 1e-6) << sim.skeleton().names[i];
      ASSERT_LT((lib.ang_vel.col(i) - mj.ang_vel.col(i)).norm(), 1e-6) << sim.skeleton().names[i];
    }
  }
}

TEST(MujocoKinematics, MassAndJointRangesMatchTheDescription) {
  MujocoHumanoidSim sim(1);
  const mjModel* m = sim.model();
  double mass = 0;
  for (int b = 0; b < m->nbody; ++b) mass += m->body_mass[b];
  EXPECT_NEAR(mass, humanoid_description().total_mass(), 1e-9);
  const int j = mj_name2id(m, mjOBJ_JOINT, "L_Knee_y");
  ASSERT_GE(j, 0);
  EXPECT_DOUBLE_EQ(m->jnt_range[2 * j + 1], humanoid_skeleton().dof_upper(humanoid_skeleton().dof_offset(hb::LKnee) + 1));
  EXPECT_DOUBLE_EQ(m->opt.timestep, 1.0 / 60.0);
  EXPECT_EQ(m->opt.integrator, mjINT_EULER);
  EXPECT_EQ(m->opt.solver, mjSOL_NEWTON);
  EXPECT_EQ(m->opt.iterations, 100);
  EXPECT_EQ(m->opt.tolerance, 1e-8);
  EXPECT_EQ(m->opt.cone, mjCONE_PYRAMIDAL);
  EXPECT_EQ(m->opt.jacobian, mjJAC_AUTO);  // sparse at nv = 69 (dense measured slower, docs/benchmarks.md)
  EXPECT_EQ(m->nv, 69);
  EXPECT_DOUBLE_EQ(m->dof_armature[m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, "L_Ankle_x")]], 0.08);
  EXPECT_DOUBLE_EQ(m->dof_armature[m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, "R_Wrist_z")]], 0.04);
  EXPECT_DOUBLE_EQ(m->geom_solref[2 * mj_name2id(m, mjOBJ_GEOM, "floor")], 0.02);
}

TEST(MujocoKinematics, CommittedAssetLoads) {
  const std::string path = maskadapt::build_paths::source_dir() + "/assets/humanoid.xml";
  auto m = mujoco_detail::load_model_from_file(path);
  EXPECT_EQ(m->nu, 63);
  EXPECT_EQ(m->nbody, 23);
}

TEST(MujocoKinematics, LoadErrorsBecomeLibraryErrors) {
  try {
    mujoco_detail::load_model_from_string("<mujoco><worldbody><body><geom type='nonsense'/></body></worldbody></mujoco>",
                                          "broken.xml");
    FAIL() << "broken MJCF accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, "broken.xml");
    EXPECT_NE(std::string(e.what()).find("MuJoCo could not load"), std::string::npos) << e.what();
  }
  EXPECT_THROW(mujoco_detail::load_model_from_file("/nonexistent/humanoid.xml"), Error);
}

TEST(MujocoKinematics, GenericSkeletonMatchesTheCommittedAsset) {
  // The skeleton's hinges (x, y, z per body, DoF order) are the joints of assets/humanoid.xml,
  // and forward_kinematics over those hinge axes gives MuJoCo's xpos/xquat and body velocities.
  const auto m = mujoco_detail::load_model_from_file(maskadapt::build_paths::source_dir() + "/assets/humanoid.xml");
  mujoco_detail::DataPtr d(mj_makeData(m.get()));
  const Skeleton& s = humanoid_skeleton();
  EXPECT_TRUE(s.has_xyz_layout());
  maskadapt::testing::expect_same_hinges(s, m.get());
  Rng r(23);
  maskadapt::testing::FkDifference worst;
  for (int trial = 0; trial < 20; ++trial) {
    const auto e = maskadapt::testing::compare_with_mujoco(s, m.get(), d.get(), random_state(r, true));
    worst.pos = std::max(worst.pos, e.pos);
    worst.rot = std::max(worst.rot, e.rot);
    worst.lin_vel = std::max(worst.lin_vel, e.lin_vel);
    worst.ang_vel = std::max(worst.ang_vel, e.ang_vel);
  }
  std::cout << "vs assets/humanoid.xml: " << worst.pos << " m, " << worst.rot << " rad, " << worst.lin_vel << " m/s, "
            << worst.ang_vel << " rad/s\n";
  EXPECT_LT(worst.pos, 1e-6);
  EXPECT_LT(worst.rot, 1e-6);
  EXPECT_LT(worst.lin_vel, 1e-6);
  EXPECT_LT(worst.ang_vel, 1e-6);
}
