import { describe, expect, it } from 'vitest';
import { bodyPosition, bodyRotation, frameAtTime, parseRollout, RolloutError, textAt } from '../src/rollout.js';
import { tinyRollout } from './fixtures.js';

describe('parseRollout', () => {
  it('reads every field of a valid document (object or string)', () => {
    for (const input of [tinyRollout(), JSON.stringify(tinyRollout())]) {
      const r = parseRollout(input);
      expect(r.numFrames).toBe(4);
      expect(r.numBodies).toBe(2);
      expect(r.fps).toBe(2);
      expect(r.duration).toBeCloseTo(1.5);
      expect(r.bodies[1]).toMatchObject({ name: 'L_Shoulder', parent: 0, part: 'left_arm', partIndex: 1 });
      expect(r.bodies[1].geoms[1]).toEqual({ type: 'box', center: [0, 0.3, 0], halfSize: [0.05, 0.05, 0.02] });
      expect(bodyPosition(r, 3, 1).map((x) => +x.toFixed(5))).toEqual([0.3, 0.2, 1.4]);
      expect(bodyRotation(r, 2, 1)[3]).toBeCloseTo(0.7071068, 6);
      expect(Array.from(r.masks)).toEqual([0, 0, 2, 2]);
      expect(r.contacts[1]).toBeNull();
      expect(Array.from(r.contacts[3])).toEqual([1, 1]);
      expect(r.texts.map((t) => t.text)).toEqual(['wave hands', 'raise arms']);  // sorted by t
      expect(r.goals.bodies).toEqual([1]);
      expect(r.goals.targets[2]).toBeNull();
      expect(r.metadata.seed).toBe(3);
    }
  });

  it('accepts a rollout without texts and goals', () => {
    const doc = tinyRollout();
    delete doc.texts;
    doc.goals = null;
    const r = parseRollout(doc);
    expect(r.texts).toEqual([]);
    expect(r.goals).toBeNull();
  });

  const broken = [
    ['format', (d) => (d.format = 'something-else')],
    ['version', (d) => (d.version = 2)],
    ['fps', (d) => delete d.fps],
    ['skeleton.bodies[1].part', (d) => (d.skeleton.bodies[1].part = 'tail')],
    ['skeleton.bodies[1].parent', (d) => (d.skeleton.bodies[1].parent = 1)],
    ['skeleton.bodies[0].geoms[0].type', (d) => (d.skeleton.bodies[0].geoms[0].type = 'cone')],
    ['frames.positions[2]', (d) => d.frames.positions[2].pop()],
    ['frames.positions[1][4]', (d) => (d.frames.positions[1][4] = 'x')],
    ['frames.rotations', (d) => d.frames.rotations.pop()],
    ['frames.masks[3]', (d) => (d.frames.masks[3] = 32)],
    ['frames.contacts[0][1]', (d) => (d.frames.contacts[0][1] = 2)],
    ['goals.bodies[0]', (d) => (d.goals.bodies[0] = 5)],
    ['goals.targets[1]', (d) => d.goals.targets[1].push(0)],
  ];
  for (const [field, breakIt] of broken) {
    it(`names the field at fault: ${field}`, () => {
      const doc = tinyRollout();
      breakIt(doc);
      let err;
      try {
        parseRollout(doc);
      } catch (e) {
        err = e;
      }
      expect(err).toBeInstanceOf(RolloutError);
      expect(err.field).toBe(field);
    });
  }

  it('reports malformed JSON', () => {
    expect(() => parseRollout('{"format": ')).toThrow(/not valid JSON/);
  });
});

describe('time helpers', () => {
  const r = parseRollout(tinyRollout());
  it('maps time to frames at the rollout fps and clamps', () => {
    expect(frameAtTime(r, 0)).toBe(0);
    expect(frameAtTime(r, 0.49)).toBe(0);
    expect(frameAtTime(r, 0.5)).toBe(1);
    expect(frameAtTime(r, 1.2)).toBe(2);
    expect(frameAtTime(r, 99)).toBe(3);
    expect(frameAtTime(r, -1)).toBe(0);
  });
  it('returns the text active at a time', () => {
    expect(textAt(r, 0)).toBe('wave hands');
    expect(textAt(r, 0.99)).toBe('wave hands');
    expect(textAt(r, 1.0)).toBe('raise arms');
    const none = parseRollout({ ...tinyRollout(), texts: [{ t: 1, text: 'later' }] });
    expect(textAt(none, 0.5)).toBe('');
  });
});
