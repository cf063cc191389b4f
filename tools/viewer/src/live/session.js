// One live run: the character on MuJoCo (sim.js), a base policy (policy.js) choosing PD targets
// from the masked observation (features.js) every control step, and what the page shows —
// simulated time, distance walked, speed, falls. No DOM: the page (live.js), the unit tests and
// tools/viewer/e2e/live-compare.mjs drive the same code.
//
// A control step is the loop of examples/usage/readme_example.cpp and `maskadapt play
// --deterministic` (include/maskadapt/train/play.hpp): s from the body states, [s̄ ; m], the
// policy's mean action, targets = offset + scale ⊙ μ, one simulator step; for a stage-2 policy
// the composite mean of adapt/residual_policy.hpp (policy.js), the mask choosing the parts the
// residual adapts. Falls are counted as in
// play: a fall begins on a step where has_fallen (sim/termination.hpp: a ground contact of a body
// not allowed to touch the ground, or the head below the model's env.termination_height) becomes
// true; the run goes on (no reset), as in play without --reset-on-fall.
//
// Tracking (a stage-2 policy of task 'tracking' with setTracking): every step also asks the target
// stream (tracking.js) for the goal features of target frames t+1 … t+goal_steps — the generator
// (generator.js) adds a primitive of F frames when they do not exist yet, with the prompt active
// then — and, after the physics step, measures the tracking error against target frame t+1, as
// play-residual does.
import { computeObservation, observationDim, observationParts, parseMask, PART_NAMES } from './features.js';
import { trajectoryFromJson } from './kinematics.js';
import { Rng } from './rng.js';
import { LiveSim } from './sim.js';
import { designatedBodies, goalDim, positionError, TargetStream, targetsAtRoot } from './tracking.js';
import { tokenizeWords } from './textFeatures.js';

export function fallCriteria(character, minHeadHeight) {
  const names = character.bodies.map((b) => b.name);
  const allowed = new Uint8Array(names.length);
  for (const n of character.ground_contacts) {
    const i = names.indexOf(n);
    if (i < 0) throw new Error(`character '${character.name}': ground_contacts names an unknown body '${n}'`);
    allowed[i] = 1;
  }
  const head = character.head ? names.indexOf(character.head) : -1;
  if (character.head && head < 0) throw new Error(`character '${character.name}': head names an unknown body '${character.head}'`);
  return { allowed, head, minHeadHeight };
}

export function hasFallen(c, states, contacts) {
  for (let i = 0; i < contacts.length; ++i) if (contacts[i] && !c.allowed[i]) return true;
  return c.head >= 0 && states.pos[3 * c.head + 2] < c.minHeadHeight;
}

export class LiveSession {
  /**
   * @param mj        loaded MuJoCo module
   * @param xml       the character's MJCF text
   * @param character character_<name>.json
   * @param policy    BasePolicy (policy.js), exported for this character
   */
  constructor(mj, xml, character, policy) {
    const nb = character.bodies.length;
    const obsDim = observationDim(nb);
    if (policy.obsDim !== obsDim || policy.actionDim !== character.joint_names.length)
      throw new Error(
        `${policy.file}: the model is for ${policy.obsDim} observation rows and ${policy.actionDim} actions; ` +
          `the character '${character.name}' has ${obsDim} and ${character.joint_names.length} (model/obs_dim, model/action_dim)`,
      );
    this.character = character;
    this.policy = policy;
    this.sim = new LiveSim(mj, xml, character);
    this.parts0 = character.bodies.map((b) => {  // part of every body
      const p = PART_NAMES.indexOf(b.part);
      if (p < 0) throw new Error(`character '${character.name}': body '${b.name}' has unknown part '${b.part}'`);
      return p;
    });
    this.parts = observationParts(this.parts0);
    const th = Number.isFinite(policy.terminationHeight) ? policy.terminationHeight : character.termination_height;
    this.fall = fallCriteria(character, th);
    this.obs = new Float32Array(obsDim);
    if (policy.setDofParts) policy.setDofParts(this.sim.dofBody.map((b) => this.parts0[b]));
    this.mask = 0;
    this.startIndex = 0;
    this.tracking = null;
    this.reset(0);
  }

