// The shipped policies from their policy-only exports, run as the C++ runs them with mean
// actions. Every malformed file throws an Error naming the file and the section.
//
// Stage 1, a base-policy export (include/maskadapt/train/policy_export.hpp, model/kind
// "maskadapt.base_policy"; rl/actor_critic.hpp GaussianActor::mean, nn/normalizer.hpp,
// nn/mlp.hpp, tasks/action_space.hpp):
//
//   x = [s̄ ; m] (policy_input_dim = obs_dim + 5)
//   x̂_i = clip((x_i − mean_i) / sqrt(m2_i / count + 1e-8), ±5)      (count 0: var 1)
//   with actor/hidden_groups (mask.hidden_value = mean): x̂_i = 0 where the part of row i is
//   masked (its running mean), and the 5 mask rows pass through as they are
//   μ = W_L σ(… σ(W_1 x̂ + b_1) …) + b_L   (actor/params: per layer W (out × in, column-major), then b)
//   PD targets = action_offset + action_scale ⊙ μ   (absent: 0 and 1)
//
// Stage 2, a residual export (train/residual_export.hpp, model/kind "maskadapt.residual_policy";
// adapt/residual_policy.hpp), composition and tracking tasks, methods ours and cml:
//
//   a_base = μ_base([s̄ ; m])                      (base/actor/*, as above)
//   x = [s ; a_base ; m]                           (residual input: obs_dim + action_dim + 5)
//   x = [s ; a_base ; m ; g]                       (tracking: + goal features, tracking.js; m = the
//                                                   designated parts)
//   Δ = μ_ψ(x̂)                                    (residual/*: normalised, no hidden groups)
//   â_k = w·a_base,k + Δ_k  on DoFs k of the masked parts, a_base,k elsewhere  (w = residual/gain,
//         one value or one per DoF)
//   PD targets = offset + scale ⊙ â                (base/actor/action_offset, _scale)
import { CheckpointError, parseCheckpoint, has, getFloat32, getFloat64, getInt64, getScalarInt, getScalarDouble, getString } from './checkpoint.js';
import { buildPolicyInput, NUM_PARTS } from './features.js';
import { ACTIVATIONS, Mlp, numMlpParams } from './mlp.js';

export const POLICY_EXPORT_KIND = 'maskadapt.base_policy';
export const RESIDUAL_EXPORT_KIND = 'maskadapt.residual_policy';

function jsonSection(ck, name, err) {
  try {
    return JSON.parse(getString(ck, name));
  } catch (e) {
    if (e instanceof CheckpointError) throw e;
    throw err(name, `not valid JSON: ${e.message}`);
  }
}

/** The activation's name (relu when absent), checked to be one the page runs. */
function activationOf(name, err, field) {
  const act = name || 'relu';
  if (!ACTIVATIONS[act]) throw err(field, `unknown activation '${name}'`);
  return act;
}

function checkHidden(hidden, err, field, what) {
  if (!Array.isArray(hidden) || hidden.some((h) => !Number.isInteger(h) || h <= 0)) throw err(field, `${what} must be a list of positive integers`);
}

/**
 * Normalised Gaussian-MLP mean network stored under `prefix` (params, log_std, norm/*[, hidden_groups]);
 * the network itself is mlp.js's Mlp. `activation`: its name (activationOf).
 */
