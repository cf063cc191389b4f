// The live page's text-driven partial tracking against the C++ on recorded inputs
// (tools/viewer/live/fixture_tracking_*.json, written by tests/viewer/live_tracking_reference.cpp
// from models/text_generator.bin and models/table4/tracking_ours_s1.bin): the random stream, the
// hashed text features, every diffusion step of the generator (x_t, conditional / unconditional /
// guided x̂₀, noise, x_{t−1}), the latent, the decoded features and frames, each primitive of an
// autoregressive rollout with a prompt switch and the goals extracted from it, and the tracking
// policy's input, mean action, PD targets and tracking error, to 1e-5 (relative to
// max(1, |value|)); one denoiser pass from the C++'s x_t to 3e-5, values carried through the
// denoising loop and the page's chained rollout (its own output fed back as history) to 1e-4 (the
// bounds are explained at ONE_STEP below). The worst differences are printed (docs/viewer.md quotes them).
import { afterAll, describe, expect, it } from 'vitest';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { computeObservation, observationDim, observationParts, parseMask, PART_NAMES } from '../src/live/features.js';
import { loadGenerator } from '../src/live/generator.js';
import { appendTrajectory, canonicalize, makeSkeleton, quatToMatrix, sliceTrajectory, trajectoryFromJson, transformToWorld } from '../src/live/kinematics.js';
import { loadPolicy } from '../src/live/policy.js';
import { ReplayNormals, Rng } from '../src/live/rng.js';
import { hashedTextFeatures } from '../src/live/textFeatures.js';
import { designatedBodies, extractGoals, positionError, TargetStream } from '../src/live/tracking.js';
import { expectClose as expectCloseTo, liveDir, readJson, repo } from './fixtures.js';

const here = path.dirname(fileURLToPath(import.meta.url));
const character = readJson(path.resolve(here, '../live/character_humanoid.json'));
const trackingChar = readJson(path.join(liveDir, 'tracking_humanoid.json'));
const fxGen = readJson(path.join(liveDir, 'fixture_tracking_generator.json'));
const fxPol = readJson(path.join(liveDir, 'fixture_tracking_ours_s1.json'));
const genBytes = new Uint8Array(fs.readFileSync(path.join(repo, 'models/text_generator.bin')));
const skel = makeSkeleton(trackingChar.skeleton);
const gen = loadGenerator(genBytes, 'text_generator.bin', skel);
const worst = {};
// Float32 rounding: the C++ sums each layer's products in float in Eigen's (blocked, FMA) order,
// the page in its own, so one denoiser pass differs by a few float ulps of its largest partial
// sums (measured worst 9.5e-6 relative to max(1, |x|) for the generator of 1bda6bb, 3.8e-6 for the
// one before). Bounds: one pass from the C++'s own x_t, and values carried through the T = 10
// steps (measured worst 1.1e-5). A wrong layer, activation or schedule differs by 1e-2 or more.
const ONE_STEP = 3e-5;
const CARRIED = 1e-4;

/** fixtures.js's expectClose, keeping the worst difference per quantity (`group`) for the summary. */
function expectClose(actual, expected, tol, what, group = what.replace(/^.*: /, '')) {
  const w = expectCloseTo(actual, expected, tol, what);
  worst[group] = Math.max(worst[group] || 0, w);
  return w;
}

/** Root rotations compared as rotation matrices (q and −q are the same rotation). */
function expectSameRotations(rot, want, tol, what) {
  const a = [], b = [];
  for (let i = 0; i < want.length; i += 4) {
    a.push(...quatToMatrix(Array.from(rot.slice(i, i + 4))));
    b.push(...quatToMatrix(want.slice(i, i + 4)));
  }
  return expectClose(a, b, tol, what);
}

function expectTrajectory(t, want, what) {
  expect(t.frames, `${what}: frames`).toBe(want.frames);
  expectClose(t.rootPos, want.root_pos, 1e-5, `${what}: root positions`, 'trajectory root positions');
  expectSameRotations(t.rootRot, want.root_rot_xyzw, 1e-5, `${what}: root rotations`);
  expectClose(t.q, want.q, 1e-5, `${what}: joint angles`, 'trajectory joint angles');
  expectClose(t.bodyPos, want.body_pos, 1e-5, `${what}: body positions`, 'trajectory body positions');
}

afterAll(() => {
  const rows = Object.entries(worst).map(([k, v]) => `  ${k}: ${v.toExponential(2)}`);
  console.log(`tracking.test.js: worst relative differences JS vs C++\n${rows.join('\n')}`);
});

