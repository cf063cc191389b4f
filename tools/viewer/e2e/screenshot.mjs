// Screenshot of the viewer showing given files, taken in headless Chromium (Debian's
// /usr/bin/chromium through playwright-core; no browser download). Used by scripts/screenshots.sh
// for the pictures in docs/.
//
//   node tools/viewer/e2e/screenshot.mjs --out PNG --rollout A.json [--rollout2 B.json]
//        [--frame N | --time S] [--label NAME] [--label2 NAME]
//   node tools/viewer/e2e/screenshot.mjs --out PNG --log a.jsonl --log b.jsonl
//        [--series episode_length --series mi_kl]   (or --series episode_length,mi_kl)
//   common: [--dist DIR] (default tools/viewer/dist, built by scripts/setup-viewer.sh)
//           [--width PX] [--height PX] (default 1280 × 720)
//
// Rollouts: A is loaded through the file picker (B next to it when given), the scrub slider is
// moved to frame N (or to the frame at time S), and the page is saved. Logs: the training-logs
// tab with every log overlaid and exactly the chosen series ticked (the viewer's defaults when
// --series is absent). Files are shown under the name "<parent dir>/<file name>" unless --label
// says otherwise. Fails (exit 1) when the viewer reports an error, a page error occurs, a frame is
// out of range or a series is missing; exit 77 when Chromium or node_modules are missing.
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { CHROMIUM, launchChromium, scrubTo, serveDir, viewerState } from './harness.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const root = path.resolve(here, '..');

const USAGE = `usage: node tools/viewer/e2e/screenshot.mjs --out PNG
         (--rollout A.json [--rollout2 B.json] [--frame N | --time S] [--label NAME] [--label2 NAME]
          | --log a.jsonl [--log b.jsonl ...] [--series KEY[,KEY...] ...])
         [--dist DIR] [--width PX] [--height PX]`;

function die(msg, code = 1) {
  console.error(`screenshot: ${msg}`);
  process.exit(code);
}

// ---- arguments (--key value; --log and --series may repeat) ------------------------------------
const REPEATED = new Set(['log', 'series']);
const KNOWN = new Set(['out', 'rollout', 'rollout2', 'frame', 'time', 'label', 'label2', 'log', 'series', 'dist', 'width', 'height']);
const args = { log: [], series: [] };
const argv = process.argv.slice(2);
for (let i = 0; i < argv.length; i += 2) {
  const key = argv[i].replace(/^--/, '');
  if (!argv[i].startsWith('--') || !KNOWN.has(key)) die(`unknown argument '${argv[i]}'\n${USAGE}`, 2);
  if (i + 1 >= argv.length) die(`${argv[i]} needs a value\n${USAGE}`, 2);
  if (REPEATED.has(key)) args[key].push(argv[i + 1]);
  else args[key] = argv[i + 1];
}
if (!args.out) die(`--out is required\n${USAGE}`, 2);
if (!args.rollout === !args.log.length) die(`give either --rollout or --log\n${USAGE}`, 2);
if (args.frame !== undefined && args.time !== undefined) die('give --frame or --time, not both', 2);
if (args.rollout2 && !args.rollout) die('--rollout2 needs --rollout', 2);
const series = args.series.flatMap((s) => s.split(',')).map((s) => s.trim()).filter(Boolean);
const width = Number(args.width || 1280);
const height = Number(args.height || 720);
if (!(width >= 320 && height >= 240)) die('--width/--height must be at least 320 × 240', 2);
const dist = path.resolve(args.dist || path.join(root, 'dist'));

if (!fs.existsSync(CHROMIUM)) die(`Chromium not found at ${CHROMIUM} (install Debian's chromium package)`, 77);
if (!fs.existsSync(path.join(root, 'node_modules', 'playwright-core')))
  die(`node_modules missing in ${root} (run scripts/setup-viewer.sh)`, 77);
if (!fs.existsSync(path.join(dist, 'index.html'))) die(`no built viewer in ${dist} (run scripts/setup-viewer.sh)`);

