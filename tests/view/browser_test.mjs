// The viewer in a real browser: makes one file of each kind with the trellis CLI (and PrusaSlicer),
// writes a viewer page for each, opens it in Debian's headless Chromium through the DevTools
// protocol (puppeteer-core, pinned in viewer/package.json) and checks: no console errors, the
// page's counts equal what Trellis reports for the same file, colour modes change the model's
// pixels, a known segment's colour equals its mixture / temperature on the colour bar, and the
// layer slider hides the layers above. Screenshots go to OUT_DIR.
// The Python package's Toolpath._repr_html_ (the viewer in an iframe, as Jupyter shows it) is
// opened the same way.
// Usage: node browser_test.mjs TRELLIS SOURCE_DIR NODE_MODULES OUT_DIR PYTHON_PACKAGE_DIR
import { createRequire } from 'node:module';
import { execFileSync } from 'node:child_process';
import { mkdirSync, readFileSync, writeFileSync, statSync, rmSync, existsSync } from 'node:fs';
import { join } from 'node:path';

const [trellis, source, nodeModules, out, pythonDir] = process.argv.slice(2);
const require = createRequire(join(nodeModules, 'noop.js'));
const puppeteer = require('puppeteer-core');
rmSync(out, { recursive: true, force: true });
mkdirSync(out, { recursive: true });

let failures = 0;
let tagNow = '';  // 'firefox.' while the Firefox round runs
function check(ok, what) {
  if (tagNow && !what.startsWith(tagNow)) what = tagNow + what;
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures += 1;
}
function run(cmd, args) {
  return execFileSync(cmd, args, { cwd: out, encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'] });
}
const tr = (...args) => run(trellis, args);
const json = (f) => JSON.parse(readFileSync(join(out, f), 'utf8'));
const profile = (name) => join(source, 'profiles', name);

// --- inputs ------------------------------------------------------------------------------------
tr('lattice2d', '--pattern', 'honeycomb', '--cell', '1', '-o', 'lattice.json');
tr('plan', 'gippo', 'lattice.json', '-o', 'toolpath.json', '--report', 'plan_report.json');
tr('gcode', 'toolpath.json', '--machine', profile('ender3_s1_pro_tpu.toml'), '-o', 'part.gcode');
tr('lattice3d', '--cell-type', 'octet', '--cell', '7', '--count', '2,2,2', '-o', 'octet.json');
tr('plan', 'aero', 'octet.json', '-o', 'octet_path.json');
tr('gcode', 'octet_path.json', '--machine', profile('embedded_aero_410um.toml'), '-o', 'octet.nc');
tr('pbf', '--cell-type', 'gyroid', '--cell', '2.5', '--size', '5,5,2', '-o', 'gyroid.cli');
// A solid part: two contours with their own power and speed and a hatch, three parameter sets.
tr('pbf', join(source, 'examples/designs/bracket_20mm.stl'), '--machine', profile('pbf_316l_25um.toml'),
  '--layer-height', '0.5', '--contours', '2', '--set', 'laser.contour_powers=60,80',
  '--set', 'laser.contour_speeds=800,900', '-o', 'bracket.cli');
// A sliced part: linked paths whose travel inside the part turns at `via` corners.
tr('slice', join(source, 'examples/designs/csg_bracket.vcad'), '--machine', profile('voron_klipper.toml'),
  '--layer-height', '0.3', '-o', 'sliced.gcode');
run('prusa-slicer', ['--export-gcode', '--layer-height', '0.3', '--first-layer-height', '0.3',
  '-o', join(out, 'prusa.gcode'), '/usr/share/PrusaSlicer/shapes/M3_hex_nut.stl']);
// A two-material, temperature-changing print written by hand (as another program would):
// layer 1 has 11 lines along X at y = 2i with mixture i/10 and 200 + 3i °C; layer 2 has lines
// along Y between them.
{
  const g = ['G21', 'G90', 'M83', ';LAYER_CHANGE', ';Z:0.2'];
  for (let i = 0; i <= 10; ++i) {
    g.push(`M165 A${(i / 10).toFixed(2)} B${(1 - i / 10).toFixed(2)}`, `M104 S${200 + 3 * i}`);
    g.push(`G0 X0 Y${2 * i} Z0.2`, `G1 X20 Y${2 * i} E1.0 F1200`);
  }
  g.push(';LAYER_CHANGE', ';Z:0.4');
  for (let i = 0; i < 10; ++i) g.push(`G0 X${2 * i + 1} Y1 Z0.4`, `G1 X${2 * i + 1} Y19 E1.0 F1200`);
  writeFileSync(join(out, 'mix.gcode'), g.join('\n') + '\n');
}

// A graded print on a mixing hotend that issues each change 960 mm early (the Mizar M profile's
// look-ahead): 40 non-planar-role lines of 60 mm along X at y = 2i, mixture 0 for 20 lines
// (1200 mm, past the look-ahead), then stepping 0.2 .. 1 every 4 lines, written by `trellis
// gcode`. Read back, each command runs 960 mm = 16 lines ahead of its region.
const GRADE = (i) => (i < 20 ? 0 : (Math.floor((i - 20) / 4) + 1) / 5);
{
  const paths = [];
  for (let i = 0; i < 40; ++i)
    paths.push({ role: 'nonplanar', tool: 0, width: 0.8, height: 0.2, speed: 0, mixture: [GRADE(i), 1 - GRADE(i)],
      points: [[0, 2 * i, 0.2], [30, 2 * i, 0.2], [60, 2 * i, 0.2]] });
  writeFileSync(join(out, 'graded.json'), JSON.stringify({ format: 'trellis.toolpath', version: 1, units: 'mm',
    source: 'browser test', layers: [{ z: 0.2, paths }] }));
  tr('gcode', 'graded.json', '--machine', profile('geeetech_mizar_m_mixing.toml'), '-o', 'graded.gcode');
}
// A small graded plate (14 x 8 x 0.8 mm, graded along X) sliced with Strategy 2 for the Mizar M
// (960 mm look-ahead): runs of extrusion cut into pieces where the deposited mixture changes.
// The panel, the legend and `trellis analyze` count the same paths (runs between travels).
writeFileSync(join(out, 'plate.vcad'), 'fgrade(["0.5 + x/14", "0.5 - x/14"], ["a", "b"]) {\n  rectprism(14, 8, 0.8);\n}\n');
tr('slice', 'plate.vcad', '--machine', profile('geeetech_mizar_m_mixing.toml'), '--strategy', '2',
  '-o', 'plate.gcode');
// The one palette of PNGs and viewer (src/render/palette.json, bundled into the page).
const PALETTE = JSON.parse(readFileSync(join(source, 'src/render/palette.json'), 'utf8'));
const paletteMix = (t) => [0, 1, 2].map((i) => Math.round(PALETTE.mixture2[0][i] + (PALETTE.mixture2[1][i] - PALETTE.mixture2[0][i]) * t));

// Three materials (M165 A B C, as a mixing hotend's G-code would): layer 1 has lines along X at
// y = 2i with the mixtures MIX3[i].
const MIX3 = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.6, 0.2, 0.2], [0.2, 0.5, 0.3], [0.1, 0.1, 0.8], [0.4, 0.4, 0.2]];
{
  const g = ['G21', 'G90', 'M83', ';LAYER_CHANGE', ';Z:0.2'];
  MIX3.forEach(([a, b, c], i) => g.push(`M165 A${a} B${b} C${c}`, `G0 X0 Y${2 * i} Z0.2`, `G1 X20 Y${2 * i} E1.0 F1200`));
  writeFileSync(join(out, 'mix3.gcode'), g.join('\n') + '\n');
}
// Hostile strings: a G-code line, a file name and a title that would end or comment out the data
// block if the page did not escape them; the page must still load and show the same counts.
const HOSTILE = '<!--<script>x.gcode';
const HOSTILE_TITLE = '<!--<script></script><script>window.pwned = 1</script>';
writeFileSync(join(out, HOSTILE), readFileSync(join(out, 'mix.gcode'), 'utf8') +
  '<!--<script>\n;</script><script>window.pwned = 1</script>\n');
