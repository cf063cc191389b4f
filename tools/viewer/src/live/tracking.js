// Partial tracking in the page (include/maskadapt/tracking/goals.hpp, tracking/generator.hpp
// rollout, and play-residual's loop in examples/maskadapt/cmd_train_residual.cpp):
//
//  - TargetStream: the target trajectory, generated autoregressively as tracking::rollout does —
//    the last H frames are canonicalised, the generator adds F frames, they are mapped back to the
//    world and appended — but lazily, one primitive whenever the policy needs frames that do not
//    exist yet. The prompt of a primitive is the prompt active at the time of its first new frame
//    (text_at of the prompt log, times from the end of the history), so a prompt typed at time s
//    takes effect with the first primitive that starts at or after s (within F/30 = 0.5 s).
//    Generated in that order with Rng(seed) it draws the same noise as `play-residual --seed`.
//  - extractGoals: the residual's goal features, for target frames t+1 … t+steps, per designated
//    body: its 3 hinge angles and its root-relative position in the target frame's heading frame.
//  - positionError: mean distance (m) between the simulated and the target root-relative
//    heading-frame positions of the designated bodies (play-residual's "mean tracking error").
import { canonicalize, headingRotation, quatConj, quatRotate, sliceTrajectory, transformToWorld } from './kinematics.js';

/** Non-root bodies whose part (index, features.js PART_NAMES) is in the mask bits, in body order. */
export function designatedBodies(bodyParts, bits) {
  const out = [];
  for (let i = 1; i < bodyParts.length; ++i) if ((bits >> bodyParts[i]) & 1) out.push(i);
  return out;
}

export const goalDim = (bodies, steps) => steps * 6 * bodies.length;

/** Root-relative position of a body in the heading frame of a root (p0, R0). */
export function headingLocal(p, p0, R0) {
  return quatRotate(quatConj(headingRotation(R0)), [p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]]);
}

const rootOf = (t, f) => [t.rootPos[3 * f], t.rootPos[3 * f + 1], t.rootPos[3 * f + 2]];
const rotOf = (t, f) => Array.from(t.rootRot.subarray(4 * f, 4 * f + 4));
const bodyOf = (t, nb, f, b) => {
  const o = 3 * (nb * f + b);
  return [t.bodyPos[o], t.bodyPos[o + 1], t.bodyPos[o + 2]];
};

/** Goal features (Float32Array, goalDim) of target frames frame+1 … frame+steps (clamped to the last). */
export function extractGoals(skel, bodies, traj, frame, steps, out = new Float32Array(goalDim(bodies, steps))) {
  const per = 6 * bodies.length;
  if (out.length !== steps * per) throw new Error(`goal vector has ${out.length} rows, expected ${steps * per}`);
  if (!(traj.frames > 0)) throw new Error('the target trajectory is empty');
  for (let k = 0; k < steps; ++k) {
    const f = Math.min(Math.max(frame + 1 + k, 0), traj.frames - 1);
    const p0 = rootOf(traj, f), R0 = rotOf(traj, f);
    bodies.forEach((b, j) => {
      const r = k * per + 6 * j;
      const q0 = skel.nd * f + skel.dofOffset[b];
      for (let c = 0; c < 3; ++c) out[r + c] = traj.q[q0 + c];
      out.set(headingLocal(bodyOf(traj, skel.nb, f, b), p0, R0), r + 3);
    });
  }
  return out;
}

/** Body states' root-relative heading-frame position of body b. */
function simLocal(states, b) {
  const p = states.pos;
  return headingLocal([p[3 * b], p[3 * b + 1], p[3 * b + 2]], [p[0], p[1], p[2]], Array.from(states.rot.subarray ? states.rot.subarray(0, 4) : states.rot.slice(0, 4)));
}

/** Mean over the bodies of |target − simulated| root-relative heading-frame position (m). */
export function positionError(skel, bodies, traj, frame, states) {
  if (!bodies.length) return 0;
  const p0 = rootOf(traj, frame), R0 = rotOf(traj, frame);
  let s = 0;
  for (const b of bodies) {
    const t = headingLocal(bodyOf(traj, skel.nb, frame, b), p0, R0);
    const c = simLocal(states, b);
    s += Math.hypot(t[0] - c[0], t[1] - c[1], t[2] - c[2]);
  }
  return s / bodies.length;
}

/** World positions (3·k) of the designated bodies' targets of frame f, placed at the simulated root (as play-residual's rollout goals). */
export function targetsAtRoot(skel, bodies, traj, f, states) {
  const root = [states.pos[0], states.pos[1], states.pos[2]];
  const Hs = headingRotation(Array.from(states.rot.subarray ? states.rot.subarray(0, 4) : states.rot.slice(0, 4)));
  const out = new Float32Array(3 * bodies.length);
  bodies.forEach((b, j) => {
    const l = headingLocal(bodyOf(traj, skel.nb, f, b), rootOf(traj, f), rotOf(traj, f));
    const w = quatRotate(Hs, l);
    for (let c = 0; c < 3; ++c) out[3 * j + c] = root[c] + w[c];
  });
  return out;
}

