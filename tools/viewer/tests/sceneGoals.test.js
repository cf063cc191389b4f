import * as THREE from 'three';
import { describe, expect, it } from 'vitest';
import { ARROW_COLOR, BASE_COLOR, GOAL_COLOR, OBJECT_COLOR, PART_COLORS, TARGET_COLOR } from '../src/colors.js';
import { parseRollout } from '../src/rollout.js';
import { arrowLength, FLOOR_OFFSET, MIN_ARROW_LENGTH, SceneGoals } from '../src/sceneGoals.js';
import { sceneRollout, tinyRollout } from './fixtures.js';

const round = (v) => v.map((x) => +x.toFixed(4) + 0);  // + 0 turns −0 into 0

describe('SceneGoals (three.js objects of the goal-task scene)', () => {
  it('builds nothing for a rollout without a scene', () => {
    const g = new SceneGoals(parseRollout(tinyRollout()));
    g.update(2);
    expect(g.group.children).toHaveLength(0);
    expect(g.state()).toEqual({ targets: [], arrows: [], objects: [] });
  });

  it('builds one marker per target/arrow of the busiest frame and one mesh per box', () => {
    const g = new SceneGoals(parseRollout(sceneRollout()));
    expect(g.targets).toHaveLength(1);
    expect(g.arrows).toHaveLength(1);
    expect(g.arrows[0]).toBeInstanceOf(THREE.ArrowHelper);
    expect(g.objects).toHaveLength(1);
    expect(g.objects[0].name).toBe('strike_box');
    const size = new THREE.Vector3();
    g.objects[0].geometry.computeBoundingBox();
    g.objects[0].geometry.boundingBox.getSize(size);
    expect(round(size.toArray())).toEqual([0.4, 0.4, 1.2]);
    expect(`#${g.objects[0].material.color.getHexString()}`).toBe(OBJECT_COLOR);
    expect(`#${g.targets[0].children[1].material.color.getHexString()}`).toBe(TARGET_COLOR);
  });

  it('poses targets on the floor scaled to their radius, per frame', () => {
    const g = new SceneGoals(parseRollout(sceneRollout()));
    g.update(0);
    expect(g.state().targets).toEqual([{ position: [3, 1.25, FLOOR_OFFSET], radius: 0.5 }]);
    // The disc is a unit circle in the floor plane: its world radius is the target radius.
    g.group.updateMatrixWorld(true);
    const box = new THREE.Box3().setFromObject(g.targets[0]);
    expect(+(box.max.x - box.min.x).toFixed(3)).toBe(1.0);
    expect(+(box.max.z - box.min.z).toFixed(6)).toBe(0);
    g.update(2);
    expect(g.state().targets).toEqual([{ position: [-1, 2, FLOOR_OFFSET], radius: 0.75 }]);
    g.update(3);
    expect(g.state().targets).toEqual([]);  // none on frame 3
  });

  it('draws heading arrows from their origin, along the direction, as long as the speed', () => {
    const g = new SceneGoals(parseRollout(sceneRollout()));
    g.update(0);
    expect(g.state().arrows).toEqual([]);
    g.update(1);
    const [a] = g.state().arrows;
    expect(round(a.origin)).toEqual([0.1, 0, 2 * FLOOR_OFFSET]);
    expect(a.length).toBeCloseTo(1.25, 6);
    g.group.updateMatrixWorld(true);
    // The arrow's tip (its local +y end) lies at origin + speed · direction.
    const tip = new THREE.Vector3(0, a.length, 0).applyMatrix4(g.arrows[0].matrixWorld);
    expect(round(tip.toArray())).toEqual(round([0.1 + 0.6 * 1.25, 0.8 * 1.25, 2 * FLOOR_OFFSET]));
    // The shaft (a cylinder inside the helper's line) runs from the origin to where the head starts.
    const shaft = g.arrows[0].line.children[0];
    expect(shaft).toBeInstanceOf(THREE.Mesh);
    const box = new THREE.Box3().setFromObject(shaft);
    const shaftLength = a.length - g.arrows[0].cone.scale.y;
    expect(box.min.x).toBeCloseTo(0.1, 1);
    expect(box.max.x).toBeCloseTo(0.1 + 0.6 * shaftLength, 1);
    expect(box.max.y).toBeCloseTo(0.8 * shaftLength, 1);
    g.update(3);  // speed 0: still drawn, at the minimum length
    expect(g.state().arrows[0].length).toBeCloseTo(MIN_ARROW_LENGTH, 6);
    expect(arrowLength(0)).toBe(MIN_ARROW_LENGTH);
    expect(arrowLength(1.5)).toBe(1.5);
  });

  it('moves and turns the box with its per-frame pose', () => {
    const g = new SceneGoals(parseRollout(sceneRollout()));
    g.update(0);
    expect(round(g.state().objects[0].position)).toEqual([2, 0.5, 0.6]);
    g.update(3);
    const o = g.state().objects[0];
    expect(round(o.position)).toEqual([2.3, 0.5, 0.2]);
    // (x, y, z, w) = (√½, 0, 0, √½) is 90° about x: the box lies on its side, its up axis along −y.
    const up = new THREE.Vector3(0, 0, 1).applyQuaternion(new THREE.Quaternion(...o.quaternion));
    expect(round(up.toArray())).toEqual([0, -1, 0]);
  });

  it('uses colours distinct from the part, base and tracking-goal colours', () => {
    const all = [...PART_COLORS, BASE_COLOR, GOAL_COLOR, TARGET_COLOR, ARROW_COLOR, OBJECT_COLOR];
    expect(new Set(all).size).toBe(all.length);
  });
});
