// Parsing and validation of maskadapt rollout files (schema "maskadapt-rollout", version 1;
// documented in docs/viewer.md and written by include/maskadapt/eval/rollout_file.hpp).
// Pure module: no DOM, no three.js, so it is unit-tested with vitest.

export const ROLLOUT_FORMAT = 'maskadapt-rollout';
export const ROLLOUT_VERSION = 1;
export const PART_NAMES = ['trunk', 'left_arm', 'right_arm', 'left_leg', 'right_leg'];
export const GEOM_TYPES = ['capsule', 'sphere', 'box'];

export class RolloutError extends Error {
  constructor(field, message) {
    super(field ? `field '${field}': ${message}` : message);
    this.name = 'RolloutError';
    this.field = field;
  }
}

function fail(field, message) {
  throw new RolloutError(field, message);
}

function need(obj, key, prefix) {
  const field = prefix ? `${prefix}.${key}` : key;
  if (obj === null || typeof obj !== 'object' || Array.isArray(obj)) fail(prefix, 'expected an object');
  if (!(key in obj)) fail(field, 'missing field');
  return obj[key];
}

function finiteNumber(v, field) {
  if (typeof v !== 'number' || !Number.isFinite(v)) fail(field, `expected a finite number, got ${JSON.stringify(v)}`);
  return v;
}

function array(v, field, length) {
  if (!Array.isArray(v)) fail(field, `expected an array, got ${v === null ? 'null' : typeof v}`);
  if (length !== undefined && v.length !== length) fail(field, `expected ${length} elements, got ${v.length}`);
  return v;
}

function vec3(v, field) {
  array(v, field, 3);
  return v.map((x, i) => finiteNumber(x, `${field}[${i}]`));
}

function parseGeom(g, field) {
  const type = need(g, 'type', field);
  if (!GEOM_TYPES.includes(type)) fail(`${field}.type`, `unknown geom type '${type}' (capsule, sphere, box)`);
  if (type === 'capsule') {
    return {
      type,
      from: vec3(need(g, 'from', field), `${field}.from`),
      to: vec3(need(g, 'to', field), `${field}.to`),
      radius: finiteNumber(need(g, 'radius', field), `${field}.radius`),
    };
  }
  if (type === 'sphere') {
    return {
      type,
      center: vec3(need(g, 'center', field), `${field}.center`),
      radius: finiteNumber(need(g, 'radius', field), `${field}.radius`),
    };
  }
  return {
    type,
    center: vec3(need(g, 'center', field), `${field}.center`),
    halfSize: vec3(need(g, 'half_size', field), `${field}.half_size`),
  };
}

/** Tolerance on the norm of unit vectors and quaternions (files store 6 decimals). */
export const UNIT_TOLERANCE = 1e-3;

function isNullish(v) {
  return v === null || v === undefined;
}

/**
 * Parses the optional `scene` (goal tasks: location targets, heading arrows, rigid boxes) of a
 * document with nf frames. Returns null when absent, else
 * { objects: [{name, halfSize: [hx, hy, hz], positions: Float32Array(nf·3), rotations: Float32Array(nf·4)}],
 *   targets: null | Array(nf) of [{position: [x, y, z], radius}],
 *   arrows: null | Array(nf) of [{origin: [x, y, z], direction: [dx, dy, dz], speed}] }.
 */
