#pragma once
/// \file humanoid_sim.hpp
/// `MujocoHumanoidSim`: a humanoid character on MuJoCo (2.2.2+), N envs stepped in parallel —
/// the reference humanoid by default, or any `MujocoCharacter` (character.hpp: the G1-like robot,
/// or your own).
///
/// One const `mjModel` (the character's MJCF), one `mjData` per env. Each
/// `step(targets)` writes the PD targets into `ctrl`, runs `substeps` Euler steps per env on the
/// thread pool, refreshes kinematics (`mj_kinematics` + `mj_comPos` + `mj_comVel`: after
/// `mj_step` MuJoCo's positions describe the state before the last integration) and converts to
/// the library's conventions:
///  - MuJoCo quaternions (w, x, y, z) → Eigen (`Quat`);
///  - free-joint angular velocity qvel[3:6] is body-local → world on reset;
///  - body velocities from `mj_objectVelocity(mjOBJ_XBODY)` (world orientation, at the body origin).
/// Contact flags come from the last substep's contact list (floor vs body geoms).
///
/// Scene objects (sim/scene.hpp, `SceneSimulator`): the boxes given to the constructor are free
/// bodies appended to the world (geoms colliding with the floor and with the character), parked
/// at (50 + 5k, 50) m until a task places them. A character reset leaves them where they are.
/// Their contacts with the character are OR-ed over the substeps of a control step, so a short
/// punch is not missed.
///
/// Failure handling: an env whose state becomes non-finite or explodes (|qvel| > 1e4, or a body
/// farther than 1e4 m), or which MuJoCo reset itself (its time went backwards — MuJoCo 2.2.2
/// resets mjData on a bad qacc), is reset to the last pose given to `reset` and counted in
/// `step_stats()`. Other envs are unaffected. Results are bit-identical for any thread count:
/// env e only touches its own mjData and output slots.
///
/// This folder is the only place that includes <mujoco/mujoco.h>.
#include <maskadapt/core/error.hpp>
#include <maskadapt/core/thread_pool.hpp>
#include <maskadapt/core/types.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/humanoid/mjcf.hpp>
#include <maskadapt/sim/mujoco/character.hpp>
#include <maskadapt/sim/scene.hpp>
#include <maskadapt/sim/simulator.hpp>

#include <mujoco/mujoco.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

namespace maskadapt {

namespace mujoco_detail {

/// Count of MuJoCo warnings seen since the handler was installed (process-wide).
inline std::atomic<std::uint64_t>& warning_count() {
  static std::atomic<std::uint64_t> n{0};
  return n;
}
inline void count_warning(const char*) { warning_count().fetch_add(1, std::memory_order_relaxed); }

/// Installs a warning handler that counts instead of appending to MUJOCO_LOG.TXT, unless the
/// application installed its own.
inline void install_warning_handler() {
  if (mju_user_warning == nullptr) mju_user_warning = &count_warning;
}

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

/// Compiles MJCF text in memory (through a VFS); errors become maskadapt::Error.
inline ModelPtr load_model_from_string(const std::string& xml, const std::string& name = "humanoid.xml") {
  auto vfs = std::make_unique<mjVFS>();  // ~2 MB: keep it off the stack
  mj_defaultVFS(vfs.get());
  require(mj_makeEmptyFileVFS(vfs.get(), name.c_str(), static_cast<int>(xml.size())) == 0,
          "cannot create an in-memory MuJoCo file", {name, {}, {}});
  const int idx = mj_findFileVFS(vfs.get(), name.c_str());
  std::memcpy(vfs->filedata[idx], xml.data(), xml.size());
  char error[1000] = "";
  mjModel* m = mj_loadXML(name.c_str(), vfs.get(), error, sizeof error);
  mj_deleteVFS(vfs.get());
  if (!m) throw Error(std::string("MuJoCo could not load the model: ") + error, {name, {}, {}});
  return ModelPtr(m);
}

/// Loads an MJCF file from disk; errors become maskadapt::Error naming the file.
inline ModelPtr load_model_from_file(const std::string& path) {
  char error[1000] = "";
  mjModel* m = mj_loadXML(path.c_str(), nullptr, error, sizeof error);
  if (!m) throw Error(std::string("MuJoCo could not load the model: ") + error, {path, {}, {}});
  return ModelPtr(m);
}

}  // namespace mujoco_detail

class MujocoHumanoidSim {
 public:
  /// `num_envs` copies of the humanoid in `desc`, stepped on `pool` (nullptr: an owned pool with
  /// `num_threads` threads, 1 by default). Every env starts at the standing zero pose.
  /// `objects`: rigid boxes in every env's scene (none by default).
  explicit MujocoHumanoidSim(std::size_t num_envs, std::size_t num_threads = 1,
                             const HumanoidDescription& desc = humanoid_description(), std::vector<BoxObject> objects = {})
      : MujocoHumanoidSim(num_envs, nullptr, num_threads, mujoco_character(desc), std::move(objects)) {}
  MujocoHumanoidSim(std::size_t num_envs, ThreadPool& pool, const HumanoidDescription& desc = humanoid_description(),
                    std::vector<BoxObject> objects = {})
      : MujocoHumanoidSim(num_envs, &pool, 1, mujoco_character(desc), std::move(objects)) {}
  /// The same for any character (character.hpp); every env starts in `character.standing`.
  MujocoHumanoidSim(std::size_t num_envs, std::size_t num_threads, const MujocoCharacter& character,
                    std::vector<BoxObject> objects = {})
      : MujocoHumanoidSim(num_envs, nullptr, num_threads, character, std::move(objects)) {}
  MujocoHumanoidSim(std::size_t num_envs, ThreadPool& pool, const MujocoCharacter& character,
                    std::vector<BoxObject> objects = {})
      : MujocoHumanoidSim(num_envs, &pool, 1, character, std::move(objects)) {}

