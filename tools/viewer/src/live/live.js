// The Live tab: a shipped base policy driving the character on MuJoCo (WebAssembly) in the page.
// The user picks a model and a start, hides body parts from the policy with the checkboxes (live,
// mid-stride), resets, and reads time, distance, speed and falls. Everything runs in the page:
// the physics (sim.js), the observation and mask (features.js), the policy (policy.js). A
// text-driven tracking policy also gets a prompt box and the generator's training prompts: the
// text generator (generator.js) turns the prompt into goal frames for the arms as the character
// walks (tracking.js), drawn as the rollout view draws tracking goals, with the tracking error.
//
// Test hook: window.__live (select, setMask, reset, runSeconds, pause, resume, state) and
// window.__liveState (the state after the last drawn frame); see docs/viewer.md.
import { PART_COLORS, bodyColors } from '../colors.js';
import { parseRollout } from '../rollout.js';
import { RolloutView } from '../scene.js';
import { maskText, observationDim, parseMask, PART_NAMES } from './features.js';
import { loadGenerator } from './generator.js';
import { makeSkeleton } from './kinematics.js';
import { loadPolicy } from './policy.js';
import { checkPrompt, LiveSession } from './session.js';
import { loadMujoco } from './sim.js';

const $ = (id) => document.getElementById(id);
const BASE = 'live/';

const ui = {
  model: $('live-model'),
  file: $('live-file'),
  start: $('live-start'),
  reset: $('live-reset'),
  run: $('live-run'),
  speed: $('live-speed'),
  parts: $('live-parts'),
  error: $('live-error'),
  name: $('live-name'),
  stats: $('live-stats'),
  maskLabel: $('live-mask-label'),
  footer: $('live-footer'),
  view: $('live-view'),
  tracking: $('live-tracking'),
  prompt: $('live-prompt'),
  promptPool: $('live-prompt-pool'),
  promptApply: $('live-prompt-apply'),
  promptPick: $('live-prompt-pick'),
  generatorFile: $('live-generator-file'),
  trackingStats: $('live-tracking-stats'),
};
const GOAL_FRAMES = 31;  // the drawn goal line: the next second of target frames (scene.js)
const TRACKING_SEED = 1;  // the diffusion noise: Rng(1), as `maskadapt play-residual --seed 1`

let mj = null;
let manifest = null;
let session = null;
let view = null;
let drawing = null;
let modelLabel = '';
let running = true;
let speed = 1;
let budget = 0;
let lastStamp = null;
let wallStart = null;
let simAtWallStart = 0;
let achieved = 0;
let fps = 0;
let framesSinceWallStart = 0;
let started = false;
const characters = new Map();  // name → { character, xml, drawingText }
const trackingData = new Map();  // character name → tracking_<name>.json
const generators = new Map();  // url → Generator
let userGenerator = null;  // a generator file the user opened (replaces the manifest's)

function showError(msg) {
  ui.error.textContent = msg;
  ui.error.classList.toggle('hidden', !msg);
  if (msg) console.error(`live: ${msg}`);
}

async function fetchOk(url, kind) {
  let res;
  try {
    res = await fetch(url);
  } catch (e) {
    throw new Error(`${url}: could not fetch the ${kind} (${e.message})`);
  }
  if (!res.ok) throw new Error(`${url}: could not fetch the ${kind} (HTTP ${res.status})`);
  return res;
}

async function loadCharacter(name) {
  if (characters.has(name)) return characters.get(name);
  const url = `${BASE}character_${name}.json`;
  const character = await (await fetchOk(url, 'character description')).json();
  if (character.format !== 'maskadapt-live-character' || character.version !== 1) throw new Error(`${url}: field 'format'/'version': not a version-1 live character file`);
  const xml = await (await fetchOk(`${BASE}${character.mjcf}`, 'MJCF model')).text();
  const entry = { character, xml, drawingText: JSON.stringify(character.drawing) };
  characters.set(name, entry);
  return entry;
}

