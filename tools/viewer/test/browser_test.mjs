#!/usr/bin/env node
// The viewer in a real browser (issue 12): Debian's Chromium, headless, driven by playwright-core.
//   node tools/viewer/test/browser_test.mjs --sinew build/bin/sinew --scenes demos/scenes [--screenshots DIR]
// Records small runs with the sinew tool, serves them with serve.mjs, and checks what the page drew:
// every body of the header is drawn, each dynamic body's centre shows a coloured (not grey) pixel in a
// screenshot of a known frame, the background shows where nothing is, two recordings play side by side
// with a distance chart, a soft body's surface is drawn, and malformed or truncated files give a readable
// message in the page. Pixel checks, not a golden image: a font or driver change does not break them.
// CTest label "browser" (scripts/dev test-browser); CI runs it.
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { PNG } from 'pngjs';
import { chromium } from 'playwright-core';
import { startServer } from '../serve.mjs';

const args = process.argv.slice(2);
const opt = (name, fallback) => { const i = args.indexOf(name); return i >= 0 ? args[i + 1] : fallback; };
const sinew = opt('--sinew', 'build/bin/sinew');
const scenes = opt('--scenes', 'demos/scenes');
const shots = opt('--screenshots', '');
const chromiumPath = process.env.CHROMIUM || '/usr/bin/chromium';
if (!fs.existsSync(chromiumPath)) { console.error(`browser test: no Chromium at ${chromiumPath}; run scripts/setup viewer`); process.exit(1); }