/** A file for the page's file picker, named "<parent dir>/<file name>" (or `label`). */
function pickFile(file, label) {
  if (!fs.existsSync(file)) die(`no such file: ${file}`);
  const abs = path.resolve(file);
  const name = label || `${path.basename(path.dirname(abs))}/${path.basename(abs)}`;
  return { name, mimeType: 'application/octet-stream', buffer: fs.readFileSync(abs) };
}

// ---- render -------------------------------------------------------------------------------------
const server = await serveDir(dist);
let browser;
try {
  browser = await launchChromium({ width, height });
  const { page } = browser;
  await page.goto(server.url);
  const viewerError = async () => (await page.textContent('#status')).trim();

  if (args.rollout) {
    const files = [pickFile(args.rollout, args.label)];
    if (args.rollout2) files.push(pickFile(args.rollout2, args.label2));
    for (const [i, f] of files.entries()) {
      await page.setInputFiles(i ? '#file-b' : '#file-a', f);
      await page
        .waitForFunction((n) => window.__viewerState.views.length === n || document.getElementById('status').textContent, i + 1, { timeout: 60000 })
        .catch(() => {});
      const err = await viewerError();
      if (err) throw new Error(`the viewer rejected ${f.name}: ${err}`);
      if ((await viewerState(page)).views.length !== i + 1) throw new Error(`${f.name} did not load within 60 s`);
    }
    const fps = JSON.parse(files[0].buffer.toString('utf8')).fps;
    const numFrames = Math.max(...(await viewerState(page)).views.map((v) => v.numFrames));
    let frame = 0;
    if (args.frame !== undefined) frame = Number(args.frame);
    else if (args.time !== undefined) frame = Math.round(Number(args.time) * fps);
    if (!Number.isInteger(frame) || frame < 0 || frame >= numFrames)
      throw new Error(`frame ${args.frame ?? args.time + ' s'} is outside 0…${numFrames - 1}`);
    const s = await scrubTo(page, frame);
    await page.waitForTimeout(300);  // let both canvases and the overlays settle
    await page.screenshot({ path: path.resolve(args.out) });
    console.log(`screenshot: ${args.out}: t = ${s.time.toFixed(2)} s`);
    for (const v of s.views)
      console.log(`  ${v.name}: frame ${v.frame} / ${v.numFrames - 1}, adapted: ${v.maskLabel}${v.text ? `, text "${v.text}"` : ''}`);
  } else {
    await page.click('#tab-logs');
    const files = args.log.map((f) => pickFile(f));
    await page.setInputFiles('#log-files', files);
    await page
      .waitForFunction((n) => window.__viewerState.logs.runs.length === n || document.getElementById('status').textContent, files.length, { timeout: 60000 })
      .catch(() => {});
    const err = await viewerError();
    if (err) throw new Error(`the viewer rejected a log: ${err}`);
    if (series.length) {
      const available = await page.$$eval('#series input', (boxes) => boxes.map((b) => b.dataset.key));
      const missing = series.filter((k) => !available.includes(k));
      if (missing.length) throw new Error(`series ${missing.join(', ')} not in the logs (available: ${available.join(', ')})`);
      await page.$$eval('#series input', (boxes, want) => {
        for (const b of boxes) if (b.checked !== want.includes(b.dataset.key)) b.click();
      }, series);
    }
    const s = await viewerState(page);
    const charts = await page.locator('#charts .uplot').count();
    if (charts !== s.logs.series.length || charts === 0) throw new Error(`${charts} charts drawn for series [${s.logs.series}]`);
    await page.waitForTimeout(200);
    await page.screenshot({ path: path.resolve(args.out) });
    console.log(`screenshot: ${args.out}: runs ${s.logs.runs.join(', ')}; series ${s.logs.series.join(', ')}`);
  }
  if (page.errors.length) throw new Error(`page errors: ${page.errors.join('; ')}`);
} catch (e) {
  console.error(`screenshot: ${e.message}`);
  fs.rmSync(path.resolve(args.out), { force: true });  // no half-right picture left behind
  process.exitCode = 1;
} finally {
  if (browser) await browser.close();
  server.close();
}
