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
