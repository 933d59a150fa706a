// Sinew's replay viewer (docs/viewer.md): plays one or more sinew-record files in sync, side by side, with
// a time series under them. Recordings come from the local server (`scripts/dev view FILE...`), from
// ?rec=URL parameters, or from files dropped on the page.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import uPlot from 'uplot';
import 'uplot/dist/uPlot.min.css';
import { parseRecording, frameAtTime, frameTime, RecordError } from './record.js';
import { RecordingView } from './recording_view.js';
import { meanSpeed, rmsDistance, referenceIndex, comparable } from './series.js';

const $ = (id) => document.getElementById(id);
const api = { ready: false, error: null, warnings: [], recordings: [] };
window.sinewViewer = api;

const state = { recs: [], views: [], t: 0, t0: 0, t1: 0, playing: false, speed: 1, loop: true, series: 'speed',
  lastReal: null, chart: null, dirty: true };

const renderer = new THREE.WebGLRenderer({ canvas: $('view'), antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio || 1);
const camera = new THREE.PerspectiveCamera(45, 1, 0.05, 2000);
const controls = new OrbitControls(camera, renderer.domElement);
controls.addEventListener('change', () => { state.dirty = true; });

function showError(message) {
  api.error = message;
  const e = $('error');
  e.textContent = message;
  e.hidden = false;
  $('status').textContent = '';
}

function showWarnings(list) {
  api.warnings.push(...list);
  if (list.length === 0) return;
  const w = $('warnings');
  w.textContent = api.warnings.join('\n');
  w.hidden = false;
}

// Viewport rectangles (CSS pixels, origin bottom-left as WebGL wants) for n views in the canvas.
function viewports(n, width, height) {
  const cols = n <= 3 ? n : Math.ceil(Math.sqrt(n));
  const rows = Math.ceil(n / cols);
  const w = width / cols, h = height / rows, out = [];
  for (let i = 0; i < n; ++i) {
    const c = i % cols, r = Math.floor(i / cols);
    out.push({ x: c * w, y: height - (r + 1) * h, w, h });
  }
  return out;
}

function resize() {
  const canvas = renderer.domElement;
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== Math.floor(w * renderer.getPixelRatio()) || canvas.height !== Math.floor(h * renderer.getPixelRatio()))
    renderer.setSize(w, h, false);
  state.dirty = true;
  if (state.chart) state.chart.setSize({ width: $('chart').clientWidth, height: $('chart').clientHeight - 30 });
}

function render() {
  const canvas = renderer.domElement;
  const vps = viewports(state.views.length, canvas.clientWidth, canvas.clientHeight);
  renderer.setScissorTest(true);
  state.views.forEach((view, i) => {
    const vp = vps[i];
    renderer.setViewport(vp.x, vp.y, vp.w, vp.h);
    renderer.setScissor(vp.x, vp.y, vp.w, vp.h);
    camera.aspect = vp.w / Math.max(vp.h, 1);
    camera.updateProjectionMatrix();
    renderer.render(view.scene, camera);
  });
  // Names over the views.
  const labels = $('labels');
  labels.replaceChildren(...state.views.map((view, i) => {
    const d = document.createElement('div');
    d.className = 'label';
    d.style.left = `${vps[i].x + 8}px`;
    d.style.top = `${canvas.clientHeight - vps[i].y - vps[i].h + 6}px`;
    d.textContent = `${view.rec.name}  ·  frame ${view.frame}/${view.rec.frames - 1}`;
    return d;
  }));
}

function setTime(t) {
  state.t = Math.min(Math.max(t, state.t0), state.t1);
  for (const view of state.views) view.setFrame(frameAtTime(view.rec, state.t));
  const first = state.views[0];
  $('timeline').value = String(state.t);
  $('clock').textContent = `t = ${state.t.toFixed(3)} s · frame ${first.frame}/${first.rec.frames - 1}`;
  if (state.chart) state.chart.redraw(false, false);
  if (state.picked) showPicked();
  state.dirty = true;
}

// Steps to the next (+1) or previous (-1) frame of the first recording.
function stepFrame(dir) {
  state.playing = false;
  updatePlayButton();
  const rec = state.views[0].rec;
  const k = Math.max(0, Math.min(rec.frames - 1, state.views[0].frame + dir));
  setTime(frameTime(rec, k));
}

