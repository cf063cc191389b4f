import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { expect } from 'vitest';

// A hand-made 2-body rollout: root + left arm, 4 frames at 2 fps, arms adapted from frame 2.
export function tinyRollout() {
  return {
    format: 'maskadapt-rollout',
    version: 1,
    fps: 2,
    num_frames: 4,
    part_names: ['trunk', 'left_arm', 'right_arm', 'left_leg', 'right_leg'],
    metadata: { command: 'test', checkpoint: '', seed: 3 },
    skeleton: {
      bodies: [
        { name: 'Pelvis', parent: -1, part: 'trunk', offset: [0, 0, 0], geoms: [{ type: 'sphere', center: [0, 0, 0], radius: 0.1 }] },
        {
          name: 'L_Shoulder', parent: 0, part: 'left_arm', offset: [0, 0.2, 0.4],
          geoms: [
            { type: 'capsule', from: [0, 0, 0], to: [0, 0.25, 0], radius: 0.04 },
            { type: 'box', center: [0, 0.3, 0], half_size: [0.05, 0.05, 0.02] },
          ],
        },
      ],
    },
    frames: {
      positions: [0, 1, 2, 3].map((f) => [0.1 * f, 0, 1, 0.1 * f, 0.2, 1.4]),
      rotations: [0, 1, 2, 3].map(() => [0, 0, 0, 1, 0, 0, 0.7071068, 0.7071068]),
      masks: [0, 0, 2, 2],
      contacts: [[0, 0], null, [1, 0], [1, 1]],
    },
    texts: [{ t: 1.0, text: 'raise arms' }, { t: 0, text: 'wave hands' }],
    goals: { bodies: [1], targets: [[0, 0.3, 1.5], [0.1, 0.3, 1.5], null, [0.3, 0.3, 1.5]] },
  };
}

// tinyRollout() plus a goal-task scene: a strike box tipping over about x (90° by frame 3), a
// location target that moves at frame 2 (none on frame 3), and a heading arrow from the root
// (none on frame 0; speed 0 on frame 3).
export function sceneRollout() {
  const doc = tinyRollout();
  const s = Math.SQRT1_2;
  doc.scene = {
    objects: [
      {
        name: 'strike_box', type: 'box', half_size: [0.2, 0.2, 0.6],
        positions: [[2, 0.5, 0.6], [2, 0.5, 0.6], [2.1, 0.5, 0.45], [2.3, 0.5, 0.2]],
        rotations: [[0, 0, 0, 1], [0, 0, 0, 1], [0.382683, 0, 0, 0.92388], [s, 0, 0, s]],
      },
    ],
    targets: [
      [{ position: [3, 1.25, 0], radius: 0.5 }],
      [{ position: [3, 1.25, 0], radius: 0.5 }],
      [{ position: [-1, 2, 0], radius: 0.75 }],
      [],
    ],
    arrows: [
      [],
      [{ origin: [0.1, 0, 0], direction: [0.6, 0.8, 0], speed: 1.25 }],
      [{ origin: [0.2, 0, 0], direction: [0, 1, 0], speed: 1.5 }],
      [{ origin: [0.3, 0, 0], direction: [-1, 0, 0], speed: 0 }],
    ],
  };
  return doc;
}

// ---- the live page's fixtures (live.test.js, tracking.test.js) ---------------------------------

const here = path.dirname(fileURLToPath(import.meta.url));
/** The checkout's root (models/, assets/). */
export const repo = path.resolve(here, '../../..');
// MASKADAPT_LIVE_FIXTURES: a folder freshly written by maskadapt_viewer_live_reference and
// maskadapt_viewer_live_tracking_reference (ctest viewer_live_js), so that a change to the C++
// that the page does not follow fails here; else the copies in tools/viewer/live/.
export const liveDir = path.resolve(process.env.MASKADAPT_LIVE_FIXTURES || path.resolve(here, '../live'));
export const readJson = (p) => JSON.parse(fs.readFileSync(p, 'utf8'));

/**
 * Expects `actual` (JavaScript) to equal `expected` (what the C++ recorded) to `tol` relative to
 * max(1, |value|); the message names `what`, the worst entry and both values. Returns the worst
 * relative error.
 */
export function expectClose(actual, expected, tol, what) {
  expect(actual.length, `${what}: length`).toBe(expected.length);
  let worst = 0, at = -1;
  for (let i = 0; i < expected.length; ++i) {
    const err = Math.abs(actual[i] - expected[i]) / Math.max(1, Math.abs(expected[i]));
    if (!(err <= worst)) {
      worst = err;
      at = i;
    }
  }
  expect(worst, `${what}: worst relative error at ${at} (js ${actual[at]}, c++ ${expected[at]})`).toBeLessThanOrEqual(tol);
  return worst;
}
