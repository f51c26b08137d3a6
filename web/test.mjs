// The web page in a real browser: `node web/test.mjs DIR [SHOTS]` serves
// the page built into DIR (`bash web/build.sh DIR`) on localhost and drives
// the system's headless Chromium (WebGPU on SwiftShader, Chrome's software
// Vulkan) with playwright-core:
// - the check of `hanging`, `drape`, the mesh scene `banner` and `cape`:
//   the GPU's positions equal the f32 CPU reference's bit for bit;
// - the check's screenshot shows the cloth (cloth-coloured pixels counted;
//   `cape`'s is drawn through its render mesh);
// - a scripted mouse drag moves the cloth: the same frames stepped with and
//   without the drag differ, the cloth pulled the way the mouse went;
// - a check that fails logs its line with the error.
// Screenshots go to SHOTS (default: a fresh temporary folder). Ends with
// the line `N passed, N failed`; exits 1 on any failure.
import { chromium } from 'playwright-core';
import http from 'node:http';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import zlib from 'node:zlib';

// Debian's Chromium; the flags give headless Chromium WebGPU on
// SwiftShader (without the Vulkan ones a screenshot of a WebGPU canvas is
// blank) and keep it off the network.
const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
const ARGS = [
  '--headless', '--no-sandbox', '--enable-unsafe-webgpu', '--enable-unsafe-swiftshader',
  '--use-angle=swiftshader', '--enable-features=Vulkan', '--use-vulkan=swiftshader',
  '--ignore-gpu-blocklist', '--disable-background-networking', '--disable-component-update',
  '--disable-sync', '--no-first-run', '--disable-quic',
];

// The checks: each scene's steps reach what the scene is about on the
// 2-vCPU machine in seconds of SwiftShader time — `hanging` (explicit)
// 0.5 s of swinging, `drape` (implicit) 0.33 s, past its contact with the
// ball (at about 0.23 s), `banner` (semi-implicit, a glTF mesh) 0.5 s,
// `cape` (implicit, a character, drawn through a render mesh) 0.25 s.
const CHECKS = [
  { scene: 'hanging', steps: 500 },
  { scene: 'drape', steps: 40 },
  { scene: 'banner', steps: 100 },
  { scene: 'cape', steps: 60 },
];
// GPU and CPU reference in f32 agree bit for bit on SwiftShader as on
// lavapipe (the kernels mirror the reference's operation order and WGSL
// forbids contracting a * b + c into a fused multiply-add on its own), so
// the largest position difference allowed is none.
const MAX_DIFF_M = 0;
// How long a check may take [ms]: drape's 80 implicit steps take about
// 20 s on SwiftShader on the 2-vCPU machine; four times that allows for a
// loaded machine.
const CHECK_TIMEOUT_MS = 240_000;

// A cloth pixel: the renderer's cloth is red in front, orange behind
// (CLOTH_FRONT, CLOTH_BACK in src/render/mod.rs); the background (30, 34,
// 44) and the checkered grey ground have red within a few levels of green
// and blue. Red ahead of both by this many levels is cloth, shaded or not.
const CLOTH_RED_LEAD = 40;
// ...and at least this bright (the darkest shaded cloth is above 100).
const CLOTH_RED_MIN = 90;
// The check's picture must show at least this many cloth pixels: the
// scenes' cloths cover tens of thousands of the 640 × 480 canvas; a
// thousand is far above noise and far below any of them.
const MIN_CLOTH_PIXELS = 1000;

// The drag: from the middle of the cloth this many canvas pixels to the
// right over the first half of this many frames (1/60 s of simulated time
// each), held for the rest.
const DRAG_PX = 80;
const DRAG_FRAMES = 20;
// The cloth's pixels must move at least this far to the right, on
// average, against the same frames without the drag [px]: the grabbed
// middle follows the cursor 80 px while the pinned corners stay, so the
// cloth's centroid moves tens of pixels; without the drag it falls
// straight down (symmetric about its pins), and the runs are otherwise
// identical (the page steps fixed frames while paused).
const MIN_DRAG_SHIFT_PX = 10;

let passed = 0;
let failed = 0;
function ok(name, condition, detail) {
  if (condition) {
    passed += 1;
    console.log(`ok   ${name}: ${detail}`);
  } else {
    failed += 1;
    console.log(`FAIL ${name}: ${detail}`);
  }
}

