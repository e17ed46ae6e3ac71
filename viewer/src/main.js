// Trellis viewer: reads the scenes the page carries (binary layer chunks, see
// src/view/view.cpp for the layout), draws them with three.js and answers the controls.
// window.trellisViewer is the page's API for tests and notebooks.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { decodeScene, unpackScenes, ATTRS } from './data.js';
import { colorMap, ROLE_COLORS, TOOL_COLORS, NO_VALUE, mixColor, mix3Color, MIX3, CLEAN, COLLIDING } from './colors.js';

const $ = (id) => document.getElementById(id);
const REFINE_CHUNK = 100000;  // segments added per frame while refining a large file

const MODES = {
  feature: { kind: 'category', title: 'Feature type' },
  tool: { kind: 'category', title: 'Tool' },
  set: { kind: 'category', title: 'Laser parameter set' },
  mixture: { kind: 'mixture', title: 'Mixture as deposited: fraction of material 1', unit: '', attr: 0 },
  commanded: { kind: 'mixture', title: 'Mixture as commanded: fraction of material 1', unit: '', attr: 7 },
  temperature: { kind: 'range', title: 'Nozzle temperature', unit: '°C', attr: 2 },
  speed: { kind: 'range', title: 'Speed', unit: 'mm/s', attr: 3 },
  width: { kind: 'range', title: 'Bead width', unit: 'mm', attr: 4 },
  order: { kind: 'range', title: 'Print order (path number)', unit: '' },
  power: { kind: 'range', title: 'Laser power', unit: 'W', attr: 5 },
  collisions: { kind: 'collisions', title: 'Collisions (nozzle replayed against the design)' },
  deviation: { kind: 'range', title: 'Deviation from the design', unit: 'mm', perPoint: true },
};

