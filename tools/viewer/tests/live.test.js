// The live page's JavaScript against the C++ of include/maskadapt, on inputs the C++ recorded
// (tools/viewer/live/fixture_*.json, written by tests/viewer/live_reference.cpp from the shipped
// models running natively on MuJoCo 2.2.2): observation, mask, policy input, normalised input,
// mean action and PD targets must agree to 1e-5 (relative to max(1, |value|)); the page's
// MuJoCo wrapper must read out the same body states as the C++ adapter at the start pose; the
// checkpoint reader must reject bad files naming the file and section.
import { describe, expect, it, beforeAll } from 'vitest';
import fs from 'node:fs';
import path from 'node:path';
import { parseCheckpoint, crc32 } from '../src/live/checkpoint.js';
import { loadBasePolicy, loadPolicy } from '../src/live/policy.js';
import { buildPolicyInput, computeObservation, maskText, observationDim, observationParts, parseMask, PART_NAMES } from '../src/live/features.js';
import { LiveSim, loadMujoco } from '../src/live/sim.js';
import { LiveSession } from '../src/live/session.js';
import { expectClose, liveDir, readJson, repo } from './fixtures.js';

const modelBytes = (name) => new Uint8Array(fs.readFileSync(path.join(repo, 'models', `${name}.bin`)));
const characters = { humanoid: readJson(path.join(liveDir, 'character_humanoid.json')), g1: readJson(path.join(liveDir, 'character_g1.json')) };
const MODELS = ['mask_mi_walk_bandai', 'amp_walk_bandai', 'g1_mask_mi_walk_bandai', 'g1_amp_walk_bandai'];
const STAGE2 = ['swim_ours_s1', 'kick_cut_ours_s1'];  // models/table2/

function statesOf(bs) {
  return { pos: Float64Array.from(bs.pos), rot: Float64Array.from(bs.rot_xyzw), linVel: Float64Array.from(bs.lin_vel), angVel: Float64Array.from(bs.ang_vel) };
}

describe('checkpoint reader', () => {
  it('reads the shipped export: sections, dtypes and shapes', () => {
    const ck = parseCheckpoint(modelBytes('mask_mi_walk_bandai'), 'mask_mi_walk_bandai.bin');
    expect(ck.sections.get('actor/params').dtype).toBe('float32');
    expect(ck.sections.get('actor/params').shape).toEqual([167487]);
    expect(ck.sections.get('actor/norm/mean').shape).toEqual([333]);
    expect(ck.sections.get('actor/hidden_groups').dtype).toBe('int64');
  });
  it('computes zlib CRC-32', () => {
    expect(crc32(new TextEncoder().encode('123456789'))).toBe(0xcbf43926);
  });
  it('rejects a corrupt, truncated or foreign file naming the file', () => {
    const good = modelBytes('mask_mi_walk_bandai');
    const flipped = good.slice();
    flipped[5000] ^= 1;
    expect(() => parseCheckpoint(flipped, 'x.bin')).toThrow(/x\.bin: checksum mismatch/);
    expect(() => parseCheckpoint(good.slice(0, good.length - 10), 'cut.bin')).toThrow(/cut\.bin: file size is/);
    expect(() => parseCheckpoint(new TextEncoder().encode('{"format":"maskadapt-rollout", "version": 1, "x": 0}'), 'r.json')).toThrow(/r\.json: not a maskadapt checkpoint/);
  });
  it('rejects a model of another character naming model/obs_dim', () => {
    expect(() => loadBasePolicy(modelBytes('g1_mask_mi_walk_bandai'), 'g1.bin', { name: 'humanoid', obsDim: 328, actionDim: 63 })).toThrow(
      /g1\.bin \[model\/obs_dim\]: this model was exported for 448 observation rows; the character 'humanoid' has 328/,
    );
  });
  it('names model/kind for a stage-2 export where a base is needed, and model/task for a goal-task policy', () => {
    const stage2 = new Uint8Array(fs.readFileSync(path.join(repo, 'models/table2/swim_ours_s1.bin')));
    expect(() => loadBasePolicy(stage2, 'res.bin')).toThrow(/res\.bin \[model\/kind\]: not a base-policy export: kind 'maskadapt.residual_policy'/);
    const location = new Uint8Array(fs.readFileSync(path.join(repo, 'models/table3/location_ours.bin')));
    expect(() => loadPolicy(location, 'loc.bin')).toThrow(/loc\.bin \[model\/task\]: a 'location' policy/);
  });
  it('names the section when a network has the wrong size', () => {
    // a G1 base's actor under the humanoid's dims: the file itself is consistent, the character is not
    expect(() => loadPolicy(modelBytes('g1_amp_walk_bandai'), 'g1amp.bin', { name: 'humanoid', obsDim: 328, actionDim: 63 })).toThrow(/g1amp\.bin \[model\/obs_dim\]/);
    const stage2 = new Uint8Array(fs.readFileSync(path.join(repo, 'models/table2/swim_ours_s1.bin')));
    expect(() => loadPolicy(stage2, 's2.bin', { name: 'g1', obsDim: 448, actionDim: 29 })).toThrow(/s2\.bin \[base\/actor\/norm\/mean\]: this model was exported for 328 observation rows; the character 'g1' has 448/);
  });
});

