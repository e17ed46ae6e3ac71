// Build step (run by CMake, see src/CMakeLists.txt): bundles src/main.js with three.js (from
// node_modules, installed by `npm ci` from package-lock.json) into src/template.html and writes
// the page as a C++ string literal (viewer_template.inc) that libtrellis compiles in; and the
// notebook loader src/notebook.js, minified, as viewer_notebook.inc beside it.
// Usage: node build.mjs OUT.inc [NODE_MODULES_DIR] [OUT.html]
import { createRequire } from 'node:module';
import { readFileSync, writeFileSync, renameSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const [out, nodeModules, htmlOut] = process.argv.slice(2);
if (!out) {
  console.error('usage: node build.mjs OUT.inc [NODE_MODULES_DIR] [OUT.html]');
  process.exit(2);
}
// esbuild from the given node_modules (the build tree's `npm ci`), else from next to this script.
const require = createRequire(join(nodeModules || join(here, 'node_modules'), 'noop.js'));
const { build, transform } = require('esbuild');
const result = await build({
  entryPoints: [join(here, 'src', 'main.js')],
  bundle: true,
  minify: true,
  format: 'iife',
  target: ['chrome110', 'firefox115'],
  write: false,
  legalComments: 'eof',
  nodePaths: nodeModules ? [nodeModules] : [],
  logLevel: 'warning',
});
const js = result.outputFiles[0].text;
if (/<\/script/i.test(js)) throw new Error('bundle contains "</script"');
const template = readFileSync(join(here, 'src', 'template.html'), 'utf8');
const marker = '/*TRELLIS_BUNDLE*/';
if (!template.includes(marker) || !template.includes('<!--TRELLIS_DATA-->'))
  throw new Error('template.html lost its markers');
const html = template.replace(marker, () => js);
const delim = 'TVIEW';
if (html.includes(')' + delim + '"')) throw new Error('page contains the raw-string delimiter');
// Adjacent raw literals of at most 60000 bytes each (some compilers limit one literal's length).
function writeLiteral(file, text) {
  const parts = [];
  const buf = Buffer.from(text, 'utf8');
  for (let i = 0; i < buf.length; ) {
    let j = Math.min(buf.length, i + 60000);
    while (j < buf.length && (buf[j] & 0xc0) === 0x80) --j;  // do not split a UTF-8 character
    parts.push('R"' + delim + '(' + buf.subarray(i, j).toString('utf8') + ')' + delim + '"');
    i = j;
  }
  writeFileSync(file + '.tmp', parts.join('\n') + '\n');
  renameSync(file + '.tmp', file);
  return buf.length;
}
const pageBytes = writeLiteral(out, html);
const loader = (await transform(readFileSync(join(here, 'src', 'notebook.js'), 'utf8'),
  { minify: true, target: ['chrome110', 'firefox115'], loader: 'js', legalComments: 'none' })).code;
if (loader.split('TRELLIS_PAGE').length !== 2) throw new Error('notebook.js: TRELLIS_PAGE must occur once');
if (/<\/script|<!--/i.test(loader) || loader.includes(')' + delim + '"')) throw new Error('notebook.js: unsafe text');
writeLiteral(join(dirname(out), 'viewer_notebook.inc'), loader);
if (htmlOut) writeFileSync(htmlOut, html);
console.log(`viewer: ${(pageBytes / 1024).toFixed(0)} KiB page template -> ${out}`);