export class MlpActor {
  constructor(ck, prefix, inputDim, hidden, outputDim, activation, err, flagRows = 0) {
    const sizes = [inputDim, ...hidden, outputDim];
    const numParams = numMlpParams(sizes);
    const params = getFloat32(ck, `${prefix}/params`);
    if (params.length !== numParams)
      throw err(`${prefix}/params`, `has ${params.length} parameters; the config's architecture (hidden [${hidden}], ${inputDim} inputs, ${outputDim} outputs) has ${numParams}`);
    this.logStd = getFloat32(ck, `${prefix}/log_std`);
    if (this.logStd.length !== outputDim) throw err(`${prefix}/log_std`, `has ${this.logStd.length} entries, expected ${outputDim}`);
    const count = getScalarDouble(ck, `${prefix}/norm/count`);
    const mean = getFloat64(ck, `${prefix}/norm/mean`);
    const m2 = getFloat64(ck, `${prefix}/norm/m2`);
    if (mean.length !== inputDim) throw err(`${prefix}/norm/mean`, `has ${mean.length} entries, the network ${inputDim} inputs`);
    if (m2.length !== inputDim) throw err(`${prefix}/norm/m2`, `has ${m2.length} entries, the network ${inputDim} inputs`);
    if (!(count >= 0) || !Number.isFinite(count)) throw err(`${prefix}/norm/count`, `must be finite and >= 0, got ${count}`);
    // (nn/normalizer.hpp refresh(): float mean, float 1/sqrt(var + eps), eps 1e-8; clip ±5)
    this.meanF = new Float32Array(inputDim);
    this.invStd = new Float32Array(inputDim);
    for (let i = 0; i < inputDim; ++i) {
      if (!Number.isFinite(mean[i]) || !Number.isFinite(m2[i]) || m2[i] < 0) throw err(`${prefix}/norm/${Number.isFinite(mean[i]) ? 'm2' : 'mean'}`, `entry ${i} is not a finite statistic`);
      this.meanF[i] = mean[i];
      this.invStd[i] = 1 / Math.sqrt((count > 0 ? m2[i] / count : 1) + 1e-8);
    }
    this.hiddenGroups = null;
    if (flagRows > 0 && has(ck, `${prefix}/hidden_groups`)) {
      const g = getInt64(ck, `${prefix}/hidden_groups`);
      if (g.length !== inputDim - flagRows) throw err(`${prefix}/hidden_groups`, `has ${g.length} entries, expected ${inputDim - flagRows}`);
      for (let i = 0; i < g.length; ++i) if (!(g[i] >= 0 && g[i] < flagRows)) throw err(`${prefix}/hidden_groups`, `body part index ${g[i]} out of range (entry ${i})`);
      this.hiddenGroups = Uint8Array.from(g);
    }
    this.net = new Mlp(params, sizes, activation, `${prefix}/params`);
    this.inputDim = inputDim;
    this.outputDim = outputDim;
    this.hidden = hidden;
    this.normalised = new Float32Array(inputDim);
    this.out = new Float32Array(outputDim);
  }

  /** Normalised input x̂ (Float32Array). */
  normalise(x, out = this.normalised) {
    if (x.length !== this.inputDim) throw new Error(`network input has ${x.length} rows, expected ${this.inputDim}`);
    const c = 5;
    for (let i = 0; i < x.length; ++i) {
      const v = Math.fround(Math.fround(x[i] - this.meanF[i]) * this.invStd[i]);
      out[i] = v < -c ? -c : v > c ? c : v;
    }
    if (this.hiddenGroups) {
      const n = this.hiddenGroups.length, G = x.length - n;
      let any = false;
      for (let g = 0; g < G; ++g) {
        out[n + g] = x[n + g];
        any = any || x[n + g] !== 0;
      }
      if (any) for (let i = 0; i < n; ++i) if (x[n + this.hiddenGroups[i]] !== 0) out[i] = 0;
    }
    return out;
  }

  /** Mean output μ (Float32Array) for input x. */
  mean(x, out = this.out) {
    return this.net.forward(this.normalise(x), out);
  }
}

function actionVector(ck, name, actionDim, err) {
  if (!has(ck, name)) return null;
  const v = getFloat32(ck, name);
  if (v.length !== actionDim) throw err(name, `has ${v.length} entries, the actor ${actionDim} actions`);
  for (let i = 0; i < v.length; ++i) if (!Number.isFinite(v[i])) throw err(name, `entry ${i} is not finite`);
  return v;
}

/** PD targets (rad) = offset + scale ⊙ a (float arithmetic, as tasks/action_space.hpp). */
function toTargets(a, offset, scale, out) {
  for (let k = 0; k < a.length; ++k) {
    let t = scale ? Math.fround(a[k] * scale[k]) : a[k];
    if (offset) t = Math.fround(t + offset[k]);
    out[k] = t;
  }
  return out;
}

/**
 * Loads a policy export (base or stage-2). `expected` (optional): { name, obsDim, actionDim } of
 * the character it is loaded for; a mismatch is an error naming model/obs_dim or the section.
 */
