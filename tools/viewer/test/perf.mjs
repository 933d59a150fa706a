#!/usr/bin/env node
// How fast the viewer plays a recording in headless Chromium (a measurement, not a test):
//   node tools/viewer/test/perf.mjs FILE
// Prints the load time (fetch and parse), the viewer's own work per frame (placing every body and
// particle: setFrameOnly, averaged over 100 frames) and the animation frames per second while playing.
// Headless Chromium draws with its software rasteriser (SwiftShader), so the last figure is a floor, not
// what a GPU gives.
import { chromium } from 'playwright-core';
import { startServer } from '../serve.mjs';
const file = process.argv[2];
if (!file) { console.error('usage: node tools/viewer/test/perf.mjs FILE'); process.exit(2); }
const { server, url } = await startServer([file], 0);
const browser = await chromium.launch({ executablePath: '/usr/bin/chromium', args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'] });
const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
const t0 = Date.now();
await page.goto(url + '?paused');
await page.waitForFunction(() => window.sinewViewer && (window.sinewViewer.ready || window.sinewViewer.error), null, { timeout: 300000 });
const error = await page.evaluate(() => window.sinewViewer.error);
if (error) { console.error(error); process.exit(1); }
const loadMs = Date.now() - t0;
const r = await page.evaluate(async () => {
  const v = window.sinewViewer;
  const t0 = performance.now();
  for (let k = 0; k < 100; ++k) v.setFrameOnly(k * 5);
  const t1 = performance.now();
  let frames = 0; const s = performance.now();
  document.getElementById('play').click();
  await new Promise((res) => { const f = () => { ++frames; if (performance.now() - s < 3000) requestAnimationFrame(f); else res(); }; requestAnimationFrame(f); });
  return { setFrameMs: (t1 - t0) / 100, rafPerSec: frames / 3 };
});
console.log(JSON.stringify({ file, loadMs, setFrameMs: +r.setFrameMs.toFixed(3), framesPerSecondPlaying: +r.rafPerSec.toFixed(1) }));
await browser.close(); server.close();
