// Shared pieces of the headless-Chromium scripts (run-e2e.mjs, live-e2e.mjs, screenshot.mjs): a
// static file server for the built viewer, a launcher for Debian's /usr/bin/chromium through
// playwright-core (never downloads a browser), and the e2e tests' start-up (arguments, skip /
// fail / check reporting, building the viewer).
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';

export const CHROMIUM = process.env.MASKADAPT_CHROMIUM || '/usr/bin/chromium';

/** Chromium flags: headless, no network chatter, WebGL through SwiftShader (no GPU needed). */
export const CHROMIUM_ARGS = [
  '--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync',
  // WebGL without a GPU: Chromium's software rasteriser (SwiftShader via ANGLE).
  '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
];

const TYPES = { '.html': 'text/html', '.js': 'text/javascript', '.css': 'text/css', '.json': 'application/json' };

/**
 * Serves directory `dir` on 127.0.0.1 at a free port.
 * @returns {Promise<{url: string, close: () => void}>}
 */
export async function serveDir(dir) {
  const root = path.resolve(dir);
  const server = http.createServer((req, res) => {
    const rel = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    const file = path.join(root, rel === '/' ? 'index.html' : rel);
    if (!file.startsWith(root) || !fs.existsSync(file) || fs.statSync(file).isDirectory()) {
      res.writeHead(404).end();
      return;
    }
    res.writeHead(200, { 'content-type': TYPES[path.extname(file)] || 'application/octet-stream' });
    fs.createReadStream(file).pipe(res);
  });
  await new Promise((r) => server.listen(0, '127.0.0.1', r));
  return { url: `http://127.0.0.1:${server.address().port}/`, close: () => server.close() };
}

/**
 * Launches headless Chromium with a throw-away profile.
 * @param viewport {width, height} in CSS pixels
 * @returns {Promise<{context, page, close: () => Promise<void>}>} page errors collect in page.errors
 */
export async function launchChromium(viewport = { width: 1280, height: 720 }) {
  const { chromium } = await import('playwright-core');
  const userDataDir = fs.mkdtempSync(path.join(os.tmpdir(), 'maskadapt-viewer-chromium-'));
  let context;
  try {
    context = await chromium.launchPersistentContext(userDataDir, {
      executablePath: CHROMIUM,
      headless: true,
      viewport,
      args: CHROMIUM_ARGS,
    });
  } catch (e) {
    fs.rmSync(userDataDir, { recursive: true, force: true });
    throw e;
  }
  const page = context.pages()[0] || (await context.newPage());
  page.errors = [];
  page.on('pageerror', (e) => page.errors.push(e.message));
  page.on('console', (m) => m.type() === 'error' && page.errors.push(m.text()));
  const close = async () => {
    await context.close();
    fs.rmSync(userDataDir, { recursive: true, force: true });
  };
  return { context, page, close };
}

/**
 * Fraction of the pixels of the canvas `selector` (copied into a 2-D canvas) that a predicate
 * accepts. `makeMatch(arg)` returns the predicate (r, g, b) => boolean; it runs in the page, sent
 * as its source text, so it may use nothing from its surroundings but `arg` (JSON).
 */
export function canvasShare(page, selector, makeMatch, arg) {
  return page.evaluate(([selector, source, arg]) => {
    const match = new Function(`return (${source});`)()(arg);
    const src = document.querySelector(selector);
    const c = document.createElement('canvas');
    c.width = src.width;
    c.height = src.height;
    const ctx = c.getContext('2d');
    ctx.drawImage(src, 0, 0);
    const d = ctx.getImageData(0, 0, c.width, c.height).data;
    let hits = 0;
    for (let i = 0; i < d.length; i += 4) if (match(d[i], d[i + 1], d[i + 2])) ++hits;
    return hits / (d.length / 4);
  }, [selector, makeMatch.toString(), arg]);
}

/** window.__viewerState of the page, as plain JSON. */
export function viewerState(page) {
  return page.evaluate(() => JSON.parse(JSON.stringify(window.__viewerState)));
}

/** Moves the viewer's scrub slider to `frame` (as a user drag would) and returns the state. */
export async function scrubTo(page, frame) {
  await page.evaluate((v) => {
    const el = document.getElementById('scrub');
    el.value = String(v);
    el.dispatchEvent(new Event('input'));
  }, frame);
  return viewerState(page);
}

/**
 * An e2e test's reporting, times counted from `t0`: skip(msg) exits 77 (ctest SKIP_RETURN_CODE),
 * fail(msg) sets exit code 1 and throws, check(cond, msg) fails or prints "ok - msg [t s]".
 */
export function reporter(t0 = Date.now()) {
  function skip(msg) {
    console.log(`SKIP: ${msg}`);
    process.exit(77);
  }
  function fail(msg) {
    console.error(`FAIL: ${msg}`);
    process.exitCode = 1;
    throw new Error(msg);
  }
  function check(cond, msg) {
    if (!cond) fail(msg);
    console.log(`ok - ${msg} [${((Date.now() - t0) / 1000).toFixed(1)} s]`);
  }
  return { skip, fail, check };
}

/** `--key value` arguments as { key: value }; a `--flag` followed by another `--…` (or last) is ''. */
export function parseArgs(argv = process.argv.slice(2)) {
  return Object.fromEntries(
    argv.reduce((acc, a, i, all) => (a.startsWith('--') ? [...acc, [a.slice(2), all[i + 1] && !all[i + 1].startsWith('--') ? all[i + 1] : '']] : acc), []),
  );
}

/** Skips (exit 77) without Chromium or without one of the packages `deps` in root/node_modules. */
export function requireBrowser(root, deps, skip) {
  if (!fs.existsSync(CHROMIUM)) skip(`Chromium not found at ${CHROMIUM} (install Debian's chromium package)`);
  for (const dep of deps)
    if (!fs.existsSync(path.join(root, 'node_modules', dep))) skip(`node_modules/${dep} missing in ${root} (run scripts/setup-viewer.sh)`);
}

/**
 * Builds the viewer in `root` (tools/viewer) into `dist` with vite; with `liveAssets` the live
 * page's models and MJCF are copied in first (scripts/copy-live-assets.mjs). Calls fail() naming
 * the step that failed, after printing its output.
 */
export function buildViewer(root, dist, fail, { liveAssets = false } = {}) {
  const steps = [
    ...(liveAssets ? [['copy-live-assets.mjs', [path.join(root, 'scripts/copy-live-assets.mjs')]]] : []),
    ['vite build', [path.join(root, 'node_modules/vite/bin/vite.js'), 'build', '--outDir', dist, '--emptyOutDir', '--logLevel', 'warn']],
  ];
  for (const [name, step] of steps) {
    const r = spawnSync(process.execPath, step, { cwd: root, encoding: 'utf8' });
    if (r.status !== 0) {
      console.error(r.stdout, r.stderr);
      fail(`${name} failed`);
    }
  }
}