function updatePlayButton() { $('play').textContent = state.playing ? '❚❚ pause' : '▶ play'; }

function tick(now) {
  if (state.playing && state.views.length) {
    if (state.lastReal !== null) {
      let t = state.t + ((now - state.lastReal) / 1000) * state.speed;
      if (t > state.t1) {
        if (state.loop) t = state.t0;
        else { t = state.t1; state.playing = false; updatePlayButton(); }
      }
      setTime(t);
    }
    state.lastReal = now;
  } else {
    state.lastReal = null;
  }
  if (state.dirty && state.views.length) { render(); state.dirty = false; }
  requestAnimationFrame(tick);
}

function fitCamera() {
  const s = state.views[0].bounds(0);
  for (const v of state.views) { v.normalLength = 0.04 * s.radius; v.updateOverlays(); }
  controls.target.copy(s.center);
  const d = s.radius * 2.2;
  camera.position.set(s.center.x + 0.55 * d, s.center.y + 0.45 * d, s.center.z + 0.75 * d);
  camera.near = Math.max(0.01, d / 500);
  camera.far = d * 50 + 500;
  camera.updateProjectionMatrix();
  controls.update();
}

// Picking: the view under the pointer, then the first body its ray meets.
const raycaster = new THREE.Raycaster();
function pickAt(clientX, clientY) {
  const canvas = renderer.domElement, rect = canvas.getBoundingClientRect();
  const x = clientX - rect.left, y = rect.height - (clientY - rect.top);
  const vps = viewports(state.views.length, rect.width, rect.height);
  const i = vps.findIndex((vp) => x >= vp.x && x < vp.x + vp.w && y >= vp.y && y < vp.y + vp.h);
  if (i < 0) return null;
  const vp = vps[i];
  camera.aspect = vp.w / vp.h;
  camera.updateProjectionMatrix();
  raycaster.setFromCamera(new THREE.Vector2(((x - vp.x) / vp.w) * 2 - 1, ((y - vp.y) / vp.h) * 2 - 1), camera);
  const hit = state.views[i].pick(raycaster);
  return hit ? { view: i, ...hit } : null;
}

const fmt = (v) => (Number.isFinite(v) ? v.toFixed(3) : String(v));
function showPicked() {
  const p = state.picked, info = $('info');
  if (!p) { info.hidden = true; return; }
  const view = state.views[p.view], rec = view.rec, k = view.frame, n = rec.frameFloats, v = rec.values;
  let text;
  if (p.kind === 'body') {
    const b = rec.header.bodies[p.index], o = k * n + 1 + 7 * p.index;
    let speed = '';
    if (k > 0) {
      const dt = v[k * n] - v[(k - 1) * n];
      const d = Math.hypot(v[o] - v[o - n], v[o + 1] - v[o + 1 - n], v[o + 2] - v[o + 2 - n]);
      if (dt > 0) speed = `\nspeed     ${fmt(d / dt)} m/s`;
    }
    text = `${b.name}  (${b.type} ${b.shape.type})\nposition  ${fmt(v[o])}, ${fmt(v[o + 1])}, ${fmt(v[o + 2])}\n` +
      `rotation  w ${fmt(v[o + 3])}  x ${fmt(v[o + 4])}  y ${fmt(v[o + 5])}  z ${fmt(v[o + 6])}${speed}`;
  } else {
    const s = rec.header.particles[p.index], off = view.softs[p.index].offset;
    let cx = 0, cy = 0, cz = 0;
    for (let i = 0; i < s.count; ++i) { cx += v[k * n + off + 3 * i]; cy += v[k * n + off + 3 * i + 1]; cz += v[k * n + off + 3 * i + 2]; }
    text = `${s.name}  (soft, ${s.method}, ${s.count} particles)\ncentroid  ${fmt(cx / s.count)}, ${fmt(cy / s.count)}, ${fmt(cz / s.count)}`;
  }
  info.textContent = `${text}\n(${rec.name}, frame ${k})`;
  info.hidden = false;
  api.picked = { view: p.view, kind: p.kind, index: p.index, name: text.split('  ')[0] };
}