describe('features and policy equal the C++ on recorded steps', () => {
  for (const name of MODELS) {
    it(name, () => {
      const fx = readJson(path.join(liveDir, `fixture_${name}.json`));
      const ch = characters[fx.character];
      const nb = ch.bodies.length;
      const policy = loadBasePolicy(modelBytes(name), `${name}.bin`, { name: ch.name, obsDim: observationDim(nb), actionDim: ch.joint_names.length });
      const parts = observationParts(ch.bodies.map((b) => PART_NAMES.indexOf(b.part)));
      expect(fx.steps.length).toBeGreaterThanOrEqual(4);
      const masks = new Set(fx.steps.map((s) => s.mask_bits));
      expect(masks.size).toBeGreaterThanOrEqual(4);  // the recorded steps cover several masks
      for (const st of fx.steps) {
        expect(maskText(st.mask_bits)).toBe(st.mask);
        expect(parseMask(st.mask)).toBe(st.mask_bits);
        const s = computeObservation(statesOf(st.body_states), nb);
        expectClose(s, st.observation, 1e-5, `${name} step ${st.step}: observation`);
        const x = buildPolicyInput(Float32Array.from(st.observation), parts, st.mask_bits);
        expectClose(x, st.policy_input, 0, `${name} step ${st.step}: policy input`);
        expectClose(policy.normalise(Float32Array.from(st.policy_input)), st.normalised_input, 1e-5, `${name} step ${st.step}: normalised input`);
        const mu = policy.mean(Float32Array.from(st.policy_input));
        expectClose(mu, st.mean_action, 1e-5, `${name} step ${st.step}: mean action`);
        expectClose(policy.targets(Float32Array.from(st.mean_action)), st.targets, 1e-5, `${name} step ${st.step}: targets`);
      }
    });
  }
});

