// Shared pieces of the headless-Chromium scripts (run-e2e.mjs, screenshot.mjs): a static file
// server for the built viewer and a launcher for Debian's /usr/bin/chromium through
// playwright-core (never downloads a browser).
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
