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
