// Wiring of the viewer UI: rollout views + playback, training-log charts.
import uPlot from 'uplot';
import 'uplot/dist/uPlot.min.css';
import './style.css';
import { parseRollout, frameAtTime, textAt } from './rollout.js';
import { legendEntries, maskLabel } from './colors.js';
import { parseLog, seriesKeys, alignSeries, DEFAULT_SERIES } from './logs.js';
import { Player } from './player.js';
import { RolloutView } from './scene.js';
import { initLive } from './live/live.js';

const $ = (id) => document.getElementById(id);
const statusEl = $('status');
function setStatus(msg) {
  statusEl.textContent = msg;
}

// ---- tabs ---------------------------------------------------------------------------------
for (const tab of document.querySelectorAll('nav .tab')) {
  tab.addEventListener('click', () => {
    for (const t of document.querySelectorAll('nav .tab')) t.classList.toggle('active', t === tab);
    for (const p of document.querySelectorAll('.panel')) p.classList.toggle('active', p.id === `panel-${tab.dataset.tab}`);
    if (tab.dataset.tab === 'rollouts') slots.forEach((s) => s.view && s.view.resize());
    else if (tab.dataset.tab === 'live') initLive();
    else renderCharts();
  });
}

// ---- rollouts -----------------------------------------------------------------------------
const player = new Player();
const slots = [
  { el: $('view-a'), view: null, rollout: null, name: '' },
  { el: $('view-b'), view: null, rollout: null, name: '' },
];
const scrub = $('scrub');
const playBtn = $('play');

function maxFrames() {
  return Math.max(0, ...slots.filter((s) => s.rollout).map((s) => s.rollout.numFrames));
}
function refFps() {
  const s = slots.find((x) => x.rollout);
  return s ? s.rollout.fps : 30;
}

function loadRollout(slotIndex, text, name) {
  let rollout;
  try {
    rollout = parseRollout(text);
  } catch (e) {
    setStatus(`${name}: ${e.message}`);
    return false;
  }
  const slot = slots[slotIndex];
  slot.el.classList.remove('hidden');
  if (!slot.view) slot.view = new RolloutView(slot.el);
  slot.rollout = rollout;
  slot.name = name;
  slot.view.setRollout(rollout);
  const meta = rollout.metadata || {};
  slot.el.querySelector('.name').textContent =
    `${slotIndex ? 'B' : 'A'}: ${name} (${rollout.numFrames} frames @ ${rollout.fps} fps)` + (meta.command ? ` · ${meta.command}` : '');
  slots.forEach((s) => s.view && s.view.resize());
  player.duration = Math.max(...slots.filter((s) => s.rollout).map((s) => s.rollout.duration));
  scrub.max = String(Math.max(0, maxFrames() - 1));
  scrub.disabled = false;
  playBtn.disabled = false;
  $('clear-b').disabled = !slots[1].rollout;
  setStatus('');
  showTime(player.time);
  return true;
}

function readFile(file) {
  return new Promise((resolve, reject) => {
    const reader = new FileReader();
    reader.onload = () => resolve(reader.result);
    reader.onerror = () => reject(reader.error);
    reader.readAsText(file);
  });
}

async function openRolloutFile(slotIndex, file) {
  if (!file) return;
  loadRollout(slotIndex, await readFile(file), file.name);
}

$('file-a').addEventListener('change', (e) => openRolloutFile(0, e.target.files[0]));
$('file-b').addEventListener('change', (e) => openRolloutFile(1, e.target.files[0]));
$('clear-b').addEventListener('click', () => {
  const b = slots[1];
  b.rollout = null;
  b.el.classList.add('hidden');
  $('clear-b').disabled = true;
  slots.forEach((s) => s.view && s.view.resize());
});

for (const [i, slot] of slots.entries()) {
  slot.el.addEventListener('dragover', (e) => {
    e.preventDefault();
    slot.el.classList.add('dragover');
  });
  slot.el.addEventListener('dragleave', () => slot.el.classList.remove('dragover'));
  slot.el.addEventListener('drop', (e) => {
    e.preventDefault();
    slot.el.classList.remove('dragover');
    openRolloutFile(i, e.dataTransfer.files[0]);
  });
}
// Let drops that miss a view do nothing (instead of the browser opening the file).
$('views').addEventListener('dragover', (e) => e.preventDefault());

playBtn.addEventListener('click', () => {
  player.playing = !player.playing;
  if (player.playing && player.time >= player.duration) player.seek(0);
  playBtn.textContent = player.playing ? 'Pause' : 'Play';
});
scrub.addEventListener('input', () => {
  player.seek(Number(scrub.value) / refFps());
  showTime(player.time);
});
$('speed').addEventListener('change', (e) => (player.speed = Number(e.target.value)));
document.addEventListener('keydown', (e) => {
  if (e.target.tagName === 'INPUT' && e.target.type !== 'range') return;
  if (!$('panel-rollouts').classList.contains('active')) return;
  if (e.code === 'Space') {
    e.preventDefault();
    playBtn.click();
  }
});

function renderLegend(mask) {
  const legend = $('legend');
  legend.replaceChildren(
    ...legendEntries(mask).map((entry) => {
      const item = document.createElement('span');
      item.className = `legend-item${entry.active ? ' active' : ''}`;
      const sw = document.createElement('span');
      sw.className = 'swatch';
      sw.style.background = entry.color;
      item.append(sw, document.createTextNode(`${entry.name}${entry.active ? ' (adapted)' : ''}`));
      return item;
    }),
  );
}
let lastLegendMask = -1;

