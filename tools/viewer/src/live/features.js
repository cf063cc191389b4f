// The observation s, the part masks and the policy input [s̄ ; m], as include/maskadapt computes
// them (motion/observation.hpp, mask/parts.hpp, mask/apply.hpp). tests/live.test.js checks them
// against values the C++ recorded (tests/viewer/live_reference.cpp) to 1e-5.
//
// Body states (one character, nb bodies), world frame, z up:
//   pos (3·nb) body origins (m), rot (4·nb) orientations x,y,z,w, linVel (3·nb) velocity of each
//   body origin (m/s), angVel (3·nb) angular velocity (rad/s).
//
// s has 1 + 3(nb−1) + 12·nb rows, all in the root's heading frame H = R_z(h), h the yaw of the
// root's x axis: [root height | Hᵀ(p_i − p_0), i ≥ 1 | first two columns of Hᵀ R_i, per body |
// Hᵀ v_i | Hᵀ ω_i]. Every element belongs to the part of the body it describes.

export const PART_NAMES = ['trunk', 'left_arm', 'right_arm', 'left_leg', 'right_leg'];
export const NUM_PARTS = 5;

export function observationDim(nb) {
  return 1 + 3 * (nb - 1) + 12 * nb;
}

/** Offsets of the blocks of s. */
export function observationLayout(nb) {
  const rot6d = 1 + 3 * (nb - 1);
  const linVel = rot6d + 6 * nb;
  const angVel = linVel + 3 * nb;
  return { rootHeight: 0, relPos: 1, rot6d, linVel, angVel, dim: angVel + 3 * nb };
}

/** Rotation matrix (row-major 3×3) of the unit quaternion x,y,z,w (normalised first, as Eigen's normalized()). */
export function quatToMatrix(x, y, z, w) {
  const n = Math.sqrt(x * x + y * y + z * z + w * w);
  x /= n;
  y /= n;
  z /= n;
  w /= n;
  // (Eigen's toRotationMatrix)
  const tx = 2 * x, ty = 2 * y, tz = 2 * z;
  const twx = tx * w, twy = ty * w, twz = tz * w;
  const txx = tx * x, txy = ty * x, txz = tz * x;
  const tyy = ty * y, tyz = tz * y, tzz = tz * z;
  return [1 - (tyy + tzz), txy - twz, txz + twy, txy + twz, 1 - (txx + tzz), tyz - twx, txz - twy, tyz + twx, 1 - (txx + tyy)];
}

/** Heading angle of the root rotation: atan2 of its x axis projected on the ground. */
export function headingAngle(rot, b = 0) {
  // x axis of q = first column of R(q) (Eigen's q * UnitX, without normalising q)
  const x = rot[4 * b], y = rot[4 * b + 1], z = rot[4 * b + 2], w = rot[4 * b + 3];
  const ax = 1 - 2 * (y * y + z * z);
  const ay = 2 * (x * y + z * w);
  return Math.atan2(ay, ax);
}

/**
 * Writes s for body states `bs` ({pos, rot, linVel, angVel}, nb bodies) into `out`
 * (Float32Array of observationDim(nb); the C++ computes in double and stores floats). Throws
 * naming the field on non-finite states.
 */
