// Drive the web app in headless Chromium for tests/e2e/test_browser.py.
// usage: node browser.mjs SCENARIO BASE_URL OUT_DIR
// Writes OUT_DIR/SCENARIO.json (observations the Python test checks) and screenshots; exits 1
// with the error message (and a screenshot SCENARIO-failed.png) when a step fails.

import { writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { chromium } from 'playwright-core';
import { measure, openRunFile, readoutAndUndo, rectangleImexRecording, urlState } from './tools.mjs';
import * as features from './features.mjs';
import * as mapElites from './map_elites.mjs';
import * as designer from './designer.mjs';
import * as access from './access.mjs';
import * as results from './results.mjs';
import { matchPanel } from './match.mjs';

const [scenario, base, out] = process.argv.slice(2);
const ARGS = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
  '--disable-component-update', '--disable-sync', '--no-first-run', '--disable-quic',
  '--disable-extensions', '--metrics-recording-only', '--disable-breakpad'];

// a cheap fingerprint of the canvas: the RGBA bytes summed in 64 bands
const canvasPrint = (page) => page.evaluate(() => {
  const c = document.getElementById('ex-canvas');
  const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
  const bands = new Array(64).fill(0);
  for (let i = 0; i < d.length; i += 1) bands[Math.floor((i / d.length) * 64)] += d[i];
  return bands;
});

const pixelAt = (page, fx, fy) => page.evaluate(([x, y]) => {
  const c = document.getElementById('ex-canvas');
  const d = c.getContext('2d').getImageData(Math.floor(x * c.width), Math.floor(y * c.height), 1, 1).data;
  return [d[0], d[1], d[2]];
}, [fx, fy]);

const framesNow = (page) => page.evaluate(() => window.morphogenExplore.frames);

async function waitFrames(page, n, timeout = 30000) {
  const start = await framesNow(page);
  await page.waitForFunction((s) => window.morphogenExplore.frames >= s, start + n, { timeout });
}

async function pause(page) {
  if (await page.evaluate(() => window.morphogenExplore.running)) await page.click('#ex-run');
  await page.waitForFunction(() => !window.morphogenExplore.inflight);
}

// one frame while paused (the Step button), waiting until it is drawn
async function step(page, times = 1) {
  for (let i = 0; i < times; i += 1) {
    const f = await framesNow(page);
    await page.click('#ex-step');
    await page.waitForFunction((s) => window.morphogenExplore.frames > s && !window.morphogenExplore.inflight, f);
  }
}

// reset from the controls and wait for the (single) frame shown after it
async function reset(page, init) {
  await page.selectOption('#ex-init', init);
  const f = await framesNow(page);
  await page.click('#ex-reset');
  await page.waitForFunction((s) => window.morphogenExplore.frames > s && !window.morphogenExplore.inflight, f);
}

async function openExplore(page) {
  await page.goto(`${base}#explore`);
  await page.waitForFunction(() => window.morphogenExplore && window.morphogenExplore.frames >= 2, null, { timeout: 60000 });
}

// drag the range input `selector` to fraction `frac` of its width with the mouse
async function dragSlider(page, selector, frac) {
  await page.locator(selector).scrollIntoViewIfNeeded();
  const box = await page.locator(selector).boundingBox();
  const y = box.y + box.height / 2;
  await page.mouse.move(box.x + box.width * 0.5, y);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width * frac, y, { steps: 8 });
  await page.mouse.up();
}

const diff = (a, b) => a.reduce((s, v, i) => s + Math.abs(v - b[i]), 0);

