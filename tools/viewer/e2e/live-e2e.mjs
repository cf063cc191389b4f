// End-to-end test of the Live tab in headless Chromium (Debian's /usr/bin/chromium through
// playwright-core; nothing downloaded): the shipped policies run in the page on MuJoCo compiled to
// WebAssembly.
//
//   node e2e/live-e2e.mjs [--out DIR] [--table]
//
// Builds the viewer (models and MJCF copied in by scripts/copy-live-assets.mjs) into DIR/dist,
// serves it on 127.0.0.1, opens `#live`, and checks, through the page's own controls:
//  - MuJoCo loads, the mask-invariant base starts, and the step cost allows >= real time;
//  - clicking both legs' checkboxes masks them (their bodies take the leg colours, on screen too),
//    Reset, 10 simulated seconds: the mask-invariant base walks >= 5 m without a fall;
//  - the AMP base picked in the model list, same start and mask: it falls;
//  - the text-driven tracking policy picked in the model list: a prompt typed into the box, 3
//    simulated seconds, a training prompt picked from the list mid-walk, 3 s more — goals were
//    generated with both prompts, drawn (state and green pixels), the tracking error is finite;
//    an empty prompt and a corrupt generator file show errors naming them; the browser's mean
//    tracking error over 10 s for three prompts next to native_tracking_ours_s1.json;
//  - the G1 robot's model loads with its MJCF and runs;
//  - a corrupt model file opened with the file picker shows an error naming the file;
// and saves screenshots into DIR. With --table it also measures distance/falls in the browser for
// both humanoid bases, every start and five masks (DIR/live_browser.json, next to the native
// figures of tools/viewer/live/native_*.json; docs/viewer.md's table). Exit codes: 0 pass, 1 fail, 77 skipped (no Chromium /
// node_modules) — ctest SKIP_RETURN_CODE.
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { buildViewer, canvasShare, launchChromium, parseArgs, reporter, requireBrowser, serveDir } from './harness.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const root = path.resolve(here, '..');
const repo = path.resolve(root, '../..');
const { skip, fail, check } = reporter();

const args = parseArgs();
const outDir = path.resolve(args.out || path.join(root, 'test-results', 'live'));
fs.mkdirSync(outDir, { recursive: true });
requireBrowser(root, ['playwright-core', 'vite', 'mujoco-js'], skip);

const { PART_COLORS, BASE_COLOR, GOAL_COLOR } = await import('../src/colors.js');

// ---- build ----------------------------------------------------------------------------------
const dist = path.join(outDir, 'dist');
buildViewer(root, dist, fail, { liveAssets: true });
check(fs.existsSync(path.join(dist, 'live', 'models', 'mask_mi_walk_bandai.bin')), 'built the viewer with the live assets');

const server = await serveDir(dist);
const { page, close } = await launchChromium({ width: 1280, height: 720 });
const live = (fn, arg) => page.evaluate(fn, arg);
// Fraction of the live view's pixels within `tol` (sum of |ΔR|, |ΔG|, |ΔB|) of colour `hex`; with
// `bluish` only those whose blue exceeds their red by more than 40.
const colourShare = (hex, tol, bluish = false) =>
  canvasShare(page, '#live-view canvas', ([hex, tol, bluish]) => {
    const t = [1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16));
    return (r, g, b) => Math.abs(r - t[0]) + Math.abs(g - t[1]) + Math.abs(b - t[2]) < tol && (!bluish || b > r + 40);
  }, [hex, tol, bluish]);