  MujocoHumanoidSim(const MujocoHumanoidSim&) = delete;
  MujocoHumanoidSim& operator=(const MujocoHumanoidSim&) = delete;

  // ---- Simulator concept -------------------------------------------------------------------
  std::size_t num_envs() const { return envs_.size(); }
  const Skeleton& skeleton() const { return ch_.skeleton; }
  double control_dt() const { return ch_.control_dt(); }
  const BodyStates& body_states(std::size_t env) const { return at(env).states; }
  const ContactFlags& contacts(std::size_t env) const { return at(env).contacts; }
  const StepStats& step_stats() const { return stats_; }

  /// Places env `env` at `pose` (root pose, joint angles, world root velocities, joint rates).
  /// Throws Error on a malformed pose. Joint angles outside the limits are accepted (MuJoCo pushes
  /// them back through its limit constraints).
  void reset(std::size_t env, const KinematicState& pose) {
    check_pose(ch_.skeleton, pose);
    Env& e = at(env);
    e.reset_pose = pose;
    if (e.reset_pose.qd.size() == 0) e.reset_pose.qd = VectorXd::Zero(ch_.skeleton.num_dofs());
    apply_reset(e);
  }

  /// One 30 Hz control step for all envs. `targets`: (num_dofs × num_envs) PD joint targets (rad);
  /// clipped to the joint ranges by MuJoCo. Throws Error (before touching any env) on wrong
  /// dimensions or NaN/inf.
  void step(const Eigen::Ref<const MatrixXf>& targets) {
    check_targets(targets, ch_.skeleton.num_dofs(), static_cast<Index>(num_envs()));
    step_impl([&](std::size_t env, mjtNum* ctrl) {
      for (Index k = 0; k < targets.rows(); ++k) ctrl[k] = static_cast<mjtNum>(targets(k, static_cast<Index>(env)));
    });
  }
  /// Double-precision targets, same contract.
  void step(const Eigen::Ref<const MatrixXd>& targets) {
    check_targets(targets, ch_.skeleton.num_dofs(), static_cast<Index>(num_envs()));
    step_impl([&](std::size_t env, mjtNum* ctrl) {
      for (Index k = 0; k < targets.rows(); ++k) ctrl[k] = targets(k, static_cast<Index>(env));
    });
  }