export function computeObservation(bs, nb, out = new Float32Array(observationDim(nb))) {
  const L = observationLayout(nb);
  if (out.length !== L.dim) throw new Error(`observation: output has ${out.length} rows, expected ${L.dim}`);
  for (const key of ['pos', 'linVel', 'angVel', 'rot'])
    for (let i = 0; i < bs[key].length; ++i)
      if (!Number.isFinite(bs[key][i])) throw new Error(`body_states.${key}[${i}] is not finite`);
  const h = headingAngle(bs.rot, 0);
  // H = R_z(h) via Eigen's AngleAxis → quaternion → matrix; Hᵀ rows = H columns.
  const hq = [0, 0, Math.sin(h / 2), Math.cos(h / 2)];
  const H = quatToMatrix(hq[0], hq[1], hq[2], hq[3]);
  const Ht = [H[0], H[3], H[6], H[1], H[4], H[7], H[2], H[5], H[8]];
  const mul = (M, v0, v1, v2) => [M[0] * v0 + M[1] * v1 + M[2] * v2, M[3] * v0 + M[4] * v1 + M[5] * v2, M[6] * v0 + M[7] * v1 + M[8] * v2];
  const p = bs.pos;
  out[L.rootHeight] = p[2];
  for (let i = 1; i < nb; ++i) {
    const r = mul(Ht, p[3 * i] - p[0], p[3 * i + 1] - p[1], p[3 * i + 2] - p[2]);
    out.set(r, L.relPos + 3 * (i - 1));
  }
  for (let i = 0; i < nb; ++i) {
    const R = quatToMatrix(bs.rot[4 * i], bs.rot[4 * i + 1], bs.rot[4 * i + 2], bs.rot[4 * i + 3]);
    // Ht * R, columns 0 and 1
    const c0 = mul(Ht, R[0], R[3], R[6]);
    const c1 = mul(Ht, R[1], R[4], R[7]);
    out.set(c0, L.rot6d + 6 * i);
    out.set(c1, L.rot6d + 6 * i + 3);
    out.set(mul(Ht, bs.linVel[3 * i], bs.linVel[3 * i + 1], bs.linVel[3 * i + 2]), L.linVel + 3 * i);
    out.set(mul(Ht, bs.angVel[3 * i], bs.angVel[3 * i + 1], bs.angVel[3 * i + 2]), L.angVel + 3 * i);
  }
  return out;
}

/** Part index (0..4) of every element of s, from the part index of every body. */
export function observationParts(bodyParts) {
  const nb = bodyParts.length;
  const L = observationLayout(nb);
  const parts = new Uint8Array(L.dim);
  parts[L.rootHeight] = bodyParts[0];
  for (let i = 1; i < nb; ++i) parts.fill(bodyParts[i], L.relPos + 3 * (i - 1), L.relPos + 3 * i);
  for (let i = 0; i < nb; ++i) {
    parts.fill(bodyParts[i], L.rot6d + 6 * i, L.rot6d + 6 * i + 6);
    parts.fill(bodyParts[i], L.linVel + 3 * i, L.linVel + 3 * i + 3);
    parts.fill(bodyParts[i], L.angVel + 3 * i, L.angVel + 3 * i + 3);
  }
  return parts;
}

/** Mask bits (bit p ⇔ part p masked) from part names or groups ("left_leg,right_leg", "arms", "none"). */
export function parseMask(text) {
  let bits = 0;
  for (const raw of String(text).split(',')) {
    const t = raw.trim();
    if (!t) continue;
    const p = PART_NAMES.indexOf(t);
    if (p >= 0) bits |= 1 << p;
    else if (t === 'none') bits |= 0;
    else if (t === 'all') bits |= 31;
    else if (t === 'arms') bits |= 6;
    else if (t === 'legs' || t === 'lower_body') bits |= 24;
    else if (t === 'upper_body') bits |= 7;
    else throw new Error(`mask: unknown body part '${t}' (expected ${PART_NAMES.join(', ')}, arms, legs, upper_body, none, all)`);
  }
  return bits;
}

/** "left_leg,right_leg" / "none", in part order. */
export function maskText(bits) {
  const names = PART_NAMES.filter((_, p) => (bits >> p) & 1);
  return names.length ? names.join(',') : 'none';
}

/** Policy input [(1 − m) ⊙ s ; bits(m)] (Float32Array of s.length + 5). */
export function buildPolicyInput(s, parts, bits, out = new Float32Array(s.length + NUM_PARTS)) {
  if (parts.length !== s.length) throw new Error(`policy input: observation has ${s.length} rows, the part list ${parts.length}`);
  for (let j = 0; j < s.length; ++j) out[j] = (bits >> parts[j]) & 1 ? 0 : s[j];
  for (let p = 0; p < NUM_PARTS; ++p) out[s.length + p] = (bits >> p) & 1;
  return out;
}
