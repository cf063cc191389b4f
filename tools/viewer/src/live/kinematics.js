// Kinematics of the reference humanoid for the generator and the tracking goals, as the C++ does it
// (include/maskadapt/motion/skeleton.hpp forward_kinematics / joint_rotation /
// joint_angles_from_rotation, motion/observation.hpp heading_angle, motion/rotation.hpp
// wrap_angle, tracking/generator.hpp Trajectory / HeadingFrame / canonicalize, and Eigen's
// quaternion ⇄ matrix conversions). Quaternions are arrays [x, y, z, w]; world z up; metres,
// radians.
//
// Skeleton (tracking_humanoid.json's `skeleton`): names, parents (−1 for the root; parents
// precede children), offsets[i] = joint position in the parent frame at q = 0, dof_offset[i] =
// first of body i's three hinges about its local x, y, z (R = R_x R_y R_z).
//
// Trajectory: { frames: N, fps, rootPos: Float64Array(3N), rootRot: Float64Array(4N) (x,y,z,w),
// q: Float64Array(nd·N), bodyPos: Float64Array(3·nb·N) } — column-major like the C++ matrices
// (frame i's values are contiguous).

export function makeSkeleton(desc) {
  const { names, parents, offsets, dof_offset: dofOffset } = desc;
  const nb = names.length;
  if (!Array.isArray(parents) || parents.length !== nb) throw new Error(`skeleton: parents must have ${nb} entries`);
  if (!Array.isArray(offsets) || offsets.length !== nb) throw new Error(`skeleton: offsets must have ${nb} entries`);
  if (!Array.isArray(dofOffset) || dofOffset.length !== nb) throw new Error(`skeleton: dof_offset must have ${nb} entries`);
  if (desc.hinges !== 'xyz') throw new Error(`skeleton: hinges '${desc.hinges}': the page's generator needs x-y-z hinges`);
  for (let i = 1; i < nb; ++i) {
    if (!(parents[i] >= 0 && parents[i] < i)) throw new Error(`skeleton: body ${i} ('${names[i]}') has parent ${parents[i]}`);
    if (dofOffset[i] !== 3 * (i - 1)) throw new Error(`skeleton: body ${i} ('${names[i]}') has dof_offset ${dofOffset[i]}, expected ${3 * (i - 1)}`);
  }
  return { names: names.slice(), parents: parents.slice(), offsets: offsets.map((o) => o.slice()), dofOffset: dofOffset.slice(), nb, nd: 3 * (nb - 1) };
}

export function emptyTrajectory(skel, n, fps = 30) {
  const rootRot = new Float64Array(4 * n);
  for (let i = 0; i < n; ++i) rootRot[4 * i + 3] = 1;
  return { frames: n, fps, rootPos: new Float64Array(3 * n), rootRot, q: new Float64Array(skel.nd * n), bodyPos: new Float64Array(3 * skel.nb * n) };
}

/** A trajectory from the JSON the C++ writes (trajectory_json). */
export function trajectoryFromJson(skel, j, fps = 30) {
  const n = j.frames;
  const t = emptyTrajectory(skel, n, fps);
  const take = (key, dst) => {
    if (!Array.isArray(j[key]) || j[key].length !== dst.length) throw new Error(`trajectory: field '${key}' must have ${dst.length} numbers`);
    for (let i = 0; i < dst.length; ++i) {
      if (!Number.isFinite(j[key][i])) throw new Error(`trajectory: field '${key}[${i}]' is not finite`);
      dst[i] = j[key][i];
    }
  };
  take('root_pos', t.rootPos);
  take('root_rot_xyzw', t.rootRot);
  take('q', t.q);
  if (j.body_pos) take('body_pos', t.bodyPos);
  else computeBodyPositions(skel, t);
  return t;
}