function partCheckboxes() {
  ui.parts.textContent = '';
  PART_NAMES.forEach((name, p) => {
    const label = document.createElement('label');
    const box = document.createElement('input');
    box.type = 'checkbox';
    box.id = `live-part-${name}`;
    box.dataset.part = String(p);
    box.addEventListener('change', () => applyMask(readMaskBoxes()));
    const sw = document.createElement('span');
    sw.className = 'swatch';
    sw.style.background = PART_COLORS[p];
    label.append(box, sw, document.createTextNode(name.replace('_', ' ')));
    ui.parts.append(label);
  });
}

function readMaskBoxes() {
  let bits = 0;
  for (const box of ui.parts.querySelectorAll('input')) if (box.checked) bits |= 1 << Number(box.dataset.part);
  return bits;
}

function applyMask(bits) {
  for (const box of ui.parts.querySelectorAll('input')) box.checked = ((bits >> Number(box.dataset.part)) & 1) === 1;
  if (session) session.setMask(bits);
  draw();
}

function fillStarts(character, keep) {
  ui.start.textContent = '';
  character.starts.forEach((s, i) => ui.start.add(new Option(s.label, String(i))));
  ui.start.value = String(keep < character.starts.length ? keep : 0);
}

async function loadTrackingData(name) {
  if (trackingData.has(name)) return trackingData.get(name);
  const url = `${BASE}tracking_${name}.json`;
  const data = await (await fetchOk(url, 'tracking data')).json();
  if (data.format !== 'maskadapt-live-tracking' || data.version !== 1) throw new Error(`${url}: field 'format'/'version': not a version-1 live tracking file`);
  data.skel = makeSkeleton(data.skeleton);
  trackingData.set(name, data);
  return data;
}

async function generatorFor(path, skel) {
  if (userGenerator) return userGenerator;
  const url = `${BASE}${path}`;
  if (!generators.has(url)) {
    const bytes = new Uint8Array(await (await fetchOk(url, 'text generator')).arrayBuffer());
    generators.set(url, loadGenerator(bytes, path, skel));
  }
  return generators.get(url);
}

/** The one-frame drawing with room for the goal line (GOAL_FRAMES frames, tracking goals). */
function trackingDrawing(drawingText, bodies) {
  const doc = JSON.parse(drawingText);
  const fr = doc.frames;
  for (const key of ['positions', 'rotations', 'masks', 'contacts']) fr[key] = Array.from({ length: GOAL_FRAMES }, () => fr[key][0]);
  doc.num_frames = GOAL_FRAMES;
  doc.goals = { bodies, targets: Array(GOAL_FRAMES).fill(null) };
  return parseRollout(JSON.stringify(doc));
}

function fillPromptPool(pool) {
  ui.promptPool.textContent = '';
  ui.promptPick.textContent = '';
  ui.promptPick.add(new Option('(pick one)', ''));
  for (const p of pool) {
    ui.promptPool.append(new Option(p));
    ui.promptPick.add(new Option(p, p));
  }
}

/** Starts a session for policy bytes; `file` labels errors; `generatorPath` for a tracking policy (else its config's). */
async function startSession(bytes, file, label, generatorPath = null) {
  showError('');
  let policy = loadPolicy(bytes, file);  // (checks the file itself; the character is in its config)
  const { character, xml, drawingText } = await loadCharacter(policy.character);
  policy = loadPolicy(bytes, file, { name: character.name, obsDim: observationDim(character.bodies.length), actionDim: character.joint_names.length });
  // A stage-2 policy starts with the mask it was trained for (the parts its residual adapts).
  const mask = policy.trainedMask ? parseMask(policy.trainedMask) : session ? session.mask : 0;
  const keepStart = session && session.character === character ? session.startIndex : 0;
  let tracking = null;
  if (policy.task === 'tracking') {
    const data = await loadTrackingData(character.name);
    const gen = await generatorFor(generatorPath || policy.generatorFile || 'models/text_generator.bin', data.skel);
    let prompt = ui.prompt.value.trim() ? ui.prompt.value : gen.armsPool[0] || 'wave right hand';
    try {
      checkPrompt(prompt);
    } catch {
      prompt = gen.armsPool[0] || 'wave right hand';
    }
    tracking = { data, gen, prompt };
  }
  const next = new LiveSession(mj, xml, character, policy);
  if (tracking) next.setTracking(tracking.gen, tracking.data, tracking.prompt, TRACKING_SEED);
  if (session) session.dispose();
  session = next;
  session.setMask(mask);
  applyMask(mask);
  fillStarts(character, keepStart);
  session.reset(Number(ui.start.value));
  drawing = tracking ? trackingDrawing(drawingText, session.tracking.bodies) : parseRollout(drawingText);
  ui.tracking.classList.toggle('hidden', !tracking);
  if (tracking) {
    fillPromptPool(tracking.gen.armsPool);
    ui.prompt.value = tracking.prompt;
  }
  ui.trackingStats.textContent = '';
  if (!view) view = new RolloutView(ui.view);
  view.setRollout(drawing);
  modelLabel = label;
  ui.name.textContent = `Live: ${label} · ${character.name} · ${character.starts[session.startIndex].label}`;
  ui.footer.textContent =
    `MuJoCo ${mj.mj_versionString()} in WebAssembly (npm mujoco-js) · ${file}: ${policy.description} · mean actions · control ${Math.round(1 / session.controlDt)} Hz` +
    (tracking ? ` · ${tracking.gen.file}: ${tracking.gen.description}, noise seed ${TRACKING_SEED}` : '');
  ui.reset.disabled = false;
  ui.run.disabled = false;
  resetClock();
  draw();
}

