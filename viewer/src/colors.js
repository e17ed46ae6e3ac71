// Colours of the viewer: categorical palettes (feature type, tool) and the continuous maps of the
// colour bar, all from the one table the PNG renderer draws with too (src/render/palette.json,
// read in C++ by render/palette.hpp), so a PNG and the viewer agree byte for byte. The same
// functions colour the model and draw the bar, so a segment's colour can be looked up on the bar.
import palette from '../../src/render/palette.json';

// Indexed by PathRole (toolpath.hpp), names and colours in enum order.
export const ROLE_NAMES = palette.roles.map((r) => r[0]);
export const ROLE_COLORS = palette.roles.map((r) => r[1]);
export const TOOL_COLORS = palette.tools;
export const NO_VALUE = palette.no_value;
// Two materials: fraction of material 1 from 0 (MIX_A) to 1 (MIX_B).
export const [MIX_A, MIX_B] = palette.mixture2;

// Three materials: the colours of materials 1, 2, 3 at the corners of the mixture triangle; a
// mixture is their barycentric blend.
export const MIX3 = palette.mixture3;
export function mix3Color(w) {
  return [0, 1, 2].map((i) => Math.round(w[0] * MIX3[0][i] + w[1] * MIX3[1][i] + w[2] * MIX3[2][i]));
}
// Collisions mode: the colliding segment and ring, and a path without collisions.
export const COLLIDING = [220, 20, 60];
export const CLEAN = [200, 204, 212];

const STOPS = palette.continuous;

function lerp(a, b, t) {
  return [0, 1, 2].map((i) => Math.round(a[i] + (b[i] - a[i]) * t));
}

export function colorMap(t) {
  t = Math.min(1, Math.max(0, t));
  for (let i = 1; i < STOPS.length; ++i)
    if (t <= STOPS[i][0]) return lerp(STOPS[i - 1][1], STOPS[i][1], (t - STOPS[i - 1][0]) / (STOPS[i][0] - STOPS[i - 1][0]));
  return STOPS[STOPS.length - 1][1];
}

export function mixColor(t) {
  return lerp(MIX_A, MIX_B, Math.min(1, Math.max(0, t)));
}
