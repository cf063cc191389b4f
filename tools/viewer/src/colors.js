// Colouring of body parts by the active (adapted) part mask. Pure module, unit-tested.
import { PART_NAMES } from './rollout.js';

/** Colour of a body whose part is not adapted (neutral grey-blue). */
export const BASE_COLOR = '#b8c0cc';
/** Colour of each part when it is adapted/masked, in part order (trunk, left_arm, right_arm, left_leg, right_leg). */
export const PART_COLORS = ['#e6a23c', '#e4572e', '#f28e2b', '#2e86de', '#17a2b8'];
/** Colour of the goal markers (tracking targets). */
export const GOAL_COLOR = '#34c759';
/** Colours of the goal-task scene: location targets (disc + ring on the floor), heading arrows,
 * rigid boxes (the strike box). Hues away from the part colours (the e2e test measures those). */
export const TARGET_COLOR = '#d63384';
export const ARROW_COLOR = '#7048e8';
export const OBJECT_COLOR = '#8a9a5b';

/** Whether part p (0..4) is set in the 5-bit mask. */
export function isPartMasked(mask, partIndex) {
  return ((mask >> partIndex) & 1) === 1;
}

/** Names of the parts set in a mask ("none" when empty), e.g. "left_leg, right_leg". */
export function maskLabel(mask) {
  const names = PART_NAMES.filter((_, p) => isPartMasked(mask, p));
  return names.length ? names.join(', ') : 'none';
}

/** Colour of one body given its part index and the frame's mask. */
export function bodyColor(partIndex, mask) {
  return isPartMasked(mask, partIndex) ? PART_COLORS[partIndex] : BASE_COLOR;
}

/** Colours of every body of `rollout` at frame f (array of '#rrggbb'). */
export function bodyColors(rollout, f) {
  const mask = rollout.numFrames ? rollout.masks[f] : 0;
  return rollout.bodies.map((b) => bodyColor(b.partIndex, mask));
}

/** Legend entries: one per part, with its colour and whether it is adapted in `mask`. */
export function legendEntries(mask) {
  return PART_NAMES.map((name, p) => ({ name, color: PART_COLORS[p], active: isPartMasked(mask, p) }));
}