// Deviation from a design: two design struts along X at y = 0 and y = 10; the print's lines along
// X lie 0, 0.25, 0.5 and 1 mm beside the first.
const DEV = [0, 0.25, 0.5, 1];
{
  writeFileSync(join(out, 'dev_design.json'), JSON.stringify({ units: 'mm',
    nodes: [[0, 0, 0.2], [20, 0, 0.2], [0, 10, 0.2], [20, 10, 0.2]], edges: [[0, 1], [2, 3]] }));
  const g = ['G21', 'G90', 'M83', ';LAYER_CHANGE', ';Z:0.2'];
  for (const d of DEV) g.push(`G0 X0 Y${d} Z0.2`, `G1 X20 Y${d} E1.0 F1200`);
  writeFileSync(join(out, 'dev.gcode'), g.join('\n') + '\n');
}
// A bath print of a dense foam with collisions the planner could not avoid, its `trellis check`
// report, and the G-code as binary G-code (the test encoder written from the specification).
tr('lattice3d', '--kind', 'foam', '--box', '8,8,8', '--density', '0.05', '-o', 'foam.json');
tr('plan', 'aero', 'foam.json', '-o', 'foam_path.json', '--machine', profile('embedded_aero_410um.toml'), '--gcode', 'foam.nc');
try { tr('check', 'foam.json', 'foam.nc', '--report', 'foam_check.json'); } catch (e) { if (e.status !== 1) throw e; }
const foamCheck = json('foam_check.json');
const foamFlagged = new Set(foamCheck.collision_list.flatMap((h) => [h.strut, h.hit_strut]).filter((e) => e >= 0)).size;
// The same machine with a round bed of 200 mm, (0,0) at its centre (a delta printer's layout).
writeFileSync(join(out, 'round_bed.toml'), readFileSync(profile('embedded_aero_410um.toml'), 'utf8')
  .replace(/^bed_shape = .*$/m, 'bed_shape = "circle"').replace(/^origin = .*$/m, 'origin = "center"')
  .replace(/^bed_x = .*$/m, 'bed_x = 200'));