// The chart under the views: mean speed per recording, or each recording's RMS distance from the reference.
function buildChart() {
  const el = $('chart');
  if (state.chart) { state.chart.destroy(); state.chart = null; }
  const recs = state.recs, ref = recs[referenceIndex(recs)];
  const xs = Array.from({ length: ref.frames }, (_, k) => frameTime(ref, k));
  const sampled = (rec, ys) => xs.map((t) => ys[frameAtTime(rec, t)]);
  const kind = state.series === 'distance' && recs.length > 1 ? 'distance' : 'speed';
  const data = [xs];
  const series = [{ label: 't (s)' }];
  recs.forEach((rec, i) => {
    if (kind === 'distance' && rec === ref) return;
    const ys = kind === 'distance' ? rmsDistance(rec, ref) : meanSpeed(rec);
    data.push(sampled(rec, ys));
    series.push({ label: rec.name, stroke: `hsl(${(i * 222.5) % 360} 70% 62%)`, width: 1.5,
      value: (u, v) => (v == null ? '-' : v.toPrecision(3)) });
  });
  const cursorLine = { hooks: { draw: [(u) => {
    const x = u.valToPos(state.t, 'x', true), ctx = u.ctx;
    ctx.save(); ctx.strokeStyle = '#f4f4f4'; ctx.lineWidth = 1;
    ctx.beginPath(); ctx.moveTo(x, u.bbox.top); ctx.lineTo(x, u.bbox.top + u.bbox.height); ctx.stroke(); ctx.restore();
  }] } };
  $('chart-title').textContent = kind === 'distance'
    ? `RMS distance of bodies and particles from "${ref.name}" (m)` : 'mean speed of moving bodies and particles (m/s)';
  state.chart = new uPlot({ width: el.clientWidth, height: Math.max(80, el.clientHeight - 30), series,
    scales: { x: { time: false } }, axes: [{ stroke: '#bbb', grid: { stroke: '#333' } }, { stroke: '#bbb', grid: { stroke: '#333' } }],
    legend: { live: true }, plugins: [cursorLine] }, data, el);
  api.chart = { kind, series: series.length - 1, points: xs.length };
}

async function loadAll(sources) {
  $('status').textContent = `loading ${sources.length} recording${sources.length > 1 ? 's' : ''}…`;
  const recs = [];
  for (const src of sources) {
    const buffer = await src.load();
    recs.push(parseRecording(src.name, buffer));
  }
  start(recs);
}

function start(recs) {
  for (const v of state.views) v.scene.traverse((o) => { if (o.geometry) o.geometry.dispose(); });
  state.recs = recs;
  state.views = recs.map((r) => new RecordingView(r));
  state.t0 = Math.min(...recs.map((r) => frameTime(r, 0)));
  state.t1 = Math.max(...recs.map((r) => frameTime(r, r.frames - 1)));
  const tl = $('timeline');
  tl.min = String(state.t0);
  tl.max = String(state.t1);
  tl.step = String(Math.max(1e-6, Math.min(...recs.map((r) => r.header.time_step || 1 / 60))) / 4);
  if (recs.length > 1 && !recs.every((r) => comparable(r, recs[0])))
    showWarnings(['these recordings hold different bodies; the distance chart is empty']);
  for (const r of recs) showWarnings(r.warnings);
  $('series').disabled = recs.length < 2;
  $('contacts').disabled = !recs.some((r) => r.contacts);
  $('joints').disabled = !recs.some((r) => (r.header.joints || []).length);
  overlays();
  $('series').value = recs.length > 1 ? 'distance' : 'speed';
  state.series = $('series').value;
  $('empty').hidden = true;
  $('status').textContent = '';
  fitCamera();
  resize();
  buildChart();
  setTime(state.t0);
  state.playing = !new URLSearchParams(location.search).has('paused');
  updatePlayButton();
  api.recordings = recs.map((r) => ({ name: r.name, frames: r.frames, bodies: r.header.bodies.length, softBodies: r.header.particles.length }));
  api.ready = true;
}