describe('random stream', () => {
  it('Rng(seed).normal() gives the C++ normals (xoshiro256++, polar method)', () => {
    const rng = new Rng(fxGen.rollout.seed);
    const got = fxGen.rollout.normals.map(() => rng.normal());
    expectClose(got, fxGen.rollout.normals, 1e-15, 'normals of Rng(3)', 'rng normals');
  });
});

describe('hashed text features', () => {
  for (const { text, features } of fxGen.texts)
    it(`"${text}"`, () => {
      expectClose(hashedTextFeatures(text, 256), features, 1e-6, `text "${text}": features`, 'text features');
    });
  it('a prompt without words is all zeros (unconditional)', () => {
    expect(Array.from(hashedTextFeatures('  ?! ', 256)).every((v) => v === 0)).toBe(true);
  });
});

describe('generator equals the C++ step by step', () => {
  const start = trackingChar.starts[0];
  const history = trajectoryFromJson(skel, start.history);
  const { local } = canonicalize(skel, history, 0);
  it('reads the shipped generator: sizes and the arms pool', () => {
    expect([gen.H, gen.F, gen.L, gen.K, gen.E, gen.T]).toEqual([5, 15, 32, 256, 32, 10]);
    expect(gen.guidance).toBe(fxGen.guidance);
    expect(gen.latentScale).toBe(Math.fround(fxGen.latent_scale));
    expect(gen.armsPool).toContain('wave right hand');
  });
  for (const rec of fxGen.generate)
    it(`generate("${rec.text}") from ${start.label}`, () => {
      const what = `generate("${rec.text}")`;
      const trace = {};
      const out = gen.generate(rec.text, local, new Rng(rec.seed), trace);
      expectClose(trace.history.bodyPos, rec.history.body_pos, 1e-9, `${what}: canonical history body positions`, 'canonical history');
      expectClose(trace.historyFeatures, rec.history_features, 1e-5, `${what}: history features`);
      expectClose(trace.historyNormalised, rec.history_normalised, 1e-5, `${what}: normalised history`);
      expectClose(trace.textFeatures, rec.text_features, 1e-6, `${what}: text features`);
      expectClose(trace.embedding, rec.embedding, 1e-5, `${what}: text embedding`);
      expect(trace.unconditional).toBe(rec.unconditional);
      expectClose(trace.initialNoise, rec.initial_noise, 0, `${what}: initial noise`);
      expect(trace.steps.length).toBe(rec.steps.length);
      // Each step starts from the page's own x_t: rounding differences are carried (CARRIED);
      // the next test starts every step from the C++'s x_t (ONE_STEP).
      rec.steps.forEach((st, k) => {
        const js = trace.steps[k];
        const w = `${what} step t=${st.t}`;
        expect(js.t).toBe(st.t);
        expectClose(js.xt, st.x_t, CARRIED, `${w}: x_t`);
        expectClose(js.cond, st.x0_cond, CARRIED, `${w}: conditional x0`);
        if (js.uncond) expectClose(js.uncond, st.x0_uncond, CARRIED, `${w}: unconditional x0`);
        expectClose(js.x0, st.x0_hat, CARRIED, `${w}: guided x0`);
        if (st.noise) expectClose(js.noise, st.noise, 0, `${w}: noise`);
        else expect(js.noise).toBe(null);
        expectClose(js.next, st.x_next, CARRIED, `${w}: x_(t-1)`);
      });
      expectClose(trace.latent, rec.latent, CARRIED, `${what}: latent`);
      expectClose(trace.decodedNormalised, rec.decoded_normalised, CARRIED, `${what}: decoded (normalised)`);
      expectClose(trace.futureFeatures, rec.future_features, CARRIED, `${what}: future features`);
      expectTrajectory(out, rec.future, `${what}: decoded frames`);
    });
  it('the denoiser on the C++ x_t of every step (no carried difference): x0 and x_(t-1) to 3e-5', () => {
    for (const rec of fxGen.generate) {
      const hn = gen.normalisedHistory(local);
      const ctx = gen.denoiserContext(gen.textFeatures(rec.text), hn);
      expect(ctx.unconditional).toBe(rec.unconditional);
      for (const st of rec.steps) {
        const w = `"${rec.text}" from the C++ x_t, step t=${st.t}`;
        const p = gen.predictX0(ctx, Float32Array.from(st.x_t), st.t);
        expectClose(p.cond, st.x0_cond, ONE_STEP, `${w}: conditional x0`, 'one step: x0');
        // (an unconditional prompt has one denoiser pass: x0 is the conditional one)
        if (p.uncond) expectClose(p.uncond, st.x0_uncond, ONE_STEP, `${w}: unconditional x0`, 'one step: x0');
        else expect(rec.unconditional || gen.guidance === 1).toBe(true);
        expectClose(p.x0, st.x0_hat, ONE_STEP, `${w}: guided x0`, 'one step: x0');
        // x_(t-1) = posterior mean of the C++'s x0_hat and x_t, plus σ_t z with the recorded z
        const next = gen.previousLatent(st.t, Float32Array.from(st.x0_hat), Float32Array.from(st.x_t), st.noise && Float32Array.from(st.noise));
        expectClose(next, st.x_next, ONE_STEP, `${w}: x_(t-1)`, 'one step: x_(t-1)');
      }
    }
  });
});

