import { describe, expect, it } from 'vitest';
import { alignSeries, LogError, parseLog, seriesKeys } from '../src/logs.js';
import { Player } from '../src/player.js';

const jsonl = [
  '{"iteration": 1, "return": 1.5, "mi_kl": 0.2, "tag": "a"}',
  '{"iteration": 2, "return": 2.5, "mi_kl": null}',
  '',
  '{"iteration": 3, "return": 3.0, "episode_length": 40}',
].join('\n');

describe('training logs', () => {
  it('parses JSONL; non-numeric keys are dropped, missing values are null', () => {
    const run = parseLog(jsonl, 'a.jsonl');
    expect(run.rows).toBe(3);
    expect(run.columns.iteration).toEqual([1, 2, 3]);
    expect(run.columns.return).toEqual([1.5, 2.5, 3.0]);
    expect(run.columns.mi_kl).toEqual([0.2, null, null]);
    expect(run.columns.episode_length).toEqual([null, null, 40]);
    expect(run.keys.sort()).toEqual(['episode_length', 'mi_kl', 'return']);
  });

  it('parses CSV with a header and quoted fields', () => {
    const run = parseLog('iteration,return,"note"\n0,1.0,"x, y"\n1,nan,z\n', 'b.csv');
    expect(run.columns.iteration).toEqual([0, 1]);
    expect(run.columns.return).toEqual([1.0, null]);
    expect(run.keys).toEqual(['return']);
  });

  it('names the line of a malformed log', () => {
    expect(() => parseLog('{"iteration": 1}\n{oops', 'bad.jsonl')).toThrow(/bad\.jsonl:2/);
    expect(() => parseLog('a,b\n1,2,3', 'bad.csv')).toThrow(LogError);
    expect(() => parseLog('  \n', 'empty.jsonl')).toThrow(/empty/);
  });

  it('uses the row index when there is no iteration column', () => {
    expect(parseLog('{"return": 5}\n{"return": 6}').columns.iteration).toEqual([0, 1]);
  });

  it('overlays runs on the union of their iterations', () => {
    const a = parseLog('{"iteration": 0, "return": 1}\n{"iteration": 2, "return": 3}', 'a');
    const b = parseLog('{"iteration": 1, "return": 10, "mi_kl": 0.5}\n{"iteration": 2, "return": 20}', 'b');
    expect(seriesKeys([a, b])).toEqual(['mi_kl', 'return']);
    expect(alignSeries([a, b], 'return')).toEqual([
      [0, 1, 2],
      [1, null, 3],
      [null, 10, 20],
    ]);
    expect(alignSeries([a, b], 'mi_kl')[1]).toEqual([null, null, null]);
  });
});

describe('Player', () => {
  it('advances by wall time × speed and loops at the end', () => {
    const p = new Player();
    p.duration = 2;
    p.tick(1);
    expect(p.time).toBe(0);  // paused
    p.playing = true;
    p.speed = 2;
    p.tick(0.5);
    expect(p.time).toBeCloseTo(1);
    p.tick(0.75);
    expect(p.time).toBeCloseTo(0.5, 6);  // 2.5 wraps to 0.5
    p.loop = false;
    p.tick(5);
    expect(p.time).toBe(2);
    expect(p.playing).toBe(false);
    p.seek(-3);
    expect(p.time).toBe(0);
  });
});