const SCENARIOS = {
  async explore(page) {
    await openExplore(page);
    const first = await canvasPrint(page);
    await page.waitForTimeout(1000);
    // frames per second over three seconds, counted in the page
    const f0 = await framesNow(page);
    const t0 = Date.now();
    await page.waitForTimeout(3000);
    const fps = ((await framesNow(page)) - f0) / ((Date.now() - t0) / 1000);
    const second = await canvasPrint(page);
    await page.screenshot({ path: join(out, 'explore.png') });
    const state = await page.evaluate(() => window.morphogenExplore.state);
    const serverMs = await page.evaluate(() => window.morphogenExplore.last.ms);
    return { fps, change: diff(first, second), size: state.size, model: state.model,
      steps_per_frame: state.steps_per_frame, server_ms: serverMs,
      measured: process.env.MORPHOGEN_E2E_MEASURE ? await measure(page, out) : null };
  },

  async slider(page) {
    await openExplore(page);
    await pause(page);
    await reset(page, 'square');
    await step(page, 12);
    const a1 = await canvasPrint(page);
    await reset(page, 'square');
    await step(page, 12);
    const a2 = await canvasPrint(page); // same start, same steps: the same picture
    const before = await page.evaluate(() => window.morphogenExplore.state.params.F);
    await dragSlider(page, 'input[data-param="F"]', 0.9);
    // wait until the server has the value the slider shows (the last of the drag)
    await page.waitForFunction(() => {
      const x = window.morphogenExplore;
      const shown = Number(document.querySelector('input[data-param="F"]').value);
      return !x.paramTimer && Math.abs(x.state.params.F - shown) < 1e-9;
    });
    const after = await page.evaluate(() => window.morphogenExplore.state.params.F);
    await reset(page, 'square');
    await step(page, 12);
    const b = await canvasPrint(page);
    await page.screenshot({ path: join(out, 'slider.png') });
    return { repeat: diff(a1, a2), change: diff(a1, b), before, after,
      shown: await page.inputValue('input[data-param="F"] + input'), ...(await urlState(page)) };
  },

  async paint(page) {
    await openExplore(page);
    await pause(page);
    await reset(page, 'uniform');
    const flat = [await pixelAt(page, 0.25, 0.25), await pixelAt(page, 0.75, 0.75)];
    const box = await page.locator('#ex-canvas').boundingBox();
    // a click at the upper left quarter, then a drag along the lower right
    await page.mouse.click(box.x + box.width * 0.25, box.y + box.height * 0.25);
    await page.mouse.move(box.x + box.width * 0.6, box.y + box.height * 0.75);
    await page.mouse.down();
    await page.mouse.move(box.x + box.width * 0.9, box.y + box.height * 0.75, { steps: 10 });
    await page.mouse.up();
    await page.waitForFunction(() => !window.morphogenExplore.tools.busy(), null, { timeout: 30000 });
    await step(page, 2);
    const painted = [await pixelAt(page, 0.25, 0.25), await pixelAt(page, 0.75, 0.75)];
    const untouched = await pixelAt(page, 0.75, 0.25);
    const tools = await readoutAndUndo(page);
    // the pointer is a ring the brush's size; the brush offers each species, or all
    const brush = await page.evaluate(() => ({
      cursor: document.getElementById('ex-canvas').style.cursor.slice(0, 26),
      ring: window.morphogenExplore.tools.cursor,
      species: Array.from(document.querySelectorAll('#ex-paint-species option'), (o) => o.value),
      width: document.getElementById('ex-canvas').getBoundingClientRect().width,
    }));
    // a PNG as v's starting state: one more undo step, and v now varies over the grid
    await page.selectOption('#ex-paint-species', 'v');
    await page.setInputFiles('#ex-image', new URL('../../docs/images/web/mesh.png', import.meta.url).pathname);
    await page.waitForFunction(() => document.getElementById('ex-undo').textContent === 'Undo stroke (1)', null, { timeout: 30000 });
    brush.imageUndo = await page.textContent('#ex-undo');
    await page.click('#ex-run');
    await waitFrames(page, 20);
    await page.screenshot({ path: join(out, 'paint.png') });
    return { flat, painted, untouched, brush, ...tools, map: await features.parameterMap(page, out) };
  },

  async download(page) {
    await openExplore(page);
    const rect = await rectangleImexRecording(page, out);
    await waitFrames(page, 5);
    const [run] = await Promise.all([page.waitForEvent('download'), page.click('#ex-save-run')]);
    await run.saveAs(join(out, 'run.json'));
    await page.selectOption('#ex-png-scale', '4');
    const [png] = await Promise.all([page.waitForEvent('download'), page.click('#ex-save-png')]);
    await png.saveAs(join(out, 'explore-saved.png'));
    return { run: run.suggestedFilename(), png: png.suggestedFilename(), ...rect, ...(await openRunFile(page, out)) };
  },

  async atlas(page) {
    await page.goto(`${base}#atlas`);
    await page.waitForFunction(() => document.querySelectorAll('#at-x option').length > 0);
    await page.fill('#at-x-n', '6');
    await page.fill('#at-y-n', '6');
    await page.selectOption('#at-tile', '32');
    await page.fill('#at-steps', '3000');
    await page.click('#at-go');
    await page.waitForSelector('#at-result:not([hidden])', { timeout: 120000 });
    await page.waitForTimeout(300);
    await page.screenshot({ path: join(out, 'atlas.png') });
    const res = await page.evaluate(() => window.morphogenAtlas.result);
    // a refused request's error replaces the atlas shown before, then a good one brings it back
    const lo = await page.inputValue('#at-x-lo');
    await page.fill('#at-x-hi', lo);
    await page.click('#at-go');
    await page.waitForSelector('#at-error:not([hidden])');
    const staleShown = await page.isVisible('#at-result') || await page.isVisible('#at-save');
    await page.fill('#at-x-hi', String(res.x.hi));
    await page.check('#at-families'); // and name each tile's pattern family
    await page.click('#at-go');
    await page.waitForSelector('#at-result:not([hidden])', { timeout: 120000 });
    const families = await features.atlasFamilies(page, out);
    const [mosaic] = await Promise.all([page.waitForEvent('download'), page.click('#at-save')]);
    await mosaic.saveAs(join(out, 'atlas-mosaic.png'));
    // click the tile in the top row, second column: x = second k, y = largest F
    const box = await page.locator('#at-image').boundingBox();
    const cell = (res.tile + res.pad) / (res.x.n * (res.tile + res.pad) + res.pad);
    await page.mouse.click(box.x + box.width * (1.5 * cell), box.y + box.height * (0.5 * cell));
    await page.waitForFunction(() => !document.getElementById('page-explore').hidden);
    await page.waitForFunction((f) => window.morphogenExplore?.state?.params?.F === f
      && window.morphogenExplore.frames >= 3, res.y.values[res.y.n - 1], { timeout: 60000 });
    await page.waitForTimeout(1500);
    await page.screenshot({ path: join(out, 'atlas-to-explore.png') });
    const params = await page.evaluate(() => window.morphogenExplore.state.params);
    const size = await page.evaluate(() => window.morphogenExplore.state.size);
    const dt = await page.evaluate(() => window.morphogenExplore.state.dt);
    return { x: res.x, y: res.y, valid: res.valid, params, size, tile: res.tile, dt, atlasDt: res.dt,
      sizeShown: await page.inputValue('#ex-size'), staleShown, ...families };
  },

  async mesh(page) {
    await page.goto(`${base}#mesh`);
    await page.waitForSelector('#me-go');
    await page.fill('#me-size', '90');
    await page.fill('#me-steps', '3000');
    await page.click('#me-go');
    await page.waitForFunction(() => !document.getElementById('me-still').hidden
      || !document.querySelector('#mesh-root .error').hidden, null, { timeout: 120000 });
    const error = await page.textContent('#mesh-root .error');
    if (error) throw new Error(`the mesh page showed an error: ${error}`);
    const print = () => page.evaluate(() => {
      const c = document.getElementById('me-canvas');
      const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
      let s = 0;
      for (let i = 0; i < d.length; i += 97) s += d[i] * (i % 13);
      return s;
    });
    const before = await print();
    const box = await page.locator('#me-canvas').boundingBox();
    await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
    await page.mouse.down();
    await page.mouse.move(box.x + box.width / 2 + 40, box.y + box.height / 2 - 60, { steps: 6 });
    await page.mouse.up();
    const after = await print();
    // a long downward drag tilts the flower, but never edge-on
    await page.mouse.move(box.x + box.width / 2, box.y + 10);
    await page.mouse.down();
    await page.mouse.move(box.x + box.width / 2, box.y + box.height - 10, { steps: 8 });
    await page.mouse.up();
    const tilt = await page.evaluate(() => window.morphogenMesh.rot.b);
    const liveFrames = await page.evaluate(() => window.morphogenMesh.live || 0);
    // the modelling loop: paint a production field (F) on the flower, continue from the last
    // state with a new k, and check the PLY the pipeline would write carries the painted field
    await page.check('#me-paint');
    await page.selectOption('#me-field', 'F');
    await page.fill('#me-value', '0.07');
    await page.mouse.move(box.x + box.width / 2 - 30, box.y + box.height / 2);
    await page.mouse.down();
    await page.mouse.move(box.x + box.width / 2 + 30, box.y + box.height / 2, { steps: 6 });
    await page.mouse.up();
    const painted = await page.evaluate(() => window.morphogenMesh.painted.size);
    await page.fill('#me-params input[data-param="k"]', '0.061');
    await page.fill('#me-steps', '400');
    const firstJob = await page.evaluate(() => window.morphogenMesh.lastJob);
    await page.click('#me-continue');
    await page.waitForFunction((j) => window.morphogenMesh.lastJob && window.morphogenMesh.lastJob !== j
      || !document.querySelector('#mesh-root .error').hidden, firstJob, { timeout: 120000 });
    const loopError = await page.textContent('#mesh-root .error');
    const plyHeader = await page.evaluate(async () => {
      const text = new TextDecoder('latin1').decode(await (await fetch(document.getElementById('me-ply').href)).arrayBuffer());
      return text.slice(0, text.indexOf('end_header'));
    });
    const pngHead = await page.evaluate(async () => Array.from(new Uint8Array(
      await (await fetch(document.getElementById('me-png').href)).arrayBuffer()).slice(1, 4)));
    await page.uncheck('#me-paint');
    // redraw rate while turning (recorded for docs/web.md, not asserted: timings are measured)
    const fps = await page.evaluate(() => {
      const m = window.morphogenMesh;
      const t0 = performance.now();
      for (let i = 0; i < 30; i += 1) { m.rot.a += 0.05; m.draw(); }
      return 30000 / (performance.now() - t0);
    });
    await page.waitForTimeout(300);
    await page.screenshot({ path: join(out, 'mesh.png') });
    const res = await page.evaluate(() => window.morphogenMesh.mesh.f.length / 3);
    return { before, after, faces: res, tilt, fps, liveFrames, painted, loopError, plyHeader,
      pngHead: String.fromCharCode(...pngHead), cases: await features.caseStudy(page, out) };
  },

  async tabs(page, context) {
    await openExplore(page);
    const other = await context.newPage();
    await openExplore(other);
    const ids = [await page.evaluate(() => window.morphogenExplore.sid),
      await other.evaluate(() => window.morphogenExplore.sid)];
    await dragSlider(page, 'input[data-param="k"]', 0.1);
    await page.waitForTimeout(500);
    const k = [await page.evaluate(() => window.morphogenExplore.state.params.k),
      await other.evaluate(() => fetch(`/api/live/${window.morphogenExplore.sid}`).then((r) => r.json()).then((s) => s.params.k))];
    return { ids, k };
  },

  async equations(page) {
    await openExplore(page);
    await page.selectOption('#ex-model', '__equations__');
    await page.fill('#ex-equations', "__import__('os').system('echo pwned')");
    await page.click('#ex-eq-apply');
    await page.waitForSelector('#ex-error:not([hidden])');
    const error = await page.textContent('#ex-error');
    // a model whose fifth line names an unknown parameter: that line is marked in the box
    await page.fill('#ex-equations', 'name = "x"\nspecies = ["u", "v"]\n\n[equations]\nu = "u*(1-u) + zz"\nv = "u"\n');
    await page.click('#ex-eq-apply');
    await page.waitForSelector('#ex-eq-mark:not([hidden])');
    const marked = await page.evaluate(() => {
      const box = document.getElementById('ex-equations');
      return { line: window.morphogenExplore.tools.badLine, mark: document.getElementById('ex-eq-mark').textContent,
        selected: box.value.slice(box.selectionStart, box.selectionEnd), bad: box.classList.contains('bad') };
    });
    await page.screenshot({ path: join(out, 'equations-rejected.png') });
    return { error, marked, model: await page.evaluate(() => window.morphogenExplore.state.model) };
  },
};