// An 8-bit RGB or RGBA PNG (what Chromium's screenshots are) as
// { width, height, channels, data }: inflate, then undo each row's filter.
function decodePng(bytes) {
  let at = 8;
  let width = 0, height = 0, channels = 0;
  const idat = [];
  while (at < bytes.length) {
    const length = bytes.readUInt32BE(at);
    const type = bytes.toString('latin1', at + 4, at + 8);
    const body = bytes.subarray(at + 8, at + 8 + length);
    if (type === 'IHDR') {
      width = body.readUInt32BE(0);
      height = body.readUInt32BE(4);
      const [depth, colour, interlace] = [body[8], body[9], body[12]];
      channels = { 2: 3, 6: 4 }[colour];
      if (depth !== 8 || !channels || interlace !== 0) {
        throw new Error(`unexpected PNG: depth ${depth}, colour type ${colour}, interlace ${interlace}`);
      }
    } else if (type === 'IDAT') {
      idat.push(body);
    }
    at += 12 + length;
  }
  const raw = zlib.inflateSync(Buffer.concat(idat));
  const stride = width * channels;
  const data = Buffer.alloc(stride * height);
  for (let y = 0; y < height; y++) {
    const filter = raw[y * (stride + 1)];
    const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let x = 0; x < stride; x++) {
      const a = x >= channels ? data[y * stride + x - channels] : 0;
      const b = y > 0 ? data[(y - 1) * stride + x] : 0;
      const c = x >= channels && y > 0 ? data[(y - 1) * stride + x - channels] : 0;
      const p = a + b - c;
      const paeth = Math.abs(p - a) <= Math.abs(p - b) && Math.abs(p - a) <= Math.abs(p - c)
        ? a : Math.abs(p - b) <= Math.abs(p - c) ? b : c;
      const predictor = [0, a, b, (a + b) >> 1, paeth][filter];
      data[y * stride + x] = (line[x] + predictor) & 0xff;
    }
  }
  return { width, height, channels, data };
}

// The cloth pixels of a screenshot: their count and centroid.
function clothPixels(png) {
  const { width, height, channels, data } = decodePng(png);
  let count = 0, sx = 0, sy = 0;
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) {
      const i = (y * width + x) * channels;
      const [r, g, b] = [data[i], data[i + 1], data[i + 2]];
      if (r >= CLOTH_RED_MIN && r - Math.max(g, b) >= CLOTH_RED_LEAD) {
        count += 1;
        sx += x;
        sy += y;
      }
    }
  }
  return { count, x: count ? sx / count : NaN, y: count ? sy / count : NaN };
}

// Serves `dir` on a free localhost port (wasm needs application/wasm).
async function serve(dir) {
  const types = { '.html': 'text/html', '.js': 'text/javascript', '.wasm': 'application/wasm' };
  const server = http.createServer((req, res) => {
    const file = path.join(dir, path.normalize(decodeURIComponent(new URL(req.url, 'http://x').pathname)));
    const name = file.endsWith(path.sep) ? path.join(file, 'index.html') : file;
    fs.readFile(name, (err, body) => {
      if (err) {
        res.writeHead(404);
        res.end();
        return;
      }
      res.writeHead(200, { 'content-type': types[path.extname(name)] || 'application/octet-stream' });
      res.end(body);
    });
  });
  await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
  return server;
}

// Opens `query` in a new tab and waits for the console line starting with
// `prefix`; returns the tab and the line's JSON.
async function open(browser, base, query, prefix, timeout) {
  const tab = await browser.newPage({ viewport: { width: 800, height: 700 } });
  tab.on('pageerror', (e) => console.log(`  page error: ${e.message}`));
  tab.on('console', (m) => {
    if (m.type() === 'error') console.log(`  console error: ${m.text()}`);
  });
  const line = tab.waitForEvent('console', {
    predicate: (m) => m.text().startsWith(prefix),
    timeout,
  });
  await tab.goto(`${base}/index.html?${query}`);
  const text = (await line).text();
  return { tab, record: JSON.parse(text.slice(prefix.length)) };
}

// Steps `frames` frames of a paused page, one at a time.
async function stepFrames(tab, frames) {
  for (let i = 0; i < frames; i++) {
    const before = await tab.evaluate(() => window.wgcloth.frames);
    await tab.evaluate(() => window.wgcloth.step());
    await tab.waitForFunction((n) => window.wgcloth.frames >= n + 2, before, { timeout: 60_000 });
  }
}