export function sliceTrajectory(skel, t, begin, n) {
  if (!(begin >= 0 && n >= 0 && begin + n <= t.frames)) throw new Error('trajectory slice out of range');
  const nd = skel.nd, nb = skel.nb;
  return {
    frames: n,
    fps: t.fps,
    rootPos: t.rootPos.slice(3 * begin, 3 * (begin + n)),
    rootRot: t.rootRot.slice(4 * begin, 4 * (begin + n)),
    q: t.q.slice(nd * begin, nd * (begin + n)),
    bodyPos: t.bodyPos.slice(3 * nb * begin, 3 * nb * (begin + n)),
  };
}

export function appendTrajectory(skel, a, b) {
  const cat = (x, y) => {
    const o = new Float64Array(x.length + y.length);
    o.set(x, 0);
    o.set(y, x.length);
    return o;
  };
  return { frames: a.frames + b.frames, fps: a.fps, rootPos: cat(a.rootPos, b.rootPos), rootRot: cat(a.rootRot, b.rootRot), q: cat(a.q, b.q), bodyPos: cat(a.bodyPos, b.bodyPos) };
}

// ---- quaternions (x, y, z, w), Eigen's formulas ---------------------------------------------
export function quatMul(a, b) {
  const [ax, ay, az, aw] = a;
  const [bx, by, bz, bw] = b;
  return [aw * bx + ax * bw + ay * bz - az * by, aw * by + ay * bw + az * bx - ax * bz, aw * bz + az * bw + ax * by - ay * bx, aw * bw - ax * bx - ay * by - az * bz];
}
export const quatConj = (q) => [-q[0], -q[1], -q[2], q[3]];
export function quatNormalized(q) {
  const n = Math.hypot(q[0], q[1], q[2], q[3]);
  return n > 0 ? [q[0] / n, q[1] / n, q[2] / n, q[3] / n] : q.slice();
}
/** Rotation about a unit axis (Eigen's Quaternion(AngleAxis)). */
export function quatAxisAngle(angle, ax, ay, az) {
  const s = Math.sin(0.5 * angle);
  return [ax * s, ay * s, az * s, Math.cos(0.5 * angle)];
}
/** q · v (Eigen: v + 2w (u × v) + 2 u × (u × v), without normalising q). */
export function quatRotate(q, v) {
  const [x, y, z, w] = q;
  let ux = y * v[2] - z * v[1], uy = z * v[0] - x * v[2], uz = x * v[1] - y * v[0];
  ux += ux;
  uy += uy;
  uz += uz;
  return [v[0] + w * ux + (y * uz - z * uy), v[1] + w * uy + (z * ux - x * uz), v[2] + w * uz + (x * uy - y * ux)];
}
/** Row-major 3×3 rotation matrix of q (normalised first). */
export function quatToMatrix(q) {
  const [x, y, z, w] = quatNormalized(q);
  const tx = 2 * x, ty = 2 * y, tz = 2 * z;
  const twx = tx * w, twy = ty * w, twz = tz * w, txx = tx * x, txy = ty * x, txz = tz * x, tyy = ty * y, tyz = tz * y, tzz = tz * z;
  return [1 - (tyy + tzz), txy - twz, txz + twy, txy + twz, 1 - (txx + tzz), tyz - twx, txz - twy, tyz + twx, 1 - (txx + tyy)];
}
/** Quaternion of a row-major rotation matrix (Eigen's algorithm), normalised. */
export function matrixToQuat(m) {
  const at = (r, c) => m[3 * r + c];
  const q = [0, 0, 0, 0];
  const tr = at(0, 0) + at(1, 1) + at(2, 2);
  if (tr > 0) {
    let t = Math.sqrt(tr + 1);
    q[3] = 0.5 * t;
    t = 0.5 / t;
    q[0] = (at(2, 1) - at(1, 2)) * t;
    q[1] = (at(0, 2) - at(2, 0)) * t;
    q[2] = (at(1, 0) - at(0, 1)) * t;
  } else {
    let i = 0;
    if (at(1, 1) > at(0, 0)) i = 1;
    if (at(2, 2) > at(i, i)) i = 2;
    const j = (i + 1) % 3, k = (j + 1) % 3;
    let t = Math.sqrt(at(i, i) - at(j, j) - at(k, k) + 1);
    q[i] = 0.5 * t;
    t = 0.5 / t;
    q[3] = (at(k, j) - at(j, k)) * t;
    q[j] = (at(j, i) + at(i, j)) * t;
    q[k] = (at(k, i) + at(i, k)) * t;
  }
  return quatNormalized(q);
}

