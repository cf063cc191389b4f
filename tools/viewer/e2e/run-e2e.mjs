// End-to-end test of the viewer in headless Chromium (Debian's /usr/bin/chromium, driven by
// playwright-core; no browser download).
//
//   node e2e/run-e2e.mjs --rollout-a A.json [--rollout-b B.json] [--rollout-goals G.json] [--out DIR]
//
// Builds the viewer into DIR/dist (vite), serves it on 127.0.0.1, loads rollout A through the
// file picker, checks that frames advance while playing and that the masked (adapted) body parts
// carry their part colour (via the window.__viewerState hook and in the rendered pixels), loads B
// side by side, loads G (a rollout with a goal-task scene) and checks its target, arrow and box,
// opens two training logs, and saves screenshots into DIR.
// Exit codes: 0 pass, 1 fail, 77 skipped (no Chromium / node_modules) — ctest SKIP_RETURN_CODE.
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { buildViewer, canvasShare, launchChromium, parseArgs, reporter, requireBrowser, scrubTo as scrubPage, serveDir, viewerState } from './harness.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const root = path.resolve(here, '..');
const { skip, fail, check } = reporter();

const args = parseArgs();
if (!args['rollout-a']) {
  console.error('usage: node e2e/run-e2e.mjs --rollout-a A.json [--rollout-b B.json] [--rollout-goals G.json] [--out DIR]');
  process.exit(2);
}
const outDir = path.resolve(args.out || path.join(root, 'test-results'));
fs.mkdirSync(outDir, { recursive: true });
requireBrowser(root, ['playwright-core', 'vite'], skip);

const { ARROW_COLOR, BASE_COLOR, PART_COLORS, TARGET_COLOR } = await import('../src/colors.js');
const { PART_NAMES } = await import('../src/rollout.js');

// ---- build the current sources into outDir/dist ------------------------------------------------
const dist = path.join(outDir, 'dist');
buildViewer(root, dist, fail);

// ---- static server ----------------------------------------------------------------------------
const server = await serveDir(dist);
const url = server.url;