// --- the page's controls -------------------------------------------------------------------------------
$('play').onclick = () => { state.playing = !state.playing; updatePlayButton(); };
$('back').onclick = () => stepFrame(-1);
$('forward').onclick = () => stepFrame(1);
$('timeline').oninput = (e) => { state.playing = false; updatePlayButton(); setTime(parseFloat(e.target.value)); };
$('series').onchange = (e) => { state.series = e.target.value; buildChart(); };
window.addEventListener('keydown', (e) => {
  if (!state.views.length || e.target.tagName === 'INPUT' || e.target.tagName === 'SELECT') return;
  if (e.code === 'Space') { state.playing = !state.playing; updatePlayButton(); e.preventDefault(); }
  else if (e.code === 'ArrowRight') stepFrame(1);
  else if (e.code === 'ArrowLeft') stepFrame(-1);
});
let down = null;
renderer.domElement.addEventListener('pointerdown', (e) => { down = [e.clientX, e.clientY]; });
renderer.domElement.addEventListener('pointerup', (e) => {
  if (!down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > 4 || !state.views.length) return;
  state.picked = pickAt(e.clientX, e.clientY);
  showPicked();
});
window.addEventListener('resize', resize);

$('speed').onchange = (e) => { state.speed = parseFloat(e.target.value); };
$('loop').onchange = (e) => { state.loop = e.target.checked; };
const overlays = () => { for (const v of state.views) v.setOverlays($('contacts').checked, $('joints').checked); state.dirty = true; };
$('contacts').onchange = overlays;
$('joints').onchange = overlays;
$('fit').onclick = () => { if (state.views.length) { fitCamera(); state.dirty = true; } };

function fileSources(files) {
  return [...files].map((f) => ({ name: f.name, load: () => f.arrayBuffer() }));
}
$('files').onchange = (e) => loadAll(fileSources(e.target.files)).catch(fail);
document.body.addEventListener('dragover', (e) => e.preventDefault());
document.body.addEventListener('drop', (e) => { e.preventDefault(); loadAll(fileSources(e.dataTransfer.files)).catch(fail); });

function fail(e) {
  showError(e instanceof RecordError ? e.message : `could not load: ${e.message || e}`);
}

function urlSource(url) {
  const name = decodeURIComponent(url.split('/').pop().split('?')[0]);
  return { name, load: async () => {
    const r = await fetch(url);
    if (!r.ok) throw new RecordError(`${name}: HTTP ${r.status} ${r.statusText}`);
    return r.arrayBuffer();
  } };
}

// --- test hooks (tools/viewer/test/browser_test.mjs) ---------------------------------------------------------
api.stats = () => state.views.map((v) => v.stats());
api.setTime = (t) => { state.playing = false; updatePlayButton(); setTime(t); render(); };
/// Places every view at frame k of the first recording without drawing (for timing the per-frame update).
api.setFrameOnly = (k) => { for (const v of state.views) v.setFrame(frameAtTime(v.rec, frameTime(state.views[0].rec, k))); };
api.frames = () => state.views.map((v) => v.frame);
api.setFrame = (k) => api.setTime(frameTime(state.views[0].rec, k));
/// Where body b of view i is drawn, in page pixels.
api.project = (i, b) => {
  const canvas = renderer.domElement, rect = canvas.getBoundingClientRect();
  const vp = viewports(state.views.length, rect.width, rect.height)[i];
  camera.aspect = vp.w / vp.h;
  camera.updateProjectionMatrix();
  const p = state.views[i].bodyPosition(b).project(camera);
  return { x: rect.left + vp.x + ((p.x + 1) / 2) * vp.w, y: rect.top + rect.height - (vp.y + ((p.y + 1) / 2) * vp.h) };
};
api.background = '#1d2128';

async function main() {
  resize();
  requestAnimationFrame(tick);
  const params = new URLSearchParams(location.search);
  const given = params.getAll('rec');
  if (given.length) return loadAll(given.map(urlSource));
  const r = await fetch('recordings/list.json').catch(() => null);
  if (r && r.ok) {
    const list = await r.json();
    if (list.length) return loadAll(list.map((e) => ({ name: e.name, load: urlSource(e.url).load })));
  }
  $('empty').hidden = false;
  api.ready = true; // nothing to play: the page waits for files
}
main().catch(fail);