async function selectModel(id) {
  const entry = manifest.models.find((m) => m.id === id);
  if (!entry) throw new Error(`models.json: no model '${id}'`);
  ui.model.value = id;
  const url = `${BASE}${entry.file}`;
  const bytes = new Uint8Array(await (await fetchOk(url, 'model')).arrayBuffer());
  await startSession(bytes, entry.file, entry.label, entry.generator || null);
}

function resetClock() {
  budget = 0;
  lastStamp = null;
  wallStart = null;
  achieved = 0;
  fps = 0;
  framesSinceWallStart = 0;
}

function reset(startIndex = Number(ui.start.value)) {
  if (!session) return;
  ui.start.value = String(startIndex);
  session.reset(startIndex);
  ui.name.textContent = `Live: ${modelLabel} · ${session.character.name} · ${session.character.starts[startIndex].label}`;
  resetClock();
  draw();
}

function draw() {
  if (!session || !view || !drawing) return;
  const s = session.sim.states;
  const nb = session.sim.nb;
  for (let i = 0; i < 3 * nb; ++i) drawing.positions[i] = s.pos[i];
  for (let i = 0; i < 4 * nb; ++i) drawing.rotations[i] = s.rot[i];
  drawing.masks[0] = session.mask;
  if (drawing.goals) {
    const g = session.goalTargets(GOAL_FRAMES);
    for (let k = 0; k < GOAL_FRAMES; ++k) drawing.goals.targets[k] = g && k < g.targets.length ? g.targets[k] : null;
  }
  view.setFrame(0);
  view.render();
  const sum = session.summary();
  const fallen = sum.fallen ? ' · <span class="fallen">FALLEN</span>' : '';
  ui.stats.innerHTML =
    `t ${sum.time.toFixed(2)} s · distance ${sum.distance.toFixed(2)} m · speed ${sum.speed.toFixed(2)} m/s · ` +
    `falls ${sum.falls}${sum.firstFall !== null ? ` (first at ${sum.firstFall.toFixed(2)} s)` : ''}${fallen}`;
  const who = session.policy.kind === 'maskadapt.residual_policy' ? 'adapted by the residual (hidden from the base)' : 'hidden from the policy';
  ui.maskLabel.textContent =
    `${who}: ${maskText(session.mask).replaceAll(',', ', ')} · ${sum.realTimeFactor > 0 ? `${sum.stepMs.toFixed(2)} ms per control step: ${sum.realTimeFactor.toFixed(1)}× real time possible` : ''}` +
    (achieved > 0 ? ` · running at ${achieved.toFixed(2)}× real time` : '') +
    (sum.physicsResets ? ` · ${sum.physicsResets} physics reset(s)` : '');
  const tr = sum.tracking;
  ui.trackingStats.textContent = tr
    ? `prompt "${tr.prompt}" · tracking error ${tr.trackingError === null ? '–' : `${tr.trackingError.toFixed(3)} m`}, mean ${tr.meanTrackingError === null ? '–' : `${tr.meanTrackingError.toFixed(3)} m`} · ` +
      `${tr.primitives} goal primitives generated` + (tr.generateMs !== null ? `, ${tr.generateMs.toFixed(1)} ms per generate (max ${tr.generateMsMax.toFixed(1)})` : '')
    : '';
  window.__liveState = state();
}

