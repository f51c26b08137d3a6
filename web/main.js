// The page's event loop: one call into the wasm module at a time, each
// awaited (scene and integrator changes, the mouse's presses, drags and
// releases, then one frame), then the next animation frame.
import init, { Page, sceneNames } from './pkg/wgcloth_web.js';

const query = new URLSearchParams(location.search);
const $ = (id) => document.getElementById(id);
const message = (e) => (e && e.message) || String(e);

// The contract `web/test.mjs` reads: one console line `wgcloth-check
// {json}` per check, carrying `error` on a failure.
function report(record) {
  console.log('wgcloth-check ' + JSON.stringify(record));
}

function showError(text) {
  $('error').textContent = text;
}

// A whole number from the query, or `fallback` when absent.
function count(name, fallback) {
  const text = query.get(name);
  if (text === null) return fallback;
  if (!/^[0-9]+$/.test(text)) throw new Error(`${name}: \`${text}\` is not a whole number`);
  return Number(text);
}

async function main() {
  const check = query.get('check') === '1';
  let scene = query.get('scene') || 'hanging';
  let steps, resolution;
  try {
    steps = count('steps', 100);
    resolution = count('resolution', 0);
    if (!navigator.gpu) throw new Error('this browser offers no WebGPU (navigator.gpu is missing)');
    await init();
  } catch (e) {
    showError(message(e));
    if (check) report({ scene, steps, error: message(e) });
    return;
  }

  const canvas = $('cloth');
  const picker = $('scene');
  for (const name of sceneNames()) picker.add(new Option(name, name));
  picker.value = scene;

  let page;
  try {
    // wgpu's adapter info has no name in a browser: WebGPU's says what it is.
    const info = (await navigator.gpu.requestAdapter())?.info;
    const adapterName = info ? [info.vendor, info.architecture].filter(Boolean).join(' ') : '';
    page = await Page.open(canvas, adapterName);
  } catch (e) {
    showError(message(e));
    if (check) report({ scene, steps, error: message(e) });
    return;
  }
  // For the browser test: the page, how many frames it has drawn, and a
  // way to step one frame while paused (`?paused=1` starts paused).
  window.wgcloth = { page, frames: 0, step: () => { stepOnce = true; } };

  let paused = false;
  let stepOnce = false;
  let pendingScene = null;
  let pendingIntegrator = null;
  const pointer = [];

  const setPaused = (on) => {
    paused = on;
    $('pause').textContent = on ? 'run' : 'pause';
    $('step').disabled = !on;
  };

  try {
    if (check) {
      const record = await page.check(scene, steps, resolution);
      report(record);
      setPaused(true);
    } else {
      const particles = await page.load(scene, '', resolution);
      setPaused(query.get('paused') === '1');
      console.log('wgcloth-ready ' + JSON.stringify({ adapter: page.adapter(), scene, particles }));
    }
  } catch (e) {
    showError(message(e));
    if (check) report({ adapter: page.adapter(), scene, steps, error: message(e) });
    setPaused(true);
  }
  $('integrator').value = page.integrator();

  picker.onchange = () => { pendingScene = picker.value; };
  $('reset').onclick = () => { pendingScene = scene; };
  $('integrator').onchange = () => { pendingIntegrator = $('integrator').value; };
  $('pause').onclick = () => setPaused(!paused);
  $('step').onclick = () => { stepOnce = true; };
  canvas.addEventListener('pointerdown', (e) => {
    canvas.setPointerCapture(e.pointerId);
    pointer.push(['press', e.offsetX, e.offsetY]);
  });
  canvas.addEventListener('pointermove', (e) => {
    if (e.buttons === 0) return;
    // Only the latest position of a run of moves matters.
    if (pointer.length && pointer[pointer.length - 1][0] === 'move') pointer.pop();
    pointer.push(['move', e.offsetX, e.offsetY]);
  });
  canvas.addEventListener('pointerup', () => pointer.push(['release']));

  // The frame-time readout: the time between drawn frames, smoothed.
  let last = performance.now();
  let frameMs = 0;
  let stepsPerFrame = 0;

  async function tick() {
    try {
      if (pendingScene !== null) {
        scene = pendingScene;
        pendingScene = null;
        await page.load(scene, '', resolution);
        $('integrator').value = page.integrator();
        showError('');
      }
      if (pendingIntegrator !== null) {
        const integrator = pendingIntegrator;
        pendingIntegrator = null;
        await page.setIntegrator(integrator);
      }
      while (pointer.length) {
        const [kind, x, y] = pointer.shift();
        if (kind === 'press') await page.press(x, y);
        else if (kind === 'move') page.moveTo(x, y);
        else page.release();
      }
      const advance = !paused || stepOnce;
      stepOnce = false;
      const steps = await page.frame(advance);
      if (advance) stepsPerFrame = steps;
      window.wgcloth.frames += 1;
    } catch (e) {
      showError(message(e));
      setPaused(true);
    }
    const now = performance.now();
    frameMs = frameMs === 0 ? now - last : 0.9 * frameMs + 0.1 * (now - last);
    last = now;
    $('status').textContent =
      `${page.adapter()} · ${scene} · frame ${frameMs.toFixed(1)} ms ` +
      `(${(1000 / frameMs).toFixed(0)} fps, ${stepsPerFrame} steps a frame)` +
      (paused ? ' · paused' : '');
    requestAnimationFrame(tick);
  }
  requestAnimationFrame(tick);
}

main();
