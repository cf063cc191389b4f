// Training logs: JSONL (one JSON object per line) or CSV with a header row. Pure module, unit-tested.

export class LogError extends Error {
  constructor(message) {
    super(message);
    this.name = 'LogError';
  }
}

function parseCsvLine(line) {
  // Simple CSV: comma separated, optional double quotes around a field ("" inside quotes = ").
  const out = [];
  let cur = '';
  let quoted = false;
  for (let i = 0; i < line.length; ++i) {
    const c = line[i];
    if (quoted) {
      if (c === '"' && line[i + 1] === '"') {
        cur += '"';
        ++i;
      } else if (c === '"') quoted = false;
      else cur += c;
    } else if (c === '"') quoted = true;
    else if (c === ',') {
      out.push(cur);
      cur = '';
    } else cur += c;
  }
  out.push(cur);
  return out.map((s) => s.trim());
}

function toNumber(v) {
  if (typeof v === 'number') return Number.isFinite(v) ? v : null;
  if (typeof v === 'boolean') return v ? 1 : 0;
  if (typeof v === 'string' && v.trim() !== '') {
    const x = Number(v);
    return Number.isFinite(x) ? x : null;
  }
  return null;
}

/**
 * Parses a training log. Returns { name, rows, columns: {key: (number|null)[]}, keys: numeric keys }.
 * Rows without an x value get the row index as iteration. Throws LogError (with the line number)
 * on a malformed JSONL line.
 */
export function parseLog(text, name = 'run') {
  const lines = text.split(/\r?\n/).filter((l) => l.trim() !== '');
  const records = [];
  if (lines.length === 0) throw new LogError(`${name}: empty log`);
  const first = lines[0].trim();
  if (first.startsWith('{')) {
    lines.forEach((line, i) => {
      let obj;
      try {
        obj = JSON.parse(line);
      } catch (e) {
        throw new LogError(`${name}:${i + 1}: not a JSON object (${e.message})`);
      }
      if (obj === null || typeof obj !== 'object' || Array.isArray(obj))
        throw new LogError(`${name}:${i + 1}: expected a JSON object per line`);
      records.push(obj);
    });
  } else {
    const header = parseCsvLine(first);
    lines.slice(1).forEach((line, i) => {
      const cells = parseCsvLine(line);
      if (cells.length !== header.length)
        throw new LogError(`${name}:${i + 2}: ${cells.length} fields, header has ${header.length}`);
      const obj = {};
      header.forEach((h, k) => (obj[h] = cells[k]));
      records.push(obj);
    });
  }
  const keySet = new Set();
  for (const r of records) for (const k of Object.keys(r)) keySet.add(k);
  const columns = {};
  const keys = [];
  for (const k of keySet) {
    const col = records.map((r) => (k in r ? toNumber(r[k]) : null));
    if (col.some((x) => x !== null)) {
      columns[k] = col;
      keys.push(k);
    }
  }
  if (!columns.iteration) columns.iteration = records.map((_, i) => i);
  return { name, rows: records.length, columns, keys: keys.filter((k) => k !== 'iteration') };
}

/** Numeric keys present in any of the runs (sorted, 'iteration' excluded). */
export function seriesKeys(runs) {
  const s = new Set();
  for (const r of runs) for (const k of r.keys) s.add(k);
  return [...s].sort();
}

/**
 * uPlot data for one key over several runs: [xs, ys_run0, ys_run1, ...] on the union of the
 * runs' iterations (sorted); a run without a value at some x gets null (a gap).
 */
export function alignSeries(runs, key, xKey = 'iteration') {
  const xs = new Set();
  for (const r of runs) for (const x of r.columns[xKey] ?? []) if (x !== null) xs.add(x);
  const sorted = [...xs].sort((a, b) => a - b);
  const index = new Map(sorted.map((x, i) => [x, i]));
  const data = [sorted];
  for (const r of runs) {
    const ys = new Array(sorted.length).fill(null);
    const xcol = r.columns[xKey] ?? [];
    const ycol = r.columns[key];
    if (ycol) xcol.forEach((x, i) => x !== null && (ys[index.get(x)] = ycol[i]));
    data.push(ys);
  }
  return data;
}

/** Series that are plotted first when logs are opened (those present). */
export const DEFAULT_SERIES = ['return', 'episode_length', 'disc_reward', 'mi_kl', 'samples_per_s'];