export function loadPolicy(buffer, file, expected = null) {
  const ck = parseCheckpoint(buffer, file);
  const err = (field, msg) => new CheckpointError(file, field, msg);
  if (!has(ck, 'model/kind')) {
    if (has(ck, 'residual_config')) throw err('model/kind', 'a stage-2 training checkpoint, not an export: make one with `maskadapt export CHECKPOINT --out FILE`');
    throw err('model/kind', 'missing section: not a policy-only export (make one with `maskadapt export CHECKPOINT --out FILE`)');
  }
  const kind = getString(ck, 'model/kind');
  if (kind === POLICY_EXPORT_KIND) return loadBase(ck, file, err, expected);
  if (kind === RESIDUAL_EXPORT_KIND) return loadResidual(ck, file, err, expected);
  throw err('model/kind', `unknown model kind '${kind}' (expected '${POLICY_EXPORT_KIND}' or '${RESIDUAL_EXPORT_KIND}')`);
}

/** A stage-1 base-policy export (throws naming model/kind for anything else). */
export function loadBasePolicy(buffer, file, expected = null) {
  const p = loadPolicy(buffer, file, expected);
  if (p.kind !== POLICY_EXPORT_KIND) throw new CheckpointError(file, 'model/kind', `not a base-policy export: kind '${p.kind}', expected '${POLICY_EXPORT_KIND}'`);
  return p;
}

function checkVersion(ck, err) {
  const version = getScalarInt(ck, 'model/format_version');
  if (version !== 1) throw err('model/format_version', `unsupported export format version ${version} (this page reads version 1)`);
}

function checkCharacter(obsDim, actionDim, expected, err, obsField, actField) {
  if (!expected) return;
  if (obsDim !== expected.obsDim) throw err(obsField, `this model was exported for ${obsDim} observation rows; the character '${expected.name}' has ${expected.obsDim}`);
  if (actionDim !== expected.actionDim) throw err(actField, `this model was exported for ${actionDim} actions; the character '${expected.name}' has ${expected.actionDim}`);
}

function loadBase(ck, file, err, expected) {
  checkVersion(ck, err);
  const config = jsonSection(ck, 'config', err);
  const net = config.net || {};
  checkHidden(net.actor_hidden, err, 'config', 'net.actor_hidden');
  const act = activationOf(net.activation, err, 'config');
  const obsDim = getScalarInt(ck, 'model/obs_dim');
  const inputDim = getScalarInt(ck, 'model/policy_input_dim');
  const actionDim = getScalarInt(ck, 'model/action_dim');
  if (inputDim !== obsDim + NUM_PARTS) throw err('model/policy_input_dim', `is ${inputDim}, expected model/obs_dim + ${NUM_PARTS} = ${obsDim + NUM_PARTS}`);
  checkCharacter(obsDim, actionDim, expected, err, 'model/obs_dim', 'model/action_dim');
  const actor = new MlpActor(ck, 'actor', inputDim, net.actor_hidden, actionDim, act, err, NUM_PARTS);
  const offset = actionVector(ck, 'actor/action_offset', actionDim, err);
  const scale = actionVector(ck, 'actor/action_scale', actionDim, err);
  if (scale) for (let i = 0; i < scale.length; ++i) if (!(scale[i] > 0)) throw err('actor/action_scale', `entry ${i} must be > 0`);
  return new BasePolicy({
    kind: POLICY_EXPORT_KIND, file, obsDim, inputDim, actionDim, actor, offset, scale, config,
    hidden: net.actor_hidden, activationName: net.activation || 'relu',
    character: (config.env && config.env.character) || 'humanoid',
    terminationHeight: config.env ? config.env.termination_height : undefined,
    iteration: has(ck, 'trainer/iteration') ? getScalarInt(ck, 'trainer/iteration') : null,
    masking: !!(config.mask && config.mask.enabled && config.mask.prob > 0),
    lambdaMi: config.mask ? config.mask.lambda_mi : undefined,
  });
}

