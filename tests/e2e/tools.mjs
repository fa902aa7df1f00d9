// Steps of browser.mjs's scenarios for Explore's tools and the Runs page's actions: the page
// address as state, the value readout and colour bar, undo of strokes, scheme and rectangular
// grids, recording, resuming and deleting runs, and the speed figures of docs/web.md.

import { readFileSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';

const x = (page, f) => page.evaluate(f);
const frames = (page) => x(page, () => window.morphogenExplore.frames);

async function nextFrame(page, timeout = 60000) {
  const f = await frames(page);
  await page.waitForFunction((s) => window.morphogenExplore.frames > s && !window.morphogenExplore.inflight, f, { timeout });
}

// the address holds the settings: a reload comes back with them
export async function urlState(page) {
  await page.selectOption('#ex-cmap', 'magma');
  await page.waitForFunction(() => window.morphogenExplore.state.cmap === 'magma');
  const hash = await x(page, () => window.location.hash);
  const before = await x(page, () => window.morphogenExplore.state);
  await page.reload();
  await page.waitForFunction(() => window.morphogenExplore?.frames >= 2
    && window.morphogenExplore.state?.cmap === 'magma' && window.morphogenExplore.lut, null, { timeout: 60000 });
  const after = await x(page, () => window.morphogenExplore.state);
  const hashAfter = await x(page, () => window.location.hash);
  // a link with refused settings says why and runs the default model instead
  const link = `${page.url().split('#')[0]}#explore?model=gray-scott&size=9999`;
  await page.goto(link);
  const keptRunning = await page.waitForSelector('#ex-error:not([hidden])').then(() => x(page, () => window.morphogenExplore.state.cmap));
  // after the refusal the address shows what runs again
  await page.waitForFunction(() => !window.morphogenExplore.loading);
  const hashKept = await x(page, () => window.location.hash);
  const fresh = await page.context().newPage(); // the same link opened afresh
  await fresh.goto(link);
  await fresh.waitForFunction(() => window.morphogenExplore?.frames >= 2 && window.morphogenExplore.state
    && !document.getElementById('ex-error').hidden, null, { timeout: 60000 });
  const refused = await fresh.textContent('#ex-error');
  const refusedSize = await x(fresh, () => window.morphogenExplore.state.size);
  await fresh.close();
  return { refused, keptRunning, refusedSize, hash, hashKept, urlBefore: { F: before.params.F, cmap: before.cmap, dt: before.dt, size: before.size },
    urlAfter: { F: after.params.F, cmap: after.cmap, dt: after.dt, size: after.size }, hashAfter };
}

// hover at a fraction of the canvas; the readout the page shows for it
async function hover(page, fx, fy) {
  const box = await page.locator('#ex-canvas').boundingBox();
  await page.mouse.move(box.x + box.width * fx + 1, box.y + box.height * fy + 1);
  await page.mouse.move(box.x + box.width * fx, box.y + box.height * fy);
  await page.waitForFunction(() => !window.morphogenExplore.tools.probing);
  await page.waitForTimeout(150);
  await page.waitForFunction(() => !window.morphogenExplore.tools.probing);
  return x(page, () => ({ ...window.morphogenExplore.tools.readout, text: document.getElementById('ex-readout').textContent }));
}

// after two strokes on a uniform start: the readout, the colour bar, then U twice undoes both
export async function readoutAndUndo(page) {
  const painted = await hover(page, 0.25, 0.25);
  const bar = await x(page, () => {
    const c = document.getElementById('ex-cb').getContext('2d').getImageData(255, 0, 1, 1).data;
    const lut = window.morphogenExplore.lut;
    return { lo: document.getElementById('ex-cb-lo').textContent, hi: document.getElementById('ex-cb-hi').textContent,
      ticks: [...document.querySelectorAll('#ex-cb-ticks span')].map((e) => e.textContent),
      last: [window.morphogenExplore.last.lo, window.morphogenExplore.last.hi],
      top: [c[0], c[1], c[2]], lutTop: [lut[765], lut[766], lut[767]] };
  });
  const undoLabel = await page.textContent('#ex-undo');
  await page.evaluate(() => document.activeElement?.blur());
  for (let i = 0; i < 2; i += 1) {
    const f = await frames(page);
    await page.keyboard.press('u');
    await page.waitForFunction((s) => window.morphogenExplore.frames > s && !window.morphogenExplore.inflight, f);
  }
  const undone = await hover(page, 0.25, 0.25);
  const undoneDrag = await hover(page, 0.75, 0.75);
  return { paintedReadout: painted, bar, undoLabel, undone, undoneDrag, undoDisabled: await page.isDisabled('#ex-undo') };
}

// a 256 x 128 grid under IMEX, recorded for a dozen frames and downloaded as a GIF
export async function rectangleImexRecording(page, out) {
  await page.selectOption('#ex-height', '128');
  await page.waitForFunction(() => window.morphogenExplore.state.height === 128 && window.morphogenExplore.frames >= 2, null, { timeout: 60000 });
  await page.selectOption('#ex-scheme', 'imex');
  await page.waitForFunction(() => window.morphogenExplore.state.scheme === 'imex', null, { timeout: 60000 });
  await nextFrame(page);
  const canvas = await x(page, () => [window.morphogenExplore.canvas.width, window.morphogenExplore.canvas.height]);
  const box = await page.locator('#ex-canvas').boundingBox();
  await page.click('#ex-record');
  const f0 = await frames(page);
  await page.waitForFunction((s) => window.morphogenExplore.frames >= s + 12, f0, { timeout: 60000 });
  await page.click('#ex-record');
  await page.waitForSelector('#ex-recorded:not([hidden])');
  const recordedLabel = await x(page, () => window.morphogenExplore.tools.recorded);
  const [gif] = await Promise.all([page.waitForEvent('download'), page.click('#ex-save-gif')]);
  await gif.saveAs(join(out, 'recording.gif'));
  return { canvas, shownRatio: box.width / box.height, recordedLabel, gif: gif.suggestedFilename(),
    scheme: await x(page, () => window.morphogenExplore.state.scheme) };
}

// the machine's 1-minute load average (Linux), recorded next to each figure
function load() {
  try { return Number(readFileSync('/proc/loadavg', 'utf8').split(' ')[0]); } catch { return null; }
}

// frames per second over `ms`, counted in the page, and the server's mean ms per frame
async function fps(page, ms = 3000) {
  const f0 = await frames(page);
  const t0 = Date.now();
  const server = [];
  while (Date.now() - t0 < ms) {
    await page.waitForTimeout(250);
    server.push(await x(page, () => window.morphogenExplore.last.ms));
  }
  const rate = ((await frames(page)) - f0) / ((Date.now() - t0) / 1000);
  return { fps: rate, serverMs: server.reduce((a, b) => a + b, 0) / server.length, load: load() };
}

// a fresh tab opening Explore: ms from the start of its navigation to the page's load event
// and to its first frame drawn
async function firstFrame(page, base) {
  const tab = await page.context().newPage();
  await tab.goto(`${base}#explore`);
  await tab.waitForFunction(() => window.morphogenExplore?.firstFrameAt !== undefined, null, { timeout: 120000 });
  const t = await tab.evaluate(() => ({ frame: window.morphogenExplore.firstFrameAt,
    loaded: performance.getEntriesByType('navigation')[0].loadEventEnd }));
  await tab.close();
  return { ...t, afterLoad: t.frame - t.loaded, load: load() };
}

async function setSize(page, size) {
  await page.selectOption('#ex-size', String(size));
  await page.waitForFunction((n) => window.morphogenExplore.state.size === n && window.morphogenExplore.frames >= 2, size, { timeout: 120000 });
}

// steps per frame changed: seconds to the first frame of the new program (it compiles once per
// model, grid and value), then the frame rate
async function rateAt(page, steps) {
  const t0 = Date.now();
  await page.selectOption('#ex-steps', String(steps));
  await page.waitForFunction((n) => window.morphogenExplore.state.steps_per_frame === n, steps);
  await nextFrame(page, 120000); // perhaps the frame asked for before the change
  await nextFrame(page, 120000);
  const firstS = (Date.now() - t0) / 1000;
  return { steps, firstS, ...(await fps(page)) };
}

// menu -> the first frame of the new model (a frame after the one the switch shows)
async function switchTo(page, name) {
  const t0 = Date.now();
  await page.selectOption('#ex-model', name);
  await page.waitForFunction((n) => window.morphogenExplore.state?.model === n && window.morphogenExplore.last
    && window.morphogenExplore.frames >= 1, name, { timeout: 120000 });
  const f = await frames(page);
  await page.waitForFunction((s) => window.morphogenExplore.frames > s, f, { timeout: 120000 });
  return { s: (Date.now() - t0) / 1000, load: load() };
}

// docs/web.md's figures, on a server that has finished its warm-up: time to the first frame of
// a freshly opened page (three tabs), frames/s of Gray-Scott (Euler) at 256² and 512² for 1, 32
// and 128 steps per frame, and model switches on the warmed 256² view (first, back, again) and
// on a 128² grid the warm-up did not compile
export async function measure(page, out) {
  const base = page.url().split('#')[0];
  const res = { loadStart: load(), firstFrame: [], rates: {}, switches: {} };
  for (let i = 0; i < 3; i += 1) res.firstFrame.push(await firstFrame(page, base));
  for (const size of [256, 512]) {
    await setSize(page, size);
    res.rates[size] = [];
    for (const steps of [1, 32, 128]) res.rates[size].push(await rateAt(page, steps));
  }
  await setSize(page, 256);
  const sw = res.switches;
  sw.warm = [['fitzhugh-nagumo', 'first'], ['gray-scott', 'back'], ['fitzhugh-nagumo', 'again'],
    ['schnakenberg', 'first'], ['activator-inhibitor', 'first']];
  for (const entry of sw.warm) {
    entry.push(await switchTo(page, entry[0]));
    if (entry[0] === 'fitzhugh-nagumo') { // its labyrinths after 40 frames
      await page.waitForFunction((f) => window.morphogenExplore.frames >= f, (await frames(page)) + 40, { timeout: 120000 });
      await page.screenshot({ path: join(out, 'explore-fhn.png') });
    }
  }
  await switchTo(page, 'gray-scott');
  await setSize(page, 128);
  sw.cold = [['brusselator', 'first'], ['gray-scott', 'back'], ['brusselator', 'again']];
  for (const entry of sw.cold) entry.push(await switchTo(page, entry[0]));
  res.loadEnd = load();
  return res;
}

// Runs page: resume the stopped run on the Evolve page, stop it, then delete it after the
// confirmation dialog
export async function resumeAndDelete(page, base, run) {
  await page.click('#runs-resume');
  await page.waitForFunction((id) => window.location.hash === '#evolve'
    && window.morphogenEvolve?.status?.run === id && window.morphogenEvolve.status.state === 'choose'
    && document.querySelectorAll('#ev-grid .tile').length === 6, run, { timeout: 120000 });
  const resumedGen = await x(page, () => window.morphogenEvolve.status.gen);
  await page.click('#ev-stop');
  await page.waitForFunction(() => window.morphogenEvolve.status.state === 'stopped', null, { timeout: 60000 });
  await page.goto(`${base}#runs`);
  await page.click(`tr[data-run="${run}"]`);
  await page.waitForSelector('#runs-delete');
  let dialog = '';
  page.once('dialog', (d) => { dialog = d.message(); d.accept(); });
  await page.click('#runs-delete');
  await page.waitForSelector('#runs-deleted');
  // the notice comes before the list's refresh: wait for the refreshed list (without the row)
  await page.waitForFunction((id) => !document.querySelector(`tr[data-run="${id}"]`), run,
    { timeout: 60000 });
  const listed = await x(page, () => [...document.querySelectorAll('tr[data-run]')].map((tr) => tr.dataset.run));
  return { resumedGen, dialog, listedAfterDelete: listed };
}

// the page opens a run.json (here the one it saved, with F and the colour map changed)
export async function openRunFile(page, out) {
  const data = JSON.parse(readFileSync(join(out, 'run.json'), 'utf8'));
  data.config.params.F = 0.05;
  data.config.cmap = 'magma';
  writeFileSync(join(out, 'run-open.json'), JSON.stringify(data));
  await page.setInputFiles('#ex-open', join(out, 'run-open.json'));
  // the load finished, not only its state shown: its last step clears the error box, which
  // would wipe the refusal below if it came after it
  await page.waitForFunction(() => window.morphogenExplore.state?.params?.F === 0.05
    && window.morphogenExplore.state.cmap === 'magma' && !window.morphogenExplore.loading, null,
  { timeout: 60000 });
  const s = await x(page, () => window.morphogenExplore.state);
  // a file that is not a run file is refused in one line
  writeFileSync(join(out, 'not-a-run.json'), JSON.stringify({ hello: 1 }));
  await page.setInputFiles('#ex-open', join(out, 'not-a-run.json'));
  // this file's refusal (it names the file), not an earlier message still in the box: under
  // load a slow-frame notice can be showing, and the next frame clears it
  // (the text is read as the wait sees it, not again afterwards)
  const shown = await page.waitForFunction(() => {
    const e = document.getElementById('ex-error');
    return e && !e.hidden && e.textContent.startsWith('not-a-run.json') && e.textContent;
  }, null, { timeout: 60000 });
  return { opened: { F: s.params.F, cmap: s.cmap, size: s.size, height: s.height, scheme: s.scheme,
    model: s.model }, openError: await shown.jsonValue() };
}

// open the Evolve page, set its selects and number fields, and start a run
export async function startEvolve(page, base, { selects = {}, fields = {} } = {}) {
  await page.goto(`${base}#evolve`);
  await page.waitForFunction(() => Number(document.getElementById('ev-population')?.value) > 0);
  for (const [name, value] of Object.entries(selects)) await page.selectOption(`#ev-${name}`, value);
  for (const [name, value] of Object.entries(fields)) await page.fill(`#ev-${name}`, String(value));
  await page.click('#ev-start');
}
