// Colours of the viewer: categorical palettes (feature type, tool) and the continuous maps of the
// colour bar. The same functions colour the model and draw the bar, so a segment's colour can be
// looked up on the bar.

// Indexed by PathRole (toolpath.hpp): strut, contour, handle, perimeter, infill, other, skin, purge.
export const ROLE_COLORS = [
  [31, 119, 180], [214, 39, 40], [148, 103, 189], [255, 127, 14], [44, 160, 44], [127, 127, 127], [227, 119, 194],
  [188, 189, 34],
];
export const TOOL_COLORS = [
  [31, 119, 180], [255, 127, 14], [44, 160, 44], [214, 39, 40], [148, 103, 189], [140, 86, 75], [23, 190, 207], [188, 189, 34],
];
export const NO_VALUE = [170, 170, 170];
// Two materials: material 2 (fraction 0) to material 1 (fraction 1).
export const MIX_A = [230, 110, 20];
export const MIX_B = [20, 90, 220];

// Three materials: the colours of materials 1, 2, 3 at the corners of the mixture triangle; a
// mixture is their barycentric blend.
export const MIX3 = [MIX_B, MIX_A, [40, 170, 60]];
export function mix3Color(w) {
  return [0, 1, 2].map((i) => Math.round(w[0] * MIX3[0][i] + w[1] * MIX3[1][i] + w[2] * MIX3[2][i]));
}
// Collisions mode: the colliding segment and ring, and a path without collisions.
export const COLLIDING = [220, 20, 60];
export const CLEAN = [200, 204, 212];

const STOPS = [
  [0.0, [48, 18, 59]], [0.15, [65, 105, 225]], [0.35, [27, 207, 212]], [0.5, [97, 252, 108]],
  [0.65, [210, 233, 53]], [0.82, [254, 155, 45]], [1.0, [180, 20, 20]],
];

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