describe('autoregressive rollout with a prompt switch, and its goals', () => {
  const r = fxGen.rollout;
  const history = trajectoryFromJson(skel, trackingChar.starts[0].history);
  const parts = character.bodies.map((b) => PART_NAMES.indexOf(b.part));
  const bodies = designatedBodies(parts, parseMask(r.designated));
  const schedule = r.schedule.split(',').map((e) => [Number(e.split(':')[0]), e.slice(e.indexOf(':') + 1)]);
  const run = (noise) => {
    const s = new TargetStream(gen, history, noise, schedule[0][1]);
    for (const [t, p] of schedule.slice(1)) s.setPrompt(t, p);
    s.ensure(r.frames);
    return s;
  };
  it('designated bodies of the arms', () => {
    expect(bodies).toEqual(r.bodies);
  });
  // Each primitive from the C++'s own history (its previous H frames) and its share of the normals:
  // what one generate call adds, without differences carried from earlier primitives.
  it(`each primitive of "${r.schedule}" from the C++ history equals the C++ to 1e-5, and so do the goals`, () => {
    const cpp = appendTrajectory(skel, history, trajectoryFromJson(skel, r.trajectory));
    const prompts = ['wave right hand', 'wave right hand', 'arms high', 'arms high'];
    const per = gen.L * gen.T;
    prompts.forEach((prompt, p) => {
      const { local, frame } = canonicalize(skel, sliceTrajectory(skel, cpp, gen.F * p, gen.H), 0);
      const fut = transformToWorld(skel, gen.generate(prompt, local, new ReplayNormals(r.normals.slice(per * p, per * (p + 1)))), frame);
      const want = sliceTrajectory(skel, cpp, gen.H + gen.F * p, gen.F);
      expectClose(fut.q, want.q, 1e-5, `primitive ${p} ("${prompt}"): joint angles`, 'trajectory joint angles');
      expectClose(fut.bodyPos, want.bodyPos, 1e-5, `primitive ${p}: body positions`, 'trajectory body positions');
      expectClose(fut.rootPos, want.rootPos, 1e-5, `primitive ${p}: root positions`, 'trajectory root positions');
    });
    const world = trajectoryFromJson(skel, r.trajectory);
    for (const g of r.goals) expectClose(extractGoals(skel, bodies, world, g.frame, r.goal_steps), g.goals, 1e-5, `goals at frame ${g.frame}: goals`, 'goals');
  });
  // Chained as the page runs it, each primitive's history is the page's previous output: float
  // rounding differences (the C++ sums its products in float, in Eigen's order) are fed back and
  // grow by ≈2–3× per primitive (max |Δq| 1.3e-6, 4.8e-6, 7.6e-6, 1.7e-5 rad over the 4 primitives).
  for (const [label, noise] of [['Rng(3)', () => new Rng(r.seed)], ['replayed normals', () => new ReplayNormals(r.normals)]])
    it(`${r.frames} frames chained, "${r.schedule}" (${label}): to 1e-4`, () => {
      const s = run(noise());
      expect(s.primitives.map((p) => p.text)).toEqual(['wave right hand', 'wave right hand', 'arms high', 'arms high']);
      const t = s.view(0);
      expectClose(t.q, r.trajectory.q, 1e-4, `chained rollout (${label}): joint angles`, 'chained rollout (4 primitives)');
      expectClose(t.bodyPos, r.trajectory.body_pos, 1e-4, `chained rollout (${label}): body positions`, 'chained rollout (4 primitives)');
      for (const g of r.goals) expectClose(extractGoals(skel, bodies, t, g.frame, r.goal_steps), g.goals, 1e-4, `chained goals at frame ${g.frame}`, 'chained rollout (4 primitives)');
    });
});