/** R_x(a) R_y(b) R_z(c): the humanoid's joint rotation from its three hinge angles. */
export function jointRotation(a, b, c) {
  return quatMul(quatMul(quatAxisAngle(a, 1, 0, 0), quatAxisAngle(b, 0, 1, 0)), quatAxisAngle(c, 0, 0, 1));
}

/** Inverse of jointRotation: (a, b, c) with b ∈ [−π/2, π/2]. */
export function jointAnglesFromRotation(q) {
  const R = quatToMatrix(q);
  const sb = Math.min(1, Math.max(-1, R[2]));
  const b = Math.asin(sb);
  if (Math.abs(sb) < 1 - 1e-12) return [Math.atan2(-R[5], R[8]), b, Math.atan2(-R[1], R[0])];
  return [Math.atan2(R[7], R[4]), b, 0];
}

/** Yaw of the x axis of q projected on the ground (rad). */
export function headingAngle(q) {
  const x = quatRotate(q, [1, 0, 0]);
  return Math.atan2(x[1], x[0]);
}
export const headingRotation = (q) => quatAxisAngle(headingAngle(q), 0, 0, 1);

/** Wraps an angle to (−π, π] (std::remainder). */
export function wrapAngle(a) {
  if (a > -Math.PI && a <= Math.PI) return a;
  const twoPi = 2 * Math.PI;
  let r = a - twoPi * Math.round(a / twoPi);
  // (std::remainder rounds halfway cases to even; Math.round rounds them up — only exact odd multiples of π differ)
  if (r <= -Math.PI) r += twoPi;
  if (r > Math.PI) r -= twoPi;
  return r;
}

/** First two columns of the rotation matrix of q (x axis, then y axis). */
export function rotationTo6d(q) {
  const R = quatToMatrix(q);
  return [R[0], R[3], R[6], R[1], R[4], R[7]];
}

/** Gram–Schmidt of a 6-vector back to a rotation (tracking/frame_features.hpp rotation_from_6d). */
export function rotationFrom6d(v) {
  let a = [v[0], v[1], v[2]];
  let b = [v[3], v[4], v[5]];
  const na = Math.hypot(...a);
  if (!(na > 1e-9)) a = [1, 0, 0];
  else a = a.map((x) => x / na);
  const d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  b = [b[0] - d * a[0], b[1] - d * a[1], b[2] - d * a[2]];
  const nb = Math.hypot(...b);
  if (!(nb > 1e-9)) b = unitOrthogonal(a);
  else b = b.map((x) => x / nb);
  const c = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  return matrixToQuat([a[0], b[0], c[0], a[1], b[1], c[1], a[2], b[2], c[2]]);
}

/** Eigen's unitOrthogonal for a 3-vector. */
function unitOrthogonal(v) {
  const eps = 1e-12;  // (Eigen: isMuchSmallerThan with the type's precision)
  if (!(Math.abs(v[0]) <= eps * Math.abs(v[2])) || !(Math.abs(v[1]) <= eps * Math.abs(v[2]))) {
    const inv = 1 / Math.hypot(v[0], v[1]);
    return [-v[1] * inv, v[0] * inv, 0];
  }
  const inv = 1 / Math.hypot(v[1], v[2]);
  return [0, -v[2] * inv, v[1] * inv];
}