/** The prompt active at time s (the last entry with start <= s; the first before any). */
export function textAt(log, s) {
  let k = 0;
  for (let i = 0; i < log.length; ++i) if (log[i][0] <= s) k = i;
  return log[k][1];
}

export class TargetStream {
  /**
   * @param generator generator.js Generator
   * @param history   world-frame trajectory of ≥ H frames whose last frame is the start pose
   * @param noise     a normal() source (rng.js Rng(seed))
   * @param prompt    the first prompt
   */
  constructor(generator, history, noise, prompt) {
    const H = generator.H;
    if (history.frames < H) throw new Error(`the target stream needs at least H = ${H} history frames, got ${history.frames}`);
    this.gen = generator;
    this.skel = generator.skel;
    this.noise = noise;
    this.fps = history.fps || 30;
    this.H = H;
    // Storage: frames [first, first + n) of the sequence "H history frames, then the generated
    // ones", in arrays of `cap` frames; frames before `keepFrom` may be dropped when they fill.
    this.first = 0;
    this.n = 0;
    this.cap = 0;
    this.keepFrom = 0;
    this.store = null;
    this.push(sliceTrajectory(this.skel, history, history.frames - H, H));
    this.log = [[0, prompt]];
    this.primitives = [];  // [{ frame, text, ms }]
  }

  /** Number of target frames generated so far (frame 0 = 1/30 s after the start pose). */
  get frames() {
    return this.first + this.n - this.H;
  }

  /** Frames before target frame t will not be asked for again (they may be dropped). */
  release(t) {
    this.keepFrom = Math.max(this.keepFrom, t);
  }

  push(t) {
    const { nb, nd } = this.skel;
    const per = { rootPos: 3, rootRot: 4, q: nd, bodyPos: 3 * nb };
    if (this.n + t.frames > this.cap) {
      // keep the last H frames (the next history) and everything from keepFrom on
      const from = Math.max(this.first, Math.min(this.keepFrom + this.H, this.first + this.n - this.H));
      const keep = this.first + this.n - from;
      const cap = Math.max(256, 2 * (keep + t.frames));
      const next = {};
      for (const [key, k] of Object.entries(per)) {
        next[key] = new Float64Array(k * cap);
        if (this.store) next[key].set(this.store[key].subarray(k * (from - this.first), k * this.n), 0);
      }
      this.store = next;
      this.first = from;
      this.n = keep;
      this.cap = cap;
    }
    for (const [key, k] of Object.entries(per)) this.store[key].set(t[key], k * this.n);
    this.n += t.frames;
  }

  /** Stored frames [from, to) of the whole sequence (global indices) as a trajectory of views. */
  window(from, to) {
    const { nb, nd } = this.skel;
    const a = from - this.first, b = to - this.first;
    if (!(a >= 0 && b <= this.n && a <= b)) throw new Error(`target frames [${from - this.H}, ${to - this.H}) are not stored`);
    const s = this.store;
    return {
      frames: b - a,
      fps: this.fps,
      rootPos: s.rootPos.subarray(3 * a, 3 * b),
      rootRot: s.rootRot.subarray(4 * a, 4 * b),
      q: s.q.subarray(nd * a, nd * b),
      bodyPos: s.bodyPos.subarray(3 * nb * a, 3 * nb * b),
    };
  }

  /** From time `s` on (simulated seconds), primitives that start then or later use `prompt`. */
  setPrompt(s, prompt) {
    const last = this.log[this.log.length - 1];
    if (last[1] === prompt) return;
    if (s <= last[0]) this.log[this.log.length - 1] = [last[0], prompt];
    else this.log.push([s, prompt]);
  }

  /** Generates primitives until target frames [0, n) exist. Returns the number generated. */
  ensure(n) {
    let made = 0;
    while (this.frames < n) {
      const produced = this.frames;
      const end = this.first + this.n;
      const { local, frame } = canonicalize(this.skel, this.window(end - this.H, end), 0);
      const text = textAt(this.log, produced / this.fps);
      const fut = this.gen.generate(text, local, this.noise);
      this.push(transformToWorld(this.skel, fut, frame));
      this.primitives.push({ frame: produced, text, ms: this.gen.lastMs });
      ++made;
    }
    return made;
  }

  /** Target frames [from, frames) as a trajectory whose frame 0 is target frame `from`. */
  view(from = Math.max(0, this.first - this.H)) {
    return this.window(from + this.H, this.first + this.n);
  }

  /** Goal features for step t (target frames t+1 … t+steps), generating what is missing. */
  goals(t, bodies, steps, out) {
    this.ensure(t + steps + 1);
    return extractGoals(this.skel, bodies, this.view(t), 0, steps, out);
  }
}