run('/usr/bin/python3', [join(source, 'tests/machine/bgcode_encode.py'), join(out, 'part.gcode'), join(out, 'part.bgcode'), '1', '0']);

// What Trellis reports for each file: [layers, paths, segments] (lattices: struts).
function analyze(file, ...extra) {
  tr('analyze', file, '--report', file + '.report.json', ...extra);
  const r = json(file + '.report.json');
  return { layers: r.layers, paths: r.paths, segments: r.segments };
}
function travelOf(file) {
  const r = json(file + '.report.json');
  return { moves: r.travel_moves, length: r.travel_length_mm };
}
const plan = json('plan_report.json');
tr('plan', 'aero', join(source, 'tests/data/aero/cubic_edges.csv'), '-o', 'cubic_path.json',
  '--report', 'cubic_report.json');
tr('analyze', 'gyroid.cli', '--report', 'cli_report.json');
const cli = json('cli_report.json');
tr('analyze', 'bracket.cli', '--report', 'bracket_report.json');
const bracket = json('bracket_report.json');
const cases = [
  { file: 'part.gcode', expect: analyze('part.gcode') },
  { file: 'prusa.gcode', expect: analyze('prusa.gcode'), travel: travelOf('prusa.gcode') },
  { file: 'sliced.gcode', expect: analyze('sliced.gcode'), travel: travelOf('sliced.gcode') },
  { file: 'octet.nc', args: ['--machine', profile('embedded_aero_410um.toml')],
    expect: analyze('octet.nc', '--valve-on', 'M3', '--valve-off', 'M5') },
  { file: 'gyroid.cli', expect: { layers: cli.layers, paths: cli.vectors } },
  { file: 'bracket.cli', expect: { layers: bracket.layers, paths: bracket.vectors } },
  { file: 'toolpath.json', expect: { layers: plan.layers_count, paths: plan.paths, segments: plan.edges } },
  { file: 'lattice.json', expect: { designLines: plan.lattice_edges } },
  { file: join(source, 'tests/data/aero/cubic_edges.csv'), name: 'cubic_edges.csv',
    expect: { designLines: json('cubic_report.json').struts } },
  { file: 'mix.gcode', expect: analyze('mix.gcode') },
  { file: 'graded.gcode', expect: analyze('graded.gcode') },
  { file: 'plate.gcode', expect: analyze('plate.gcode') },
  { file: 'mix3.gcode', expect: analyze('mix3.gcode') },
  { file: HOSTILE, args: ['--title', HOSTILE_TITLE], expect: analyze(HOSTILE) },
  { file: 'part.bgcode', expect: analyze('part.bgcode') },
  { file: 'dev.gcode', args: ['--design', 'dev_design.json'], expect: { ...analyze('dev.gcode'), designLines: 2 } },
  { file: 'foam.nc', args: ['--design', 'foam.json', '--machine', profile('embedded_aero_410um.toml')],
    expect: { paths: foamCheck.paths, segments: foamCheck.segments, collisions: foamCheck.collisions,
      ringed: foamCheck.collision_list.length, designLines: foamCheck.struts, designFlagged: foamFlagged } },
  { file: 'foam_check.json', args: ['--design', 'foam.json'],
    expect: { collisions: foamCheck.collisions, ringed: foamCheck.collision_list.length, designLines: foamCheck.struts,
      designFlagged: foamFlagged } },
  { file: 'foam.nc', name: 'foam_round_bed.nc', args: ['--machine', join(out, 'round_bed.toml')], expect: analyze('foam.nc', '--valve-on', 'M3', '--valve-off', 'M5') },
  { file: 'foam.nc', name: 'foam_bed.nc', args: ['--machine', profile('embedded_aero_410um.toml')], expect: analyze('foam.nc', '--valve-on', 'M3', '--valve-off', 'M5') },
].filter((c) => !process.env.TV_ONLY || process.env.TV_ONLY.split(',').includes(c.name || c.file));

// --- browser -----------------------------------------------------------------------------------
let browser = await puppeteer.launch({
  executablePath: '/usr/bin/chromium',
  headless: true,
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--mute-audio'],
});

async function open(html) {
  const page = await browser.newPage();
  await page.setViewport({ width: 1000, height: 700 });
  const errors = [];
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('requestfailed', (r) => errors.push('request failed: ' + r.url()));
  page.on('request', (r) => { if (!r.url().startsWith('file:') && !r.url().startsWith('data:')) errors.push('network: ' + r.url()); });
  await page.goto('file://' + html, { waitUntil: 'load' });
  await page.waitForFunction(() => window.trellisViewer !== undefined);
  await page.evaluate(() => window.trellisViewer.whenDrawn());
  return { page, errors };
}