/** Switches the prompt of a tracking run (from now on); a prompt without words is an error in the page. */
function applyPrompt(prompt) {
  if (!session || !session.tracking) {
    showError('prompt: the prompt drives a text-driven tracking policy: pick one in the model list first');
    return false;
  }
  try {
    session.setPrompt(prompt);
  } catch (e) {
    showError(`prompt: ${e.message}`);
    return false;
  }
  showError('');
  ui.prompt.value = prompt;
  draw();
  return true;
}

/** Replaces the text generator by a file the user opened (the run restarts with it). */
async function openGenerator(bytes, name) {
  if (!session || !session.tracking) throw new Error(`${name}: a generator drives a text-driven tracking policy: pick one in the model list first`);
  const data = await loadTrackingData(session.character.name);
  const gen = loadGenerator(bytes, name, data.skel);  // (throws naming the file and section)
  userGenerator = gen;
  session.setTracking(gen, data, session.tracking.prompt, TRACKING_SEED);
  ui.footer.textContent = ui.footer.textContent.replace(/ · [^·]*: text generator: .*$/, '') + ` · ${gen.file}: ${gen.description}, noise seed ${TRACKING_SEED}`;
  fillPromptPool(gen.armsPool);
  resetClock();
  showError('');
  draw();
}

function state() {
  if (!session) return { ready: false, error: ui.error.classList.contains('hidden') ? '' : ui.error.textContent };
  return {
    ready: true,
    model: ui.model.value,
    kind: session.policy.kind,
    modelLabel,
    character: session.character.name,
    start: session.startIndex,
    running,
    speed,
    achievedRealTime: achieved,
    framesPerSecond: fps,
    bodyNames: session.character.bodies.map((b) => b.name),
    bodyColors: drawing ? bodyColors(drawing, 0) : [],
    meshColors: view ? view.materials.map((m) => `#${m.color.getHexString()}`) : [],
    error: ui.error.classList.contains('hidden') ? '' : ui.error.textContent,
    goalsDrawn: drawing && drawing.goals ? drawing.goals.targets.filter((t) => t).length : 0,
    goalSpheres: view && view.goalMeshes ? view.goalMeshes.filter((m) => m.visible).map((m) => m.position.toArray()) : [],
    ...session.summary(),
    maskText: maskText(session.mask),
  };
}

function loop(stamp) {
  requestAnimationFrame(loop);
  if (!session || !$('panel-live').classList.contains('active')) {
    lastStamp = null;
    return;
  }
  if (running) {
    // (up to 1 s of wall time per frame: a slow renderer lowers the frame rate, not the speed)
    const dtWall = lastStamp === null ? 0 : Math.min(1, (stamp - lastStamp) / 1000);
    if (wallStart === null) {
      wallStart = stamp;
      simAtWallStart = session.time;
    }
    budget += dtWall * speed;
    const dt = session.controlDt;
    let n = 0;
    const cap = Math.ceil((4 * speed) / dt);
    while (budget >= dt && n < cap) {
      session.step();
      budget -= dt;
      ++n;
    }
    if (n === cap) budget = 0;  // the machine cannot keep up: drop the backlog
    ++framesSinceWallStart;
    if (stamp - wallStart > 500) {
      achieved = (session.time - simAtWallStart) / ((stamp - wallStart) / 1000);
      fps = framesSinceWallStart / ((stamp - wallStart) / 1000);
    }
    lastStamp = stamp;
    if (n > 0) draw();
  } else {
    lastStamp = null;
  }
}

function setRunning(on) {
  running = on;
  ui.run.textContent = running ? 'Pause' : 'Run';
  resetClock();
}