function parseScene(sc, nf) {
  if (isNullish(sc)) return null;
  if (typeof sc !== 'object' || Array.isArray(sc)) fail('scene', 'expected an object or null');
  const objects = isNullish(sc.objects)
    ? []
    : array(sc.objects, 'scene.objects').map((o, i) => {
        const f = `scene.objects[${i}]`;
        const name = need(o, 'name', f);
        if (typeof name !== 'string') fail(`${f}.name`, 'expected a string');
        if ('type' in o && o.type !== 'box') fail(`${f}.type`, `unknown object type '${o.type}' (box)`);
        const halfSize = vec3(need(o, 'half_size', f), `${f}.half_size`);
        if (!halfSize.every((h) => h > 0)) fail(`${f}.half_size`, `half sizes must be positive, got ${JSON.stringify(halfSize)}`);
        const pj = array(need(o, 'positions', f), `${f}.positions`, nf);
        const qj = array(need(o, 'rotations', f), `${f}.rotations`, nf);
        const positions = new Float32Array(nf * 3);
        const rotations = new Float32Array(nf * 4);
        for (let t = 0; t < nf; ++t) {
          positions.set(vec3(pj[t], `${f}.positions[${t}]`), 3 * t);
          const q = array(qj[t], `${f}.rotations[${t}]`, 4).map((x, k) => finiteNumber(x, `${f}.rotations[${t}][${k}]`));
          const norm = Math.hypot(...q);
          if (Math.abs(norm - 1) > UNIT_TOLERANCE)
            fail(`${f}.rotations[${t}]`, `frame ${t}: rotation is not a unit quaternion (norm ${norm.toFixed(6)})`);
          rotations.set(q, 4 * t);
        }
        return { name, halfSize, positions, rotations };
      });
  const perFrame = (key, parseEntry) => {
    if (isNullish(sc[key])) return null;
    return array(sc[key], `scene.${key}`, nf).map((row, t) =>
      isNullish(row) ? [] : array(row, `scene.${key}[${t}]`).map((e, k) => parseEntry(e, `scene.${key}[${t}][${k}]`, t)),
    );
  };
  const targets = perFrame('targets', (e, f, t) => {
    const position = vec3(need(e, 'position', f), `${f}.position`);
    const radius = finiteNumber(need(e, 'radius', f), `${f}.radius`);
    if (radius <= 0) fail(`${f}.radius`, `frame ${t}: radius must be positive, got ${radius}`);
    return { position, radius };
  });
  const arrows = perFrame('arrows', (e, f, t) => {
    const origin = vec3(need(e, 'origin', f), `${f}.origin`);
    const direction = vec3(need(e, 'direction', f), `${f}.direction`);
    if (Math.abs(Math.hypot(...direction) - 1) > UNIT_TOLERANCE || Math.abs(direction[2]) > UNIT_TOLERANCE)
      fail(`${f}.direction`, `frame ${t}: direction must be a horizontal unit vector, got ${JSON.stringify(direction)}`);
    const speed = finiteNumber(need(e, 'speed', f), `${f}.speed`);
    if (speed < 0) fail(`${f}.speed`, `frame ${t}: speed must be >= 0, got ${speed}`);
    return { origin, direction, speed };
  });
  return { objects, targets, arrows };
}

/**
 * Parses a rollout document (a JSON string or an already parsed object).
 * Returns { fps, numFrames, numBodies, bodies: [{name, parent, part, partIndex, offset, geoms}],
 *   positions: Float32Array (numFrames·numBodies·3, world metres, z-up),
 *   rotations: Float32Array (numFrames·numBodies·4, quaternion x, y, z, w),
 *   masks: Uint8Array (numFrames, bit p ⇔ part p adapted), contacts: Array<Uint8Array|null>,
 *   texts: [{t, text}] sorted, goals: {bodies, targets: Array<Float32Array|null>} | null,
 *   scene: {objects, targets, arrows} | null (see parseScene; null when the file has none), metadata }.
 * Throws RolloutError naming the field at fault.
 */