  // ---- scene objects (SceneSimulator) -------------------------------------------------------
  std::size_t num_objects() const { return objects_.size(); }
  const std::vector<BoxObject>& objects() const { return objects_; }
  const RigidState& object_state(std::size_t env, std::size_t k) const { return at(env).object_states.at(object_index(k)); }
  const ContactFlags& object_contacts(std::size_t env, std::size_t k) const {
    return at(env).object_contacts.at(object_index(k));
  }
  /// Puts object k of env `env` at `state` (world pose, world velocities); its contact flags are
  /// cleared. Takes effect from the next step. Throws Error on a bad index or state.
  void place_object(std::size_t env, std::size_t k, const RigidState& state) {
    check_rigid_state(state, "object_state");
    Env& e = at(env);
    RigidState s = state;
    s.rot.normalize();
    e.object_states[object_index(k)] = s;
    write_object(e.data.get(), k, s);
    std::fill(e.object_contacts[k].begin(), e.object_contacts[k].end(), 0);
  }

  // ---- extras --------------------------------------------------------------------------------
  /// The character this simulator runs (skeleton, MJCF, physics step, fall rules, geoms).
  const MujocoCharacter& character() const { return ch_; }
  const mjModel* model() const { return model_.get(); }
  /// Raw MuJoCo data of one env (advanced use and tests; writing it bypasses all checks).
  mjData* data(std::size_t env) { return at(env).data.get(); }
  const mjData* data(std::size_t env) const { return at(env).data.get(); }
  std::size_t num_threads() const { return pool_->num_threads(); }

  /// Joint angles (num_dofs) of an env, read from MuJoCo's qpos.
  VectorXd joint_angles(std::size_t env) const {
    const Env& e = at(env);
    VectorXd q(ch_.skeleton.num_dofs());
    for (Index k = 0; k < q.size(); ++k) q[k] = e.data->qpos[qpos_adr_[static_cast<std::size_t>(k)]];
    return q;
  }

  // ---- exact state of one env (bit-exact resume; tasks::StateSavingSimulator) ----------------
  // Saves everything that determines the env's next steps and what the library reads of it:
  // MuJoCo's time, qpos (nq), qvel (nv), act (na), qacc_warmstart (nv: the constraint solver's
  // initial guess), ctrl (nu), the contact flags and the body states read out after the last
  // step, and the pose a failure reset returns to. Layout: [nq, nv, na, nu, num_bodies,
  // num_dofs, time, qpos, qvel, act, qacc_warmstart, ctrl, contacts (nb), body pos (3·nb),
  // body rot xyzw (4·nb), body lin_vel (3·nb), body ang_vel (3·nb), reset pose (root_pos 3,
  // root_rot xyzw 4, q, root_lin_vel 3, root_ang_vel 3, qd)].
  //
  // Why the body states are saved rather than recomputed: MuJoCo 2.2.2's mj_kinematics
  // normalises every free/ball-joint quaternion of qpos IN PLACE, and normalising a quaternion
  // twice does not always give the same last bit (measured: 0.97648943284853129 →
  // 0.97648943284853151). After a step, qpos already went through one such normalisation; a
  // load that recomputed the body states would normalise it a second time, and both the next
  // observation and the next step would differ in the last bits — on some trajectories and not
  // others, which is why the resume test failed with one BLAS kernel and passed with another.

  /// Flat copy of env `env`'s state.
  std::vector<double> save_state(std::size_t env) const {
    const Env& e = at(env);
    const mjModel* m = model_.get();
    const mjData* d = e.data.get();
    const int nb = ch_.skeleton.num_bodies(), nd = ch_.skeleton.num_dofs();
    std::vector<double> v{double(m->nq), double(m->nv), double(m->na), double(m->nu), double(nb), double(nd), d->time};
    auto append = [&](const auto* p, int n) { v.insert(v.end(), p, p + n); };
    append(d->qpos, m->nq);
    append(d->qvel, m->nv);
    append(d->act, m->na);
    append(d->qacc_warmstart, m->nv);
    append(d->ctrl, m->nu);
    append(e.contacts.data(), nb);
    append(e.states.pos.data(), 3 * nb);
    for (const Quat& q : e.states.rot) append(q.coeffs().data(), 4);
    append(e.states.lin_vel.data(), 3 * nb);
    append(e.states.ang_vel.data(), 3 * nb);
    const KinematicState& p = e.reset_pose;
    append(p.root_pos.data(), 3);
    append(p.root_rot.coeffs().data(), 4);
    append(p.q.data(), nd);
    append(p.root_lin_vel.data(), 3);
    append(p.root_ang_vel.data(), 3);
    append(p.qd.data(), nd);
    for (std::size_t k = 0; k < objects_.size(); ++k) {  // (only with scene objects)
      const RigidState& o = e.object_states[k];
      append(o.pos.data(), 3);
      append(o.rot.coeffs().data(), 4);
      append(o.lin_vel.data(), 3);
      append(o.ang_vel.data(), 3);
      append(e.object_contacts[k].data(), nb);
    }
    return v;
  }

