// The character on MuJoCo compiled to WebAssembly (npm `mujoco-js`, DeepMind's official module:
// MuJoCo 3.3.8), driven exactly as include/maskadapt/sim/mujoco/humanoid_sim.hpp drives MuJoCo
// 2.2.2 natively:
//  - reset: mj_resetData, root position, root quaternion (MuJoCo w,x,y,z), free-joint linear
//    velocity (world) and angular velocity (body-local: R⁻¹ ω), joint angles and rates,
//    ctrl = joint angles (hold the pose until the first step), mj_forward;
//  - step: ctrl = PD targets (position actuators in the MJCF), `substeps` × mj_step, then
//    mj_kinematics + mj_comPos + mj_comVel (after mj_step MuJoCo's positions describe the state
//    before the last integration);
//  - read-out: body origin positions (xpos), orientations (xquat → x,y,z,w), velocities of the
//    body origins from mj_objectVelocity(mjOBJ_XBODY, world orientation), ground contacts from
//    the contact list (floor vs any geom of the body);
//  - failure: a non-finite or exploded state (|qpos|, |qvel| > 1e4) or time going backwards (MuJoCo
//    reset itself) resets the env to the last start pose and is counted.

/** Loads the module once (it is large: 11 MB with its WebAssembly inside). */
let modulePromise = null;
export function loadMujoco(loader) {
  if (!modulePromise) modulePromise = loader ? loader() : import('mujoco-js').then((m) => m.default());
  return modulePromise;
}

let fileCounter = 0;

export class LiveSim {
  /**
   * @param mj       the loaded module
   * @param xml      MJCF text of the character
   * @param character the character description (character_<name>.json)
   */
  constructor(mj, xml, character) {
    this.mj = mj;
    this.character = character;
    const dir = '/maskadapt';
    try {
      mj.FS.mkdir(dir);
    } catch {
      /* exists */
    }
    const path = `${dir}/${character.name}_${fileCounter++}.xml`;
    mj.FS.writeFile(path, xml);
    try {
      this.model = mj.MjModel.loadFromXML(path);
    } catch (e) {
      throw new Error(`${character.mjcf}: MuJoCo could not load the model: ${e && e.message ? e.message : e}`);
    }
    if (!this.model) throw new Error(`${character.mjcf}: MuJoCo could not load the model`);
    this.data = new mj.MjData(this.model);
    const m = this.model;
    const nb = character.bodies.length;
    const nd = character.joint_names.length;
    this.nb = nb;
    this.nd = nd;
    if (Math.abs(m.opt.timestep - character.physics_dt) > 1e-12 * character.physics_dt)
      throw new Error(`${character.mjcf}: the MJCF's timestep ${m.opt.timestep} differs from physics_dt ${character.physics_dt}`);
    if (m.nu !== nd) throw new Error(`${character.mjcf}: model has ${m.nu} actuators, expected ${nd}`);
    const OBJ = mj.mjtObj;
    const id = (type, name) => mj.mj_name2id(m, type.value, name);
    this.bodyId = character.bodies.map((b) => {
      const i = id(OBJ.mjOBJ_BODY, b.name);
      if (i <= 0) throw new Error(`${character.mjcf}: model has no body '${b.name}'`);
      return i;
    });
    const root = id(OBJ.mjOBJ_JOINT, 'root');
    if (root < 0 || m.jnt_type[root] !== 0) throw new Error(`${character.mjcf}: model has no free joint 'root'`);
    this.rootQpos = m.jnt_qposadr[root];
    this.rootDof = m.jnt_dofadr[root];
    this.qposAdr = new Int32Array(nd);
    this.dofAdr = new Int32Array(nd);
    this.dofBody = new Array(nd);  // character body (index) that DoF k moves
    character.joint_names.forEach((name, k) => {
      const j = id(OBJ.mjOBJ_JOINT, name);
      if (j < 0 || m.jnt_type[j] !== 3) throw new Error(`${character.mjcf}: model has no hinge '${name}'`);
      if (m.actuator_trnid[2 * k] !== j) throw new Error(`${character.mjcf}: actuator ${k} does not drive joint '${name}'`);
      this.dofBody[k] = this.bodyId.indexOf(m.jnt_bodyid[j]);
      if (this.dofBody[k] < 0) throw new Error(`${character.mjcf}: hinge '${name}' is not on a body of the character`);
      this.qposAdr[k] = m.jnt_qposadr[j];
      this.dofAdr[k] = m.jnt_dofadr[j];
    });
    this.bodyOfGeom = new Int32Array(m.ngeom).fill(-1);
    for (let g = 0; g < m.ngeom; ++g) this.bodyOfGeom[g] = this.bodyId.indexOf(m.geom_bodyid[g]);
    this.floorGeom = id(OBJ.mjOBJ_GEOM, 'floor');
    if (this.floorGeom < 0) throw new Error(`${character.mjcf}: model has no geom 'floor'`);
    this.xbody = OBJ.mjOBJ_XBODY.value;
    this.states = {
      pos: new Float64Array(3 * nb),
      rot: new Float64Array(4 * nb),
      linVel: new Float64Array(3 * nb),
      angVel: new Float64Array(3 * nb),
    };
    this.contacts = new Uint8Array(nb);
    // (an output array must live in the module's memory: a plain Float64Array is copied in, not back)
    this.vel = new mj.DoubleBuffer(6);
    this.physicsResets = 0;
    this.substeps = character.substeps;
    this.controlDt = character.physics_dt * character.substeps;
  }

