// Hashed text features (include/maskadapt/tracking/text_encoder.hpp, HashedTextFeatures): the
// prompt's UTF-8 bytes are split into words (runs of ASCII letters/digits, lower-cased; every other
// byte separates), every word unigram "w:<word>" (weight 1) and adjacent bigram "b:<w1> <w2>"
// (weight 0.7) is hashed with 64-bit FNV-1a into one of `dim` buckets with the sign of the hash's
// top bit, and the float vector is L2-normalised. The empty prompt (no word) gives zeros: the
// generator then samples unconditionally.

const FNV_OFFSET = 0xcbf29ce484222325n;
const FNV_PRIME = 0x100000001b3n;
const MASK = (1n << 64n) - 1n;

/** Lower-cased ASCII words of `text` (C's isalnum/tolower on bytes, as the C++). */
export function tokenizeWords(text) {
  const bytes = new TextEncoder().encode(String(text));
  const words = [];
  let cur = '';
  for (const c of bytes) {
    const alnum = (c >= 48 && c <= 57) || (c >= 65 && c <= 90) || (c >= 97 && c <= 122);
    if (alnum) cur += String.fromCharCode(c >= 65 && c <= 90 ? c + 32 : c);
    else if (cur) {
      words.push(cur);
      cur = '';
    }
  }
  if (cur) words.push(cur);
  return words;
}

/** 64-bit FNV-1a of an ASCII string (BigInt). */
export function fnv1a64(s) {
  let h = FNV_OFFSET;
  for (let i = 0; i < s.length; ++i) {
    h ^= BigInt(s.charCodeAt(i) & 0xff);
    h = (h * FNV_PRIME) & MASK;
  }
  return h;
}

/** Hashed features (Float32Array of `dim`) of a prompt. */
export function hashedTextFeatures(text, dim = 256, bigramWeight = 0.7) {
  if (!(Number.isInteger(dim) && dim >= 8)) throw new Error(`hashed text feature dimension must be an integer >= 8, got ${dim}`);
  const v = new Float32Array(dim);
  const bw = Math.fround(bigramWeight);
  const add = (token, w) => {
    const h = fnv1a64(token);
    const bucket = Number(h % BigInt(dim));
    const sign = (h >> 63n) & 1n ? -1 : 1;
    v[bucket] = Math.fround(v[bucket] + Math.fround(sign * w));
  };
  const words = tokenizeWords(text);
  for (let i = 0; i < words.length; ++i) {
    add(`w:${words[i]}`, 1);
    if (i + 1 < words.length) add(`b:${words[i]} ${words[i + 1]}`, bw);
  }
  let sq = 0;
  for (let i = 0; i < dim; ++i) sq += v[i] * v[i];
  const n = Math.fround(Math.sqrt(Math.fround(sq)));
  if (n > 0) for (let i = 0; i < dim; ++i) v[i] = Math.fround(v[i] / n);
  return v;
}