/** Opens the tab's content once (MuJoCo is loaded on first use: 11 MB). */
export async function initLive() {
  if (started) return window.__live.ready;
  started = true;
  partCheckboxes();
  ui.name.textContent = 'Live: loading MuJoCo (WebAssembly, 11 MB)…';
  ui.model.addEventListener('change', () => selectModel(ui.model.value).catch((e) => showError(e.message)));
  ui.start.addEventListener('change', () => reset(Number(ui.start.value)));
  ui.reset.addEventListener('click', () => reset());
  ui.run.addEventListener('click', () => setRunning(!running));
  ui.speed.addEventListener('change', () => {
    speed = Number(ui.speed.value);
    resetClock();
  });
  ui.promptApply.addEventListener('click', () => applyPrompt(ui.prompt.value));
  ui.prompt.addEventListener('keydown', (e) => {
    if (e.key === 'Enter') applyPrompt(ui.prompt.value);
  });
  ui.promptPick.addEventListener('change', () => {
    if (ui.promptPick.value) applyPrompt(ui.promptPick.value);
    ui.promptPick.value = '';
  });
  ui.generatorFile.addEventListener('change', async (e) => {
    const f = e.target.files[0];
    if (!f) return;
    try {
      await openGenerator(new Uint8Array(await f.arrayBuffer()), f.name);
    } catch (err) {
      showError(err.message);
    }
  });
  $('live-mask-none').addEventListener('click', () => applyMask(0));
  $('live-mask-legs').addEventListener('click', () => applyMask(parseMask('left_leg,right_leg')));
  $('live-mask-arms').addEventListener('click', () => applyMask(parseMask('arms')));
  ui.file.addEventListener('change', async (e) => {
    const f = e.target.files[0];
    if (!f) return;
    try {
      await startSession(new Uint8Array(await f.arrayBuffer()), f.name, f.name);
      ui.model.value = '';
    } catch (err) {
      showError(err.message);
    }
  });
  requestAnimationFrame(loop);
  const ready = (async () => {
    try {
      manifest = await (await fetchOk(`${BASE}models.json`, 'model list')).json();
      if (!Array.isArray(manifest.models) || !manifest.models.length) throw new Error(`${BASE}models.json: field 'models' must be a non-empty list`);
      for (const m of manifest.models) ui.model.add(new Option(m.label, m.id));
      mj = await loadMujoco();
      await selectModel(manifest.models[0].id);
      return true;
    } catch (e) {
      showError(e.message);
      ui.name.textContent = 'Live: not running (see the error above)';
      return false;
    }
  })();
  window.__live.ready = ready;
  return ready;
}

window.__live = {
  ready: null,
  init: () => initLive(),
  async select(id) {
    await selectModel(id);
    return state();
  },
  setMask(m) {
    applyMask(typeof m === 'number' ? m : parseMask(m));
    return state();
  },
  reset(startIndex) {
    reset(startIndex === undefined ? Number(ui.start.value) : startIndex);
    return state();
  },
  /** Runs `seconds` of simulated time at once (the animation is paused first), then draws. */
  runSeconds(seconds) {
    setRunning(false);
    const t0 = performance.now();
    const steps0 = session.steps;
    session.runSeconds(seconds);
    const wallMs = performance.now() - t0;
    draw();
    const simulated = (session.steps - steps0) * session.controlDt;
    return { ...state(), runWallMs: wallMs, runRealTimeFactor: simulated / (wallMs / 1000) };
  },
  /** Types a prompt into the box and applies it (errors go to the page); returns the state. */
  setPrompt(prompt) {
    ui.prompt.value = prompt;
    const ok = applyPrompt(prompt);
    return { ...state(), promptAccepted: ok };
  },
  /** Opens generator bytes as if the user had picked a generator file (errors go to the page). */
  async openGeneratorBytes(bytes, name) {
    try {
      await openGenerator(bytes instanceof Uint8Array ? bytes : Uint8Array.from(bytes), name);
      return state();
    } catch (e) {
      showError(e.message);
      return { ...state(), error: e.message };
    }
  },
  pause: () => setRunning(false),
  resume: () => setRunning(true),
  /** Loads policy bytes as if the user had opened a file (errors go to the page and are returned). */
  async openBytes(bytes, name) {
    try {
      await startSession(bytes instanceof Uint8Array ? bytes : Uint8Array.from(bytes), name, name);
      return state();
    } catch (e) {
      showError(e.message);
      return { ...state(), error: e.message };
    }
  },
  state,
};
