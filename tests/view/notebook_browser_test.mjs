// The viewer in a notebook, in headless Chromium: a notebook with two toolpath views is run in a
// Jupyter kernel (nbclient) and exported to HTML by nbconvert, as a reader gets it. The first view
// carries the viewer's script, the second only its data; both must draw, with the counts of the
// toolpath shown, and only the first may carry the script. A page holding only a data view (the
// output with the script cleared) must say so instead of staying blank.
// Usage: node notebook_browser_test.mjs TRELLIS SOURCE_DIR NODE_MODULES OUT_DIR PYTHON_PACKAGE_DIR
import { createRequire } from 'node:module';
import { execFileSync } from 'node:child_process';
import { mkdirSync, readFileSync, rmSync } from 'node:fs';
import { join } from 'node:path';

const [trellis, source, nodeModules, out, pythonDir] = process.argv.slice(2);
const require = createRequire(join(nodeModules, 'noop.js'));
const puppeteer = require('puppeteer-core');
rmSync(out, { recursive: true, force: true });
mkdirSync(out, { recursive: true });

let failures = 0;
function check(ok, what) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures += 1;
}
const tr = (...args) => execFileSync(trellis, args, { cwd: out, stdio: ['ignore', 'pipe', 'pipe'] });
tr('lattice2d', '--pattern', 'honeycomb', '--cell', '1', '-o', 'lattice.json');
tr('plan', 'gippo', 'lattice.json', '-o', 'honeycomb.json');
tr('lattice3d', '--cell-type', 'octet', '--cell', '7', '--count', '2,2,2', '-o', 'octet.json');
tr('plan', 'aero', 'octet.json', '-o', 'octet_path.json');

// Run the notebook and export it; write the page of a data view alone; and the counts to expect.
execFileSync('/usr/bin/python3', ['-c', `
import json, nbformat, trellis
from nbclient import NotebookClient
from nbconvert import HTMLExporter
from nbformat.v4 import new_code_cell, new_notebook
nb = new_notebook(cells=[
    new_code_cell("import trellis\\na = trellis.read_toolpath('honeycomb.json')\\nb = trellis.read_toolpath('octet_path.json')"),
    new_code_cell("a"), new_code_cell("b")])
NotebookClient(nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": "."}}).execute()
nbformat.write(nb, "two_views.ipynb")
html = [c.outputs[0]["data"]["text/html"] for c in nb.cells[1:]]
open("two_views.html", "w").write(HTMLExporter().from_notebook_node(nb)[0])
open("data_only.html", "w").write("<html><body><h2>Out[3]</h2>" + html[1] + "</body></html>")
script = trellis._trellis.viewer_notebook_script()
counts = []
for name in ("honeycomb.json", "octet_path.json"):
    t = trellis.read_toolpath(name)
    o = t.path_offsets  # first and last points of three paths, to compare with what the page unpacked
    probe = {int(p): [t.points[o[p]].tolist(), t.points[o[p + 1] - 1].tolist()] for p in (0, t.path_count // 2, t.path_count - 1)}
    counts.append({"layers": t.layer_count, "paths": t.path_count, "segments": t.point_count - t.path_count, "probe": probe})
json.dump({"counts": counts, "sizes": [len(h) for h in html], "script": len(script),
           "first_has_script": html[0].startswith(script), "second_has_script": script in html[1]},
          open("expect.json", "w"))
`], { cwd: out, env: { ...process.env, PYTHONPATH: pythonDir, PYDEVD_DISABLE_FILE_VALIDATION: '1' }, stdio: ['ignore', 'inherit', 'inherit'] });
const expect = JSON.parse(readFileSync(join(out, 'expect.json'), 'utf8'));
check(expect.first_has_script && !expect.second_has_script,
  `the first view carries the viewer script (${expect.script} bytes), the second only its data (${expect.sizes[1]} bytes)`);

const browser = await puppeteer.launch({
  executablePath: '/usr/bin/chromium',
  headless: true,
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--mute-audio'],
});