  /**
   * Makes this a tracking run: `generator` (generator.js), `trackingChar` (tracking_humanoid.json:
   * the skeleton and each start's history), the first prompt and the seed of the diffusion noise.
   */
  setTracking(generator, trackingChar, prompt, seed = 1) {
    const p = this.policy;
    if (p.task !== 'tracking') throw new Error(`${p.file}: not a tracking policy (task '${p.task}')`);
    if (trackingChar.character !== this.character.name) throw new Error(`tracking data is for '${trackingChar.character}', the character is '${this.character.name}'`);
    const bodies = designatedBodies(this.parts0, parseMask(this.policy.designated));
    if (goalDim(bodies, p.goalSteps) !== p.goalDim)
      throw new Error(`${p.file}: its residual reads ${p.goalDim} goal rows; ${p.goalSteps} goal frames of the ${bodies.length} designated bodies make ${goalDim(bodies, p.goalSteps)}`);
    const histories = this.character.starts.map((st) => {
      const h = trackingChar.starts.find((x) => x.label === st.label);
      if (!h) throw new Error(`tracking_${this.character.name}.json: no history for the start '${st.label}'`);
      return trajectoryFromJson(generator.skel, h.history);
    });
    checkPrompt(prompt);
    this.tracking = { generator, histories, bodies, seed, prompt, goals: new Float32Array(p.goalDim) };
    this.reset(this.startIndex);
  }

  /** Switches the prompt from now on (primitives that start at or after the current time). */
  setPrompt(prompt) {
    if (!this.tracking) throw new Error('not a tracking run');
    checkPrompt(prompt);
    this.tracking.prompt = prompt;
    this.tracking.stream.setPrompt(this.time, prompt);
  }

  dispose() {
    this.sim.dispose();
  }

  get controlDt() {
    return this.sim.controlDt;
  }

  /** Back to start pose `startIndex` (character.starts), time 0, counters cleared; the mask stays. */
  reset(startIndex = this.startIndex) {
    const starts = this.character.starts;
    if (!(startIndex >= 0 && startIndex < starts.length)) throw new Error(`start ${startIndex} out of range (${starts.length} starts)`);
    this.startIndex = startIndex;
    this.sim.reset(starts[startIndex]);
    this.steps = 0;
    this.time = 0;
    this.falls = 0;
    this.firstFall = null;
    this.fallen = hasFallen(this.fall, this.sim.states, this.sim.contacts);
    this.origin = [this.sim.states.pos[0], this.sim.states.pos[1]];
    this.rootTrail = [[0, this.origin[0], this.origin[1]]];
    this.maskLog = [[0, this.mask]];
    this.stepMs = 0;
    const tr = this.tracking;
    if (tr) {
      tr.stream = new TargetStream(tr.generator, tr.histories[startIndex], new Rng(tr.seed), tr.prompt);
      tr.error = null;
      tr.errorSum = 0;
      tr.errorSteps = 0;
      tr.generateMsSum = 0;
      tr.generateMsMax = 0;
      tr.generateCalls = 0;
    }
  }

  setMask(bits) {
    if (!(Number.isInteger(bits) && bits >= 0 && bits < 32)) throw new Error(`mask bits must be 0..31, got ${bits}`);
    if (bits !== this.mask) this.maskLog.push([this.time, bits]);
    this.mask = bits;
  }

  /** One control step (obs → [s̄ ; m] → μ → targets → physics). */
  step() {
    const t0 = typeof performance !== 'undefined' ? performance.now() : Date.now();
    const s = this.sim.states;
    computeObservation(s, this.sim.nb, this.obs);
    const tr = this.tracking;
    let goals = null;
    if (tr) {
      const before = tr.stream.primitives.length;
      goals = tr.stream.goals(this.steps, tr.bodies, this.policy.goalSteps, tr.goals);
      for (const p of tr.stream.primitives.slice(before)) {
        tr.generateMsSum += p.ms;
        tr.generateMsMax = Math.max(tr.generateMsMax, p.ms);
        ++tr.generateCalls;
      }
    }
    this.sim.step(this.policy.act(this.obs, this.parts, this.mask, goals));
    if (tr) {
      tr.error = positionError(tr.generator.skel, tr.bodies, tr.stream.view(this.steps + 1), 0, s);
      tr.errorSum += tr.error;
      ++tr.errorSteps;
      tr.stream.release(this.steps);
    }
    ++this.steps;
    this.time = this.steps * this.controlDt;
    const fallen = hasFallen(this.fall, s, this.sim.contacts);
    if (fallen && !this.fallen) {
      ++this.falls;
      if (this.firstFall === null) this.firstFall = this.time;
    }
    this.fallen = fallen;
    this.rootTrail.push([this.time, s.pos[0], s.pos[1]]);
    if (this.rootTrail.length > 200) this.rootTrail.shift();
    const t1 = typeof performance !== 'undefined' ? performance.now() : Date.now();
    this.stepMs = this.stepMs ? 0.95 * this.stepMs + 0.05 * (t1 - t0) : t1 - t0;
  }