describe('MuJoCo (WebAssembly) wrapper', () => {
  let mj;
  beforeAll(async () => {
    mj = await loadMujoco();
  }, 60000);

  for (const name of ['mask_mi_walk_bandai', 'g1_mask_mi_walk_bandai']) {
    it(`reads out the C++ adapter's body states at the start pose (${name})`, () => {
      const fx = readJson(path.join(liveDir, `fixture_${name}.json`));
      const ch = characters[fx.character];
      const sim = new LiveSim(mj, fs.readFileSync(path.join(repo, 'assets', ch.mjcf), 'utf8'), ch);
      sim.reset(ch.starts[0]);
      const want = statesOf(fx.steps[0].body_states);
      expect(fx.steps[0].step).toBe(0);
      for (const key of ['pos', 'rot', 'linVel', 'angVel']) expectClose(sim.states[key], want[key], 1e-9, `${name}: ${key}`);
      sim.dispose();
    });
  }

  for (const name of STAGE2) {
    it(`stage-2 composition policy ${name} equals the C++ on recorded steps`, () => {
      const fx = readJson(path.join(liveDir, `fixture_${name}.json`));
      const ch = characters[fx.character];
      const nb = ch.bodies.length;
      const policy = loadPolicy(new Uint8Array(fs.readFileSync(path.join(repo, 'models/table2', `${name}.bin`))), `${name}.bin`,
        { name: ch.name, obsDim: observationDim(nb), actionDim: ch.joint_names.length });
      expect(policy.kind).toBe('maskadapt.residual_policy');
      expect(parseMask(policy.trainedMask)).toBe(parseMask(fx.trained_mask));
      const partOfBody = ch.bodies.map((b) => PART_NAMES.indexOf(b.part));
      const sim = new LiveSim(mj, fs.readFileSync(path.join(repo, 'assets', ch.mjcf), 'utf8'), ch);
      policy.setDofParts(sim.dofBody.map((b) => partOfBody[b]));
      sim.dispose();
      const parts = observationParts(partOfBody);
      expect(new Set(fx.steps.map((s) => s.mask_bits)).size).toBeGreaterThanOrEqual(3);
      for (const st of fx.steps) {
        const what = `${name} step ${st.step} (mask ${st.mask})`;
        const s = computeObservation(statesOf(st.body_states), nb);
        expectClose(s, st.observation, 1e-5, `${what}: observation`);
        const x = policy.residualInput(Float32Array.from(st.observation), parts, st.mask_bits);
        expectClose(policy.baseIn, st.base_input, 0, `${what}: base input`);
        expectClose(x.subarray(policy.obsDim, policy.obsDim + policy.actionDim), st.base_mean, 1e-5, `${what}: base mean`);
        expectClose(x, st.residual_input, 1e-5, `${what}: residual input`);
        const xr = Float32Array.from(st.residual_input);
        expectClose(policy.residual.normalise(xr, new Float32Array(xr.length)), st.residual_normalised_input, 1e-5, `${what}: normalised residual input`);
        expectClose(policy.residual.mean(xr, new Float32Array(policy.actionDim)), st.residual_mean, 1e-5, `${what}: residual mean`);
        const mu = policy.compose(xr, st.mask_bits, new Float32Array(policy.actionDim));
        expectClose(mu, st.mean_action, 1e-5, `${what}: composite mean`);
        expectClose(policy.targets(Float32Array.from(st.mean_action)), st.targets, 1e-5, `${what}: targets`);
      }
    });
  }

  it('names the MJCF when it does not load', () => {
    const ch = { ...characters.humanoid, mjcf: 'broken.xml' };
    expect(() => new LiveSim(mj, '<mujoco><worldbody><body></worldbody></mujoco>', ch)).toThrow(/broken\.xml: MuJoCo could not load the model/);
  });

  it('a session walks 10 s with both legs masked on the mask-invariant base, and the AMP base falls', () => {
    const ch = characters.humanoid;
    const xml = fs.readFileSync(path.join(repo, 'assets/humanoid.xml'), 'utf8');
    const run = (name) => {
      const policy = loadBasePolicy(modelBytes(name), `${name}.bin`, { name: 'humanoid', obsDim: 328, actionDim: 63 });
      const s = new LiveSession(mj, xml, ch, policy);
      s.setMask(parseMask('left_leg,right_leg'));
      s.reset(0);
      s.runSeconds(10);
      const out = s.summary();
      s.dispose();
      return out;
    };
    const mi = run('mask_mi_walk_bandai');
    const amp = run('amp_walk_bandai');
    expect(mi.steps).toBe(300);
    expect(mi.falls, JSON.stringify(mi)).toBe(0);
    expect(mi.distance, JSON.stringify(mi)).toBeGreaterThanOrEqual(5);
    expect(amp.falls, JSON.stringify(amp)).toBeGreaterThanOrEqual(1);
  }, 60000);
});