  dispose() {
    this.vel?.delete();
    this.data?.delete();
    this.model?.delete();
    this.data = this.model = this.vel = null;
  }

  /** Places the character at `pose` (a start of character_<name>.json). */
  reset(pose) {
    const nd = this.nd;
    for (const [key, n] of [['root_pos', 3], ['root_rot_xyzw', 4], ['q', nd], ['root_lin_vel', 3], ['root_ang_vel', 3], ['qd', nd]]) {
      if (!Array.isArray(pose[key]) || pose[key].length !== n) throw new Error(`start pose '${pose.label}': field '${key}' must have ${n} numbers`);
      if (!pose[key].every(Number.isFinite)) throw new Error(`start pose '${pose.label}': field '${key}' is not finite`);
    }
    this.resetPose = pose;
    this.applyReset();
  }

  applyReset() {
    const { mj, model: m, data: d } = this;
    const p = this.resetPose;
    mj.mj_resetData(m, d);
    const qpos = d.qpos, qvel = d.qvel, ctrl = d.ctrl;
    let [x, y, z, w] = p.root_rot_xyzw;
    const n = Math.hypot(x, y, z, w);
    x /= n;
    y /= n;
    z /= n;
    w /= n;
    const r = this.rootQpos;
    qpos[r] = p.root_pos[0];
    qpos[r + 1] = p.root_pos[1];
    qpos[r + 2] = p.root_pos[2];
    qpos[r + 3] = w;
    qpos[r + 4] = x;
    qpos[r + 5] = y;
    qpos[r + 6] = z;
    // body-local angular velocity: conj(q) * ω
    const wl = rotateByConjugate(x, y, z, w, p.root_ang_vel);
    for (let k = 0; k < 3; ++k) {
      qvel[this.rootDof + k] = p.root_lin_vel[k];
      qvel[this.rootDof + 3 + k] = wl[k];
    }
    for (let k = 0; k < this.nd; ++k) {
      qpos[this.qposAdr[k]] = p.q[k];
      qvel[this.dofAdr[k]] = p.qd[k];
      ctrl[k] = p.q[k];
    }
    mj.mj_forward(m, d);
    this.readOut();
  }

  failed() {
    const { qpos, qvel } = this.data;
    for (let k = 0; k < qpos.length; ++k) if (!Number.isFinite(qpos[k]) || Math.abs(qpos[k]) > 1e4) return true;
    for (let k = 0; k < qvel.length; ++k) if (!Number.isFinite(qvel[k]) || Math.abs(qvel[k]) > 1e4) return true;
    return false;
  }

  /** One control step with PD targets (rad, num_dofs). Returns false when the physics failed (then reset). */
  step(targets) {
    if (targets.length !== this.nd) throw new Error(`targets have ${targets.length} entries, expected ${this.nd}`);
    for (let k = 0; k < this.nd; ++k) if (!Number.isFinite(targets[k])) throw new Error(`targets[${k}] is not finite`);
    const { mj, model: m, data: d } = this;
    const ctrl = d.ctrl;
    for (let k = 0; k < this.nd; ++k) ctrl[k] = targets[k];
    let bad = false;
    for (let s = 0; s < this.substeps && !bad; ++s) {
      const t0 = d.time;
      mj.mj_step(m, d);
      bad = !(d.time > t0) || this.failed();
    }
    if (bad) {
      ++this.physicsResets;
      this.applyReset();
      return false;
    }
    mj.mj_kinematics(m, d);
    mj.mj_comPos(m, d);
    mj.mj_comVel(m, d);
    this.readOut();
    return true;
  }

  readOut() {
    const { mj, model: m, data: d, states: b, vel } = this;
    const xpos = d.xpos, xquat = d.xquat;
    for (let i = 0; i < this.nb; ++i) {
      const id = this.bodyId[i];
      b.pos[3 * i] = xpos[3 * id];
      b.pos[3 * i + 1] = xpos[3 * id + 1];
      b.pos[3 * i + 2] = xpos[3 * id + 2];
      b.rot[4 * i] = xquat[4 * id + 1];
      b.rot[4 * i + 1] = xquat[4 * id + 2];
      b.rot[4 * i + 2] = xquat[4 * id + 3];
      b.rot[4 * i + 3] = xquat[4 * id];
      mj.mj_objectVelocity(m, d, this.xbody, id, vel, 0);
      const v = vel.GetView();  // [angular; linear], world orientation, at the body origin
      for (let k = 0; k < 3; ++k) {
        b.angVel[3 * i + k] = v[k];
        b.linVel[3 * i + k] = v[3 + k];
      }
    }
    this.contacts.fill(0);
    const n = d.ncon;
    if (n > 0) {
      const list = d.contact;
      for (let k = 0; k < n; ++k) {
        const c = list.get(k);
        const g1 = c.geom1, g2 = c.geom2;
        let other = -1;
        if (g1 === this.floorGeom) other = g2;
        else if (g2 === this.floorGeom) other = g1;
        if (other >= 0 && this.bodyOfGeom[other] >= 0) this.contacts[this.bodyOfGeom[other]] = 1;
      }
    }
  }
}

/** conj(q) · v for the unit quaternion x,y,z,w. */
export function rotateByConjugate(x, y, z, w, v) {
  // R(q)ᵀ v
  const R = [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
    2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
    2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)];
  return [R[0] * v[0] + R[3] * v[1] + R[6] * v[2], R[1] * v[0] + R[4] * v[1] + R[7] * v[2], R[2] * v[0] + R[5] * v[1] + R[8] * v[2]];
}