SCENARIOS.details = async (page) => {
  // elements marked hidden must not show on any page before anything has run
  const hiddenShown = {};
  for (const name of ['atlas', 'evolve', 'mesh']) {
    await page.goto(`${base}#${name}`);
    await page.waitForSelector(`#page-${name}:not([hidden])`);
    await page.waitForTimeout(500);
    hiddenShown[name] = await page.evaluate(() => [...document.querySelectorAll('[hidden]')]
      .filter((e) => getComputedStyle(e).display !== 'none').map((e) => e.id || e.tagName));
  }
  await openExplore(page);
  await pause(page);
  const x = () => page.evaluate(() => window.morphogenExplore.running);
  await page.evaluate(() => document.activeElement?.blur());
  const running = [];
  await page.keyboard.press('Space');
  running.push(await x());
  await page.keyboard.press('Space');
  running.push(await x());
  await page.waitForFunction(() => !window.morphogenExplore.inflight);
  const f0 = await framesNow(page);
  await page.keyboard.press('s');
  await page.waitForFunction((f) => window.morphogenExplore.frames > f && !window.morphogenExplore.inflight, f0);
  await page.waitForTimeout(300);
  const stepped = (await framesNow(page)) - f0;
  // a brush stroke or a reset while paused is drawn without advancing time
  const stepsNow = () => page.evaluate(() => window.morphogenExplore.last.steps);
  const beforePaint = await stepsNow();
  const f1 = await framesNow(page);
  const box = await page.locator('#ex-canvas').boundingBox();
  await page.mouse.move(box.x + box.width * 0.3, box.y + box.height * 0.3);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width * 0.7, box.y + box.height * 0.3, { steps: 10 });
  await page.mouse.up();
  await page.waitForFunction((f) => window.morphogenExplore.frames > f && !window.morphogenExplore.inflight, f1);
  await page.waitForTimeout(500);
  const afterPaint = await stepsNow();
  await reset(page, 'square');
  const afterReset = await stepsNow();
  const runLabel = await page.textContent('#ex-run');
  // choosing a preset keeps it shown in the menu
  await page.selectOption('#ex-preset', 'mazes');
  await page.waitForFunction(() => Math.abs(window.morphogenExplore.state.params.F - 0.029) < 1e-9);
  const preset = await page.inputValue('#ex-preset');
  // typing a value beyond the slider widens it; a value back inside restores the model's range
  const rangeMax = () => page.evaluate(() => Number(document.querySelector('input[data-param="F"]').max));
  const maxBefore = await rangeMax();
  const num = 'input[data-param="F"] + input';
  await page.fill(num, '50');
  await page.press(num, 'Enter');
  const maxAt50 = await rangeMax();
  await page.fill(num, '0.037');
  await page.press(num, 'Enter');
  const maxBack = await rangeMax();
  const rendering = await page.evaluate(() => getComputedStyle(document.getElementById('ex-canvas')).imageRendering);
  // a lost connection says so (and reconnects)
  await page.evaluate(() => window.morphogenExplore.ws.close());
  await page.waitForSelector('#ex-error:not([hidden])');
  const lost = await page.textContent('#ex-error');
  const statsLost = await page.textContent('#ex-stats');
  await page.waitForSelector('#ex-error', { state: 'hidden', timeout: 10000 });
  return { lost, statsLost, hiddenShown, running, stepped, beforePaint, afterPaint, afterReset, runLabel, preset, maxBefore, maxAt50, maxBack, rendering,
    presetAfterEdit: await page.inputValue('#ex-preset') };
};