let failures = 0;
const check = (ok, what) => { console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`); if (!ok) failures++; };

// --- recordings ----------------------------------------------------------------------------------------
const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'sinew-viewer-'));
const record = (scene, file, extra = []) => {
  execFileSync(sinew, ['run', path.join(scenes, scene), '--record', path.join(tmp, file), ...extra], { stdio: ['ignore', 'ignore', 'inherit'] });
  return path.join(tmp, file);
};
const boxes = record('showcase-falling-boxes.json', 'boxes.jsonl', ['--steps', '90']);
const boxesFine = record('showcase-falling-boxes.json', 'boxes-h2.jsonl', ['--steps', '180', '--dt', String(1 / 120)]);
const boxesBin = record('showcase-falling-boxes.json', 'boxes.sinrec', ['--steps', '90']);
const cloth = record('showcase-cloth.json', 'cloth.sinrec', ['--steps', '120']);
// A chain of three capsules on ball joints from a post, and a crate resting on the ground: joints and
// contacts for the overlays.
const chainScene = path.join(tmp, 'chain.json');
const link = (i) => ({ name: `link-${i}`, shape: { type: 'capsule', radius: 0.08, half_height: 0.2 }, position: [0.35 + 0.6 * i, 3, 0],
  rotation: [Math.SQRT1_2, 0, 0, Math.SQRT1_2] });
fs.writeFileSync(chainScene, JSON.stringify({ format: 'sinew-scene', version: 1, name: 'chain', settings: { steps: 60 },
  bodies: [{ name: 'ground', type: 'static', shape: { type: 'box', half_extents: [5, 0.5, 5] }, position: [0, -0.5, 0] },
    { name: 'post', type: 'static', shape: { type: 'box', half_extents: [0.1, 1.5, 0.1] }, position: [0, 1.5, 0] },
    link(0), link(1), link(2),
    { name: 'crate', shape: { type: 'box', half_extents: [0.25, 0.25, 0.25] }, position: [1.5, 0.25, 0.8] }],
  joints: [{ type: 'ball', body_a: 'link-0', body_b: 'post', anchor_a: [0, 0.3, 0] },
    { type: 'ball', body_a: 'link-1', body_b: 'link-0', anchor_a: [0, 0.3, 0] },
    { type: 'ball', body_a: 'link-2', body_b: 'link-1', anchor_a: [0, 0.3, 0] }] }));
const chainBin = path.join(tmp, 'chain.sinrec'), chainJson = path.join(tmp, 'chain.jsonl');
for (const f of [chainBin, chainJson])
  execFileSync(sinew, ['run', chainScene, '--record', f, '--record-contacts'], { stdio: ['ignore', 'ignore', 'inherit'] });
const header = JSON.parse(fs.readFileSync(boxes, 'utf8').split('\n')[0]);
const lines = fs.readFileSync(boxes, 'utf8').split('\n');
const bad = {
  notRecord: path.join(tmp, 'not-a-record.jsonl'),
  badFrame: path.join(tmp, 'bad-frame.jsonl'),
  truncated: path.join(tmp, 'truncated.sinrec'),
  truncatedJson: path.join(tmp, 'truncated.jsonl'),
  truncatedContacts: path.join(tmp, 'truncated-contacts.sinrec'),
};
fs.writeFileSync(bad.notRecord, '{"hello": "world"}\n');
{ // line 3 (frame 1): the first body loses a number
  const f = JSON.parse(lines[2]);
  f.bodies[0].pop();
  fs.writeFileSync(bad.badFrame, [lines[0], lines[1], JSON.stringify(f), ...lines.slice(3)].join('\n'));
}
{ // the binary file cut in the middle of its last frame; and the JSON file in the middle of a line
  const b = fs.readFileSync(boxesBin);
  fs.writeFileSync(bad.truncated, b.subarray(0, b.length - 100));
  const t = fs.readFileSync(boxes, 'utf8');
  fs.writeFileSync(bad.truncatedJson, t.slice(0, t.length - 200));
  const c = fs.readFileSync(chainBin); // frames of varying length (contacts): cut inside the last one
  fs.writeFileSync(bad.truncatedContacts, c.subarray(0, c.length - 10));
}

// --- the browser -----------------------------------------------------------------------------------------
const browser = await chromium.launch({ executablePath: chromiumPath, args: ['--no-sandbox', '--disable-gpu', '--disable-quic',
  '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync',
  '--use-angle=swiftshader', '--enable-unsafe-swiftshader'] });

async function open(files, { width = 1280, height = 800 } = {}) {
  const { server, url } = await startServer(files, 0);
  const page = await browser.newPage({ viewport: { width, height } });
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  await page.goto(url + '?paused');
  await page.waitForFunction(() => window.sinewViewer && (window.sinewViewer.ready || window.sinewViewer.error), null, { timeout: 60000 });
  return { page, server, errors };
}
async function close(o) { await o.page.close(); o.server.close(); }
const state = (page) => page.evaluate(() => ({ error: window.sinewViewer.error, warnings: window.sinewViewer.warnings,
  recordings: window.sinewViewer.recordings, stats: window.sinewViewer.stats(), chart: window.sinewViewer.chart }));

// The colour at a page pixel of a screenshot (PNG buffer) and its saturation.
function pixel(png, x, y) {
  const i = (Math.round(y) * png.width + Math.round(x)) * 4;
  const [r, g, b] = [png.data[i], png.data[i + 1], png.data[i + 2]];
  const max = Math.max(r, g, b), min = Math.min(r, g, b);
  return { r, g, b, saturation: max === 0 ? 0 : (max - min) / max };
}
// Dynamic bodies are drawn in saturated colours (HSL saturation 0.55); the ground, static bodies and the
// background are grey. A body whose centre projects into the view must show a coloured pixel there (its
// own or another dynamic body's in front of it).
async function checkBodiesDrawn(page, view, rec, what) {
  const png = PNG.sync.read(await page.screenshot());
  const canvas = await page.evaluate(() => { const r = document.getElementById('view').getBoundingClientRect(); return { l: r.left, t: r.top, w: r.width, h: r.height }; });
  let inside = 0, coloured = 0;
  const misses = [];
  for (let b = 0; b < rec.bodies.length; ++b) {
    if (rec.bodies[b].type !== 'dynamic') continue;
    const p = await page.evaluate(([v, k]) => window.sinewViewer.project(v, k), [view, b]);
    if (p.x < canvas.l + 2 || p.x > canvas.l + canvas.w - 2 || p.y < canvas.t + 2 || p.y > canvas.t + canvas.h - 2) continue;
    ++inside;
    const c = pixel(png, p.x, p.y);
    if (c.saturation > 0.15) ++coloured; else misses.push(`${rec.bodies[b].name} at (${p.x.toFixed(0)}, ${p.y.toFixed(0)}) rgb ${c.r},${c.g},${c.b}`);
  }
  check(inside > 0 && coloured === inside, `${what}: ${coloured} of ${inside} dynamic bodies in view show their colour at their centre${misses.length ? ' (missing: ' + misses.join('; ') + ')' : ''}`);
  return png;
}

try {
  { // one recording, JSON lines
    const o = await open([boxes]);
    const s = await state(o.page);
    check(!s.error && o.errors.length === 0, `boxes.jsonl loads without an error (${s.error || o.errors.join('; ') || 'none'})`);
    check(s.recordings[0].frames === 91, `91 frames read (got ${s.recordings[0].frames})`);
    check(s.stats[0].bodies === header.bodies.length, `every body of the header is drawn: ${s.stats[0].bodies} of ${header.bodies.length}`);
    await o.page.evaluate(() => window.sinewViewer.setFrame(60));
    const png = await checkBodiesDrawn(o.page, 0, header, 'boxes.jsonl frame 60');
    // Nothing is drawn in the top right corner of the view: the background colour shows there.
    const canvas = await o.page.evaluate(() => { const r = document.getElementById('view').getBoundingClientRect(); return { l: r.left, t: r.top, w: r.width }; });
    const bg = pixel(png, canvas.l + canvas.w - 10, canvas.t + 10);
    check(Math.abs(bg.r - 0x1d) < 8 && Math.abs(bg.g - 0x21) < 8 && Math.abs(bg.b - 0x28) < 8, `background shows where nothing is drawn (rgb ${bg.r},${bg.g},${bg.b})`);
    // Picking: a click on a dynamic body's centre names it.
    const b = header.bodies.findIndex((x) => x.type === 'dynamic');
    const p = await o.page.evaluate((k) => window.sinewViewer.project(0, k), b);
    await o.page.mouse.click(p.x, p.y);
    const info = await o.page.locator('#info').textContent();
    check(/\(dynamic /.test(info) && /position/.test(info), `a click on a body shows its name and state ("${info.split('\n')[0]}")`);
    if (shots) fs.writeFileSync(path.join(shots, 'viewer-falling-boxes.png'), PNG.sync.write(png));
    await close(o);
  }
  { // the same run in float32 frames reads back to the same frames
    const o = await open([boxesBin]);
    const s = await state(o.page);
    check(!s.error && s.recordings[0].frames === 91 && s.stats[0].bodies === header.bodies.length, `boxes.sinrec: 91 frames, ${s.stats[0] && s.stats[0].bodies} bodies drawn`);
    await close(o);
  }
  { // side by side: two runs of one scene at different steps, in sync, with the distance chart
    const o = await open([boxes, boxesFine], { width: 1400, height: 800 });
    const s = await state(o.page);
    check(!s.error && s.stats.length === 2 && s.stats.every((x) => x.bodies === header.bodies.length), `side by side: two views, ${s.stats.map((x) => x.bodies).join(' and ')} bodies drawn`);
    check(s.chart && s.chart.kind === 'distance' && s.chart.series === 1, `side by side: the chart shows the distance of one run from the other (${JSON.stringify(s.chart)})`);
    await o.page.evaluate(() => window.sinewViewer.setTime(1.0));
    const frames = await o.page.evaluate(() => window.sinewViewer.frames());
    check(frames[0] === 60 && frames[1] === 120, `side by side: t = 1 s is frame 60 at h = 1/60 and frame 120 at h = 1/120 (got ${frames})`);
    await checkBodiesDrawn(o.page, 0, header, 'side by side, left view');
    const png = await checkBodiesDrawn(o.page, 1, header, 'side by side, right view');
    if (shots) fs.writeFileSync(path.join(shots, 'viewer-side-by-side.png'), PNG.sync.write(png));
    await close(o);
  }
  { // soft bodies: cloth, rope and pressure ball surfaces
    const o = await open([cloth]);
    const s = await state(o.page);
    const ch = JSON.parse(fs.readFileSync(cloth).subarray(0, fs.readFileSync(cloth).indexOf(10)).toString());
    check(!s.error && s.stats[0].softBodies === ch.particles.length && ch.particles.length >= 2, `cloth.sinrec: ${s.stats[0] && s.stats[0].softBodies} of ${ch.particles.length} soft bodies drawn`);
    await o.page.evaluate(() => window.sinewViewer.setFrame(100));
    const png = PNG.sync.read(await o.page.screenshot());
    if (shots) fs.writeFileSync(path.join(shots, 'viewer-cloth.png'), PNG.sync.write(png));
    // The cloth is drawn in its own blue: count such pixels.
    let blue = 0;
    for (let i = 0; i < png.data.length; i += 4) if (png.data[i + 2] > 120 && png.data[i + 2] > png.data[i] + 40) ++blue;
    check(blue > 2000, `cloth.sinrec frame 100: the soft surfaces cover ${blue} blue pixels`);
    await close(o);
  }
  for (const file of [chainBin, chainJson]) { // overlays: the crate's four contact points, three joints' six anchors
    const o = await open([file]);
    await o.page.evaluate(() => window.sinewViewer.setFrame(60));
    const s = await state(o.page);
    check(!s.error && s.stats[0].contacts >= 4 && s.stats[0].jointAnchors === 6 && s.stats[0].jointLines === 3,
      `${path.basename(file)}: ${s.stats[0] && s.stats[0].contacts} contact points (at least the crate's 4) and ${s.stats[0] && s.stats[0].jointAnchors} joint anchors (6) drawn`);
    await o.page.locator('#contacts').uncheck();
    await o.page.locator('#joints').uncheck();
    const hidden = (await state(o.page)).stats[0];
    check(hidden.contacts === 0 && hidden.jointAnchors === 0, `${path.basename(file)}: the contacts and joints boxes hide the overlays`);
    await close(o);
  }
  // Malformed and truncated files: a readable message in the page, naming the file and the line.
  for (const [file, pattern, what] of [[bad.notRecord, /not-a-record\.jsonl: line 1 .*not a sinew-record file/, 'a JSON file that is not a recording'],
    [bad.badFrame, /bad-frame\.jsonl: line 3: body 0 \("ground"\) needs 7 numbers/, 'a frame with a body of 6 numbers']]) {
    const o = await open([file]);
    const shown = await o.page.locator('#error').isVisible() ? await o.page.locator('#error').textContent() : '';
    check(pattern.test(shown), `${what}: the page says "${shown}"`);
    await close(o);
  }
  for (const [file, frames] of [[bad.truncated, 90], [bad.truncatedJson, 90], [bad.truncatedContacts, 60]]) {
    const o = await open([file]);
    const s = await state(o.page);
    const shown = await o.page.locator('#warnings').isVisible() ? await o.page.locator('#warnings').textContent() : '';
    check(!s.error && s.recordings[0].frames === frames && /truncated/.test(shown),
      `${path.basename(file)}: plays the ${s.recordings[0] && s.recordings[0].frames} complete frames and says "${shown}"`);
    await close(o);
  }
} finally {
  await browser.close();
  fs.rmSync(tmp, { recursive: true, force: true });
}
console.log(failures ? `browser test: ${failures} check(s) failed` : 'browser test: all checks passed');
process.exit(failures ? 1 : 0);