try {
  await page.goto(`${server.url}#live`);
  const ready = await page.evaluate(() => window.__live.ready);
  const err0 = await page.textContent('#live-error');
  check(ready === true, `the live page started (MuJoCo loaded, first model running)${err0 ? `; error: ${err0}` : ''}`);
  const footer = await page.textContent('#live-footer');
  check(/MuJoCo 3\.\d+\.\d+ in WebAssembly/.test(footer), `footer names the engine: "${footer.slice(0, 60)}…"`);
  let s = await live(() => window.__live.state());
  check(s.model === 'mask_mi_walk_bandai' && s.character === 'humanoid', 'the mask-invariant base is selected first');

  // Real time: let the page run on its own clock (warm-up 3 s, then 5 s measured).
  await page.waitForTimeout(3000);
  await page.click('#live-speed');  // (no-op click: focus) then restart the measurement window
  await page.selectOption('#live-speed', '1');
  await page.evaluate(() => document.getElementById('live-speed').dispatchEvent(new Event('change')));
  await page.waitForTimeout(5000);
  s = await live(() => window.__live.state());
  console.log(`   step cost ${s.stepMs.toFixed(2)} ms per 1/30 s control step → ${s.realTimeFactor.toFixed(1)}× real time possible; ` +
    `the page's clock ran at ${s.achievedRealTime.toFixed(2)}× real time, ${s.framesPerSecond.toFixed(1)} frames/s (SwiftShader software WebGL)`);
  check(s.realTimeFactor >= 1, `physics + policy run faster than real time (${s.realTimeFactor.toFixed(1)}×)`);
  check(s.time > 0, 'simulated time advances on its own');
  await page.screenshot({ path: path.join(outDir, 'live-unmasked.png') });

  // Both legs masked through the checkboxes, reset, 10 simulated seconds (paused first, so that
  // the figures are exactly 10 simulated seconds from the start).
  await page.click('#live-run');
  check((await page.textContent('#live-run')) === 'Run', 'Pause stops the clock');
  await page.click('#live-part-left_leg');
  await page.click('#live-part-right_leg');
  await page.click('#live-reset');
  s = await live(() => window.__live.state());
  check(s.maskText === 'left_leg,right_leg' && s.time === 0, `checkboxes mask both legs (${s.maskText}); Reset restarts at t = 0`);
  const leg = (name) => s.bodyNames.indexOf(name);
  check(s.meshColors[leg('L_Knee')] === PART_COLORS[3] && s.meshColors[leg('R_Knee')] === PART_COLORS[4] && s.meshColors[leg('Head')] === BASE_COLOR,
    'the legs take their part colours, the head stays grey');
  s = await live(() => window.__live.runSeconds(5));
  await page.screenshot({ path: path.join(outDir, 'live-mi-legs-masked.png') });
  const legShare = await colourShare(PART_COLORS[3], 90, true);
  check(legShare > 0.001, `rendered pixels show the left-leg colour (${(100 * legShare).toFixed(2)}% of the view)`);
  s = await live(() => window.__live.runSeconds(5));
  const mi = s;
  check(Math.abs(s.time - 10) < 1e-9 && s.steps === 300, '10 simulated seconds (300 control steps)');
  check(s.runRealTimeFactor >= 1,
    `the last 5 simulated seconds took ${(s.runWallMs / 1000).toFixed(2)} s of wall time in Chromium: ${s.runRealTimeFactor.toFixed(1)}× real time (>= 1×)`);
  check(s.falls === 0 && s.distance >= 5,
    `mask-invariant base, both legs masked: walked ${s.distance.toFixed(2)} m in 10 s, ${s.falls} falls (needs >= 5 m and none)`);

  // The AMP base, chosen in the model list; same start, same mask.
  await page.selectOption('#live-model', 'amp_walk_bandai');
  await page.waitForFunction(() => window.__liveState && window.__liveState.model === 'amp_walk_bandai');
  await page.click('#live-reset');
  await page.click('#live-reset');
  s = await live(() => window.__live.state());
  check(s.maskText === 'left_leg,right_leg' && s.start === mi.start, 'the AMP base keeps the mask and the start');
  s = await live(() => window.__live.runSeconds(10));
  check(s.falls >= 1, `AMP base, both legs masked: falls (${s.falls} falls, first at ${s.firstFall?.toFixed(2)} s; ${s.distance.toFixed(2)} m)`);
  await page.screenshot({ path: path.join(outDir, 'live-amp-legs-masked-fallen.png') });

  // A stage-2 composition policy: the swim stroke on the arms, switched off mid-stride.
  await page.selectOption('#live-model', 'swim_ours_s1');
  await page.waitForFunction(() => window.__liveState && window.__liveState.model === 'swim_ours_s1');
  s = await live(() => window.__live.reset(0));
  check(s.kind === 'maskadapt.residual_policy' && s.maskText === 'left_arm,right_arm',
    `the stage-2 swim policy loads with the parts its residual adapts masked (${s.maskText})`);
  s = await live(() => window.__live.runSeconds(5));
  const swimOn = s;
  await page.screenshot({ path: path.join(outDir, 'live-stage2-swim-arms.png') });
  await page.click('#live-part-left_arm');
  await page.click('#live-part-right_arm');
  s = await live(() => window.__live.runSeconds(5));
  check(s.maskText === 'none' && Math.abs(s.time - 10) < 1e-9,
    `unticking both arms at 5 s switches the residual off mid-stride: ${swimOn.distance.toFixed(2)} m and ${swimOn.falls} falls after 5 s with the swim, ${s.distance.toFixed(2)} m and ${s.falls} falls after 10 s`);
  await page.screenshot({ path: path.join(outDir, 'live-stage2-switched-off.png') });

  // Text-driven partial tracking: the tracking policy, a typed prompt, a picked prompt mid-walk.
  await page.selectOption('#live-model', 'tracking_ours_s1');
  await page.waitForFunction(() => window.__liveState && window.__liveState.model === 'tracking_ours_s1', null, { timeout: 60000 });
  check(await page.isVisible('#live-prompt'), 'the tracking policy shows the prompt box');
  const pool = await page.$$eval('#live-prompt-pick option', (o) => o.map((x) => x.value).filter(Boolean));
  check(pool.length >= 10 && pool.includes('arms high'), `the training prompts are offered as a pick list (${pool.length}: ${pool.slice(0, 4).join(', ')}, …)`);
  s = await live(() => window.__live.reset(0));
  check(s.tracking && s.maskText === 'left_arm,right_arm', `the tracking policy runs with its designated arms adapted (${s.maskText})`);
  await page.fill('#live-prompt', 'punch');
  await page.press('#live-prompt', 'Enter');
  s = await live(() => window.__live.state());
  check(s.tracking.prompt === 'punch' && !s.error, 'a prompt typed into the box and Enter: "punch"');
  s = await live(() => window.__live.runSeconds(3));
  const tr3 = s.tracking;
  check(tr3.primitives >= 6 && tr3.goalFrames >= 90 && tr3.primitiveTexts.every((t) => t === 'punch'),
    `3 s: ${tr3.primitives} goal primitives generated from "punch" (${tr3.goalFrames} target frames), ${tr3.generateMs.toFixed(1)} ms per generate in Chromium (max ${tr3.generateMsMax.toFixed(1)})`);
  check(Number.isFinite(tr3.trackingError) && Number.isFinite(tr3.meanTrackingError),
    `tracking error is finite: now ${tr3.trackingError.toFixed(3)} m, mean ${tr3.meanTrackingError.toFixed(3)} m; ${s.falls} falls, ${s.distance.toFixed(2)} m`);
  check(s.goalsDrawn >= 2 && s.goalSpheres.length === 8, `the goals are drawn: ${s.goalSpheres.length} target spheres, a line through ${s.goalsDrawn} target frames`);
  await page.selectOption('#live-prompt-pick', 'arms high');
  s = await live(() => window.__live.state());
  check(s.tracking.prompt === 'arms high', 'a training prompt picked from the list mid-walk (at 3 s): "arms high"');
  s = await live(() => window.__live.runSeconds(3));
  const texts = s.tracking.primitiveTexts;
  check(texts.includes('arms high') && texts[0] === 'punch' && Number.isFinite(s.tracking.meanTrackingError),
    `6 s: primitives ${texts.filter((t) => t === 'punch').length}× "punch" then ${texts.filter((t) => t === 'arms high').length}× "arms high"; tracking error now ${s.tracking.trackingError.toFixed(3)} m, mean ${s.tracking.meanTrackingError.toFixed(3)} m; ${s.falls} falls`);
  await page.screenshot({ path: path.join(outDir, 'live-tracking.png') });
  const goalShare = await colourShare(GOAL_COLOR, 60);
  check(goalShare > 0.0002, `rendered pixels show the green goal targets (${(100 * goalShare).toFixed(3)}% of the view)`);
  await page.fill('#live-prompt', '  ?! ');
  await page.click('#live-prompt-apply');
  const promptErr = await page.textContent('#live-error');
  s = await live(() => window.__live.state());
  check(/has no words/.test(promptErr) && s.tracking.prompt === 'arms high', `an empty prompt is refused in the page: "${promptErr}"`);
  await page.screenshot({ path: path.join(outDir, 'live-tracking-empty-prompt.png') });
  const badGen = Buffer.from(fs.readFileSync(path.join(repo, 'models/text_generator.bin')));
  badGen[200000] ^= 0xff;
  await page.setInputFiles('#live-generator-file', { name: 'broken_generator.bin', mimeType: 'application/octet-stream', buffer: badGen });
  await page.waitForFunction(() => /broken_generator/.test(document.getElementById('live-error').textContent));
  const genErr = await page.textContent('#live-error');
  s = await live(() => window.__live.runSeconds(0.5));
  check(/broken_generator\.bin: checksum mismatch/.test(genErr) && Number.isFinite(s.tracking.trackingError),
    `a corrupt generator file shows an error naming it and the run goes on with the loaded generator: "${genErr}"`);
  // Browser vs native (the same start, seed and loop natively: live_tracking_reference.cpp --native).
  const nativeTracking = JSON.parse(fs.readFileSync(path.join(root, 'live/native_tracking_ours_s1.json'), 'utf8')).runs;
  const trackingTable = [];
  for (const n of nativeTracking) {
    const r = await live((prompt) => {
      window.__live.setPrompt(prompt);
      window.__live.reset(0);
      return window.__live.runSeconds(10);
    }, n.prompt);
    trackingTable.push({ prompt: n.prompt, browser_mean_tracking_error_m: r.tracking.meanTrackingError, browser_falls: r.falls, browser_distance_m: r.distance,
      browser_generate_ms: r.tracking.generateMs, browser_generate_ms_max: r.tracking.generateMsMax, browser_step_ms: r.stepMs,
      native_mean_tracking_error_m: n.mean_tracking_error_m, native_falls: n.falls, native_distance_m: n.distance_m });
    console.log(`   tracking "${n.prompt}", 10 s from ${n.start}, seed 1: browser ${r.tracking.meanTrackingError.toFixed(4)} m mean error, ${r.falls} falls, ${r.distance.toFixed(2)} m, ` +
      `${r.tracking.generateMs.toFixed(1)} ms/generate (max ${r.tracking.generateMsMax.toFixed(1)}, ${r.tracking.generateCalls} calls) | native ${n.mean_tracking_error_m.toFixed(4)} m, ${n.falls} falls, ${n.distance_m.toFixed(2)} m`);
  }
  check(trackingTable.every((r) => Number.isFinite(r.browser_mean_tracking_error_m)), 'browser tracking error over 10 s for three prompts (vs native above)');
  fs.writeFileSync(path.join(outDir, 'live_tracking_browser.json'), JSON.stringify({ chromium: await page.evaluate(() => navigator.userAgent), runs: trackingTable }, null, 1));

  // G1.
  await page.selectOption('#live-model', 'g1_mask_mi_walk_bandai');
  await page.waitForFunction(() => window.__liveState && window.__liveState.character === 'g1');
  await page.click('#live-mask-none');
  await page.click('#live-reset');
  s = await live(() => window.__live.runSeconds(5));
  check(s.character === 'g1' && s.bodyNames.length === 30, `the G1 robot's MJCF loads and its mask-invariant base runs (5 s: ${s.distance.toFixed(2)} m, ${s.falls} falls)`);
  await page.screenshot({ path: path.join(outDir, 'live-g1.png') });

  // A corrupt file through the file picker.
  const bad = Buffer.from(fs.readFileSync(path.join(repo, 'models/mask_mi_walk_bandai.bin')));
  bad[4000] ^= 0xff;
  await page.setInputFiles('#live-file', { name: 'broken_model.bin', mimeType: 'application/octet-stream', buffer: bad });
  await page.waitForFunction(() => !document.getElementById('live-error').classList.contains('hidden'));
  const errText = await page.textContent('#live-error');
  check(/broken_model\.bin: checksum mismatch/.test(errText), `a corrupt model shows an error naming the file: "${errText}"`);
  await page.screenshot({ path: path.join(outDir, 'live-error.png') });
  const truncated = bad.subarray(0, 3000);
  await page.setInputFiles('#live-file', { name: 'cut_model.bin', mimeType: 'application/octet-stream', buffer: Buffer.from(truncated) });
  await page.waitForFunction(() => /cut_model/.test(document.getElementById('live-error').textContent));
  check(true, `a truncated model: "${await page.textContent('#live-error')}"`);

  // Browser figures for the comparison with native MuJoCo 2.2.2 (--table: 60 runs of 10 s).
  const table = [];
  if (args.table !== undefined) {
    const starts = JSON.parse(fs.readFileSync(path.join(root, 'live/character_humanoid.json'), 'utf8')).starts;
    const masksOf = { swim_ours_s1: ['left_arm,right_arm', 'none'], kick_cut_ours_s1: ['left_leg,right_leg', 'none'] };
    for (const model of ['mask_mi_walk_bandai', 'amp_walk_bandai', 'swim_ours_s1', 'kick_cut_ours_s1']) {
      await live((id) => window.__live.select(id), model);
      const native = JSON.parse(fs.readFileSync(path.join(root, `live/native_${model}.json`), 'utf8')).runs;
      for (let k = 0; k < starts.length; ++k)
        for (const mask of masksOf[model] || ['none', 'left_leg,right_leg', 'arms', 'left_leg', 'trunk']) {
          const r = await live(([k, mask]) => {
            window.__live.setMask(mask);
            window.__live.reset(k);
            return window.__live.runSeconds(10);
          }, [k, mask]);
          const n = native.find((x) => x.start === starts[k].label && x.mask === mask);
          table.push({ model, start: starts[k].label, mask, browser_distance_m: r.distance, browser_falls: r.falls, browser_first_fall_s: r.firstFall,
            native_distance_m: n?.distance_m, native_falls: n?.falls, native_first_fall_s: n?.first_fall_s });
        }
  }
  fs.writeFileSync(path.join(outDir, 'live_browser.json'), JSON.stringify({ chromium: await page.evaluate(() => navigator.userAgent), runs: table }, null, 1));
  console.log('   model | start | mask | browser (MuJoCo 3.3.8 wasm): m, falls | native (MuJoCo 2.2.2): m, falls');
  for (const r of table)
    console.log(`   ${r.model} | ${r.start} | ${r.mask} | ${r.browser_distance_m.toFixed(2)} m, ${r.browser_falls} | ${r.native_distance_m?.toFixed(2)} m, ${r.native_falls}`);
  }
  const errors = page.errors.filter((e) => !/broken_model|cut_model|broken_generator|live: prompt: /.test(e));
  check(errors.length === 0, `no page errors${errors.length ? `: ${errors.join(' | ')}` : ''}`);
  console.log(`PASS (screenshots and live_browser.json in ${outDir})`);
} finally {
  await close();
  server.close();
}