  /** Runs `seconds` of simulated time (rounded to control steps) as fast as it can. */
  runSeconds(seconds) {
    const n = Math.max(1, Math.round(seconds / this.controlDt));
    for (let i = 0; i < n; ++i) this.step();
  }

  /** Distance from the start in the ground plane (m). */
  get distance() {
    const p = this.sim.states.pos;
    return Math.hypot(p[0] - this.origin[0], p[1] - this.origin[1]);
  }

  /** Ground speed over the last second (m/s). */
  get speed() {
    const tr = this.rootTrail;
    const last = tr[tr.length - 1];
    let first = tr[0];
    for (const e of tr) if (last[0] - e[0] <= 1.0 + 1e-9) { first = e; break; }
    const dt = last[0] - first[0];
    return dt > 0 ? Math.hypot(last[1] - first[1], last[2] - first[2]) / dt : 0;
  }

  /** Simulated seconds per wall-clock second that the machine sustains (from the mean step cost). */
  get realTimeFactor() {
    return this.stepMs > 0 ? (this.controlDt * 1000) / this.stepMs : 0;
  }

  /**
   * Tracking: world positions of the designated bodies' targets for the next `frames` target frames
   * that exist (from the current one), placed at the simulated root as play-residual writes them.
   */
  goalTargets(frames = 30) {
    const tr = this.tracking;
    if (!tr) return null;
    const first = this.steps;  // target frame of the current state (t), the next the policy aims at
    const have = tr.stream.frames - first;
    const out = [];
    if (have <= 0) return { bodies: tr.bodies, targets: out };
    const v = tr.stream.view(first);
    for (let k = 0; k < Math.min(frames, have); ++k) out.push(targetsAtRoot(tr.generator.skel, tr.bodies, v, k, this.sim.states));
    return { bodies: tr.bodies, targets: out };
  }

  trackingSummary() {
    const tr = this.tracking;
    if (!tr) return null;
    return {
      prompt: tr.prompt,
      promptLog: tr.stream.log.map(([t, p]) => ({ t, prompt: p })),
      primitives: tr.stream.primitives.length,
      primitiveTexts: tr.stream.primitives.map((p) => p.text),
      goalFrames: tr.stream.frames,
      trackingError: tr.error,
      meanTrackingError: tr.errorSteps ? tr.errorSum / tr.errorSteps : null,
      generateMs: tr.generateCalls ? tr.generateMsSum / tr.generateCalls : null,
      generateMsMax: tr.generateCalls ? tr.generateMsMax : null,
      generateCalls: tr.generateCalls,
      seed: tr.seed,
    };
  }

  summary() {
    return {
      tracking: this.trackingSummary(),
      time: this.time,
      steps: this.steps,
      distance: this.distance,
      speed: this.speed,
      falls: this.falls,
      firstFall: this.firstFall,
      fallen: this.fallen,
      mask: this.mask,
      physicsResets: this.sim.physicsResets,
      realTimeFactor: this.realTimeFactor,
      stepMs: this.stepMs,
    };
  }
}

/** A prompt must have a word (letters or digits): one without would make the generator unconditional. */
export function checkPrompt(prompt) {
  if (typeof prompt !== 'string' || !tokenizeWords(prompt).length)
    throw new Error(`the prompt ${JSON.stringify(String(prompt ?? ''))} has no words (letters or digits): type what the arms should do, e.g. "wave right hand"`);
  if (prompt.length > 200) throw new Error(`the prompt is ${prompt.length} characters long; at most 200`);
}
