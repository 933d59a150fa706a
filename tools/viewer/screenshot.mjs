#!/usr/bin/env node
// A picture of recordings as the viewer draws them, from headless Chromium (Debian's, via playwright-core):
//   node tools/viewer/screenshot.mjs OUT.png FILE... [--time T] [--size WIDTHxHEIGHT]
// Plays FILE... side by side (as `scripts/dev view` would), stops at T seconds (default: the end) and
// writes OUT.png. `scripts/dev screenshots` makes docs/img/viewer-*.png this way.
import path from 'node:path';
import { chromium } from 'playwright-core';
import { startServer } from './serve.mjs';

export async function screenshot(out, files, { time = null, width = 1280, height = 800 } = {}) {
  const { server, url } = await startServer(files, 0);
  const browser = await chromium.launch({ executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking',
      '--disable-component-update', '--disable-sync', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'] });
  try {
    const page = await browser.newPage({ viewport: { width, height } });
    await page.goto(url + '?paused');
    await page.waitForFunction(() => window.sinewViewer && (window.sinewViewer.ready || window.sinewViewer.error), null, { timeout: 120000 });
    const error = await page.evaluate(() => window.sinewViewer.error);
    if (error) throw new Error(error);
    await page.evaluate((t) => window.sinewViewer.setTime(t === null ? Infinity : t), time);
    await page.screenshot({ path: out });
  } finally {
    await browser.close();
    server.close();
  }
}

if (process.argv[1] && path.resolve(process.argv[1]) === path.resolve(new URL(import.meta.url).pathname)) {
  const args = process.argv.slice(2), files = [];
  let out = null, time = null, width = 1280, height = 800;
  for (let i = 0; i < args.length; ++i) {
    if (args[i] === '--time') time = Number(args[++i]);
    else if (args[i] === '--size') [width, height] = args[++i].split('x').map(Number);
    else if (out === null) out = args[i];
    else files.push(args[i]);
  }
  if (!out || files.length === 0 || !(width > 0 && height > 0) || (time !== null && !Number.isFinite(time))) {
    console.error('usage: node tools/viewer/screenshot.mjs OUT.png FILE... [--time T] [--size WIDTHxHEIGHT]');
    process.exit(2);
  }
  try {
    await screenshot(out, files, { time, width, height });
    console.log(`screenshot: ${out}`);
  } catch (e) {
    console.error(`screenshot: ${e.message}`);
    process.exit(1);
  }
}
