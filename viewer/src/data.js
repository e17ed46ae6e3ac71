// Decodes one scene of the page: the JSON meta block and the base64 binary layer chunks written
// by src/view/view.cpp, merged into the flat arrays the renderer draws (one draw call per kind,
// layers contiguous so a layer range is one draw range).
import { Box3, Vector3 } from 'three';

// Float attributes per path (src/view/encode.cpp, attribute()): mixture[0], mixture[1],
// temperature, speed, width, power, mixture[2] (the mixture deposited), then the commanded
// mixture[0], [1], [2].
export const ATTRS = 10;

// Layer chunks unpacked from a scene's packed block (unpackScenes), by element id.
const unpacked = new Map();

function bytes(id) {
  if (unpacked.has(id)) return unpacked.get(id);
  const el = document.getElementById(id);
  const text = el.textContent.trim();
  if (Uint8Array.fromBase64) return Uint8Array.fromBase64(text);
  const bin = atob(text);
  const out = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; ++i) out[i] = bin.charCodeAt(i);
  return out;
}

// Scenes written packed (src/view/encode.cpp, pack_layers: a notebook view) are inflated and
// turned back into the per-layer chunks decodeScene reads. Resolves at once when there are none.
export async function unpackScenes() {
  for (const el of document.querySelectorAll('script[id$="-pack"]')) {
    const id = el.id.slice(0, -'-pack'.length);
    const stream = new Blob([bytes(el.id)]).stream().pipeThrough(new DecompressionStream('deflate'));
    const layers = unpackLayers(new Uint8Array(await new Response(stream).arrayBuffer()), id);
    layers.forEach((chunk, l) => unpacked.set(`${id}-l${l}`, chunk));
  }
}

function unpackLayers(b, id) {
  if (String.fromCharCode(...b.subarray(0, 4)) !== 'TVP1') throw new Error(`${id}: not a packed scene`);
  const dv = new DataView(b.buffer, b.byteOffset, b.byteLength);
  const quantum = dv.getFloat64(4, true);
  let at = 12;
  const varint = () => {
    let v = 0, scale = 1, c;
    do { c = b[at++]; v += (c & 0x7f) * scale; scale *= 128; } while (c & 0x80);
    return v;
  };
  const zigzag = () => { const v = varint(); return v % 2 ? -(v + 1) / 2 : v / 2; };
  const steps = (n, last, into, from) => {
    for (let k = 0; k < n * 3; ++k) { last[k % 3] += zigzag(); into[from + k] = last[k % 3] * quantum; }
  };
  const lastPoint = [0, 0, 0], lastVia = [0, 0, 0];
  const L = varint(), out = [];
  for (let l = 0; l < L; ++l) {
    const np = varint(), nq = varint(), nv = varint();
    const attrAt = 8 + np * 12 + nq * 4, roleAt = attrAt + nq * ATTRS * 4;
    const viaAt = (roleAt + 3 * nq + 3) & ~3;
    const size = viaAt + 4 + (nv > 0 ? (nq + 1) * 4 + nv * 12 : 0);
    const chunk = new Uint8Array(size), c = new DataView(chunk.buffer);
    c.setUint32(0, np, true);
    c.setUint32(4, nq, true);
    for (let q = 0, first = 0; q < nq; ++q) { c.setUint32(8 + np * 12 + 4 * q, first, true); first += varint(); }
    const pos = new Float32Array(chunk.buffer, 8, np * 3);
    steps(np, lastPoint, pos, 0);
    const attr = new Float32Array(chunk.buffer, attrAt, nq * ATTRS);
    for (let k = 0; k < ATTRS; ++k)
      for (let q = 0; q < nq; ++q, at += 4) attr[q * ATTRS + k] = dv.getFloat32(at, true);
    chunk.set(b.subarray(at, at + 3 * nq), roleAt);  // role, tool and set bytes
    at += 3 * nq;
    c.setUint32(viaAt, nv, true);
    if (nv > 0) {
      for (let q = 0, first = 0; q <= nq; ++q) { c.setUint32(viaAt + 4 + 4 * q, first, true); if (q < nq) first += varint(); }
      steps(nv, lastVia, new Float32Array(chunk.buffer, viaAt + 8 + nq * 4, nv * 3), 0);
    }
    out.push(chunk);
  }
  if (at !== b.length) throw new Error(`${id}: ${b.length - at} bytes left over in the packed scene`);
  return out;
}