export class BasePolicy {
  constructor(fields) {
    Object.assign(this, fields);
    this.input = new Float32Array(this.inputDim);
    this.targetsBuf = new Float32Array(this.actionDim);
  }
  get description() {
    return `${this.inputDim} → [${this.hidden.join(', ')}] → ${this.actionDim} ${this.activationName}` +
      (this.iteration !== null ? `, ${this.iteration} iterations` : '') +
      ` · ${this.masking ? `trained with masking (λ_MI ${this.lambdaMi})` : 'trained without masking'}`;
  }
  normalise(x) {
    return this.actor.normalise(x);
  }
  /** Mean action μ for the policy input x = [s̄ ; m]. */
  mean(x) {
    return this.actor.mean(x);
  }
  targets(a, out = new Float32Array(this.actionDim)) {
    return toTargets(a, this.offset, this.scale, out);
  }
  /** PD targets for observation s, its part layout and mask bits (one control step). */
  act(s, parts, mask) {
    buildPolicyInput(s, parts, mask, this.input);
    return this.targets(this.mean(this.input), this.targetsBuf);
  }
}

function loadResidual(ck, file, err, expected) {
  checkVersion(ck, err);
  const rc = jsonSection(ck, 'residual_config', err);
  const task = getString(ck, 'model/task');
  const method = getString(ck, 'model/method');
  if (task !== 'composition' && task !== 'tracking')
    throw err('model/task', `a '${task}' policy: its residual reads goal features that the live page does not compute; the page runs composition policies (models/table2/) and text-driven tracking policies (models/table4/)`);
  if (method !== 'ours' && method !== 'cml') throw err('model/method', `method '${method}': the live page runs residual policies (ours, cml)`);
  if (task === 'tracking' && method !== 'ours')
    throw err('model/method', `a tracking policy of method '${method}': its base reads the full state (residual_config.hpp masked_base_input), which the page does not run; it runs method 'ours' (models/table4/tracking_ours_*.bin)`);
  const base = rc.rl || {};
  const net = base.net || {};
  checkHidden(net.actor_hidden, err, 'residual_config', 'rl.net.actor_hidden');
  checkHidden(rc.residual_hidden, err, 'residual_config', 'residual_hidden');
  const act = activationOf(net.activation, err, 'residual_config');
  if (rc.goal_parts) throw err('residual_config', `goal_parts '${rc.goal_parts}': a goal task's residual, not run by the page`);
  const actionDim = getFloat32(ck, 'base/actor/log_std').length;
  const baseInput = getFloat64(ck, 'base/actor/norm/mean').length;
  const obsDim = baseInput - NUM_PARTS;
  if (obsDim <= 0) throw err('base/actor/norm/mean', `has ${baseInput} entries: a base's input is [s̄ ; m] with ${NUM_PARTS} mask bits`);
  checkCharacter(obsDim, actionDim, expected, err, 'base/actor/norm/mean', 'base/actor/log_std');
  const baseActor = new MlpActor(ck, 'base/actor', baseInput, net.actor_hidden, actionDim, act, err, NUM_PARTS);
  // Tracking: the residual also reads goal features (goal_steps · 6 per designated body, tracking.js);
  // their number comes from the residual's normaliser and is checked against the character later.
  const resRows = getFloat64(ck, 'residual/norm/mean').length;
  const goalDim = task === 'tracking' ? resRows - (obsDim + actionDim + NUM_PARTS) : 0;
  let goalSteps = 0, designated = null;
  if (task === 'tracking') {
    goalSteps = rc.goal_steps;
    designated = rc.designated;
    if (!Number.isInteger(goalSteps) || goalSteps < 1) throw err('residual_config', `goal_steps must be an integer >= 1, got ${JSON.stringify(goalSteps)}`);
    if (typeof designated !== 'string' || !designated) throw err('residual_config', 'a tracking policy needs its designated parts (field designated)');
    if (!(goalDim > 0) || goalDim % (6 * goalSteps)) throw err('residual/norm/mean', `has ${resRows} entries: not [s ; a_base ; m ; goals] with goal_steps ${goalSteps}`);
  }
  const resInput = obsDim + actionDim + NUM_PARTS + goalDim;
  const residual = new MlpActor(ck, 'residual', resInput, rc.residual_hidden, actionDim, act, err, 0);
  const gain = getFloat32(ck, 'residual/gain');
  const gainMode = rc.gain || 'scalar';
  if (!(gain.length === 1 || gain.length === actionDim)) throw err('residual/gain', `has ${gain.length} entries, expected 1 or ${actionDim}`);
  if ((gainMode === 'per_dof') !== (gain.length === actionDim && actionDim !== 1)) throw err('residual/gain', `has ${gain.length} entries for gain mode '${gainMode}'`);
  const offset = actionVector(ck, 'base/actor/action_offset', actionDim, err);
  const scale = actionVector(ck, 'base/actor/action_scale', actionDim, err);
  // (play-residual runs a tracking policy with its designated parts adapted)
  const trainedMask = task === 'tracking' ? designated : Array.isArray(rc.masks) && rc.masks.length ? rc.masks[0] : 'none';
  return new ResidualPolicy({
    kind: RESIDUAL_EXPORT_KIND, file, task, method, obsDim, actionDim, baseActor, residual, gain, perDof: gain.length > 1, goalDim, goalSteps, designated,
    generatorFile: task === 'tracking' ? rc.generator : null,
    offset, scale, config: rc, trainedMask, hidden: rc.residual_hidden, baseHidden: net.actor_hidden, activationName: net.activation || 'relu',
    character: (base.env && base.env.character) || 'humanoid',
    terminationHeight: base.env ? base.env.termination_height : undefined,
    iteration: has(ck, 'trainer/iteration') ? getScalarInt(ck, 'trainer/iteration') : null,
    newMotions: (rc.new_motions || []).map((m) => String(m).split('/').pop()),
  });
}