  /// Restores a state written by save_state for the same model; throws Error on a size mismatch
  /// or non-finite values (the env is left unchanged then).
  void load_state(std::size_t env, const std::vector<double>& v) {
    Env& e = at(env);
    const mjModel* m = model_.get();
    const int nb = ch_.skeleton.num_bodies(), nd = ch_.skeleton.num_dofs();
    const std::size_t expected = 7 + static_cast<std::size_t>(m->nq + 2 * m->nv + m->na + m->nu + 14 * nb + 13 + 2 * nd) +
                                 objects_.size() * static_cast<std::size_t>(13 + nb);
    require(v.size() == expected && v.size() >= 6 && v[0] == m->nq && v[1] == m->nv && v[2] == m->na && v[3] == m->nu &&
                v[4] == nb && v[5] == nd,
            "saved simulator state does not match this model (" + std::to_string(v.size()) + " values, expected " +
                std::to_string(expected) + "; states saved before body states were part of it cannot be resumed)",
            {{}, {}, "sim_state"});
    for (double x : v) require(std::isfinite(x), "saved simulator state has a non-finite value", {{}, {}, "sim_state"});
    mjData* d = e.data.get();
    std::size_t k = 6;
    d->time = v[k++];
    auto take = [&](auto* p, int n) {
      for (int i = 0; i < n; ++i) p[i] = static_cast<std::remove_pointer_t<decltype(p)>>(v[k++]);
    };
    take(d->qpos, m->nq);
    take(d->qvel, m->nv);
    take(d->act, m->na);
    take(d->qacc_warmstart, m->nv);
    take(d->ctrl, m->nu);
    std::vector<std::uint8_t> contacts(static_cast<std::size_t>(nb));
    take(contacts.data(), nb);
    BodyStates states;
    states.resize(nb);
    take(states.pos.data(), 3 * nb);
    for (Quat& q : states.rot) take(q.coeffs().data(), 4);
    take(states.lin_vel.data(), 3 * nb);
    take(states.ang_vel.data(), 3 * nb);
    KinematicState& p = e.reset_pose;
    take(p.root_pos.data(), 3);
    take(p.root_rot.coeffs().data(), 4);
    p.q.resize(nd);
    take(p.q.data(), nd);
    take(p.root_lin_vel.data(), 3);
    take(p.root_ang_vel.data(), 3);
    p.qd.resize(nd);
    take(p.qd.data(), nd);
    std::vector<RigidState> object_states(objects_.size());
    std::vector<ContactFlags> object_contacts(objects_.size(), ContactFlags(static_cast<std::size_t>(nb)));
    for (std::size_t o = 0; o < objects_.size(); ++o) {
      take(object_states[o].pos.data(), 3);
      take(object_states[o].rot.coeffs().data(), 4);
      take(object_states[o].lin_vel.data(), 3);
      take(object_states[o].ang_vel.data(), 3);
      take(object_contacts[o].data(), nb);
    }
    // mjData's derived quantities as after a step (positional only; the solver state is
    // untouched). mj_kinematics renormalises qpos's quaternions in place (see above), so qpos is
    // written back afterwards, and the body states are the saved ones, not a second read-out.
    mj_kinematics(m, d);
    mj_comPos(m, d);
    mj_comVel(m, d);
    std::memcpy(d->qpos, v.data() + 7, sizeof(mjtNum) * static_cast<std::size_t>(m->nq));
    e.states = std::move(states);
    e.contacts = std::move(contacts);
    e.object_states = std::move(object_states);
    e.object_contacts = std::move(object_contacts);
  }

 private:
  struct Env {
    mujoco_detail::DataPtr data;
    BodyStates states;
    ContactFlags contacts;
    KinematicState reset_pose;
    std::vector<RigidState> object_states;     ///< (num_objects)
    std::vector<ContactFlags> object_contacts;  ///< (num_objects) × (num_bodies)
  };