export function decodeScene(i) {
  const id = `tv-${i}`;
  const meta = JSON.parse(document.getElementById(`${id}-meta`).textContent);
  const L = meta.layer_z.length;
  const chunks = [];
  let points = 0, paths = 0;
  for (let l = 0; l < L; ++l) {
    const b = bytes(`${id}-l${l}`);
    const u32 = new Uint32Array(b.buffer, b.byteOffset, 2);
    const np = u32[0], nq = u32[1];
    let off = 8;
    const pos = new Float32Array(b.buffer, b.byteOffset + off, np * 3); off += np * 12;
    const first = new Uint32Array(b.buffer, b.byteOffset + off, nq); off += nq * 4;
    const attr = new Float32Array(b.buffer, b.byteOffset + off, nq * ATTRS); off += nq * ATTRS * 4;
    const role = b.subarray(off, off + nq); off += nq;
    const tool = b.subarray(off, off + nq); off += nq;
    const set = b.subarray(off, off + nq); off += nq;  // laser parameter set + 1 (0: none)
    off = (off + 3) & ~3;
    // The corners of the travel into each path (Path::via), if any.
    let viaFirst = null, via = null;
    const nv = off + 4 <= b.length ? new Uint32Array(b.buffer, b.byteOffset + off, 1)[0] : 0;
    off += 4;
    if (nv > 0) {
      viaFirst = new Uint32Array(b.buffer, b.byteOffset + off, nq + 1); off += (nq + 1) * 4;
      via = new Float32Array(b.buffer, b.byteOffset + off, nv * 3);
    }
    chunks.push({ np, nq, pos, first, attr, role, tool, set, viaFirst, via });
    points += np;
    paths += nq;
  }
  const positions = new Float32Array(points * 3);
  const pathFirst = new Uint32Array(paths + 1);
  const pathLayer = new Uint32Array(paths);
  const attr = new Float32Array(paths * ATTRS);
  const role = new Uint8Array(paths), tool = new Uint8Array(paths), set = new Uint8Array(paths);
  // Pieces that continue the previous path's run (the role byte's high bit: no travel between,
  // cut where the mixture, role, tool or temperature changes): not paths of their own in the
  // counts. A path is a run of extrusion between travels, as `trellis analyze` counts them.
  let joined = 0;
  const joinedOf = new Uint8Array(paths);
  const layerSeg = new Uint32Array(L + 1), layerTravel = new Uint32Array(L + 1);
  const viaOf = new Array(paths).fill(null);  // a path's travel corners (Float32Array xyz), if any
  let segments = 0, P = 0, Q = 0;
  for (let l = 0; l < L; ++l) {
    const c = chunks[l];
    positions.set(c.pos, P * 3);
    attr.set(c.attr, Q * ATTRS);
    for (let q = 0; q < c.nq; ++q) {
      role[Q + q] = c.role[q] & 0x7f;
      if (c.role[q] & 0x80) joined += 1, joinedOf[Q + q] = 1;
    }
    tool.set(c.tool, Q);
    set.set(c.set, Q);
    for (let q = 0; q < c.nq; ++q) {
      if (c.via && c.viaFirst[q + 1] > c.viaFirst[q]) viaOf[Q + q] = c.via.subarray(3 * c.viaFirst[q], 3 * c.viaFirst[q + 1]);
      pathFirst[Q + q] = P + c.first[q];
      pathLayer[Q + q] = l;
      const end = q + 1 < c.nq ? c.first[q + 1] : c.np;
      segments += Math.max(0, end - c.first[q] - 1);
    }
    P += c.np;
    Q += c.nq;
    layerSeg[l + 1] = segments;
  }
  pathFirst[paths] = points;
  const index = new Uint32Array(segments * 2);
  let k = 0, extruded = 0;
  for (let q = 0; q < paths; ++q)
    for (let v = pathFirst[q]; v + 1 < pathFirst[q + 1]; ++v) {
      index[k++] = v;
      index[k++] = v + 1;
      const dx = positions[3 * v + 3] - positions[3 * v], dy = positions[3 * v + 4] - positions[3 * v + 1],
        dz = positions[3 * v + 5] - positions[3 * v + 2];
      extruded += Math.sqrt(dx * dx + dy * dy + dz * dz);
    }
  const lod = lodIndex(pathFirst, pathLayer, paths, L, segments);
  // Travel: from each path's last point through its travel corners (if any) to the next path's
  // first point, in print order; one travel move per path, drawn as segments.
  const travelList = [];  // segment ends, xyz
  let travelLength = 0, travelMoves = 0, t = 0;
  for (let q = 1; q < paths; ++q) {
    const a = (pathFirst[q] - 1) * 3, b = pathFirst[q] * 3;
    const pts = [positions.subarray(a, a + 3)];
    const v = viaOf[q];
    if (v) for (let j = 0; j < v.length; j += 3) pts.push(v.subarray(j, j + 3));
    pts.push(positions.subarray(b, b + 3));
    let moved = false;
    for (let j = 1; j < pts.length; ++j) {
      const p0 = pts[j - 1], p1 = pts[j];
      const dx = p1[0] - p0[0], dy = p1[1] - p0[1], dz = p1[2] - p0[2];
      // Length in XY, as `trellis analyze` reports travel (a Z hop adds nothing).
      if (dx * dx + dy * dy + dz * dz > 1e-18) { travelList.push(p0, p1); travelLength += Math.sqrt(dx * dx + dy * dy); moved = true; }
    }
    if (moved) ++travelMoves;
    while (t < pathLayer[q]) layerTravel[++t] = travelList.length / 2;
  }
  while (t < L) layerTravel[++t] = travelList.length / 2;
  const travel = new Float32Array(travelList.length * 3);
  for (let j = 0; j < travelList.length; ++j) travel.set(travelList[j], j * 3);
  const bbox = new Box3();
  const v = new Vector3();
  for (let j = 0; j < positions.length; j += 3) bbox.expandByPoint(v.set(positions[j], positions[j + 1], positions[j + 2]));
  let design = null;
  const del = document.getElementById(`${id}-design`);
  if (del) {
    const b = bytes(`${id}-design`);
    const n = new Uint32Array(b.buffer, b.byteOffset, 1)[0];
    const dpos = new Float32Array(b.buffer, b.byteOffset + 4, n * 6).slice();
    const flag = b.subarray(4 + n * 24, 4 + n * 25);
    const colors = new Uint8Array(n * 6);
    for (let e = 0; e < n; ++e) {
      const c = flag[e] ? [220, 30, 30] : [120, 120, 135];
      colors.set(c, 6 * e);
      colors.set(c, 6 * e + 3);
    }
    for (let j = 0; j < dpos.length; j += 3) bbox.expandByPoint(v.set(dpos[j], dpos[j + 1], dpos[j + 2]));
    design = { positions: dpos, colors, lines: n, flag: flag.slice() };
  }
  // Extras: deviation from the design per point, collisions (path, segment, point).
  let deviation = null, hits = [];
  if (document.getElementById(`${id}-extras`)) {
    const b = bytes(`${id}-extras`);
    const dv = new DataView(b.buffer, b.byteOffset, b.byteLength);
    const n = dv.getUint32(0, true);
    if (n) deviation = new Float32Array(b.buffer.slice(b.byteOffset + 4, b.byteOffset + 4 + 4 * n));
    let off = 4 + 4 * n;
    const h = dv.getUint32(off, true); off += 4;
    for (let j = 0; j < h; ++j, off += 20)
      hits.push({ path: dv.getInt32(off, true), segment: dv.getInt32(off + 4, true),
        point: [dv.getFloat32(off + 8, true), dv.getFloat32(off + 12, true), dv.getFloat32(off + 16, true)] });
    if (deviation && deviation.length !== points) throw new Error(`scene ${i}: ${deviation.length} deviations for ${points} points`);
    for (const hit of hits) bbox.expandByPoint(v.set(...hit.point));
  }
  if (bbox.isEmpty()) bbox.set(new Vector3(0, 0, 0), new Vector3(1, 1, 1));
  return {
    meta, layerCount: L, positions, pathFirst, pathLayer, pathCount: paths, attr, role, tool, set, joinedOf, index,
    layerSeg, layerTravel, travel, bbox, design, lod, deviation, hits,
    stats: { layers: L, paths: paths - joined, segments, points, extruded, travelMoves, travelLength,
      designLines: design ? design.lines : 0, designFlagged: design ? flaggedCount(design) : 0,
      collisions: meta.checked ? meta.collisions : null, ringed: hits.length },
  };
}