// every control inside the sidebar (nothing cut off at its right edge)
const overflowing = (page, selector) => page.evaluate((sel) => {
  const box = document.querySelector(sel).getBoundingClientRect();
  return [...document.querySelectorAll(`${sel} select, ${sel} input, ${sel} button`)]
    .filter((e) => e.offsetParent && e.getBoundingClientRect().right > box.right + 1)
    .map((e) => e.id || e.tagName);
}, selector);

// the server's model list fails once: the page says so with a button, which then starts the app
SCENARIOS.modelsdown = async (page) => {
  let failures = 0;
  await page.route('**/api/models', (route) => {
    failures += 1;
    return route.fulfill({ status: 500, contentType: 'application/json', body: '{"error": "the catalogue is away"}' });
  });
  await page.goto(`${base}#explore`);
  await page.waitForSelector('#start-error');
  const shown = await page.textContent('#start-error');
  await page.unroute('**/api/models');
  await page.click('#start-error button');
  await page.waitForFunction(() => window.morphogenExplore?.frames >= 1, null, { timeout: 60000 });
  return { shown, failures, gone: (await page.locator('#start-error').count()) === 0 };
};

SCENARIOS.layout = async (page) => {
  await page.goto(`${base}#evolve`);
  await page.waitForFunction(() => Number(document.getElementById('ev-population')?.value) > 0);
  const evolveDesktop = await overflowing(page, '#ev-controls');
  await page.setViewportSize({ width: 390, height: 844 });
  const width = {};
  for (const name of ['explore', 'atlas', 'evolve', 'runs', 'mesh']) {
    await page.goto(`${base}#${name}`);
    await page.waitForSelector(`#page-${name}:not([hidden])`);
    if (name === 'explore') await page.waitForFunction(() => window.morphogenExplore?.frames >= 2, null, { timeout: 60000 });
    await page.waitForTimeout(400);
    width[name] = await page.evaluate(() => document.documentElement.scrollWidth);
    await page.screenshot({ path: join(out, `phone-${name}.png`), fullPage: true });
  }
  await page.goto(`${base}#explore`);
  await page.waitForFunction(() => window.morphogenExplore?.frames >= 2, null, { timeout: 60000 });
  const canvas = await page.locator('#ex-canvas').boundingBox();
  const controls = await page.locator('#page-explore .controls').boundingBox();
  return { evolveDesktop, width, canvasWidth: canvas.width, stacked: canvas.y + canvas.height <= controls.y + 1 };
};