describe('tracking policy equals the C++ on recorded steps', () => {
  const nb = character.bodies.length;
  const policy = loadPolicy(new Uint8Array(fs.readFileSync(path.join(repo, 'models/table4/tracking_ours_s1.bin'))), 'tracking_ours_s1.bin',
    { name: 'humanoid', obsDim: observationDim(nb), actionDim: character.joint_names.length });
  const partOfBody = character.bodies.map((b) => PART_NAMES.indexOf(b.part));
  const parts = observationParts(partOfBody);
  it('reads it as a tracking residual with 96 goal rows on the arms', () => {
    expect(policy.task).toBe('tracking');
    expect(policy.goalDim).toBe(96);
    expect(parseMask(policy.trainedMask)).toBe(parseMask('arms'));
  });
  it(`steps of "${fxPol.schedule}" from ${fxPol.start}, seed ${fxPol.seed}: goals, input, mean, targets, error`, () => {
    // (the DoF parts from the MJCF's hinge order: the character's joint names are body-major x, y, z)
    policy.setDofParts(character.joint_names.map((_, k) => partOfBody[1 + Math.floor(k / 3)]));
    const bodies = designatedBodies(partOfBody, parseMask(policy.designated));
    const history = trajectoryFromJson(skel, trackingChar.starts[0].history);
    const schedule = fxPol.schedule.split(',').map((e) => [Number(e.split(':')[0]), e.slice(e.indexOf(':') + 1)]);
    const stream = new TargetStream(gen, history, new Rng(fxPol.seed), schedule[0][1]);
    for (const [t, p] of schedule.slice(1)) stream.setPrompt(t, p);
    const states = (bs) => ({ pos: Float64Array.from(bs.pos), rot: Float64Array.from(bs.rot_xyzw), linVel: Float64Array.from(bs.lin_vel), angVel: Float64Array.from(bs.ang_vel) });
    for (const st of fxPol.steps) {
      const what = `step ${st.step} ("${st.text}")`;
      const s = computeObservation(states(st.body_states), nb);
      expectClose(s, st.observation, 1e-5, `${what}: observation`);
      // (the page's own chained stream: 1e-4 as above; the policy below gets the C++'s goals)
      const g = stream.goals(st.step, bodies, policy.goalSteps, new Float32Array(policy.goalDim));
      expectClose(g, st.goals, 1e-4, `${what}: goals from the page's generator stream`, 'chained rollout (policy run, 5 primitives)');
      const x = policy.residualInput(Float32Array.from(st.observation), parts, st.mask_bits, Float32Array.from(st.goals));
      expectClose(x, st.residual_input, 1e-5, `${what}: residual input`);
      const xr = Float32Array.from(st.residual_input);
      expectClose(policy.residual.normalise(xr, new Float32Array(xr.length)), st.residual_normalised_input, 1e-5, `${what}: normalised residual input`);
      expectClose(policy.residual.mean(xr, new Float32Array(policy.actionDim)), st.residual_mean, 1e-5, `${what}: residual mean`);
      const mu = policy.compose(xr, st.mask_bits, new Float32Array(policy.actionDim));
      expectClose(mu, st.mean_action, 1e-5, `${what}: composite mean action`);
      expectClose(policy.targets(Float32Array.from(st.mean_action)), st.targets, 1e-5, `${what}: PD targets`);
      const err = positionError(skel, bodies, stream.view(0), st.step + 1, states(st.body_states_after));
      expectClose([err], [st.tracking_error_after], 1e-5, `${what}: tracking error`);
    }
  });
});

describe('bad input', () => {
  it('a corrupt generator file names the file', () => {
    const bad = genBytes.slice();
    bad[123456] ^= 4;
    expect(() => loadGenerator(bad, 'gen.bin', skel)).toThrow(/gen\.bin: checksum mismatch/);
    expect(() => loadGenerator(genBytes.slice(0, 5000), 'cut.bin', skel)).toThrow(/cut\.bin: file size is 5000 bytes/);
  });
  it('a policy file where a generator is expected names generator.format', () => {
    const pol = new Uint8Array(fs.readFileSync(path.join(repo, 'models/table4/tracking_ours_s1.bin')));
    expect(() => loadGenerator(pol, 'pol.bin', skel)).toThrow(/pol\.bin \[generator\.format\]: missing section/);
  });
  it('a generator for another skeleton names generator.config.bodies', () => {
    const other = { ...skel, names: skel.names.map((n, i) => (i === 3 ? 'Belly' : n)) };
    expect(() => loadGenerator(genBytes, 'g.bin', other)).toThrow(/g\.bin \[generator\.config\.bodies\]/);
  });
});