  MujocoHumanoidSim(std::size_t num_envs, ThreadPool* pool, std::size_t num_threads, const MujocoCharacter& character,
                    std::vector<BoxObject> objects)
      : ch_(character), objects_(std::move(objects)) {
    require(num_envs >= 1, "a simulator needs at least one env", {{}, {}, "num_envs"});
    ch_.validate();
    mujoco_detail::install_warning_handler();
    for (const BoxObject& o : objects_) o.validate();
    model_ = mujoco_detail::load_model_from_string(scene_mjcf(ch_.mjcf), ch_.name + ".xml");
    require(std::abs(model_->opt.timestep - ch_.physics_dt) <= 1e-12 * ch_.physics_dt,
            "character '" + ch_.name + "': the MJCF's timestep differs from physics_dt", {{}, {}, "physics_dt"});
    if (pool) {
      pool_ = pool;
    } else {
      owned_pool_ = std::make_unique<ThreadPool>(num_threads == 0 ? 1 : num_threads);
      pool_ = owned_pool_.get();
    }
    index_model();
    envs_.resize(num_envs);
    stats_.physics_reset.assign(num_envs, 0);
    const KinematicState standing = standing_pose();
    for (auto& e : envs_) {
      e.data.reset(mj_makeData(model_.get()));
      require(e.data != nullptr, "MuJoCo could not allocate mjData", {{}, {}, "num_envs"});
      e.states.resize(ch_.skeleton.num_bodies());
      e.contacts.assign(static_cast<std::size_t>(ch_.skeleton.num_bodies()), 0);
      e.reset_pose = standing;
      for (std::size_t k = 0; k < objects_.size(); ++k) e.object_states.push_back(parked_state(k));
      e.object_contacts.assign(objects_.size(), ContactFlags(static_cast<std::size_t>(ch_.skeleton.num_bodies()), 0));
      apply_reset(e);
    }
  }

  /// Where object k waits until a task places it: on the floor, far from the character.
  RigidState parked_state(std::size_t k) const {
    RigidState s;
    s.pos = Vec3(50.0 + 5.0 * static_cast<double>(k), 50.0, objects_[k].half_size.z());
    return s;
  }

  /// The character's MJCF with one free body per scene object appended to the world.
  std::string scene_mjcf(std::string xml) const {
    if (objects_.empty()) return xml;
    using detail::mjcf_num, detail::mjcf_vec;
    std::string bodies;
    for (std::size_t k = 0; k < objects_.size(); ++k) {
      const BoxObject& o = objects_[k];
      const std::string n = "object_" + o.name;
      bodies += "    <body name=\"" + n + "\" pos=\"" + mjcf_vec(parked_state(k).pos) + "\">\n";
      bodies += "      <freejoint name=\"" + n + "\"/>\n";
      bodies += "      <geom name=\"" + n + "\" type=\"box\" size=\"" + mjcf_vec(o.half_size) + "\" mass=\"" +
                mjcf_num(o.mass) + "\" contype=\"1\" conaffinity=\"1\" condim=\"3\" friction=\"" + mjcf_num(o.friction) +
                " 0.005 0.0001\"/>\n";
      bodies += "    </body>\n";
    }
    const auto at_end = xml.rfind("  </worldbody>");
    require(at_end != std::string::npos, "generated MJCF has no </worldbody>", {{}, {}, "mjcf"});
    xml.insert(at_end, bodies);
    return xml;
  }

  std::size_t object_index(std::size_t k) const {
    require(k < objects_.size(), "object index " + std::to_string(k) + " out of range (num_objects " +
                                     std::to_string(objects_.size()) + ")", {{}, {}, "object"});
    return k;
  }

  /// Writes object k's free joint (MuJoCo: w, x, y, z; body-local angular velocity).
  void write_object(mjData* d, std::size_t k, const RigidState& s) const {
    const int qa = object_qpos_[k], da = object_dof_[k];
    for (int i = 0; i < 3; ++i) d->qpos[qa + i] = s.pos[i];
    d->qpos[qa + 3] = s.rot.w();
    d->qpos[qa + 4] = s.rot.x();
    d->qpos[qa + 5] = s.rot.y();
    d->qpos[qa + 6] = s.rot.z();
    const Vec3 w_local = s.rot.conjugate() * s.ang_vel;
    for (int i = 0; i < 3; ++i) {
      d->qvel[da + i] = s.lin_vel[i];
      d->qvel[da + 3 + i] = w_local[i];
    }
  }

