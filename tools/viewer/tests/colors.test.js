import { describe, expect, it } from 'vitest';
import { BASE_COLOR, PART_COLORS, bodyColor, bodyColors, isPartMasked, legendEntries, maskLabel } from '../src/colors.js';
import { PART_NAMES, parseRollout } from '../src/rollout.js';
import { tinyRollout } from './fixtures.js';

describe('mask colouring', () => {
  it('decodes the 5-bit mask in part order', () => {
    const legs = (1 << 3) | (1 << 4);
    expect(PART_NAMES.map((_, p) => isPartMasked(legs, p))).toEqual([false, false, false, true, true]);
    expect(maskLabel(legs)).toBe('left_leg, right_leg');
    expect(maskLabel(0)).toBe('none');
    expect(maskLabel(31)).toBe(PART_NAMES.join(', '));
  });

  it('gives every part a distinct colour, different from the unmasked colour', () => {
    expect(new Set([...PART_COLORS, BASE_COLOR]).size).toBe(6);
  });

  it('colours a body by its part only when that part is masked', () => {
    for (let mask = 0; mask < 32; ++mask)
      for (let p = 0; p < 5; ++p) expect(bodyColor(p, mask)).toBe((mask >> p) & 1 ? PART_COLORS[p] : BASE_COLOR);
  });

  it('colours the bodies of a rollout per frame', () => {
    const r = parseRollout(tinyRollout());
    expect(bodyColors(r, 0)).toEqual([BASE_COLOR, BASE_COLOR]);
    expect(bodyColors(r, 2)).toEqual([BASE_COLOR, PART_COLORS[1]]);  // left arm adapted
  });

  it('builds legend entries with the active parts', () => {
    const entries = legendEntries(0b00110);
    expect(entries.map((e) => e.active)).toEqual([false, true, true, false, false]);
    expect(entries[1]).toEqual({ name: 'left_arm', color: PART_COLORS[1], active: true });
  });
});