/** Body world positions (3·nb) of one frame: root pos, root rot (x,y,z,w), joint angles q (nd) at qOff. */
export function forwardPositions(skel, rootPos, rootRot, q, qOff, out, outOff) {
  const nb = skel.nb;
  const rots = new Array(nb);
  rots[0] = quatNormalized(rootRot);
  out[outOff] = rootPos[0];
  out[outOff + 1] = rootPos[1];
  out[outOff + 2] = rootPos[2];
  for (let i = 1; i < nb; ++i) {
    const p = skel.parents[i];
    const Rp = rots[p];
    const o = quatRotate(Rp, skel.offsets[i]);
    for (let k = 0; k < 3; ++k) out[outOff + 3 * i + k] = out[outOff + 3 * p + k] + o[k];
    const k0 = qOff + skel.dofOffset[i];
    let r = quatMul(Rp, quatAxisAngle(q[k0], 1, 0, 0));
    r = quatMul(r, quatAxisAngle(q[k0 + 1], 0, 1, 0));
    r = quatMul(r, quatAxisAngle(q[k0 + 2], 0, 0, 1));
    rots[i] = r;
  }
  return out;
}

/** Fills t.bodyPos by forward kinematics. */
export function computeBodyPositions(skel, t) {
  for (let i = 0; i < t.frames; ++i)
    forwardPositions(skel, t.rootPos.subarray(3 * i, 3 * i + 3), Array.from(t.rootRot.subarray(4 * i, 4 * i + 4)), t.q, skel.nd * i, t.bodyPos, 3 * skel.nb * i);
  return t;
}

export const frameRot = (t, i) => Array.from(t.rootRot.subarray(4 * i, 4 * i + 4));

/** Heading frame of frame i of t: origin (x, y, 0) below the root, yaw of its heading. */
export function headingFrameOf(t, i) {
  return { origin: [t.rootPos[3 * i], t.rootPos[3 * i + 1], 0], yaw: headingAngle(frameRot(t, i)) };
}

function transform(skel, t, f, toLocal) {
  const o = { ...t, rootPos: t.rootPos.slice(), rootRot: t.rootRot.slice(), q: t.q.slice(), bodyPos: t.bodyPos.slice() };
  const Rq = quatAxisAngle(f.yaw, 0, 0, 1);
  const M = quatToMatrix(toLocal ? quatConj(Rq) : Rq);
  const apply = (src, dst, off) => {
    let x = src[off], y = src[off + 1], z = src[off + 2];
    if (toLocal) {
      x -= f.origin[0];
      y -= f.origin[1];
      z -= f.origin[2];
    }
    dst[off] = M[0] * x + M[1] * y + M[2] * z + (toLocal ? 0 : f.origin[0]);
    dst[off + 1] = M[3] * x + M[4] * y + M[5] * z + (toLocal ? 0 : f.origin[1]);
    dst[off + 2] = M[6] * x + M[7] * y + M[8] * z + (toLocal ? 0 : f.origin[2]);
  };
  const nbRows = t.bodyPos.length / (3 * t.frames);
  for (let i = 0; i < t.frames; ++i) {
    apply(t.rootPos, o.rootPos, 3 * i);
    const r = quatNormalized(quatMul(toLocal ? quatConj(Rq) : Rq, frameRot(t, i)));
    o.rootRot.set(r, 4 * i);
    for (let k = 0; k < nbRows; ++k) apply(t.bodyPos, o.bodyPos, 3 * (i * nbRows + k));
  }
  return o;
}
export const transformToLocal = (skel, t, f) => transform(skel, t, f, true);
export const transformToWorld = (skel, t, f) => transform(skel, t, f, false);

/** The trajectory in the heading frame of its frame `ref`, and that frame. */
export function canonicalize(skel, t, ref = 0) {
  const f = headingFrameOf(t, ref);
  return { local: transformToLocal(skel, t, f), frame: f };
}