// While the view moves, large files are drawn from a reduced index of about LOD_BUDGET segments:
// every k-th segment and the first and last of every path, so what is drawn keeps the shape of
// the part (software WebGL is bound by the pixels the lines cover, so the segments are kept short
// rather than merged); the full index is drawn once the view rests. Null for small files.
export const LOD_BUDGET = 40000;

function lodIndex(pathFirst, pathLayer, paths, L, segments) {
  if (segments <= LOD_BUDGET) return null;
  const k = Math.ceil(segments / LOD_BUDGET);
  const out = new Uint32Array(Math.ceil(segments / k) * 2 + paths * 4 + 2);
  const layerSeg = new Uint32Array(L + 1);
  let n = 0, layer = 0, c = 0;
  for (let q = 0; q < paths; ++q) {
    while (layer < pathLayer[q]) layerSeg[++layer] = n / 2;
    const a = pathFirst[q], b = pathFirst[q + 1] - 1;
    for (let v = a; v < b; ++v, ++c)
      if (c % k === 0 || v === a || v === b - 1) { out[n++] = v; out[n++] = v + 1; }
  }
  while (layer < L) layerSeg[++layer] = n / 2;
  return { index: out.slice(0, n), layerSeg, step: k };
}

function flaggedCount(design) {
  let n = 0;
  for (const f of design.flag) if (f) n += 1;
  return n;
}
