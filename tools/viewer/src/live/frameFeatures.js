// The generator's per-frame representation (include/maskadapt/tracking/frame_features.hpp), for a
// trajectory in its canonical frame. One frame's D = 13 + 9(nb − 1) values (202 for the humanoid):
//   [0, 3) root position · [3, 9) root rotation, 6-D (first two matrix columns) ·
//   [9, 12) root delta from the previous frame · [12] heading delta, wrapped (0 for frame 0) ·
//   [13 + 6(k−1), +6) joint k's local rotation, 6-D · [13 + 6(nb−1) + 3(k−1), +3) body k's position.
// Decoding keeps the root position, root rotation and joint rotations (Gram–Schmidt, then the
// three hinge angles) and recomputes body positions by forward kinematics.
import { computeBodyPositions, emptyTrajectory, frameRot, headingAngle, jointAnglesFromRotation, jointRotation, rotationFrom6d, rotationTo6d, wrapAngle } from './kinematics.js';

export function frameLayout(skel) {
  const nj = skel.nb - 1;
  const jointRot = 13;
  const bodyPos = jointRot + 6 * nj;
  return { rootPos: 0, rootRot: 3, rootDelta: 9, yawDelta: 12, jointRot, bodyPos, dim: bodyPos + 3 * nj };
}

/** Features (Float32Array, D·N, frame after frame) of a canonical trajectory with body positions. */
export function encodeFrames(skel, t) {
  const L = frameLayout(skel);
  const D = L.dim, nb = skel.nb, nd = skel.nd;
  const f = new Float32Array(D * t.frames);
  for (let i = 0; i < t.frames; ++i) {
    const o = D * i;
    for (let k = 0; k < 3; ++k) f[o + L.rootPos + k] = t.rootPos[3 * i + k];
    f.set(rotationTo6d(frameRot(t, i)), o + L.rootRot);
    if (i > 0) {
      for (let k = 0; k < 3; ++k) f[o + L.rootDelta + k] = t.rootPos[3 * i + k] - t.rootPos[3 * (i - 1) + k];
      f[o + L.yawDelta] = wrapAngle(headingAngle(frameRot(t, i)) - headingAngle(frameRot(t, i - 1)));
    }
    for (let k = 1; k < nb; ++k) {
      const q0 = nd * i + skel.dofOffset[k];
      f.set(rotationTo6d(jointRotation(t.q[q0], t.q[q0 + 1], t.q[q0 + 2])), o + L.jointRot + 6 * (k - 1));
      for (let c = 0; c < 3; ++c) f[o + L.bodyPos + 3 * (k - 1) + c] = t.bodyPos[3 * nb * i + 3 * k + c];
    }
  }
  for (let i = 0; i < f.length; ++i) if (!Number.isFinite(f[i])) throw new Error(`frame features: value ${i} is not finite`);
  return f;
}

/** Canonical trajectory of N frames from features (D·N). */
export function decodeFrames(skel, f, n, fps = 30) {
  const L = frameLayout(skel);
  const D = L.dim;
  if (f.length !== D * n) throw new Error(`frame features have ${f.length} values, expected ${D}·${n}`);
  for (let i = 0; i < f.length; ++i) if (!Number.isFinite(f[i])) throw new Error(`frame features: value ${i} is not finite`);
  const t = emptyTrajectory(skel, n, fps);
  for (let i = 0; i < n; ++i) {
    const o = D * i;
    for (let k = 0; k < 3; ++k) t.rootPos[3 * i + k] = f[o + L.rootPos + k];
    t.rootRot.set(rotationFrom6d(Array.from(f.subarray(o + L.rootRot, o + L.rootRot + 6))), 4 * i);
    for (let k = 1; k < skel.nb; ++k) {
      const s = o + L.jointRot + 6 * (k - 1);
      const a = jointAnglesFromRotation(rotationFrom6d(Array.from(f.subarray(s, s + 6))));
      t.q.set(a, skel.nd * i + skel.dofOffset[k]);
    }
  }
  return computeBodyPositions(skel, t);
}