function showTime(t) {
  const views = [];
  for (const slot of slots) {
    if (!slot.rollout) continue;
    const f = frameAtTime(slot.rollout, t);
    slot.view.setFrame(f);
    slot.view.render();
    const mask = slot.rollout.masks[f];
    slot.el.querySelector('.text').textContent = textAt(slot.rollout, t);
    slot.el.querySelector('.mask').textContent = `adapted parts: ${maskLabel(mask)}`;
    views.push({
      name: slot.name,
      frame: f,
      numFrames: slot.rollout.numFrames,
      mask,
      maskLabel: maskLabel(mask),
      text: textAt(slot.rollout, t),
      bodyNames: slot.rollout.bodies.map((b) => b.name),
      bodyParts: slot.rollout.bodies.map((b) => b.part),
      bodyColors: slot.view.colors.slice(),
      meshColors: slot.view.materials.map((m) => `#${m.color.getHexString()}`),
      scene: slot.view.sceneGoals.state(),
    });
  }
  const first = views[0];
  const frame = first ? first.frame : 0;
  scrub.value = String(Math.round(t * refFps()));
  $('time-label').textContent = `${t.toFixed(2)} s · frame ${frame} / ${Math.max(0, maxFrames() - 1)}`;
  if (first && first.mask !== lastLegendMask) {
    renderLegend(first.mask);
    lastLegendMask = first.mask;
  }
  state.frame = frame;
  state.time = t;
  state.views = views;
}

// Test hook (used by the headless end-to-end test): current playback state and body colours.
const state = { frame: 0, time: 0, views: [], logs: { runs: [], series: [] } };
Object.defineProperty(state, 'playing', { get: () => player.playing, enumerable: true });
Object.defineProperty(state, 'speed', { get: () => player.speed, enumerable: true });
window.__viewerState = state;
window.__viewerSlots = slots;  // the views (three.js scenes), for debugging from the console

let lastStamp = null;
function animate(stamp) {
  const dt = lastStamp === null ? 0 : Math.min((stamp - lastStamp) / 1000, 0.25);
  lastStamp = stamp;
  if (player.playing) {
    player.tick(dt);
    if (!player.playing) playBtn.textContent = 'Play';
    showTime(player.time);
  }  // paused: views re-render on demand (orbit controls' change events, resizes)
  requestAnimationFrame(animate);
}
requestAnimationFrame(animate);
renderLegend(0);

// ---- training logs ------------------------------------------------------------------------
const RUN_COLORS = ['#1f77b4', '#d62728', '#2ca02c', '#9467bd', '#ff7f0e', '#8c564b', '#e377c2', '#17becf'];
const runs = [];
const selected = new Set();
let plots = [];

async function openLogs(files) {
  for (const file of files) {
    try {
      runs.push(parseLog(await readFile(file), file.name));
      setStatus('');
    } catch (e) {
      setStatus(e.message);
    }
  }
  if (selected.size === 0) for (const k of DEFAULT_SERIES) if (seriesKeys(runs).includes(k)) selected.add(k);
  renderSeriesPicker();
  renderCharts();
}

function renderSeriesPicker() {
  $('runs').replaceChildren(
    ...runs.map((r, i) => {
      const chip = document.createElement('span');
      chip.className = 'run-chip';
      chip.style.background = RUN_COLORS[i % RUN_COLORS.length];
      chip.textContent = `${r.name} (${r.rows})`;
      return chip;
    }),
  );
  $('series').replaceChildren(
    ...seriesKeys(runs).map((key) => {
      const label = document.createElement('label');
      const box = document.createElement('input');
      box.type = 'checkbox';
      box.checked = selected.has(key);
      box.dataset.key = key;
      box.addEventListener('change', () => {
        if (box.checked) selected.add(key);
        else selected.delete(key);
        renderCharts();
      });
      label.append(box, document.createTextNode(` ${key}`));
      return label;
    }),
  );
  state.logs.runs = runs.map((r) => r.name);
}

function renderCharts() {
  for (const p of plots) p.destroy();
  plots = [];
  const charts = $('charts');
  charts.replaceChildren();
  if (!runs.length) {
    const hint = document.createElement('p');
    hint.className = 'hint';
    hint.textContent = 'Drop training log files here (several runs are overlaid).';
    charts.append(hint);
  }
  // Two charts per row on wide screens (grid gap 16 px, padding 2 × 16 px).
  const inner = charts.clientWidth - 32;
  const width = Math.max(320, inner >= 1000 ? Math.floor((inner - 16) / 2) : inner);
  for (const key of [...selected].sort()) {
    const box = document.createElement('div');
    charts.append(box);
    const opts = {
      title: key,
      width,
      height: 260,
      scales: { x: { time: false } },
      axes: [{ label: 'iteration' }, {}],
      series: [{ label: 'iteration' }, ...runs.map((r, i) => ({ label: r.name, stroke: RUN_COLORS[i % RUN_COLORS.length], width: 1.5, spanGaps: true }))],
    };
    plots.push(new uPlot(opts, alignSeries(runs, key), box));
  }
  state.logs.series = [...selected].sort();
}

$('log-files').addEventListener('change', (e) => openLogs([...e.target.files]));
$('clear-logs').addEventListener('click', () => {
  runs.length = 0;
  selected.clear();
  renderSeriesPicker();
  renderCharts();
});
const chartsEl = $('charts');
chartsEl.addEventListener('dragover', (e) => {
  e.preventDefault();
  chartsEl.classList.add('dragover');
});
chartsEl.addEventListener('dragleave', () => chartsEl.classList.remove('dragover'));
chartsEl.addEventListener('drop', (e) => {
  e.preventDefault();
  chartsEl.classList.remove('dragover');
  openLogs([...e.dataTransfer.files]);
});

// `#live` in the address opens the Live tab directly (the README's link).
if (location.hash === '#live') $('tab-live').click();