// RGBA of canvas pixels around page pixel (x, y): the (2r+1)² neighbourhood.
async function around(page, x, y, r = 1) {
  return page.evaluate((x, y, r) => {
    const v = window.trellisViewer, gl = v.renderer.getContext();
    const h = gl.drawingBufferHeight, px = new Uint8Array(4), out = [];
    for (let dy = -r; dy <= r; ++dy)
      for (let dx = -r; dx <= r; ++dx) {
        gl.readPixels(Math.floor(x) + dx, h - 1 - (Math.floor(y) + dy), 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
        out.push([px[0], px[1], px[2]]);
      }
    return out;
  }, x, y, r);
}
// Every 2nd canvas pixel, RGB.
async function frame(page) {
  return page.evaluate(() => {
    const gl = window.trellisViewer.renderer.getContext();
    const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    const all = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, all);
    const out = [];
    for (let y = 0; y < h; y += 2) for (let x = 0; x < w; x += 2) { const k = 4 * (y * w + x); out.push(all[k], all[k + 1], all[k + 2]); }
    return out;
  });
}
const BG = [0xf4, 0xf5, 0xf7];
const diff = (a, b) => Math.max(...[0, 1, 2].map((i) => Math.abs(a[i] - b[i])));
const isBg = (c) => diff(c, BG) <= 2;