  /// ORs the character–object contacts of d's current contact list into e.object_contacts.
  void accumulate_object_contacts(Env& e, const mjData* d) const {
    for (int c = 0; c < d->ncon; ++c) {
      const int g1 = d->contact[c].geom1, g2 = d->contact[c].geom2;
      const int o1 = object_of_geom_[static_cast<std::size_t>(g1)], o2 = object_of_geom_[static_cast<std::size_t>(g2)];
      const int b1 = body_of_geom_[static_cast<std::size_t>(g1)], b2 = body_of_geom_[static_cast<std::size_t>(g2)];
      if (o1 >= 0 && b2 >= 0) e.object_contacts[static_cast<std::size_t>(o1)][static_cast<std::size_t>(b2)] = 1;
      if (o2 >= 0 && b1 >= 0) e.object_contacts[static_cast<std::size_t>(o2)][static_cast<std::size_t>(b1)] = 1;
    }
  }

  KinematicState standing_pose() const { return ch_.standing; }

  /// Maps the skeleton's bodies/DoFs to MuJoCo ids and addresses (by name).
  void index_model() {
    const Skeleton& s = ch_.skeleton;
    const mjModel* m = model_.get();
    require(m->nu == s.num_dofs(), "model has " + std::to_string(m->nu) + " actuators, expected " +
                                       std::to_string(s.num_dofs()), {{}, {}, "actuators"});
    body_id_.resize(static_cast<std::size_t>(s.num_bodies()));
    for (int i = 0; i < s.num_bodies(); ++i) {
      body_id_[static_cast<std::size_t>(i)] = mj_name2id(m, mjOBJ_BODY, s.names[static_cast<std::size_t>(i)].c_str());
      require(body_id_[static_cast<std::size_t>(i)] > 0, "model has no body '" + s.names[static_cast<std::size_t>(i)] + "'",
              {{}, {}, "bodies"});
    }
    const int root_joint = mj_name2id(m, mjOBJ_JOINT, "root");
    require(root_joint >= 0 && m->jnt_type[root_joint] == mjJNT_FREE, "model has no free joint 'root'",
            {{}, {}, "root"});
    root_qpos_ = m->jnt_qposadr[root_joint];
    root_dof_ = m->jnt_dofadr[root_joint];
    qpos_adr_.resize(static_cast<std::size_t>(s.num_dofs()));
    dof_adr_.resize(static_cast<std::size_t>(s.num_dofs()));
    for (int k = 0; k < s.num_dofs(); ++k) {
      const std::string& name = ch_.joint_names[static_cast<std::size_t>(k)];
      const int j = mj_name2id(m, mjOBJ_JOINT, name.c_str());
      require(j >= 0 && m->jnt_type[j] == mjJNT_HINGE, "model has no hinge '" + name + "'", {{}, {}, "joints"});
      require(m->jnt_bodyid[j] == body_id_[static_cast<std::size_t>(s.dof_body(k))],
              "hinge '" + name + "' is not on body '" + s.names[static_cast<std::size_t>(s.dof_body(k))] + "'",
              {{}, {}, "joints"});
      const Vec3 axis(m->jnt_axis[3 * j], m->jnt_axis[3 * j + 1], m->jnt_axis[3 * j + 2]);
      require((axis - s.dof_axis(k)).norm() < 1e-9, "hinge '" + name + "' has another axis than the skeleton's DoF " +
                                                         std::to_string(k), {{}, {}, "joints"});
      qpos_adr_[static_cast<std::size_t>(k)] = m->jnt_qposadr[j];
      dof_adr_[static_cast<std::size_t>(k)] = m->jnt_dofadr[j];
      require(m->actuator_trnid[2 * k] == j, "actuator " + std::to_string(k) + " does not drive joint '" + name + "'",
              {{}, {}, "actuators"});
    }
    body_of_geom_.resize(static_cast<std::size_t>(m->ngeom), -1);
    for (int g = 0; g < m->ngeom; ++g)
      for (int i = 0; i < s.num_bodies(); ++i)
        if (m->geom_bodyid[g] == body_id_[static_cast<std::size_t>(i)]) body_of_geom_[static_cast<std::size_t>(g)] = i;
    floor_geom_ = mj_name2id(m, mjOBJ_GEOM, "floor");
    require(floor_geom_ >= 0, "model has no geom 'floor'", {{}, {}, "floor"});
    object_of_geom_.assign(static_cast<std::size_t>(m->ngeom), -1);
    for (std::size_t k = 0; k < objects_.size(); ++k) {
      const std::string n = "object_" + objects_[k].name;
      const int body = mj_name2id(m, mjOBJ_BODY, n.c_str()), joint = mj_name2id(m, mjOBJ_JOINT, n.c_str());
      require(body > 0 && joint >= 0 && m->jnt_type[joint] == mjJNT_FREE, "model has no free body '" + n + "'",
              {{}, {}, "objects"});
      object_body_.push_back(body);
      object_qpos_.push_back(m->jnt_qposadr[joint]);
      object_dof_.push_back(m->jnt_dofadr[joint]);
      for (int g = 0; g < m->ngeom; ++g)
        if (m->geom_bodyid[g] == body) object_of_geom_[static_cast<std::size_t>(g)] = static_cast<int>(k);
    }
  }

