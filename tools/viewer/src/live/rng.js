// The library's random stream (include/maskadapt/core/rng.hpp): xoshiro256++ seeded through
// SplitMix64, uniform = 53 high bits · 2⁻⁵³, standard normals by the Marsaglia polar method with
// the second variate cached. The same seed gives the same numbers as the C++ (checked against
// normals the C++ drew in tools/viewer/tests/tracking.test.js), so the page's generator draws the
// diffusion noise `maskadapt play-residual --seed S` draws. 64-bit arithmetic on BigInt.

const MASK = (1n << 64n) - 1n;
const rotl = (x, k) => ((x << BigInt(k)) | (x >> BigInt(64 - k))) & MASK;

function splitmix64(state) {
  state.x = (state.x + 0x9e3779b97f4a7c15n) & MASK;
  let z = state.x;
  z = ((z ^ (z >> 30n)) * 0xbf58476d1ce4e5b9n) & MASK;
  z = ((z ^ (z >> 27n)) * 0x94d049bb133111ebn) & MASK;
  return z ^ (z >> 31n);
}

export class Rng {
  /** @param seed a non-negative integer (Number or BigInt) */
  constructor(seed = 0x5eed) {
    this.reseed(seed);
  }

  reseed(seed) {
    const st = { x: BigInt.asUintN(64, BigInt(seed)) };
    this.s = [splitmix64(st), splitmix64(st), splitmix64(st), splitmix64(st)];
    this.hasSpare = false;
    this.spare = 0;
  }

  /** Next raw 64-bit value (BigInt). */
  next() {
    const s = this.s;
    const result = (rotl((s[0] + s[3]) & MASK, 23) + s[0]) & MASK;
    const t = (s[1] << 17n) & MASK;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return result;
  }

  /** Uniform in [0, 1) with 53 random bits. */
  uniform() {
    return Number(this.next() >> 11n) * 2 ** -53;
  }

  /** Standard normal (Marsaglia polar method; caches the second variate). */
  normal() {
    if (this.hasSpare) {
      this.hasSpare = false;
      return this.spare;
    }
    let u, v, s;
    do {
      u = 2 * this.uniform() - 1;
      v = 2 * this.uniform() - 1;
      s = u * u + v * v;
    } while (s >= 1 || s === 0);
    const f = Math.sqrt((-2 * Math.log(s)) / s);
    this.spare = v * f;
    this.hasSpare = true;
    return u * f;
  }
}

/** A noise source that replays recorded normals in order (tests); throws when they run out. */
export class ReplayNormals {
  constructor(values) {
    this.values = values;
    this.i = 0;
  }
  normal() {
    if (this.i >= this.values.length) throw new Error(`replayed noise exhausted after ${this.values.length} draws`);
    return this.values[this.i++];
  }
}