async function open(file) {
  const page = await browser.newPage();
  await page.setViewport({ width: 1100, height: 1400 });
  const errors = [];
  // Failed loads are judged by their URL (requestfailed), not by the console's copy of them.
  page.on('console', (m) => { if (m.type() === 'error' && !/^Failed to load resource/.test(m.text())) errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(e.message));
  // Debian's nbconvert page links require.js and MathJax from /usr/share/javascript (packages
  // this test does not need); nothing of ours may fail, and nothing is fetched from a network.
  page.on('requestfailed', (r) => { if (!r.url().startsWith('file:///usr/share/javascript/')) errors.push('request failed: ' + r.url()); });
  await page.setRequestInterception(true);
  page.on('request', (r) => (r.url().startsWith('file:') || r.url().startsWith('about:') || r.url().startsWith('data:') ? r.continue() : r.abort()));
  await page.goto('file://' + join(out, file), { waitUntil: 'load' });
  return { page, errors };
}

const BG = [0xf4, 0xf5, 0xf7];
{
  const { page, errors } = await open('two_views.html');
  await page.waitForFunction(() => document.querySelectorAll('iframe.trellis-view').length === 2, { timeout: 30000 });
  const frames = page.frames().filter((f) => f !== page.mainFrame());
  check(frames.length === 2, `two viewer frames in the exported notebook (${frames.length})`);
  for (const [i, frame] of frames.entries()) {
    await frame.waitForFunction(() => window.trellisViewer !== undefined, { timeout: 30000 });
    await frame.evaluate(() => window.trellisViewer.whenDrawn());
    const st = await frame.evaluate(() => window.trellisViewer.stats());
    const want = expect.counts[i];
    check(st.layers === want.layers && st.paths === want.paths && st.segments === want.segments,
      `view ${i + 1}${i ? ' (data only)' : ''}: ${st.layers} layers, ${st.paths} paths, ${st.segments} segments (toolpath: ${want.layers}, ${want.paths}, ${want.segments})`);
    // Positions unpacked from 1 µm steps: within half a step (and float32) of the toolpath's.
    let worst = 0;
    for (const [p, [first, last]] of Object.entries(want.probe)) {
      const got = await frame.evaluate((p) => {
        const s = window.trellisViewer.s, P = s.positions, a = s.pathFirst[p] * 3, b = (s.pathFirst[p + 1] - 1) * 3;
        return [[P[a], P[a + 1], P[a + 2]], [P[b], P[b + 1], P[b + 2]]];
      }, Number(p));
      for (const [g, w] of [[got[0], first], [got[1], last]]) for (let k = 0; k < 3; ++k) worst = Math.max(worst, Math.abs(g[k] - w[k]));
    }
    check(worst <= 6e-4, `view ${i + 1}: first and last points of three paths within ${worst.toExponential(1)} mm of the toolpath's`);
    const drawn = await frame.evaluate((bg) => {
      const gl = window.trellisViewer.renderer.getContext();
      const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight, px = new Uint8Array(w * h * 4);
      gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
      let n = 0;
      for (let k = 0; k < px.length; k += 4) if (Math.max(...[0, 1, 2].map((c) => Math.abs(px[k + c] - bg[c]))) > 8) n += 1;
      return n;
    }, BG);
    check(drawn > 500, `view ${i + 1}: ${drawn} model pixels drawn`);
  }
  check(errors.length === 0, `no console errors${errors.length ? ': ' + errors.join(' | ') : ''}`);
  await page.screenshot({ path: join(out, 'two_views.png'), fullPage: true });
  await page.close();
}
{
  const { page, errors } = await open('data_only.html');
  await page.waitForFunction(() => /not on this page/.test(document.querySelector('.tv-nb-msg').textContent), { timeout: 10000 })
    .catch(() => {});
  const msg = await page.$eval('.tv-nb-msg', (e) => e.textContent);
  const frames = await page.$$('iframe');
  check(/viewer script is not on this page/.test(msg) && /notebook_viewer\(\)/.test(msg) && frames.length === 0,
    `a data view without the script says so: "${msg.slice(0, 80)}..."`);
  check(errors.length === 0, `data view alone: no console errors${errors.length ? ': ' + errors.join(' | ') : ''}`);
  await page.screenshot({ path: join(out, 'data_only.png') });
  await page.close();
}
await browser.close();
console.log(failures ? `${failures} check(s) failed` : 'all checks passed');
process.exit(failures ? 1 : 0);