  Env& at(std::size_t env) {
    require(env < envs_.size(), "env index " + std::to_string(env) + " out of range (num_envs " +
                                    std::to_string(envs_.size()) + ")", {{}, {}, "env"});
    return envs_[env];
  }
  const Env& at(std::size_t env) const { return const_cast<MujocoHumanoidSim*>(this)->at(env); }

  /// Writes e.reset_pose into MuJoCo (qpos, qvel), clears actuation, recomputes everything.
  void apply_reset(Env& e) const {
    const mjModel* m = model_.get();
    mjData* d = e.data.get();
    mj_resetData(m, d);
    const KinematicState& p = e.reset_pose;
    const Quat r = p.root_rot.normalized();
    d->qpos[root_qpos_ + 0] = p.root_pos.x();
    d->qpos[root_qpos_ + 1] = p.root_pos.y();
    d->qpos[root_qpos_ + 2] = p.root_pos.z();
    d->qpos[root_qpos_ + 3] = r.w();  // MuJoCo: w, x, y, z
    d->qpos[root_qpos_ + 4] = r.x();
    d->qpos[root_qpos_ + 5] = r.y();
    d->qpos[root_qpos_ + 6] = r.z();
    const Vec3 w_local = r.conjugate() * p.root_ang_vel;  // free joint: body-local angular velocity
    for (int k = 0; k < 3; ++k) {
      d->qvel[root_dof_ + k] = p.root_lin_vel[k];
      d->qvel[root_dof_ + 3 + k] = w_local[k];
    }
    for (std::size_t k = 0; k < qpos_adr_.size(); ++k) {
      d->qpos[qpos_adr_[k]] = p.q[static_cast<Index>(k)];
      d->qvel[dof_adr_[k]] = p.qd[static_cast<Index>(k)];
      d->ctrl[k] = p.q[static_cast<Index>(k)];  // hold the pose until the first step
    }
    for (std::size_t k = 0; k < objects_.size(); ++k) write_object(d, k, e.object_states[k]);  // objects stay put
    mj_forward(m, d);  // also runs collision detection, for the contact flags
    read_out(e);
  }

  /// True if the env's state is non-finite or exploded.
  bool failed(const mjData* d) const {
    const mjModel* m = model_.get();
    for (int k = 0; k < m->nq; ++k)
      if (!std::isfinite(d->qpos[k]) || std::abs(d->qpos[k]) > 1e4) return true;
    for (int k = 0; k < m->nv; ++k)
      if (!std::isfinite(d->qvel[k]) || std::abs(d->qvel[k]) > 1e4) return true;
    return false;
  }