for (const name of ['restart', 'refusals', 'schemes', 'checkpoint', 'dtNotices']) SCENARIOS[name] = (page) => designer[name](page, base, out);
for (const name of ['axe', 'keyboard', 'phone']) SCENARIOS[name] = (page) => access[name](page, base, out);
SCENARIOS.evolve = (page) => results.evolve(page, base, out);
SCENARIOS.atlasunstable = (page) => results.atlasUnstable(page, base, out);
SCENARIOS.match = (page) => matchPanel(page, base, out);
SCENARIOS.mapelites = (page) => mapElites.mapElitesOnRuns(page, base, out);
SCENARIOS.evolvemap = (page) => mapElites.mapElitesOnEvolve(page, base, out);

// one case study for docs/web.md's picture (MORPHOGEN_E2E_CASE, a flower of the server's examples)
SCENARIOS.casestudy = async (page) => {
  await page.goto(`${base}#mesh`);
  return features.caseStudy(page, out, process.env.MORPHOGEN_E2E_CASE || 'tiny', null);
};

SCENARIOS.meshsize = async (page) => {
  const posts = [];
  page.on('request', (r) => { if (r.method() === 'POST' && r.url().endsWith('/api/mesh')) posts.push(r.url()); });
  await page.goto(`${base}#mesh`);
  await page.waitForSelector('#me-detail');
  await page.fill('#me-detail', '1.5');
  await page.dispatchEvent('#me-detail', 'input');
  const max = await page.evaluate(() => Number(document.getElementById('me-size').max));
  await page.fill('#me-size', '200');
  await page.click('#me-go');
  await page.waitForSelector('#page-mesh .error:not([hidden])');
  return { max, error: await page.textContent('#page-mesh .error'), posts: posts.length };
};

const browser = await chromium.launch({
  executablePath: process.env.MORPHOGEN_CHROMIUM || '/usr/bin/chromium',
  args: ARGS,
});
// launch() gives every run a fresh temporary profile
const context = await browser.newContext({ viewport: { width: 1280, height: 800 }, acceptDownloads: true });
const page = await context.newPage();
const problems = [];
const consoleErrors = [];
page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
page.on('request', (r) => {
  if (!r.url().startsWith(base) && !r.url().startsWith('data:') && !r.url().startsWith('blob:')
      && !r.url().startsWith(base.replace('http', 'ws'))) problems.push(`outside request: ${r.url()}`);
});
let status = 0;
try {
  const result = await SCENARIOS[scenario](page, context);
  writeFileSync(join(out, `${scenario}.json`), JSON.stringify({ ...result, problems, consoleErrors }, null, 2));
} catch (err) {
  console.error(`${scenario}: ${err.message}`);
  await page.screenshot({ path: join(out, `${scenario}-failed.png`) }).catch(() => {});
  status = 1;
} finally {
  await browser.close();
}
process.exit(status);