async function runCase(c, tag = '') {
  const base = c.name || c.file, name = tag + base;
  tagNow = tag;
  const html = join(out, name + '.html');
  tr('view', c.file, ...(c.args || []), '-o', html);
  const { page, errors } = await open(html);
  const st = await page.evaluate(() => window.trellisViewer.stats());
  check(errors.length === 0, `${name}: no console errors${errors.length ? ': ' + errors.join(' | ') : ''}`);
  for (const [k, v] of Object.entries(c.expect))
    check(st[k] === v, `${name}: page ${k} ${st[k]} == Trellis report ${v}`);
  if (c.travel)  // drawn through the travel's corners, as the G-code moves (float32 positions)
    check(st.travelMoves === c.travel.moves && Math.abs(st.travelLength - c.travel.length) <= 1e-4 * c.travel.length + 0.01,
      `${name}: page travel ${st.travelMoves} moves, ${st.travelLength.toFixed(2)} mm == analyze ${c.travel.moves}, ${c.travel.length.toFixed(2)} mm`);
  const shown = await page.$$eval('#tv-stats-table td.v', (tds) => Object.fromEntries(tds.map((td) => [td.dataset.stat, td.textContent])));
  if (c.expect.layers !== undefined)
    check(shown.layers === String(c.expect.layers) && shown.paths === String(c.expect.paths),
      `${name}: statistics panel shows layers ${shown.layers}, paths ${shown.paths}`);
  const legend = await page.$eval('#tv-legend', (e) => e.innerText);
  check(/Feature type/.test(legend), `${name}: legend says what colour means ("${legend.split('\n')[0]}")`);
  // One definition of a path: the legend's counts per feature add up to the panel's.
  const perRole = [...legend.matchAll(/\((\d+) paths\)/g)].map((m) => Number(m[1]));
  if (perRole.length && c.expect.paths !== undefined)
    check(perRole.reduce((a, b) => a + b, 0) === c.expect.paths,
      `${name}: legend counts ${perRole.join(' + ')} = ${c.expect.paths} paths (panel and analyze)`);
  check(/\d mm/.test(await page.$eval('#tv-scale', (e) => e.innerText)), `${name}: scale bar in mm`);
  await page.screenshot({ path: join(out, name + '.png') });
  if (base === 'part.gcode') {
    check(statSync(html).size - statSync(join(out, 'part.gcode')).size < 2e6,
      `part.gcode: page ${statSync(html).size} bytes, under 2 MB plus the data`);
    // Colour modes change the pixels where the model is.
    const a = await frame(page);
    await page.select('#tv-mode', 'order');
    await page.evaluate(() => window.trellisViewer.whenDrawn());
    const b = await frame(page);
    let model = 0, changed = 0;
    for (let i = 0; i < a.length; i += 3) {
      const pa = [a[i], a[i + 1], a[i + 2]], pb = [b[i], b[i + 1], b[i + 2]];
      if (isBg(pa)) continue;
      model += 1;
      if (diff(pa, pb) > 8) changed += 1;
    }
    check(model > 200 && changed > 0.5 * model,
      `part.gcode: feature -> order changes ${changed} of ${model} model pixels`);
    await page.screenshot({ path: join(out, 'part.gcode.order.png') });
  }
  if (base === 'mix.gcode') {
    await page.click('#tv-top');
    for (const mode of ['mixture', 'temperature']) {
      await page.select('#tv-mode', mode);
      await page.evaluate(() => window.trellisViewer.whenDrawn());
      let worst = 0;
      for (const i of [1, 4, 8]) {
        const value = mode === 'mixture' ? i / 10 : 200 + 3 * i;
        const [x, y] = await page.evaluate((yy) => window.trellisViewer.project(4.5, yy, 0.2), 2 * i);
        const bar = await page.evaluate((v) => {
          const at = window.trellisViewer.colorbarAt(v), cv = document.getElementById('tv-colorbar');
          const r = cv.getBoundingClientRect();
          const p = cv.getContext('2d').getImageData(Math.round(at.x - r.left - 1.5), 7, 1, 1).data;
          return [p[0], p[1], p[2]];
        }, value);
        const px = await around(page, x, y, 1);
        const best = Math.min(...px.map((p) => diff(p, bar)));
        worst = Math.max(worst, best);
        const next = mode === 'mixture' ? (i + 1) / 10 : 200 + 3 * (i + 1);
        const barNext = await page.evaluate((v) => window.trellisViewer.colorbarAt(v).color, next);
        check(best <= 6 && diff(bar, barNext) > 12,
          `mix.gcode: ${mode} ${value}: segment pixel within ${best} of the colour bar at that value (neighbour value ${diff(bar, barNext)} away)`);
      }
      await page.screenshot({ path: join(out, `mix.gcode.${mode}.png`) });
    }
    // One picture language: `trellis render` draws mixtures 0, 0.5 and 1 in the palette's
    // colours, and the viewer's pixels on the same lines are those colours too.
    await page.select('#tv-mode', 'mixture');
    await page.evaluate(() => window.trellisViewer.whenDrawn());
    tr('render', 'mix.gcode', '--layer', '0', '--colour', 'mixture', '--no-travel', '-o', 'mix.layer0.png');
    const pngPixel = async (x, y) => page.evaluate(async (data, x, y) => {
      const img = new Image();
      img.src = 'data:image/png;base64,' + data;
      await img.decode();
      const cv = document.createElement('canvas');
      cv.width = img.width; cv.height = img.height;
      const ctx = cv.getContext('2d');
      ctx.drawImage(img, 0, 0);
      const p = ctx.getImageData(x, y, 1, 1).data;
      return [p[0], p[1], p[2]];
    }, readFileSync(join(out, 'mix.layer0.png')).toString('base64'), x, y);
    // The PNG's geometry (src/render/render.cpp): 20 x 20 mm plus 1 mm margins in 1000 px, a title
    // band of 1000 / 12 px above.
    const s = 1000 / 22, band = Math.floor(1000 / 12);
    for (const i of [0, 5, 10]) {
      const want = paletteMix(i / 10);
      const png = await pngPixel(Math.round((10 + 1) * s), Math.round(band + 1000 - (2 * i + 1) * s));
      const [x, y] = await page.evaluate((yy) => window.trellisViewer.project(4.5, yy, 0.2), 2 * i);
      const best = Math.min(...(await around(page, x, y, 1)).map((p) => diff(p, png)));
      check(diff(png, want) === 0 && best <= 2,
        `mix.gcode: mixture ${i / 10}: PNG pixel ${png} == palette ${want}, viewer pixel within ${best} of it`);
    }
    // The layer slider hides the layers above: a point on a layer-2 line only.
    const [x, y] = await page.evaluate(() => window.trellisViewer.project(5, 11, 0.4));
    const before = await around(page, x, y, 2);
    await page.evaluate(() => { const e = document.getElementById('tv-layer-hi'); e.value = 0; e.dispatchEvent(new Event('input')); });
    await page.evaluate(() => window.trellisViewer.whenDrawn());
    const after = await around(page, x, y, 2);
    check(before.some((p) => !isBg(p)) && after.every(isBg),
      `mix.gcode: layer 2 drawn at (${x.toFixed(0)}, ${y.toFixed(0)}) before, gone with the slider at layer 1`);
    const label = await page.$eval('#tv-layer-label', (e) => e.textContent);
    check(/^1 of 2/.test(label), `mix.gcode: layer label "${label}"`);
    await page.screenshot({ path: join(out, 'mix.gcode.layer1.png') });
  }
  if (base === 'graded.gcode') {
    // Feature type: the lines carry the non-planar role, by name.
    const roles = await page.$eval('#tv-legend', (e) => e.innerText);
    check(/nonplanar \(40 paths\)/.test(roles) && !/other/.test(roles), `graded.gcode: feature legend "${roles.replace(/\n/g, ' ')}"`);
    await page.click('#tv-top');
    // Deposited (the default mixture mode): every line in the colour of its planned mixture.
    // Commanded: the lines printed while the next change was already issued show the next one.
    // The file is placed on the bed: line i runs along X at the part's lowest y + 2i.
    const lineColours = async () => {
      const got = [];
      for (let i = 0; i < 40; ++i) {
        const [x, y] = await page.evaluate((i) => {
          const v = window.trellisViewer, b = v.s.bbox;
          return v.project(b.min.x + 45, b.min.y + 2 * i, b.min.z);
        }, i);
        got.push(await around(page, x, y, 1));
      }
      return got;
    };
    await page.select('#tv-mode', 'mixture');
    await page.evaluate(() => window.trellisViewer.whenDrawn());
    const depLegend = await page.$eval('#tv-legend', (e) => e.innerText);
    const dep = await lineColours();
    let depOk = 0;
    dep.forEach((px, i) => { if (Math.min(...px.map((p) => diff(p, paletteMix(GRADE(i))))) <= 6) depOk += 1; });
    check(depOk === 40, `graded.gcode: as deposited, ${depOk} of 40 lines in their planned mixture's colour`);
    check(/as deposited/.test(depLegend) && /960 mm/.test(depLegend), `graded.gcode: legend "${depLegend.replace(/\n/g, ' ')}"`);
    await page.screenshot({ path: join(out, 'graded.gcode.deposited.png') });
    await page.select('#tv-mode', 'commanded');
    await page.evaluate(() => window.trellisViewer.whenDrawn());
    const cmdLegend = await page.$eval('#tv-legend', (e) => e.innerText);
    const cmd = await lineColours();
    let cmdOff = 0;
    cmd.forEach((px, i) => { if (Math.min(...px.map((p) => diff(p, paletteMix(GRADE(i))))) > 6) cmdOff += 1; });
    // Commanded 16 lines early: lines 4-19 show 0.2-0.8 where 0 is planned, lines 20-35 the
    // next steps' mixtures; only 0-3 and 36-39 agree.
    check(cmdOff === 32, `graded.gcode: as commanded, ${cmdOff} of 40 lines show another mixture than planned`);
    check(/as commanded/.test(cmdLegend), `graded.gcode: legend "${cmdLegend.replace(/\n/g, ' ')}"`);
    await page.screenshot({ path: join(out, 'graded.gcode.commanded.png') });
  }
  if (base === 'gyroid.cli') {
    const shown = await page.$$eval('#tv-stats-table td.v', (tds) => Object.fromEntries(tds.map((td) => [td.dataset.stat, td.textContent])));
    const legend = await page.$eval('#tv-legend', (e) => e.innerText);
    check(shown['scan length'] !== undefined && shown['extruded length'] === undefined,
      `gyroid.cli: a laser file shows "scan length" (${shown['scan length']}), no extruded length`);
    check(/hatch/.test(legend) && /contour/.test(legend) && !/infill/.test(legend), `gyroid.cli: feature legend "${legend.replace(/\n/g, ' ')}"`);
  }
  if (base === 'bracket.cli') {
    // Coloured by laser parameter set: one legend entry per set `trellis analyze` names, with
    // its vector count, in the colours `trellis render --colour set` uses.
    await page.select('#tv-mode', 'set');
    await page.evaluate(() => window.trellisViewer.whenDrawn());
    const legend = await page.$eval('#tv-legend', (e) => e.innerText);
    const want = bracket.parameter_sets.map((p) => `${p.name} (${p.vectors} paths)`).sort();
    const got = [...legend.matchAll(/^(.*\(\d+ paths\))$/gm)].map((m) => m[1].trim()).sort();
    check(bracket.parameter_sets.length === 3 && JSON.stringify(got) === JSON.stringify(want),
      `bracket.cli: set legend ${JSON.stringify(got)} == analyze ${JSON.stringify(want)}`);
    check(/Laser parameter set/.test(legend), `bracket.cli: legend says "Laser parameter set"`);
    await page.screenshot({ path: join(out, 'bracket.cli.set.png') });
  }
  if (base === HOSTILE) {
    const title = await page.title();
    check(title === HOSTILE_TITLE, `${name}: the page title is the --title as given ("${title}")`);
    check(await page.evaluate(() => window.pwned === undefined), `${name}: no script from the file or the title ran`);
    const index = await page.evaluate(() => JSON.parse(document.getElementById('tv-index').textContent).title);
    check(index === HOSTILE_TITLE, `${name}: the data block holds the title as given`);
  }
  if (base === 'mix3.gcode') {
    await page.click('#tv-top');
    await page.select('#tv-mode', 'mixture');
    await page.evaluate(() => window.trellisViewer.whenDrawn());
    check(await page.$('#tv-triangle') !== null, 'mix3.gcode: three materials: the mixture triangle is the legend');
    for (const [i, w] of MIX3.entries()) {
      const [x, y] = await page.evaluate((yy) => window.trellisViewer.project(4.5, yy, 0.2), 2 * i);
      const tri = await page.evaluate((w) => {
        const at = window.trellisViewer.triangleAt(w);
        const p = document.getElementById('tv-triangle').getContext('2d').getImageData(Math.floor(at.cx), Math.floor(at.cy), 1, 1).data;
        return [p[0], p[1], p[2]];
      }, w);
      const px = await around(page, x, y, 1);
      const best = Math.min(...px.map((p) => diff(p, tri)));
      // The nearest other mixture of the file, on the triangle: the colours must tell them apart.
      let other = 255;
      for (const [j, v] of MIX3.entries())
        if (j !== i) other = Math.min(other, diff(tri, await page.evaluate((v) => window.trellisViewer.triangleAt(v).color, v)));
      check(best <= 6 && other > 12,
        `mix3.gcode: mixture ${w.join(':')}: segment pixel within ${best} of the triangle at that mixture (next mixture ${other} away)`);
    }
    await page.screenshot({ path: join(out, 'mix3.gcode.mixture.png') });
  }
  if (base === 'dev.gcode') {
    await page.click('#tv-top');
    await page.click('#tv-design');  // the design struts off: the print's own colours
    await page.select('#tv-mode', 'deviation');
    await page.evaluate(() => window.trellisViewer.whenDrawn());
    for (const d of [0.25, 0.5, 1]) {
      const [x, y] = await page.evaluate((yy) => window.trellisViewer.project(10, yy, 0.2), d);
      const bar = await page.evaluate((v) => {
        const at = window.trellisViewer.colorbarAt(v), cv = document.getElementById('tv-colorbar');
        const r = cv.getBoundingClientRect();
        const p = cv.getContext('2d').getImageData(Math.round(at.x - r.left - 1.5), 7, 1, 1).data;
        return [p[0], p[1], p[2]];
      }, d);
      const px = await around(page, x, y, 1);
      const best = Math.min(...px.map((p) => diff(p, bar)));
      const zero = await page.evaluate(() => window.trellisViewer.colorbarAt(0).color);
      check(best <= 6 && diff(bar, zero) > 12,
        `dev.gcode: a line ${d} mm beside the design strut: pixel within ${best} of the colour bar at ${d} mm`);
    }
    const legend = await page.$eval('#tv-legend', (e) => e.innerText);
    check(/Deviation from the design/.test(legend) && /1\.0 mm/.test(legend), `dev.gcode: colour bar "${legend.replace(/\n/g, ' ')}"`);
    await page.screenshot({ path: join(out, 'dev.gcode.deviation.png') });
  }
  if (base === 'foam.nc') {
    await page.select('#tv-mode', 'collisions');
    await page.evaluate(() => window.trellisViewer.whenDrawn());
    // Every listed collision is ringed: the ring colour around the hit point.
    const RING = [220, 20, 60];
    let ringed = 0;
    for (const h of foamCheck.collision_list) {
      const [x, y] = await page.evaluate((p) => window.trellisViewer.project(...p), h.point);
      // A ring, not the colliding line through the point: ring colour at the ring's radius
      // (22 px marker, circle of radius 25/64 of it) in at least 6 of 8 directions.
      let dirs = 0;
      for (let k = 0; k < 8; ++k) {
        const a = (k * Math.PI) / 4, r = 22 * 25 / 64;
        const px = await around(page, x + r * Math.cos(a), y + r * Math.sin(a), 1);
        if (px.some((p) => diff(p, RING) <= 10)) dirs += 1;
      }
      if (dirs >= 6) ringed += 1;
    }
    check(ringed === foamCheck.collision_list.length, `foam.nc: ${ringed} of ${foamCheck.collision_list.length} collisions ringed on screen`);
    // The colliding segments are red: at each one's midpoint, away from every ring.
    const rings = [];
    for (const h of foamCheck.collision_list) rings.push(await page.evaluate((p) => window.trellisViewer.project(...p), h.point));
    let tested = 0, red = 0;
    for (const h of foamCheck.collision_list) {
      const seg = await page.evaluate((path, segment) => {
        const v = window.trellisViewer, s = v.s, k = (s.pathFirst[path] + segment) * 3, P = s.positions;
        return [(P[k] + P[k + 3]) / 2, (P[k + 1] + P[k + 4]) / 2, (P[k + 2] + P[k + 5]) / 2];
      }, h.path, h.segment);
      const [x, y] = await page.evaluate((p) => window.trellisViewer.project(...p), seg);
      if (rings.some(([rx, ry]) => Math.hypot(rx - x, ry - y) < 14)) continue;
      tested += 1;
      if ((await around(page, x, y, 1)).some((p) => diff(p, RING) <= 10)) red += 1;
    }
    check(tested >= 3 && red === tested, `foam.nc: ${red} of ${tested} colliding segments (away from the rings) drawn red`);
    const legend = await page.$eval('#tv-legend', (e) => e.innerText);
    check(new RegExp(`${foamCheck.collisions} collisions`).test(legend), `foam.nc: legend names the ${foamCheck.collisions} collisions`);
    await page.screenshot({ path: join(out, 'foam.nc.collisions.png') });
  }
  if (base === 'foam_check.json') await page.screenshot({ path: join(out, 'foam_check.json.png') });
  if (base === 'foam_round_bed.nc') {
    const bed = await page.evaluate(() => window.trellisViewer.bedBox());
    const close = (a, b) => a.every((v, i) => Math.abs(v - b[i]) < 1e-3);
    check(bed && close(bed.min, [-100, -100, 0]) && close(bed.max, [100, 100, 100]),
      `foam_round_bed.nc: round build volume ${bed && bed.min.map((v) => v.toFixed(1))} to ${bed && bed.max.map((v) => v.toFixed(1))} (profile: circle of 200 mm, centre origin, 100 mm high)`);
    await page.screenshot({ path: join(out, 'foam_round_bed.nc.png') });
  }
  if (base === 'foam_bed.nc') {
    // The camera frames the part, not the 300 mm bed: the part's box spans over a third of the
    // view and lies inside it.
    const span = await page.evaluate(() => {
      const v = window.trellisViewer, b = v.s.bbox, xs = [], ys = [];
      for (const x of [b.min.x, b.max.x]) for (const y of [b.min.y, b.max.y]) for (const z of [b.min.z, b.max.z]) {
        const [px, py] = v.project(x, y, z); xs.push(px); ys.push(py);
      }
      return { w: Math.max(...xs) - Math.min(...xs), h: Math.max(...ys) - Math.min(...ys), x0: Math.min(...xs), x1: Math.max(...xs),
        y0: Math.min(...ys), y1: Math.max(...ys), W: window.innerWidth, H: window.innerHeight };
    });
    check(Math.max(span.w / span.W, span.h / span.H) > 0.33 && span.x0 >= 0 && span.y0 >= 0 && span.x1 <= span.W && span.y1 <= span.H,
      `foam_bed.nc: the camera frames the part: ${span.w.toFixed(0)} x ${span.h.toFixed(0)} px of ${span.W} x ${span.H}`);
    await page.screenshot({ path: join(out, 'foam_bed.nc.png') });
    const bed = await page.evaluate(() => window.trellisViewer.bedBox());
    // Framed with the build volume (the page's API), its edges show.
    await page.evaluate(() => window.trellisViewer.view('iso', true));
    await page.evaluate(() => window.trellisViewer.whenDrawn());
    check(bed && bed.min.join() === '0,0,0' && bed.max.join() === '300,300,100',
      `foam_bed.nc: build volume ${bed && bed.min.join(',')} to ${bed && bed.max.join(',')} (profile: 300 x 300 x 100 mm, corner origin)`);
    const on = await frame(page);
    await page.click('#tv-bed');
    await page.evaluate(() => window.trellisViewer.whenDrawn());
    const off = await frame(page);
    await page.click('#tv-bed');
    await page.evaluate(() => window.trellisViewer.view('iso', true));
    await page.evaluate(() => window.trellisViewer.whenDrawn());
    const again = await frame(page);
    const dark = (f) => { let n = 0; for (let i = 0; i < f.length; i += 3) if (diff([f[i], f[i + 1], f[i + 2]], [0x5a, 0x62, 0x70]) <= 12) n += 1; return n; };
    check(dark(on) > 300 && dark(again) > 300 && dark(off) < dark(on) / 10,
      `foam_bed.nc: build volume edges ${dark(on)} pixels, ${dark(off)} when switched off`);
  }
  await page.close();
}
for (const c of cases) await runCase(c);
// Python: Toolpath._repr_html_ inside a notebook-like page.
{
  execFileSync('/usr/bin/python3', ['-c', `
import trellis
t = trellis.read_toolpath("toolpath.json")
open("notebook.html", "w").write("<html><body><h2>In [1]: toolpath</h2>" + t._repr_html_() + "</body></html>")
`], { cwd: out, env: { ...process.env, PYTHONPATH: pythonDir } });
  const page = await browser.newPage();
  await page.setViewport({ width: 1000, height: 700 });
  const errors = [];
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(e.message));
  await page.goto('file://' + join(out, 'notebook.html'), { waitUntil: 'load' });
  const frame = page.frames().find((f) => f !== page.mainFrame());
  await frame.waitForFunction(() => window.trellisViewer !== undefined);
  await frame.evaluate(() => window.trellisViewer.whenDrawn());
  const st = await frame.evaluate(() => window.trellisViewer.stats());
  check(errors.length === 0, `python _repr_html_: no console errors${errors.length ? ': ' + errors.join(' | ') : ''}`);
  check(st.layers === plan.layers_count && st.paths === plan.paths && st.segments === plan.edges,
    `python _repr_html_: viewer in the iframe shows ${st.layers} layer(s), ${st.paths} paths, ${st.segments} segments (plan report ${plan.layers_count}, ${plan.paths}, ${plan.edges})`);
  await page.screenshot({ path: join(out, 'python_repr_html.png') });
  await page.close();
}
await browser.close();