let browser;
try {
  browser = await launchChromium({ width: 1280, height: 720 });
  const page = browser.page;
  const pageErrors = page.errors;
  await page.goto(url);
  const state = () => viewerState(page);

  // Load A through the file picker.
  await page.setInputFiles('#file-a', path.resolve(args['rollout-a']));
  await page.waitForFunction(() => window.__viewerState.views.length === 1, null, { timeout: 10000 });
  let s = await state();
  const nf = s.views[0].numFrames;
  check(nf > 30 && s.views[0].bodyNames.length > 1, `rollout A loaded (${nf} frames, ${s.views[0].bodyNames.length} bodies)`);
  check(!(await page.textContent('#status')), 'no error shown');

  // Frames advance while playing.
  await page.click('#play');
  await page.waitForTimeout(700);
  const f1 = (await state()).frame;
  await page.waitForTimeout(700);
  s = await state();
  check(s.playing && f1 > 0 && s.frame > f1, `frames advance while playing (${f1} → ${s.frame})`);
  await page.click('#play');  // pause
  const paused = (await state()).frame;
  await page.waitForTimeout(400);
  check((await state()).frame === paused, 'pause stops playback');

  // Scrub to a frame and check the colours of the masked parts.
  const scrubTo = (frame) => scrubPage(page, frame);
  function checkColours(view, label) {
    for (let b = 0; b < view.bodyNames.length; ++b) {
      const p = PART_NAMES.indexOf(view.bodyParts[b]);
      const expected = (view.mask >> p) & 1 ? PART_COLORS[p] : BASE_COLOR;
      if (view.bodyColors[b] !== expected || view.meshColors[b] !== expected)
        fail(`${label}: body ${view.bodyNames[b]} (${view.bodyParts[b]}) coloured ${view.meshColors[b]}, expected ${expected}`);
    }
    const coloured = view.bodyColors.filter((c) => c !== BASE_COLOR).length;
    check(coloured > 0, `${label}: ${coloured} bodies of the adapted parts (${view.maskLabel}) carry their part colour, the rest ${BASE_COLOR}`);
  }
  // Fraction of pixels of view A whose hue is within 10° of `hex` and clearly saturated
  // (lighting changes brightness and saturation a little, hardly the hue).
  function pixelShare(hex) {
    return canvasShare(page, '#view-a canvas', (hex) => {
      const hsv = (r, g, b) => {
        const max = Math.max(r, g, b), min = Math.min(r, g, b), delta = max - min;
        let h = 0;
        if (delta > 0) {
          if (max === r) h = 60 * (((g - b) / delta) % 6);
          else if (max === g) h = 60 * ((b - r) / delta + 2);
          else h = 60 * ((r - g) / delta + 4);
        }
        return [(h + 360) % 360, max ? delta / max : 0, max / 255];
      };
      const [th] = hsv(...[1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16)));
      return (r, g, b) => {
        const [h, s, v] = hsv(r, g, b);
        const dh = Math.min(Math.abs(h - th), 360 - Math.abs(h - th));
        return dh < 10 && s > 0.35 && v > 0.15;
      };
    }, hex);
  }

  s = await scrubTo(10);
  check(s.frame === 10 && s.views[0].mask === 0b11000, `frame 10: legs adapted (mask ${s.views[0].mask})`);
  checkColours(s.views[0], 'frame 10');
  const legsShare = await pixelShare(PART_COLORS[3]);
  check(legsShare > 0.001, `rendered pixels show the left-leg colour (${(100 * legsShare).toFixed(2)}% of the view)`);
  const armShareEarly = await pixelShare(PART_COLORS[1]);
  await page.screenshot({ path: path.join(outDir, 'viewer-legs-masked.png') });

  s = await scrubTo(nf - 10);
  check(s.views[0].mask === 0b00110, `frame ${nf - 10}: arms adapted (mask ${s.views[0].mask})`);
  checkColours(s.views[0], `frame ${nf - 10}`);
  const armShare = await pixelShare(PART_COLORS[1]);
  const legsLate = await pixelShare(PART_COLORS[3]);
  check(armShare > 0.0002 && armShare > 5 * armShareEarly, `left-arm colour appears once the arms are adapted (${(100 * armShareEarly).toFixed(3)}% → ${(100 * armShare).toFixed(3)}%)`);
  check(legsLate < legsShare / 5, `left-leg colour disappears once the legs are no longer adapted (${(100 * legsLate).toFixed(3)}%)`);
  await page.screenshot({ path: path.join(outDir, 'viewer-arms-masked.png') });
  check((await page.textContent('#view-a .text')).length > 0, `text command shown: "${await page.textContent('#view-a .text')}"`);

  // Side by side: B in the second view, synchronised frame.
  if (args['rollout-b']) {
    await page.setInputFiles('#file-b', path.resolve(args['rollout-b']));
    await page.waitForFunction(() => window.__viewerState.views.length === 2, null, { timeout: 10000 });
    s = await scrubTo(45);
    check(s.views[0].frame === 45 && s.views[1].frame === 45, 'two views show the same frame');
    await page.waitForTimeout(200);
    await page.screenshot({ path: path.join(outDir, 'viewer-side-by-side.png') });
  }

  // Goal-task scene: the rollout with a location target, a heading arrow and the strike box, in A.
  if (args['rollout-goals']) {
    const name = path.basename(args['rollout-goals']);
    await page.setInputFiles('#file-a', path.resolve(args['rollout-goals']));
    await page.waitForFunction((n) => window.__viewerState.views[0]?.name === n, name, { timeout: 10000 });
    check(!(await page.textContent('#status')), 'goal-scene rollout loaded without error');
    s = await scrubTo(30);
    let sc = s.views[0].scene;
    check(sc.targets.length === 1 && sc.arrows.length === 1 && sc.objects.length === 1,
      `frame 30: ${sc.targets.length} target, ${sc.arrows.length} arrow, ${sc.objects.length} box drawn`);
    check(Math.abs(sc.targets[0].radius - 0.5) < 1e-6 && Math.abs(sc.targets[0].position[0] - 2) < 1e-6,
      `target ring of radius ${sc.targets[0].radius} m at (${sc.targets[0].position.map((x) => x.toFixed(2)).join(', ')})`);
    await page.waitForTimeout(200);
    const targetShare = await pixelShare(TARGET_COLOR);
    const arrowShare = await pixelShare(ARROW_COLOR);
    check(targetShare > 0.0002 && arrowShare > 0.00002,
      `rendered pixels show the target (${(100 * targetShare).toFixed(3)}%) and the arrow (${(100 * arrowShare).toFixed(3)}%)`);
    await page.screenshot({ path: path.join(outDir, 'viewer-goal-scene.png') });
    const upright = sc.objects[0].quaternion;
    s = await scrubTo(nf - 1);
    sc = s.views[0].scene;
    const q = sc.objects[0].quaternion;  // x, y, z, w: 90° about x once it has fallen
    check(Math.abs(upright[3] - 1) < 1e-6 && Math.abs(Math.abs(q[0]) - Math.SQRT1_2) < 1e-3,
      `the box follows its per-frame pose (upright at frame 30, on its side at frame ${nf - 1})`);
    await page.screenshot({ path: path.join(outDir, 'viewer-goal-scene-end.png') });
  }
  // Training logs: two runs overlaid.
  const logA = path.join(outDir, 'log_mi.jsonl');
  const logB = path.join(outDir, 'log_no_mi.jsonl');
  const lines = (k) =>
    Array.from({ length: 60 }, (_, i) =>
      JSON.stringify({ iteration: i, return: k * Math.log1p(i), episode_length: 30 + k * i, mi_kl: 0.5 / (1 + i * k), samples_per_s: 900 + 10 * k, disc_reward: 0.4 + 0.1 * Math.sin(i / 7) }),
    ).join('\n');
  fs.writeFileSync(logA, lines(1));
  fs.writeFileSync(logB, lines(2));
  await page.click('#tab-logs');
  await page.setInputFiles('#log-files', [logA, logB]);
  await page.waitForFunction(() => window.__viewerState.logs.runs.length === 2, null, { timeout: 10000 });
  s = await state();
  const plots = await page.locator('#charts .uplot').count();
  check(plots === s.logs.series.length && plots >= 4, `training logs: ${s.logs.runs.length} runs, ${plots} charts (${s.logs.series.join(', ')})`);
  await page.screenshot({ path: path.join(outDir, 'viewer-training-logs.png') });

  check(pageErrors.length === 0, `no page errors${pageErrors.length ? ': ' + pageErrors.join('; ') : ''}`);
  console.log(`PASS (screenshots in ${outDir})`);
} catch (e) {
  if (!process.exitCode) {
    console.error(`FAIL: ${e.stack || e.message}`);
    process.exitCode = 1;
  }
} finally {
  if (browser) await browser.close();
  server.close();
}