export function parseRollout(input) {
  let doc = input;
  if (typeof input === 'string') {
    try {
      doc = JSON.parse(input);
    } catch (e) {
      throw new RolloutError('', `not valid JSON: ${e.message}`);
    }
  }
  if (doc === null || typeof doc !== 'object' || Array.isArray(doc)) fail('', 'expected a JSON object');
  if (doc.format !== ROLLOUT_FORMAT) fail('format', `not a rollout file (expected "${ROLLOUT_FORMAT}")`);
  if (doc.version !== ROLLOUT_VERSION)
    fail('version', `unsupported version ${JSON.stringify(doc.version)} (this viewer reads ${ROLLOUT_VERSION})`);
  const fps = finiteNumber(need(doc, 'fps', ''), 'fps');
  if (fps <= 0) fail('fps', 'must be positive');

  const bodiesIn = array(need(need(doc, 'skeleton', ''), 'bodies', 'skeleton'), 'skeleton.bodies');
  if (bodiesIn.length === 0) fail('skeleton.bodies', 'no bodies');
  const bodies = bodiesIn.map((b, i) => {
    const f = `skeleton.bodies[${i}]`;
    const name = need(b, 'name', f);
    if (typeof name !== 'string') fail(`${f}.name`, 'expected a string');
    const parent = need(b, 'parent', f);
    if (!Number.isInteger(parent) || (i === 0 ? parent !== -1 : parent < 0 || parent >= i))
      fail(`${f}.parent`, `parent must precede the body (root: -1), got ${parent}`);
    const part = need(b, 'part', f);
    const partIndex = PART_NAMES.indexOf(part);
    if (partIndex < 0) fail(`${f}.part`, `unknown body part '${part}'`);
    const geoms = array(need(b, 'geoms', f), `${f}.geoms`).map((g, k) => parseGeom(g, `${f}.geoms[${k}]`));
    return { name, parent, part, partIndex, offset: vec3(need(b, 'offset', f), `${f}.offset`), geoms };
  });
  const nb = bodies.length;

  const frames = need(doc, 'frames', '');
  const pos = array(need(frames, 'positions', 'frames'), 'frames.positions');
  const nf = pos.length;
  const rot = array(need(frames, 'rotations', 'frames'), 'frames.rotations', nf);
  const masksIn = array(need(frames, 'masks', 'frames'), 'frames.masks', nf);
  const contactsIn = array(need(frames, 'contacts', 'frames'), 'frames.contacts', nf);

  const positions = new Float32Array(nf * nb * 3);
  const rotations = new Float32Array(nf * nb * 4);
  const masks = new Uint8Array(nf);
  const contacts = new Array(nf);
  for (let f = 0; f < nf; ++f) {
    const pf = array(pos[f], `frames.positions[${f}]`, 3 * nb);
    const qf = array(rot[f], `frames.rotations[${f}]`, 4 * nb);
    for (let k = 0; k < 3 * nb; ++k) positions[f * nb * 3 + k] = finiteNumber(pf[k], `frames.positions[${f}][${k}]`);
    for (let k = 0; k < 4 * nb; ++k) rotations[f * nb * 4 + k] = finiteNumber(qf[k], `frames.rotations[${f}][${k}]`);
    const m = masksIn[f];
    if (!Number.isInteger(m) || m < 0 || m > 31) fail(`frames.masks[${f}]`, `mask must be an integer in [0, 31], got ${m}`);
    masks[f] = m;
    if (contactsIn[f] === null) contacts[f] = null;
    else {
      const c = array(contactsIn[f], `frames.contacts[${f}]`, nb);
      contacts[f] = Uint8Array.from(c, (x, k) => {
        if (x !== 0 && x !== 1) fail(`frames.contacts[${f}][${k}]`, 'contact flags must be 0 or 1');
        return x;
      });
    }
  }

  const texts = (doc.texts ?? []).map((t, k) => ({
    t: finiteNumber(need(t, 't', `texts[${k}]`), `texts[${k}].t`),
    text: String(need(t, 'text', `texts[${k}]`)),
  }));
  texts.sort((a, b) => a.t - b.t);

  let goals = null;
  if (doc.goals) {
    const gb = array(need(doc.goals, 'bodies', 'goals'), 'goals.bodies');
    gb.forEach((b, k) => {
      if (!Number.isInteger(b) || b < 0 || b >= nb) fail(`goals.bodies[${k}]`, `body index ${b} out of range`);
    });
    const gt = array(need(doc.goals, 'targets', 'goals'), 'goals.targets', nf);
    const targets = gt.map((row, f) => {
      if (row === null) return null;
      array(row, `goals.targets[${f}]`, 3 * gb.length);
      return Float32Array.from(row, (x, k) => finiteNumber(x, `goals.targets[${f}][${k}]`));
    });
    goals = { bodies: gb.slice(), targets };
  }
  const scene = parseScene(doc.scene, nf);

  return {
    fps,
    numFrames: nf,
    numBodies: nb,
    duration: nf > 0 ? (nf - 1) / fps : 0,
    bodies,
    positions,
    rotations,
    masks,
    contacts,
    texts,
    goals,
    scene,
    metadata: doc.metadata && typeof doc.metadata === 'object' ? doc.metadata : {},
  };
}

/** World position [x, y, z] of body b at frame f. */
export function bodyPosition(rollout, f, b) {
  const i = (f * rollout.numBodies + b) * 3;
  return [rollout.positions[i], rollout.positions[i + 1], rollout.positions[i + 2]];
}

/** World orientation [x, y, z, w] of body b at frame f. */
export function bodyRotation(rollout, f, b) {
  const i = (f * rollout.numBodies + b) * 4;
  return [rollout.rotations[i], rollout.rotations[i + 1], rollout.rotations[i + 2], rollout.rotations[i + 3]];
}

/** Frame index shown at time t (seconds): nearest earlier frame, clamped to the rollout. */
export function frameAtTime(rollout, t) {
  if (rollout.numFrames === 0) return 0;
  const f = Math.floor(t * rollout.fps + 1e-6);
  return Math.min(Math.max(f, 0), rollout.numFrames - 1);
}

/** The text command active at time t (the last entry with entry.t ≤ t), or '' when none. */
export function textAt(rollout, t) {
  let current = '';
  for (const entry of rollout.texts) {
    if (entry.t <= t + 1e-9) current = entry.text;
    else break;
  }
  return current;
}

/**
 * The scene goals shown at frame f: { targets: [{position, radius}], arrows: [{origin, direction,
 * speed}], objects: [{name, halfSize, position: [x, y, z], rotation: [x, y, z, w]}] } (empty
 * arrays when the rollout has no scene).
 */
export function sceneAt(rollout, f) {
  const sc = rollout.scene;
  if (!sc) return { targets: [], arrows: [], objects: [] };
  return {
    targets: sc.targets ? sc.targets[f] : [],
    arrows: sc.arrows ? sc.arrows[f] : [],
    objects: sc.objects.map((o) => ({
      name: o.name,
      halfSize: o.halfSize,
      position: Array.from(o.positions.subarray(3 * f, 3 * f + 3)),
      rotation: Array.from(o.rotations.subarray(4 * f, 4 * f + 4)),
    })),
  };
}
