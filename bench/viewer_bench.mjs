// Viewer benchmark (`make bench-viewer`): a ~100 MB G-code file (bench/make_large_gcode.py) through
// `trellis view`, opened in headless Chromium (Debian's chromium, software WebGL): time to write
// the page, time from navigation to the first picture, time until the full-detail picture, and
// frames per second while orbiting the whole model (reduced drawing, as while the mouse moves) and
// at full detail.
// Usage: node viewer_bench.mjs TRELLIS NODE_MODULES WORK_DIR [MEGABYTES=100]
import { createRequire } from 'node:module';
import { execFileSync } from 'node:child_process';
import { mkdirSync, statSync } from 'node:fs';
import { join, dirname, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

const [trellisArg, nodeModules, workArg, mb = '100'] = process.argv.slice(2);
const trellis = resolve(trellisArg), work = resolve(workArg);
const puppeteer = createRequire(join(resolve(nodeModules), 'noop.js'))('puppeteer-core');
mkdirSync(work, { recursive: true });
const gcode = join(work, 'large.gcode'), html = join(work, 'large.html');
const here = dirname(fileURLToPath(import.meta.url));
execFileSync('/usr/bin/python3', [join(here, 'make_large_gcode.py'), gcode, mb], { stdio: 'inherit' });
let t = Date.now();
const summary = execFileSync(trellis, ['view', gcode, '-o', html], { encoding: 'utf8' });
const writeMs = Date.now() - t;
const browser = await puppeteer.launch({ executablePath: '/usr/bin/chromium', headless: true,
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'] });
const page = await browser.newPage();
await page.setViewport({ width: 1200, height: 800 });
const errors = [];
page.on('pageerror', (e) => errors.push(e.message));
page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
await page.goto('file://' + html, { waitUntil: 'load', timeout: 300000 });
await page.waitForFunction(() => window.trellisViewer && window.trellisViewer.firstFrameMs !== undefined,
  { timeout: 300000 });
const st = await page.evaluate(() => window.trellisViewer.stats());
t = Date.now();
await page.evaluate(() => window.trellisViewer.whenDrawn());
const refineMs = Date.now() - t;
const fps = await page.evaluate(() => window.trellisViewer.measureFps(60));
const fullFps = await page.evaluate(() => window.trellisViewer.measureFps(3, false));
await page.evaluate(() => window.trellisViewer.whenDrawn());
await page.screenshot({ path: join(work, 'large.png') });
await browser.close();
const r = (v, d = 0) => v.toFixed(d);
console.log(summary.trim());
console.log(`G-code ${r(statSync(gcode).size / 1e6, 1)} MB, page ${r(statSync(html).size / 1e6, 1)} MB, ` +
  `${st.segments} segments in ${st.layers} layers`);
console.log(`trellis view: ${writeMs} ms`);
console.log(`browser: first picture ${r(st.firstFrameMs)} ms after navigation start (decode ${r(st.decodeMs)} ms), ` +
  `full detail ${refineMs} ms later`);
console.log(`orbit: ${r(fps, 1)} fps drawing ${st.reducedSegments} of ${st.segments} segments while moving; ` +
  `${r(fullFps, 2)} fps at full detail`);
console.log(`console errors: ${errors.length}`);
process.exit(errors.length ? 1 : 0);