// Firefox (Debian's firefox-esr, driven over WebDriver BiDi): the same pages from file://, with
// WebGL on Mesa's software renderer. The same checks as in Chromium for one file of each kind.
if (!existsSync('/usr/bin/firefox-esr')) check(false, 'firefox: /usr/bin/firefox-esr missing (scripts/install-deps.sh installs it)');
else {
  browser = await puppeteer.launch({
    browser: 'firefox', executablePath: '/usr/bin/firefox-esr', headless: true,
    extraPrefsFirefox: { 'webgl.force-enabled': true, 'gfx.webrender.software': true, 'webgl.out-of-process': false },
    env: { ...process.env, LIBGL_ALWAYS_SOFTWARE: '1', MOZ_HEADLESS: '1', EGL_PLATFORM: 'surfaceless', MOZ_WEBGL_FORCE_EGL: '1' },
  });
  const firefoxCases = new Set(['part.gcode', 'mix.gcode', 'mix3.gcode', 'gyroid.cli', 'foam.nc', 'lattice.json']);
  for (const c of cases) if (firefoxCases.has(c.name || c.file)) await runCase(c, 'firefox.');
  await browser.close();
}
console.log(failures ? `${failures} check(s) failed` : 'all checks passed');
process.exit(failures ? 1 : 0);