async function main() {
  const [dir, shotsArg] = process.argv.slice(2);
  if (!dir || !fs.existsSync(path.join(dir, 'index.html'))) {
    console.error('usage: node web/test.mjs DIR [SHOTS] (DIR: built by `bash web/build.sh DIR`)');
    process.exit(2);
  }
  const shots = shotsArg || fs.mkdtempSync(path.join(os.tmpdir(), 'wgcloth-shots-'));
  fs.mkdirSync(shots, { recursive: true });
  const server = await serve(dir);
  const base = `http://127.0.0.1:${server.address().port}`;
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'wgcloth-chromium-'));
  const browser = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM,
    headless: true,
    args: ARGS,
  });
  try {
    for (const { scene, steps } of CHECKS) {
      const started = Date.now();
      const { tab, record } = await open(
        browser, base, `scene=${scene}&steps=${steps}&check=1`, 'wgcloth-check ', CHECK_TIMEOUT_MS);
      const seconds = ((Date.now() - started) / 1000).toFixed(1);
      console.log(`  ${scene}: ${JSON.stringify(record)} (${seconds} s)`);
      ok(`${scene} check`, record.error === undefined && record.max_diff_m <= MAX_DIFF_M
        && record.steps === steps && record.particles > 0 && record.ms_per_step > 0
        && typeof record.adapter === 'string' && record.adapter.length > 0,
        record.error ?? `max_diff_m ${record.max_diff_m} (allowed ${MAX_DIFF_M}) on ${record.adapter}`);
      const shot = path.join(shots, `check-${scene}.png`);
      const png = await tab.locator('#cloth').screenshot({ path: shot });
      const cloth = clothPixels(png);
      ok(`${scene} picture`, cloth.count >= MIN_CLOTH_PIXELS,
        `${cloth.count} cloth pixels (at least ${MIN_CLOTH_PIXELS}) in ${shot}`);
      await tab.close();
    }

    // An unknown scene: the check's line carries the library's error,
    // which names the scene and the built-in ones.
    {
      const { tab, record } = await open(
        browser, base, 'scene=no-such-scene&steps=5&check=1', 'wgcloth-check ', CHECK_TIMEOUT_MS);
      ok('error line', typeof record.error === 'string' && record.error.includes('no-such-scene')
        && record.error.includes('hanging') && record.max_diff_m === undefined,
        `error: ${record.error}`);
      await tab.close();
    }

    // The drag: the same paused start, the same frames stepped, with and
    // without the mouse pulling the cloth's middle to the right.
    const runs = {};
    for (const drag of [false, true]) {
      const { tab } = await open(browser, base, 'scene=hanging&paused=1', 'wgcloth-ready ', CHECK_TIMEOUT_MS);
      await tab.waitForFunction(() => window.wgcloth.frames >= 1);
      const canvas = tab.locator('#cloth');
      const box = await canvas.boundingBox();
      const start = clothPixels(await canvas.screenshot());
      const from = { x: box.x + start.x, y: box.y + start.y };
      if (drag) {
        await tab.mouse.move(from.x, from.y);
        await tab.mouse.down();
      }
      // The mouse moves a tenth of the way each frame over the first
      // half of the frames (as a hand would), then holds.
      for (let frame = 1; frame <= DRAG_FRAMES; frame++) {
        const t = Math.min(1, frame / (DRAG_FRAMES / 2));
        if (drag) await tab.mouse.move(from.x + DRAG_PX * t, from.y);
        await stepFrames(tab, 1);
      }
      const shot = path.join(shots, drag ? 'drag-held.png' : 'drag-none.png');
      runs[drag] = clothPixels(await canvas.screenshot({ path: shot }));
      if (drag) await tab.mouse.up();
      console.log(`  ${drag ? 'dragged' : 'not dragged'}: ${JSON.stringify(runs[drag])} in ${shot}`);
      await tab.close();
    }
    const shift = runs[true].x - runs[false].x;
    ok('drag', shift >= MIN_DRAG_SHIFT_PX && runs[true].count >= MIN_CLOTH_PIXELS,
      `the cloth's centroid moved ${shift.toFixed(1)} px the way the mouse went `
      + `(at least ${MIN_DRAG_SHIFT_PX})`);
  } finally {
    await browser.close();
    server.close();
    fs.rmSync(profile, { recursive: true, force: true });
  }
  console.log(`screenshots in ${shots}`);
  console.log(`${passed} passed, ${failed} failed`);
  process.exit(failed === 0 ? 0 : 1);
}

main().catch((e) => {
  console.error(`error: ${e.stack || e}`);
  console.log(`${passed} passed, ${failed + 1} failed`);
  process.exit(1);
});
