// Reader of the library's checkpoint files (include/maskadapt/core/checkpoint.hpp, version 1):
//
//   offset 0   8 bytes  magic "MASKCKPT"
//          8   u32      format version (1)
//         12   u32      number of sections S
//         16   u64      total file size in bytes
//         24   S × section: u32 name length, name bytes, u8 dtype (1 f32, 2 f64, 3 i64, 4 bytes),
//                u8 rank (≤ 8), u16 zero, rank × i64 dims, u64 data byte count, data
//         end−4 u32     CRC-32 (zlib) of every byte before it
//
// Arrays are column-major. Like the C++ reader, the whole file is verified (magic, version, size,
// checksum, every section's bounds) before anything is returned; every error names the file and,
// where there is one, the section.

export const DTYPES = { 1: 'float32', 2: 'float64', 3: 'int64', 4: 'bytes' };
const DTYPE_SIZE = { 1: 4, 2: 8, 3: 8, 4: 1 };

export class CheckpointError extends Error {
  constructor(file, field, message) {
    super(`${file}${field ? ` [${field}]` : ''}: ${message}`);
    this.file = file;
    this.field = field;
  }
}

let crcTable = null;
/** CRC-32 (zlib's polynomial 0xEDB88320) of bytes[0, n). */
export function crc32(bytes, n = bytes.length) {
  if (!crcTable) {
    crcTable = new Uint32Array(256);
    for (let i = 0; i < 256; ++i) {
      let c = i;
      for (let k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
      crcTable[i] = c >>> 0;
    }
  }
  let c = 0xffffffff;
  for (let i = 0; i < n; ++i) c = crcTable[(c ^ bytes[i]) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
}

/**
 * Parses a checkpoint. `buffer`: ArrayBuffer or Uint8Array; `file` labels errors.
 * Returns { file, version, sections: Map(name → { dtype, shape, bytes (Uint8Array view) }) }.
 */
export function parseCheckpoint(buffer, file = 'checkpoint') {
  const bytes = buffer instanceof Uint8Array ? buffer : new Uint8Array(buffer);
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const fail = (msg, field) => {
    throw new CheckpointError(file, field, msg);
  };
  if (bytes.length < 28) fail(`too short for a checkpoint (${bytes.length} bytes)`);
  const magic = String.fromCharCode(...bytes.subarray(0, 8));
  if (magic !== 'MASKCKPT') fail(`not a maskadapt checkpoint (magic '${magic.replace(/[^\x20-\x7e]/g, '?')}', expected 'MASKCKPT')`);
  const version = view.getUint32(8, true);
  if (version !== 1) fail(`unsupported checkpoint format version ${version} (this viewer reads version 1)`);
  const count = view.getUint32(12, true);
  const total = Number(view.getBigUint64(16, true));
  if (total !== bytes.length) fail(`file size is ${bytes.length} bytes, the header says ${total} (truncated or padded)`);
  const stored = view.getUint32(bytes.length - 4, true);
  const actual = crc32(bytes, bytes.length - 4);
  if (stored !== actual) fail(`checksum mismatch (stored ${stored.toString(16)}, computed ${actual.toString(16)}): the file is corrupt`);
  const end = bytes.length - 4;
  let off = 24;
  const need = (n, field) => {
    if (off + n > end) fail(`section runs past the end of the file`, field);
  };
  const sections = new Map();
  for (let s = 0; s < count; ++s) {
    need(4, `section ${s}`);
    const nameLen = view.getUint32(off, true);
    off += 4;
    if (nameLen < 1 || nameLen > 4096) fail(`section name length ${nameLen} out of range`, `section ${s}`);
    need(nameLen, `section ${s}`);
    const name = new TextDecoder().decode(bytes.subarray(off, off + nameLen));
    off += nameLen;
    need(4, name);
    const dtype = bytes[off];
    const rank = bytes[off + 1];
    off += 4;
    if (!DTYPES[dtype]) fail(`unknown dtype ${dtype}`, name);
    if (rank > 8) fail(`rank ${rank} > 8`, name);
    need(8 * rank + 8, name);
    const shape = [];
    let numel = 1;
    for (let r = 0; r < rank; ++r) {
      const d = Number(view.getBigInt64(off, true));
      off += 8;
      if (d < 0) fail(`negative dimension ${d}`, name);
      shape.push(d);
      numel *= d;
    }
    const byteCount = Number(view.getBigUint64(off, true));
    off += 8;
    if (byteCount !== numel * DTYPE_SIZE[dtype]) fail(`byte count ${byteCount} does not match shape [${shape}]`, name);
    need(byteCount, name);
    if (sections.has(name)) fail('duplicate section', name);
    sections.set(name, { dtype: DTYPES[dtype], shape, numel, bytes: bytes.subarray(off, off + byteCount) });
    off += byteCount;
  }
  if (off !== end) fail(`${end - off} unexpected bytes after the last section`);
  return { file, version, sections };
}

function section(ck, name, dtype) {
  const s = ck.sections.get(name);
  if (!s) throw new CheckpointError(ck.file, name, 'missing section');
  if (dtype && s.dtype !== dtype) throw new CheckpointError(ck.file, name, `dtype mismatch: expected ${dtype}, found ${s.dtype}`);
  return s;
}
function copyOut(s, Type) {
  // (section data is not aligned inside the file: copy into an aligned buffer first)
  const aligned = new Uint8Array(s.bytes.length);
  aligned.set(s.bytes);
  return new Type(aligned.buffer);
}

export const has = (ck, name) => ck.sections.has(name);
export function getFloat32(ck, name) {
  return copyOut(section(ck, name, 'float32'), Float32Array);
}
export function getFloat64(ck, name) {
  return copyOut(section(ck, name, 'float64'), Float64Array);
}
export function getInt64(ck, name) {
  return Array.from(copyOut(section(ck, name, 'int64'), BigInt64Array), Number);
}
export function getScalarInt(ck, name) {
  const s = section(ck, name, 'int64');
  if (s.numel !== 1) throw new CheckpointError(ck.file, name, `expected a scalar, found ${s.numel} elements`);
  return getInt64(ck, name)[0];
}
export function getScalarDouble(ck, name) {
  const s = section(ck, name, 'float64');
  if (s.numel !== 1) throw new CheckpointError(ck.file, name, `expected a scalar, found ${s.numel} elements`);
  return getFloat64(ck, name)[0];
}
export function getString(ck, name) {
  return new TextDecoder().decode(section(ck, name, 'bytes').bytes);
}