  template <class WriteCtrl>
  void step_impl(WriteCtrl&& write_ctrl) {
    const mjModel* m = model_.get();
    pool_->parallel_for(0, envs_.size(), [&](std::size_t env) {
      Env& e = envs_[env];
      mjData* d = e.data.get();
      write_ctrl(env, d->ctrl);
      bool bad = false;
      for (auto& flags : e.object_contacts) std::fill(flags.begin(), flags.end(), 0);
      for (int s = 0; s < ch_.substeps && !bad; ++s) {
        const mjtNum t0 = d->time;
        mj_step(m, d);
        bad = !(d->time > t0) || failed(d);  // MuJoCo resets data (time → 0) on instability
        if (!objects_.empty()) accumulate_object_contacts(e, d);
      }
      stats_.physics_reset[env] = bad ? 1 : 0;
      if (bad) {
        for (std::size_t k = 0; k < objects_.size(); ++k) e.object_states[k] = parked_state(k);  // (state lost)
        apply_reset(e);
        return;
      }
      mj_kinematics(m, d);
      mj_comPos(m, d);
      mj_comVel(m, d);
      read_out(e);
    });
    ++stats_.control_steps;
    for (auto r : stats_.physics_reset) stats_.physics_resets += r;
  }

  /// Copies body poses, velocities and contacts of one env into the library's types.
  void read_out(Env& e) const {
    const mjModel* m = model_.get();
    const mjData* d = e.data.get();
    BodyStates& b = e.states;
    mjtNum vel[6];
    for (std::size_t i = 0; i < body_id_.size(); ++i) {
      const int id = body_id_[i];
      const auto c = static_cast<Index>(i);
      b.pos.col(c) = Vec3(d->xpos[3 * id], d->xpos[3 * id + 1], d->xpos[3 * id + 2]);
      b.rot[i] = Quat(d->xquat[4 * id], d->xquat[4 * id + 1], d->xquat[4 * id + 2], d->xquat[4 * id + 3]);
      // mjOBJ_XBODY: at the body frame origin (mjOBJ_BODY would give the velocity at the body's CoM).
      mj_objectVelocity(m, d, mjOBJ_XBODY, id, vel, 0);  // [angular; linear], world orientation
      b.ang_vel.col(c) = Vec3(vel[0], vel[1], vel[2]);
      b.lin_vel.col(c) = Vec3(vel[3], vel[4], vel[5]);
    }
    std::fill(e.contacts.begin(), e.contacts.end(), 0);
    for (int k = 0; k < d->ncon; ++k) {
      const mjContact& c = d->contact[k];
      int other = -1;
      if (c.geom1 == floor_geom_) other = c.geom2;
      else if (c.geom2 == floor_geom_) other = c.geom1;
      if (other < 0) continue;
      const int body = body_of_geom_[static_cast<std::size_t>(other)];
      if (body >= 0) e.contacts[static_cast<std::size_t>(body)] = 1;
    }
    for (std::size_t k = 0; k < objects_.size(); ++k) {
      const int id = object_body_[k];
      RigidState& o = e.object_states[k];
      o.pos = Vec3(d->xpos[3 * id], d->xpos[3 * id + 1], d->xpos[3 * id + 2]);
      o.rot = Quat(d->xquat[4 * id], d->xquat[4 * id + 1], d->xquat[4 * id + 2], d->xquat[4 * id + 3]);
      mj_objectVelocity(m, d, mjOBJ_XBODY, id, vel, 0);
      o.ang_vel = Vec3(vel[0], vel[1], vel[2]);
      o.lin_vel = Vec3(vel[3], vel[4], vel[5]);
    }
  }

  MujocoCharacter ch_;
  std::vector<BoxObject> objects_;
  mujoco_detail::ModelPtr model_;
  std::unique_ptr<ThreadPool> owned_pool_;
  ThreadPool* pool_ = nullptr;
  std::vector<Env> envs_;
  StepStats stats_;
  std::vector<int> body_id_;       ///< (num_bodies) MuJoCo body id of skeleton body i
  std::vector<int> qpos_adr_;      ///< (num_dofs) qpos address of DoF k
  std::vector<int> dof_adr_;       ///< (num_dofs) qvel address of DoF k
  std::vector<int> body_of_geom_;  ///< (ngeom) skeleton body of a MuJoCo geom, −1 for the floor
  int floor_geom_ = -1;
  std::vector<int> object_body_, object_qpos_, object_dof_;  ///< (num_objects) MuJoCo body id, free-joint addresses
  std::vector<int> object_of_geom_;                           ///< (ngeom) scene object of a geom, −1 if none
  int root_qpos_ = 0, root_dof_ = 0;
};

static_assert(Simulator<MujocoHumanoidSim>);
static_assert(SceneSimulator<MujocoHumanoidSim>);

}  // namespace maskadapt
