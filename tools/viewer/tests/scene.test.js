import { describe, expect, it } from 'vitest';
import { parseRollout, RolloutError, sceneAt } from '../src/rollout.js';
import { sceneRollout, tinyRollout } from './fixtures.js';

describe('parseRollout: scene goals (targets, arrows, boxes)', () => {
  it('reads the scene and looks it up per frame', () => {
    const r = parseRollout(JSON.stringify(sceneRollout()));
    expect(r.scene.objects).toHaveLength(1);
    expect(r.scene.objects[0].name).toBe('strike_box');
    expect(r.scene.objects[0].halfSize).toEqual([0.2, 0.2, 0.6]);
    expect(r.scene.targets).toHaveLength(4);
    expect(r.scene.arrows).toHaveLength(4);
    const s2 = sceneAt(r, 2);
    expect(s2.targets).toEqual([{ position: [-1, 2, 0], radius: 0.75 }]);
    expect(s2.arrows).toEqual([{ origin: [0.2, 0, 0], direction: [0, 1, 0], speed: 1.5 }]);
    expect(s2.objects[0].name).toBe('strike_box');
    expect(s2.objects[0].position.map((x) => +x.toFixed(5))).toEqual([2.1, 0.5, 0.45]);
    expect(s2.objects[0].rotation[0]).toBeCloseTo(0.382683, 6);
    expect(sceneAt(r, 3).targets).toEqual([]);
    expect(sceneAt(r, 0).arrows).toEqual([]);
  });

  it('loads files without a scene as before', () => {
    const r = parseRollout(tinyRollout());
    expect(r.scene).toBeNull();
    expect(sceneAt(r, 1)).toEqual({ targets: [], arrows: [], objects: [] });
    const withNull = parseRollout({ ...tinyRollout(), scene: null });
    expect(withNull.scene).toBeNull();
    // Everything else is identical with and without the key.
    const { scene, ...rest } = parseRollout(sceneRollout());
    const { scene: none, ...restOld } = r;
    expect(rest).toEqual(restOld);
    expect(scene).not.toBeNull();
    expect(none).toBeNull();
  });

  it('accepts a scene with some kinds absent (null or missing) and null frames', () => {
    const doc = sceneRollout();
    doc.scene.targets = null;
    delete doc.scene.objects;
    doc.scene.arrows[1] = null;
    const r = parseRollout(doc);
    expect(r.scene.targets).toBeNull();
    expect(r.scene.objects).toEqual([]);
    expect(r.scene.arrows[1]).toEqual([]);
    expect(sceneAt(r, 0)).toEqual({ targets: [], arrows: [], objects: [] });
  });

  const broken = [
    ['scene', (d) => (d.scene = 3)],
    ['scene.targets', (d) => d.scene.targets.pop()],
    ['scene.targets[1]', (d) => (d.scene.targets[1] = { position: [0, 0, 0], radius: 1 })],
    ['scene.targets[2][0].radius', (d) => (d.scene.targets[2][0].radius = -0.5)],
    ['scene.targets[2][0].radius', (d) => delete d.scene.targets[2][0].radius],
    ['scene.targets[0][0].position[1]', (d) => (d.scene.targets[0][0].position[1] = null)],  // NaN is written as null
    ['scene.arrows', (d) => d.scene.arrows.push([])],
    ['scene.arrows[1][0].direction', (d) => (d.scene.arrows[1][0].direction = [1, 1, 0])],
    ['scene.arrows[1][0].direction', (d) => (d.scene.arrows[1][0].direction = [0.6, 0, 0.8])],
    ['scene.arrows[2][0].speed', (d) => (d.scene.arrows[2][0].speed = -1)],
    ['scene.arrows[2][0].origin', (d) => d.scene.arrows[2][0].origin.pop()],
    ['scene.objects[0].type', (d) => (d.scene.objects[0].type = 'sphere')],
    ['scene.objects[0].name', (d) => delete d.scene.objects[0].name],
    ['scene.objects[0].half_size', (d) => (d.scene.objects[0].half_size[2] = -0.6)],
    ['scene.objects[0].half_size', (d) => (d.scene.objects[0].half_size[0] = 0)],
    ['scene.objects[0].positions', (d) => d.scene.objects[0].positions.pop()],
    ['scene.objects[0].positions[1][2]', (d) => (d.scene.objects[0].positions[1][2] = 'x')],
    ['scene.objects[0].rotations[2]', (d) => (d.scene.objects[0].rotations[2] = [0, 0, 0, 2])],
    ['scene.objects[0].rotations[2]', (d) => d.scene.objects[0].rotations[2].pop()],
  ];
  for (const [field, breakIt] of broken) {
    it(`names the field at fault: ${field}`, () => {
      const doc = sceneRollout();
      breakIt(doc);
      let err;
      try {
        parseRollout(doc);
      } catch (e) {
        err = e;
      }
      expect(err).toBeInstanceOf(RolloutError);
      expect(err.field).toBe(field);
      expect(err.message).toContain(`field '${field}'`);
    });
  }

  it('names the frame of per-frame value errors', () => {
    const doc = sceneRollout();
    doc.scene.objects[0].rotations[2] = [0, 0, 0, 2];
    expect(() => parseRollout(doc)).toThrow(/frame 2: rotation is not a unit quaternion/);
    const doc2 = sceneRollout();
    doc2.scene.targets[1][0].radius = 0;
    expect(() => parseRollout(doc2)).toThrow(/frame 1: radius must be positive/);
  });
});