export class ResidualPolicy {
  constructor(fields) {
    Object.assign(this, fields);
    this.baseIn = new Float32Array(this.obsDim + NUM_PARTS);
    this.x = new Float32Array(this.obsDim + this.actionDim + NUM_PARTS + this.goalDim);
    this.mu = new Float32Array(this.actionDim);
    this.targetsBuf = new Float32Array(this.actionDim);
    this.dofParts = null;
  }
  get description() {
    const what = this.task === 'tracking' ? `text-driven tracking with the ${this.designated} designated, ${this.goalSteps} goal frames` : `${this.task} of ${this.newMotions.join(', ') || 'a new motion'} on ${this.trainedMask}`;
    return `stage 2 (${this.method}, ${what}): residual ${this.x.length} → [${this.hidden.join(', ')}] → ${this.actionDim} on a frozen base ${this.obsDim + NUM_PARTS} → [${this.baseHidden.join(', ')}] → ${this.actionDim}` +
      (this.iteration !== null ? `, ${this.iteration} iterations` : '');
  }
  /** Part index of every action DoF (the body part its joint moves). */
  setDofParts(dofParts) {
    if (dofParts.length !== this.actionDim) throw new Error(`${this.file}: ${dofParts.length} DoF parts for ${this.actionDim} actions`);
    this.dofParts = dofParts;
  }
  /** Residual input x = [s ; a_base ; m (; g)] (a_base = the base's mean on [s̄ ; m]; g: goal features, tracking). */
  residualInput(s, parts, mask, goals = null) {
    buildPolicyInput(s, parts, mask, this.baseIn);
    const aBase = this.baseActor.mean(this.baseIn);
    this.x.set(s, 0);
    this.x.set(aBase, this.obsDim);
    for (let p = 0; p < NUM_PARTS; ++p) this.x[this.obsDim + this.actionDim + p] = (mask >> p) & 1;
    if (this.goalDim > 0) {
      if (!goals || goals.length !== this.goalDim) throw new Error(`${this.file}: the tracking residual needs ${this.goalDim} goal features, got ${goals ? goals.length : 'none'}`);
      this.x.set(goals, this.obsDim + this.actionDim + NUM_PARTS);
    }
    return this.x;
  }
  /** Composite mean â from a residual input x and the mask. */
  compose(x, mask, out = this.mu) {
    const delta = this.residual.mean(x);
    for (let k = 0; k < this.actionDim; ++k) {
      const aBase = x[this.obsDim + k];
      const w = this.gain[this.perDof ? k : 0];
      out[k] = (mask >> this.dofParts[k]) & 1 ? Math.fround(Math.fround(w * aBase) + delta[k]) : aBase;
    }
    return out;
  }
  targets(a, out = new Float32Array(this.actionDim)) {
    return toTargets(a, this.offset, this.scale, out);
  }
  act(s, parts, mask, goals = null) {
    if (!this.dofParts) throw new Error(`${this.file}: setDofParts was not called`);
    const x = this.residualInput(s, parts, mask, goals);
    return this.targets(this.compose(x, mask), this.targetsBuf);
  }
}