class Viewer {
  constructor() {
    const index = JSON.parse($('tv-index').textContent);
    this.title = index.title;
    this.t0 = performance.now();
    this.scenes = [];
    for (let i = 0; i < index.scenes; ++i) this.scenes.push(decodeScene(i));
    this.decodeMs = performance.now() - this.t0;
    this.canvas = $('tv-canvas');
    this.renderer = new THREE.WebGLRenderer({ canvas: this.canvas, antialias: false, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(1);
    // Colours go to the screen as they are, so a segment's pixel equals its colour on the bar.
    this.renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
    this.renderer.setClearColor(new THREE.Color().setRGB(0xf4 / 255, 0xf5 / 255, 0xf7 / 255, THREE.LinearSRGBColorSpace));
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(35, 1, 0.01, 1e6);
    this.camera.up.set(0, 0, 1);
    this.controls = new OrbitControls(this.camera, this.canvas);
    this.controls.addEventListener('change', () => this.requestRender());
    this.mode = 'feature';
    this.current = -1;
    this.showTravel = false;
    this.showDesign = true;
    this.playing = null;
    this.buildUi();
    window.addEventListener('resize', () => this.resize());
    this.resize();
    this.select(0);
    this.loadMs = performance.now() - this.t0;
  }

  buildUi() {
    $('tv-title').textContent = this.title;
    const sel = $('tv-scene');
    this.scenes.forEach((s, i) => {
      const o = document.createElement('option');
      o.value = i;
      o.textContent = `${s.meta.name} (${s.meta.kind})`;
      sel.appendChild(o);
    });
    if (this.scenes.length < 2) $('tv-scene-row').style.display = 'none';
    sel.addEventListener('change', () => this.select(Number(sel.value)));
    $('tv-mode').addEventListener('change', () => this.setMode($('tv-mode').value));
    $('tv-fit').addEventListener('click', () => this.view('fit'));
    $('tv-top').addEventListener('click', () => this.view('top'));
    $('tv-front').addEventListener('click', () => this.view('front'));
    $('tv-iso').addEventListener('click', () => this.view('iso'));
    const range = () => this.setLayers(Number($('tv-layer-lo').value), Number($('tv-layer-hi').value));
    $('tv-layer-lo').addEventListener('input', range);
    $('tv-layer-hi').addEventListener('input', range);
    $('tv-single').addEventListener('change', range);
    $('tv-travel').addEventListener('change', () => this.setTravel($('tv-travel').checked));
    $('tv-design').addEventListener('change', () => { this.showDesign = $('tv-design').checked; this.applyRange(); });
    $('tv-play').addEventListener('click', () => this.play());
    $('tv-bed').addEventListener('change', () => { if (this.bed) this.bed.visible = $('tv-bed').checked; this.requestRender(); });
  }

  resize() {
    const w = window.innerWidth, h = window.innerHeight;
    this.renderer.setSize(w, h, false);
    this.canvas.style.width = w + 'px';
    this.canvas.style.height = h + 'px';
    this.camera.aspect = w / Math.max(1, h);
    this.camera.updateProjectionMatrix();
    this.requestRender();
  }

  select(i) {
    if (i === this.current) return;
    for (const obj of [this.lines, this.lod, this.travel, this.design, this.rings, this.hitLines, this.bed]) {
      if (!obj) continue;
      this.scene.remove(obj);
      obj.geometry.dispose();
    }
    this.current = i;
    const s = this.scenes[i];
    this.s = s;
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(s.positions, 3));
    this.colors = new Uint8Array(s.positions.length);
    g.setAttribute('color', new THREE.BufferAttribute(this.colors, 3, true));
    g.setIndex(new THREE.BufferAttribute(s.index, 1));
    g.boundingBox = s.bbox.clone();
    g.boundingSphere = s.bbox.getBoundingSphere(new THREE.Sphere());
    const material = new THREE.LineBasicMaterial({ vertexColors: true });
    this.lines = new THREE.LineSegments(g, material);
    this.lines.frustumCulled = false;
    this.scene.add(this.lines);
    this.lod = null;
    if (s.lod) {
      const lg = new THREE.BufferGeometry();
      lg.setAttribute('position', g.attributes.position);
      lg.setAttribute('color', g.attributes.color);
      lg.setIndex(new THREE.BufferAttribute(s.lod.index, 1));
      this.lod = new THREE.LineSegments(lg, material);
      this.lod.frustumCulled = false;
      this.lod.visible = false;
      this.scene.add(this.lod);
    }
    const tg = new THREE.BufferGeometry();
    tg.setAttribute('position', new THREE.BufferAttribute(s.travel, 3));
    this.travel = new THREE.LineSegments(tg, new THREE.LineBasicMaterial({ color: 0x9a9aa6, transparent: true, opacity: 0.6 }));
    this.travel.frustumCulled = false;
    this.travel.visible = this.showTravel;
    this.scene.add(this.travel);
    this.design = null;
    if (s.design) {
      const dg = new THREE.BufferGeometry();
      dg.setAttribute('position', new THREE.BufferAttribute(s.design.positions, 3));
      dg.setAttribute('color', new THREE.BufferAttribute(s.design.colors, 3, true));
      this.design = new THREE.LineSegments(dg, new THREE.LineBasicMaterial({ vertexColors: true }));
      this.design.frustumCulled = false;
      this.scene.add(this.design);
    }
    $('tv-design').parentElement.style.display = s.design ? '' : 'none';
    this.rings = null;
    if (s.hits.length) {
      const pts = new Float32Array(s.hits.length * 3);
      s.hits.forEach((h, j) => pts.set(h.point, 3 * j));
      const rg = new THREE.BufferGeometry();
      rg.setAttribute('position', new THREE.BufferAttribute(pts, 3));
      this.rings = new THREE.Points(rg, new THREE.PointsMaterial({ size: 22, sizeAttenuation: false, map: ringTexture(),
        transparent: true, alphaTest: 0.5, depthTest: false, color: 0xffffff }));
      this.rings.frustumCulled = false;
      this.rings.renderOrder = 3;
      this.scene.add(this.rings);
    }
    // The colliding segments, drawn over the model in the collisions mode.
    this.hitLines = null;
    const segs = s.hits.filter((h) => h.path >= 0 && h.path < s.pathCount &&
      s.pathFirst[h.path] + h.segment + 1 < s.pathFirst[h.path + 1]);
    if (segs.length) {
      const hi = new Uint32Array(segs.length * 2);
      segs.forEach((h, j) => { hi[2 * j] = s.pathFirst[h.path] + h.segment; hi[2 * j + 1] = hi[2 * j] + 1; });
      const hg = new THREE.BufferGeometry();
      hg.setAttribute('position', g.attributes.position);
      hg.setIndex(new THREE.BufferAttribute(hi, 1));
      this.hitLines = new THREE.LineSegments(hg, new THREE.LineBasicMaterial({ color: new THREE.Color().setRGB(...COLLIDING.map((c) => c / 255), THREE.LinearSRGBColorSpace), depthTest: false }));
      this.hitLines.frustumCulled = false;
      this.hitLines.renderOrder = 2;
      this.hitLines.visible = false;
      this.scene.add(this.hitLines);
    }
    this.bed = null;
    if (s.meta.bed) {
      this.bed = new THREE.LineSegments(bedGeometry(s.meta.bed), new THREE.LineBasicMaterial({ color: new THREE.Color().setRGB(0x5a / 255, 0x62 / 255, 0x70 / 255, THREE.LinearSRGBColorSpace) }));
      this.bed.frustumCulled = false;
      this.bed.visible = $('tv-bed').checked;
      this.scene.add(this.bed);
    }
    $('tv-bed').parentElement.style.display = s.meta.bed ? '' : 'none';
    const L = s.layerCount;
    for (const id of ['tv-layer-lo', 'tv-layer-hi']) $(id).max = Math.max(0, L - 1);
    $('tv-layer-lo').value = 0;
    $('tv-layer-hi').value = Math.max(0, L - 1);
    $('tv-single').checked = false;
    this.layerLo = 0;
    this.layerHi = Math.max(0, L - 1);
    this.applyRange();
    // A build file of several lasers opens coloured by laser (which laser scans each vector).
    if (this.lasers() > 1) this.mode = 'tool';
    this.setMode(this.mode);
    this.fillStats();
    this.view('iso');
  }

  setMode(mode) {
    if (!MODES[mode]) throw new Error(`unknown colour mode ${mode}`);
    this.mode = mode;
    $('tv-mode').value = mode;
    const s = this.s;
    const n = s.pathCount;
    const rgb = new Uint8Array(n * 3);
    const m = MODES[mode];
    let legend;
    let perPoint = null;  // per-vertex colours (deviation) instead of per-path ones
    if (this.hitLines) this.hitLines.visible = m.kind === 'collisions';
    if (m.kind === 'collisions') {
      const hitPaths = new Set(s.hits.map((h) => h.path));
      for (let p = 0; p < n; ++p) {
        const c = hitPaths.has(p) ? [235, 170, 160] : CLEAN;
        rgb[3 * p] = c[0]; rgb[3 * p + 1] = c[1]; rgb[3 * p + 2] = c[2];
      }
      const items = [];
      if (s.meta.checked) {
        items.push({ label: `colliding segment, ringed (${s.meta.collisions} collisions)`, color: COLLIDING, count: s.hits.length });
        items.push({ label: 'path with a collision', color: [235, 170, 160] });
        items.push({ label: 'no collision', color: CLEAN });
      }
      legend = { kind: 'category', items, note: s.meta.checked ? null
        : 'no collision check: give the design (trellis view FILE --design LATTICE) or open a trellis check report' };
    } else if (m.kind === 'mixture' && s.meta.materials >= 3) {
      for (let p = 0; p < n; ++p) {
        const w = this.mixture3(p, m.attr);
        const c = w ? mix3Color(w) : NO_VALUE;
        rgb[3 * p] = c[0]; rgb[3 * p + 1] = c[1]; rgb[3 * p + 2] = c[2];
      }
      legend = { kind: 'triangle', note: this.mixtureNote(mode) };
    } else if (m.perPoint) {
      const d = s.deviation;
      let hi = 0;
      if (d) for (let k = 0; k < d.length; ++k) if (d[k] > hi) hi = d[k];
      const span = hi > 0 ? hi : 1;
      perPoint = new Uint8Array(s.positions.length);
      for (let k = 0; k < perPoint.length / 3; ++k) {
        const c = d ? colorMap(d[k] / span) : NO_VALUE;
        perPoint[3 * k] = c[0]; perPoint[3 * k + 1] = c[1]; perPoint[3 * k + 2] = c[2];
      }
      legend = { kind: 'bar', lo: 0, hi: d ? hi : 1, has: d !== null, fn: colorMap, unit: m.unit,
        note: d ? null : 'no design given (trellis view FILE --design LATTICE)' };
    } else if (m.kind === 'category') {
      const key = mode === 'feature' ? s.role : mode === 'set' ? s.set : s.tool;
      const palette = mode === 'feature' ? ROLE_COLORS : TOOL_COLORS;
      // A laser parameter set k is byte k + 1 (0: a path of no set) and has the colour of tool
      // k, as in `trellis render --colour set`.
      const colorOf = (k) => (mode !== 'set' ? palette[k % palette.length] : k > 0 ? palette[(k - 1) % palette.length] : NO_VALUE);
      const labelOf = (k) => (mode === 'feature' ? s.meta.roles[k]
        : mode === 'set' ? (k > 0 ? s.meta.parameter_sets[k - 1] : 'no parameter set')
          : this.laser() ? `laser ${k + 1}` : `tool ${k}`);
      // Paths as the panel counts them (runs between travels), each under the role / tool / set
      // it starts with, so the legend's counts add up to the panel's.
      const used = new Map();
      for (let p = 0; p < n; ++p) {
        const c = colorOf(key[p]);
        rgb[3 * p] = c[0]; rgb[3 * p + 1] = c[1]; rgb[3 * p + 2] = c[2];
        used.set(key[p], (used.get(key[p]) || 0) + (s.joinedOf[p] ? 0 : 1));
      }
      legend = { kind: 'category', items: [...used.keys()].sort((a, b) => a - b).map((k) => ({
        label: labelOf(k), color: colorOf(k), paths: used.get(k) })),
      note: mode === 'set' && !s.meta.parameter_sets.length ? 'no laser parameter sets in this file (a PBF solid part or a build file that names them has them)' : null };
    } else {
      const value = this.valueOf(mode);
      let lo = Infinity, hi = -Infinity;
      for (let p = 0; p < n; ++p) {
        const v = value(p);
        if (v === null) continue;
        if (v < lo) lo = v;
        if (v > hi) hi = v;
      }
      if (m.kind === 'mixture') { lo = 0; hi = 1; }
      const has = lo <= hi;
      if (!has) { lo = 0; hi = 1; }
      const span = hi > lo ? hi - lo : 1;
      const fn = m.kind === 'mixture' ? mixColor : colorMap;
      for (let p = 0; p < n; ++p) {
        const v = value(p);
        const c = v === null ? NO_VALUE : fn(hi > lo ? (v - lo) / span : 0.5);
        rgb[3 * p] = c[0]; rgb[3 * p + 1] = c[1]; rgb[3 * p + 2] = c[2];
      }
      legend = { kind: 'bar', lo, hi, has, fn, unit: m.unit, note: m.kind === 'mixture' && has ? this.mixtureNote(mode) : null, explain: m.kind === 'mixture' };
    }
    const colors = this.colors;
    const first = s.pathFirst;
    if (perPoint) colors.set(perPoint);
    else for (let p = 0; p < n; ++p) {
      const r = rgb[3 * p], g = rgb[3 * p + 1], b = rgb[3 * p + 2];
      for (let k = first[p] * 3, e = first[p + 1] * 3; k < e; k += 3) { colors[k] = r; colors[k + 1] = g; colors[k + 2] = b; }
    }
    this.lines.geometry.attributes.color.needsUpdate = true;
    this.legend = legend;
    const title = mode === 'tool' && this.laser() ? 'Laser' : m.title;
    this.drawLegend(legend.kind === 'triangle' ? `Mixture as ${mode === 'commanded' ? 'commanded' : 'deposited'}: materials 1, 2 and 3` : title, legend);
    this.requestRender();
  }

  // The value a path is coloured by in `mode` (null = not known for this path).
  valueOf(mode) {
    const s = this.s, a = s.attr;
    if (mode === 'order') return (p) => p;
    if (MODES[mode].kind === 'mixture') {
      const k = MODES[mode].attr;
      return (p) => (a[ATTRS * p + k] >= 0 ? a[ATTRS * p + k] : null);
    }
    if (mode === 'collisions') return () => null;
    if (mode === 'deviation') return (p) => (s.deviation ? s.deviation[s.pathFirst[p]] : null);
    const k = MODES[mode].attr;
    return (p) => (a[ATTRS * p + k] > 0 ? a[ATTRS * p + k] : null);
  }

  // What the mixture shown is: as deposited (a G-code file's commands shifted by its mixing
  // look-ahead), as commanded, or as planned (a toolpath).
  mixtureNote(mode) {
    const meta = this.s.meta, L = meta.mixture_lookahead_mm;
    if (!meta.mixture_read_back) return 'as planned (a toolpath: no mixing look-ahead applies)';
    if (!(L > 0)) return 'the file records no mixing look-ahead: deposited = commanded';
    return mode === 'commanded'
      ? `M165 commands where issued, ${L.toFixed(0)} mm of printed path before the region they are for`
      : `commands shifted ${L.toFixed(0)} mm of printed path later (the file's mixing look-ahead)`;
  }

  // A path's mixture of three (or more) materials as fractions of materials 1, 2, 3 summing to 1
  // (materials past the third are not shown); null when the path has none. `at`: the attribute
  // of material 1 (0 deposited, 7 commanded).
  mixture3(p, at = 0) {
    const a = this.s.attr, o = ATTRS * p + at;
    const w = [a[o], a[o + 1], a[at === 0 ? o + 6 : o + 2]].map((x) => (x > 0 ? x : 0));
    const sum = w[0] + w[1] + w[2];
    return a[o] < 0 || sum <= 0 ? null : w.map((x) => x / sum);
  }

  drawLegend(title, legend) {
    $('tv-legend-title').textContent = title;
    const body = $('tv-legend-body');
    body.textContent = '';
    if (legend.kind === 'category') {
      for (const it of legend.items) {
        const row = document.createElement('div');
        const sw = document.createElement('span');
        sw.className = 'tv-swatch';
        sw.style.background = `rgb(${it.color.join(',')})`;
        row.appendChild(sw);
        row.appendChild(document.createTextNode(it.paths !== undefined ? `${it.label} (${it.paths} paths)` : it.label));
        body.appendChild(row);
      }
      if (legend.note) {
        const note = document.createElement('div');
        note.textContent = legend.note;
        body.appendChild(note);
      } else if (!legend.items.length) body.textContent = 'no paths';
      if (this.s.design) {
        const row = document.createElement('div');
        const sw = document.createElement('span');
        sw.className = 'tv-swatch';
        sw.style.background = 'rgb(120,120,135)';
        row.appendChild(sw);
        row.appendChild(document.createTextNode(`design strut (${this.s.design.lines})`));
        body.appendChild(row);
        if (this.s.stats.designFlagged) {
          const r2 = document.createElement('div');
          const s2 = document.createElement('span');
          s2.className = 'tv-swatch';
          s2.style.background = 'rgb(220,30,30)';
          r2.appendChild(s2);
          r2.appendChild(document.createTextNode(`strut in a collision (${this.s.stats.designFlagged})`));
          body.appendChild(r2);
        }
      }
      if (this.s.hits.length && this.mode !== 'collisions') {
        const row = document.createElement('div');
        const ring = document.createElement('span');
        ring.className = 'tv-swatch';
        ring.style.cssText = `border: 2px solid rgb(${COLLIDING.join(',')}); border-radius: 50%; width: 8px; height: 8px;`;
        row.appendChild(ring);
        row.appendChild(document.createTextNode(`collision, ringed (${this.s.hits.length} of ${this.s.meta.collisions})`));
        body.appendChild(row);
      }
      return;
    }
    if (legend.kind === 'triangle') {
      body.appendChild(drawTriangle());
      const note = document.createElement('div');
      note.textContent = legend.note;
      body.appendChild(note);
      return;
    }
    const cv = document.createElement('canvas');
    cv.id = 'tv-colorbar';
    cv.width = 200; cv.height = 14;
    const ctx = cv.getContext('2d');
    for (let x = 0; x < cv.width; ++x) {
      const c = legend.fn(x / (cv.width - 1));
      ctx.fillStyle = `rgb(${c[0]},${c[1]},${c[2]})`;
      ctx.fillRect(x, 0, 1, cv.height);
    }
    body.appendChild(cv);
    const labels = document.createElement('div');
    labels.className = 'tv-bar-labels';
    const fmt = (v) => (Math.abs(v) >= 100 ? v.toFixed(0) : Math.abs(v) >= 1 ? v.toFixed(1) : v.toFixed(2));
    const u = legend.unit ? ' ' + legend.unit : '';
    for (const v of [legend.lo, (legend.lo + legend.hi) / 2, legend.hi]) {
      const sp = document.createElement('span');
      sp.textContent = fmt(v) + u;
      labels.appendChild(sp);
    }
    body.appendChild(labels);
    if (!legend.has || legend.note) {
      const note = document.createElement('div');
      note.className = 'tv-legend-note';
      note.textContent = legend.note || 'no path in this file carries this value (grey)';
      body.appendChild(note);
    }
  }

  setLayers(lo, hi) {
    const L = this.s.layerCount;
    lo = Math.max(0, Math.min(lo, L - 1));
    hi = Math.max(0, Math.min(hi, L - 1));
    if ($('tv-single').checked) lo = hi;
    if (lo > hi) [lo, hi] = [hi, lo];
    this.layerLo = lo;
    this.layerHi = hi;
    $('tv-layer-lo').value = lo;
    $('tv-layer-hi').value = hi;
    this.applyRange();
  }

  applyRange() {
    const s = this.s;
    const L = s.layerCount;
    const lo = this.layerLo, hi = this.layerHi;
    const z = s.meta.layer_z;
    $('tv-layer-label').textContent = L === 0 ? '(none)' : lo === hi
      ? `${lo + 1} of ${L} (z ${z[lo].toFixed(3)} mm)`
      : `${lo + 1}–${hi + 1} of ${L} (z ${z[lo].toFixed(2)}–${z[hi].toFixed(2)} mm)`;
    if (L === 0) {
      this.lines.geometry.setDrawRange(0, 0);
      if (this.lod) this.lod.geometry.setDrawRange(0, 0);
      this.travel.geometry.setDrawRange(0, 0);
    } else {
      const a = s.layerSeg[lo] * 2, b = s.layerSeg[hi + 1] * 2;
      this.lines.geometry.setDrawRange(a, b - a);
      if (this.lod) {
        const la = s.lod.layerSeg[lo] * 2, lb = s.lod.layerSeg[hi + 1] * 2;
        this.lod.geometry.setDrawRange(la, lb - la);
      }
      const ta = s.layerTravel[lo] * 2, tb = s.layerTravel[hi + 1] * 2;
      this.travel.geometry.setDrawRange(ta, tb - ta);
    }
    if (this.design) this.design.visible = this.showDesign;
    this.requestRender();
  }

  setTravel(on) {
    this.showTravel = on;
    $('tv-travel').checked = on;
    this.travel.visible = on;
    this.requestRender();
  }

  // Points the camera along `which` (top, front, iso, or fit: the current direction). It frames
  // the part; the build volume, while shown, stays in the depth range (drawn around the part, off
  // screen where it is larger than the view), and is framed too with `withBed`.
  view(which, withBed = false) {
    const box = this.s.bbox.clone();
    const all = box.clone();
    if (this.bed && this.bed.visible) all.union(new THREE.Box3().setFromBufferAttribute(this.bed.geometry.attributes.position));
    if (withBed) box.copy(all);
    const center = box.getCenter(new THREE.Vector3());
    const radius = Math.max(1e-3, box.getSize(new THREE.Vector3()).length() / 2);
    const dist = radius / Math.sin(THREE.MathUtils.degToRad(this.camera.fov / 2)) * 1.05;
    let dir;
    if (which === 'top') dir = new THREE.Vector3(0, -1e-4, 1);
    else if (which === 'front') dir = new THREE.Vector3(0, -1, 0);
    else if (which === 'iso') dir = new THREE.Vector3(1, -1, 0.9);
    else dir = this.camera.position.clone().sub(this.controls.target);
    if (dir.lengthSq() === 0) dir.set(1, -1, 0.9);
    dir.normalize();
    this.controls.target.copy(center);
    this.camera.position.copy(center).addScaledVector(dir, dist);
    this.camera.near = dist / 1000;
    this.camera.far = dist * 10 + radius * 4 + 2 * all.distanceToPoint(this.camera.position) + all.getSize(new THREE.Vector3()).length();
    this.camera.updateProjectionMatrix();
    this.controls.update();
    this.requestRender();
  }

  fillStats() {
    const st = this.s.stats, meta = this.s.meta;
    const rows = [['file', meta.name], ['kind', meta.kind]];
    if (meta.kind === 'lattice') rows.push(['struts', st.designLines]);
    else if (meta.kind === 'check') { if (st.designLines) rows.push(['design struts', st.designLines]); }
    else {
      rows.push(['layers', st.layers], ['paths', st.paths], ['segments', st.segments],
        [this.laser() ? 'scan length' : 'extruded length', st.extruded.toFixed(1) + ' mm'],
        [this.laser() ? 'jumps' : 'travel moves', st.travelMoves],
        [this.laser() ? 'jump length (XY)' : 'travel length (XY)', st.travelLength.toFixed(1) + ' mm']);
      if (meta.print_time_s >= 0) rows.push(['time estimate', formatTime(meta.print_time_s)]);
      if (meta.filament_mm >= 0) rows.push(['filament', meta.filament_mm.toFixed(1) + ' mm']);
      if (st.designLines) rows.push(['design struts', st.designLines]);
    }
    if (meta.checked) rows.push(['collisions', meta.collisions], ['collisions ringed', st.ringed]);
    if (this.s.deviation) {
      let hi = 0;
      for (const d of this.s.deviation) if (d > hi) hi = d;
      rows.push(['deviation (max)', hi.toFixed(3) + ' mm']);
    }
    for (const [k, v] of meta.extra_stats) rows.push([k, v]);
    if (meta.bed) rows.push(['build volume', `${meta.bed.machine}: ${meta.bed.shape === 'circle' ? 'Ø' + meta.bed.x : meta.bed.x + ' × ' + meta.bed.y} × ${meta.bed.z} mm`]);
    rows.push(['warnings', meta.warnings.length]);
    const table = $('tv-stats-table');
    table.textContent = '';
    for (const [k, v] of rows) {
      const tr = table.insertRow();
      tr.insertCell().textContent = k;
      const td = tr.insertCell();
      td.className = 'v';
      td.textContent = v;
      td.dataset.stat = k;
    }
    $('tv-warnings').textContent = meta.warnings.join('\n');
  }

  // The lasers of a laser file (its paths' tools are laser indices), 0 for any other file.
  lasers() {
    if (!this.laser()) return 0;
    let hi = -1;
    for (let p = 0; p < this.s.pathCount; ++p) if (this.s.tool[p] > hi) hi = this.s.tool[p];
    return hi + 1;
  }

  // A laser file (a .cli build file, or paths that carry a laser power): scans and jumps, not
  // extrusion and travel.
  laser() {
    if (this.s.meta.kind === 'cli') return true;
    const a = this.s.attr;
    for (let p = 0; p < this.s.pathCount; ++p) if (a[ATTRS * p + 5] > 0) return true;
    return false;
  }

  play() {
    if (this.playing) { cancelAnimationFrame(this.playing); this.playing = null; this.applyRange(); return; }
    const s = this.s;
    const a = s.layerSeg[this.layerLo] * 2, b = s.layerSeg[this.layerHi + 1] * 2;
    const steps = 600;
    let i = 0;
    const tick = () => {
      i += 1;
      const n = Math.round(((b - a) / 2) * Math.min(1, i / steps)) * 2;
      this.lines.geometry.setDrawRange(a, n);
      this.render();
      this.playing = i < steps ? requestAnimationFrame(tick) : null;
    };
    this.playing = requestAnimationFrame(tick);
  }

  // Draws on the next frame. A large file is drawn reduced first (data.js, lodIndex) and then
  // refined in chunks of the full index over the following frames while the view rests, so the
  // page answers the mouse at once whatever the file size.
  requestRender() {
    this.cancelRefine();
    if (this.pending) return;
    this.pending = requestAnimationFrame(() => {
      this.pending = 0;
      this.render(this.lod !== null);
      if (this.lod) this.restTimer = setTimeout(() => this.refine(), 150);
    });
  }

  cancelRefine() {
    clearTimeout(this.restTimer);
    if (this.refining) cancelAnimationFrame(this.refining);
    this.refining = 0;
  }

  // Draws the scene; `reduced` draws the reduced index of a large file.
  render(reduced = false) {
    const lod = reduced && this.lod !== null;
    this.lines.visible = !lod;
    if (this.lod) this.lod.visible = lod;
    this.renderer.render(this.scene, this.camera);
    this.updateScale();
    this.fullFrame = !lod;
    if (this.firstFrameMs === undefined) {
      const gl = this.renderer.getContext();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
      this.firstFrameMs = performance.now();
    }
  }

  // Adds the full index over the reduced picture, REFINE_CHUNK segments per frame (the reduced
  // lines are a subset of the full ones, so the result is the full picture).
  refine() {
    const s = this.s, g = this.lines.geometry;
    const a = g.drawRange.start, end = a + g.drawRange.count;
    let at = a;
    const others = [this.lod, this.travel, this.design, this.rings, this.hitLines, this.bed].filter((o) => o && o.visible);
    const step = () => {
      const n = Math.min(REFINE_CHUNK * 2, end - at);
      others.forEach((o) => (o.visible = false));
      this.lines.visible = true;
      g.setDrawRange(at, n);
      this.renderer.autoClear = false;
      this.renderer.render(this.scene, this.camera);
      this.renderer.autoClear = true;
      g.setDrawRange(a, end - a);
      others.forEach((o) => (o.visible = true));
      at += n;
      if (at < end) this.refining = requestAnimationFrame(step);
      else { this.refining = 0; this.fullFrame = true; }
    };
    this.refining = requestAnimationFrame(step);
  }

  // Resolves once the full picture is drawn.
  async whenDrawn() {
    for (;;) {
      await new Promise((r) => requestAnimationFrame(r));
      if (this.fullFrame && !this.pending && !this.refining) return;
    }
  }

  updateScale() {
    const h = this.renderer.domElement.height;
    const d = this.camera.position.distanceTo(this.controls.target);
    const mmVisible = 2 * d * Math.tan(THREE.MathUtils.degToRad(this.camera.fov / 2));
    const pxPerMm = h / mmVisible;
    const target = 120 / pxPerMm;
    const p = Math.pow(10, Math.floor(Math.log10(target)));
    const nice = [1, 2, 5, 10].map((k) => k * p).filter((v) => v <= target).pop() || p;
    $('tv-scale-bar').style.width = (nice * pxPerMm).toFixed(1) + 'px';
    $('tv-scale-label').textContent = `${nice >= 1 ? nice : nice.toPrecision(1)} mm (at the orbit centre)`;
    this.pxPerMm = pxPerMm;
  }

  // --- API for tests and notebooks ---------------------------------------------------------
  stats() {
    const st = this.s.stats;
    return { ...st, name: this.s.meta.name, kind: this.s.meta.kind, decodeMs: this.decodeMs, loadMs: this.loadMs,
      firstFrameMs: this.firstFrameMs,
      reducedSegments: this.s.lod ? this.s.lod.index.length / 2 : st.segments };
  }

  // Page pixel (CSS px) of a model point.
  project(x, y, z) {
    const v = new THREE.Vector3(x, y, z).project(this.camera);
    const r = this.canvas.getBoundingClientRect();
    return [r.left + (v.x + 1) / 2 * r.width, r.top + (1 - v.y) / 2 * r.height];
  }

  // Page pixel of the mixture `w` (fractions of materials 1, 2, 3) on the mixture triangle, and
  // the triangle's colour there.
  triangleAt(w) {
    const cv = $('tv-triangle');
    if (!cv) return null;
    const [x, y] = trianglePoint(w);
    const r = cv.getBoundingClientRect();
    return { x: r.left + 1 + x, y: r.top + 1 + y, cx: x, cy: y, color: mix3Color(w) };
  }

  // The build volume drawn: its box in model coordinates, or null.
  bedBox() {
    if (!this.bed) return null;
    const b = new THREE.Box3().setFromBufferAttribute(this.bed.geometry.attributes.position);
    return { min: b.min.toArray(), max: b.max.toArray(), visible: this.bed.visible };
  }

  // Page pixel of `value` on the colour bar, and the colour the bar has there.
  colorbarAt(value) {
    const L = this.legend;
    if (!L || L.kind !== 'bar') return null;
    const t = L.hi > L.lo ? (value - L.lo) / (L.hi - L.lo) : 0.5;
    const cv = $('tv-colorbar');
    const r = cv.getBoundingClientRect();
    const x = Math.round(t * (cv.width - 1));
    return { x: r.left + 1 + x + 0.5, y: r.top + r.height / 2, color: L.fn(t) };
  }

  // A path's first segment: [a, b] in model coordinates, its layer and its value in `mode`.
  pathInfo(p) {
    const s = this.s, k = s.pathFirst[p] * 3, P = s.positions;
    return { a: [P[k], P[k + 1], P[k + 2]], b: [P[k + 3], P[k + 4], P[k + 5]], layer: s.pathLayer[p],
      value: this.valueOf(this.mode === 'feature' || this.mode === 'tool' ? 'order' : this.mode)(p),
      mixture: s.attr[ATTRS * p], commanded: s.attr[ATTRS * p + 7], temperature: s.attr[ATTRS * p + 2],
      mixture3: this.mixture3(p), role: s.meta.roles[s.role[p]] };
  }

  // Renders `frames` frames while orbiting the whole model as the view draws it while moving
  // (`reduced`, the default) or in full; returns frames per second (each frame waits for the GPU
  // by reading back a pixel).
  measureFps(frames = 60, reduced = true) {
    this.cancelRefine();
    const gl = this.renderer.getContext();
    const px = new Uint8Array(4);
    const t = performance.now();
    for (let i = 0; i < frames; ++i) {
      const off = this.camera.position.clone().sub(this.controls.target);
      off.applyAxisAngle(new THREE.Vector3(0, 0, 1), 0.02);
      this.camera.position.copy(this.controls.target).add(off);
      this.camera.lookAt(this.controls.target);
      this.render(reduced);
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
    }
    const fps = frames / ((performance.now() - t) / 1000);
    this.requestRender();
    return fps;
  }
}

// A ring (the collision marker) as a texture drawn here, so the page fetches nothing.
let ringTex = null;
function ringTexture() {
  if (ringTex) return ringTex;
  const cv = document.createElement('canvas');
  cv.width = cv.height = 64;
  const ctx = cv.getContext('2d');
  ctx.strokeStyle = `rgb(${COLLIDING.join(',')})`;
  ctx.lineWidth = 9;
  ctx.beginPath();
  ctx.arc(32, 32, 25, 0, 2 * Math.PI);
  ctx.stroke();
  ringTex = new THREE.CanvasTexture(cv);
  return ringTex;
}

// Build volume edges: a box, or a cylinder for a round bed, from z = 0 to the build height.
function bedGeometry(bed) {
  const v = [];
  const x0 = bed.center ? -bed.x / 2 : 0, y0 = bed.center ? -bed.y / 2 : 0, z1 = bed.z;
  if (bed.shape === 'circle') {
    const cx = x0 + bed.x / 2, cy = y0 + bed.y / 2, r = bed.x / 2, N = 96;
    for (let i = 0; i < N; ++i) {
      const a = (2 * Math.PI * i) / N, b = (2 * Math.PI * (i + 1)) / N;
      for (const z of [0, z1]) v.push(cx + r * Math.cos(a), cy + r * Math.sin(a), z, cx + r * Math.cos(b), cy + r * Math.sin(b), z);
      if (i % (N / 4) === 0) v.push(cx + r * Math.cos(a), cy + r * Math.sin(a), 0, cx + r * Math.cos(a), cy + r * Math.sin(a), z1);
    }
  } else {
    const X = [x0, x0 + bed.x], Y = [y0, y0 + bed.y], Z = [0, z1];
    for (const z of Z) for (const [a, b] of [[0, 0, 1, 0], [1, 0, 1, 1], [1, 1, 0, 1], [0, 1, 0, 0]].map((q) => [[q[0], q[1]], [q[2], q[3]]]))
      v.push(X[a[0]], Y[a[1]], z, X[b[0]], Y[b[1]], z);
    for (const i of [0, 1]) for (const j of [0, 1]) v.push(X[i], Y[j], 0, X[i], Y[j], z1);
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(new Float32Array(v), 3));
  return g;
}

// The mixture triangle: corners material 1 (top), 2 (bottom left), 3 (bottom right); each pixel
// has the colour of its barycentric mixture, the colour segments of that mixture are drawn in.
const TRI_W = 190, TRI_H = 150, TRI_PAD = 10;
const TRI = [[TRI_W / 2, TRI_PAD], [TRI_PAD, TRI_H - TRI_PAD], [TRI_W - TRI_PAD, TRI_H - TRI_PAD]];
function trianglePoint(w) {
  return [0, 1].map((k) => w[0] * TRI[0][k] + w[1] * TRI[1][k] + w[2] * TRI[2][k]);
}
function drawTriangle() {
  const wrap = document.createElement('div');
  wrap.style.position = 'relative';
  const cv = document.createElement('canvas');
  cv.id = 'tv-triangle';
  cv.width = TRI_W; cv.height = TRI_H;
  cv.style.border = '1px solid #888';
  cv.style.display = 'block';
  const ctx = cv.getContext('2d');
  const img = ctx.createImageData(TRI_W, TRI_H);
  const [[ax, ay], [bx, by], [cx, cy]] = TRI;
  const det = (by - cy) * (ax - cx) + (cx - bx) * (ay - cy);
  for (let y = 0; y < TRI_H; ++y)
    for (let x = 0; x < TRI_W; ++x) {
      const px = x + 0.5, py = y + 0.5;
      const l1 = ((by - cy) * (px - cx) + (cx - bx) * (py - cy)) / det;
      const l2 = ((cy - ay) * (px - cx) + (ax - cx) * (py - cy)) / det;
      const l3 = 1 - l1 - l2;
      const k = 4 * (y * TRI_W + x);
      if (l1 < -0.01 || l2 < -0.01 || l3 < -0.01) { img.data.set([255, 255, 255, 255], k); continue; }
      const c = mix3Color([l1, l2, l3].map((l) => Math.max(0, l)));
      img.data.set([c[0], c[1], c[2], 255], k);
    }
  ctx.putImageData(img, 0, 0);
  wrap.appendChild(cv);
  const labels = document.createElement('div');
  labels.className = 'tv-bar-labels';
  labels.style.width = TRI_W + 'px';
  for (const [i, name] of ['2', '1 (top)', '3'].entries()) {
    const sp = document.createElement('span');
    sp.textContent = name;
    sp.style.color = `rgb(${MIX3[[1, 0, 2][i]].join(',')})`;
    labels.appendChild(sp);
  }
  wrap.appendChild(labels);
  return wrap;
}

function formatTime(s) {
  const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), sec = Math.round(s % 60);
  return h ? `${h} h ${m} min` : m ? `${m} min ${sec} s` : `${sec} s`;
}

// A page with packed scenes (a notebook view) is inflated first (asynchronously); a page of
// `trellis view` starts at once. Failures show on the page as well as in the console.
if (document.querySelector('script[id$="-pack"]')) {
  unpackScenes().then(() => { window.trellisViewer = new Viewer(); }).catch((e) => {
    const p = document.createElement('div');
    p.className = 'tv-panel';
    p.style.cssText = 'left: 30%; top: 40%; color: #a00';
    p.textContent = `The viewer could not read this view's data: ${e.message}`;
    document.body.appendChild(p);
    throw e;
  });
} else {
  window.trellisViewer = new Viewer();
}
