// Steps of browser.mjs's scenarios for how pages show results. Evolve: one generation with two
// favourites, a reload while the run waits (its settings and tiles come back), a stopped run
// that keeps its tiles after a reload, then resuming and deleting it from the Runs page. Atlas:
// numerically unstable tiles counted and named.

import { join } from 'node:path';
import { resumeAndDelete, startEvolve } from './tools.mjs';

const x = (page, f, arg) => page.evaluate(f, arg);

// what the Evolve controls show (strings, as typed)
const controls = (page) => x(page, () => Object.fromEntries(['population', 'size', 'steps', 'generations']
  .map((k) => [k, document.getElementById(`ev-${k}`).value])));

export async function evolve(page, base, out) {
  await startEvolve(page, base, { fields: { population: 6, size: 48, steps: 2000, generations: 3 } });
  await page.waitForSelector('#ev-grid .tile', { timeout: 120000 });
  await page.click('#ev-grid .tile[data-idx="1"]');
  await page.click('#ev-grid .tile[data-idx="4"]');
  const picked = await page.locator('#ev-grid .tile.picked').count();
  await page.screenshot({ path: join(out, 'evolve-choose.png') });
  const run = await x(page, () => window.morphogenEvolve.status.run);
  await page.click('#ev-next');
  await page.waitForFunction(() => window.morphogenEvolve.status.gen === 2
    && window.morphogenEvolve.status.state === 'choose', null, { timeout: 120000 });
  await page.waitForTimeout(500);
  await page.screenshot({ path: join(out, 'evolve-next.png') });
  const runs = await x(page, () => fetch('/api/runs').then((r) => r.json()));
  const gen1 = await x(page, (id) => fetch(`/api/runs/${id}/generations/1`).then((r) => r.json()), run);
  // a reload while the run waits for favourites brings it back, tiles, settings, picks and all
  await page.click('#ev-grid .tile[data-idx="3"]');
  await page.reload();
  await page.waitForFunction((id) => window.morphogenEvolve?.status?.run === id
    && document.querySelectorAll('#ev-grid .tile').length === 6, run, { timeout: 60000 });
  const reloaded = await x(page, () => ({ gen: window.morphogenEvolve.status.gen,
    state: window.morphogenEvolve.status.state, stop: !document.getElementById('ev-stop').hidden }));
  reloaded.controls = await controls(page);
  reloaded.picked = await x(page, () => [...document.querySelectorAll('#ev-grid .tile.picked')]
    .map((t) => t.dataset.idx));
  // the Runs page offers to continue it, and its detail says nothing is "null"
  await page.goto(`${base}#runs`);
  await page.click(`tr[data-run="${run}"]`);
  await page.waitForSelector('#runs-continue');
  const detailText = await page.textContent('#runs-detail');
  await page.click('#runs-continue');
  await page.waitForFunction((id) => window.location.hash === '#evolve'
    && window.morphogenEvolve?.status?.run === id
    && document.querySelectorAll('#ev-grid .tile').length === 6, run, { timeout: 60000 });
  const continued = await x(page, () => window.morphogenEvolve.status.state);
  // stopped while choosing: generation 2 was evaluated, so its six tiles stay, after a reload too
  await page.click('#ev-stop');
  await page.waitForFunction(() => window.morphogenEvolve.status.state === 'stopped', null, { timeout: 60000 });
  await page.reload();
  await page.waitForFunction((id) => window.morphogenEvolve?.status?.run === id
    && window.morphogenEvolve.status.state === 'stopped'
    && document.querySelectorAll('#ev-grid .tile').length === 6, run, { timeout: 60000 });
  // every picture drawn (or given up on after 30 s: then the count says how many were)
  await page.waitForFunction(() => [...document.querySelectorAll('#ev-grid .tile img')]
    .every((i) => i.complete && i.naturalWidth > 0), null, { timeout: 30000 }).catch(() => {});
  const stopped = await x(page, () => ({
    captions: [...document.querySelectorAll('#ev-grid .tile .cap')].map((c) => c.textContent),
    loaded: [...document.querySelectorAll('#ev-grid .tile img')].filter((i) => i.complete && i.naturalWidth > 0).length,
  }));
  stopped.controls = await controls(page);
  await page.goto(`${base}#runs`);
  await page.click(`tr[data-run="${run}"]`);
  await page.waitForSelector('#runs-sheet img');
  await page.waitForTimeout(800);
  await page.screenshot({ path: join(out, 'runs.png'), fullPage: true });
  const actions = await resumeAndDelete(page, base, run);
  return { ...actions, run, picked, runs: runs.runs, gen1: gen1.individuals.map((i) => i.fitness), reloaded,
    detailText, continued, stopped };
}

// an atlas whose k = 0 row is numerically unstable at dt = 1 (Gray-Scott, 32², 1500 steps):
// the count line, and the hover text of an unstable tile (bottom row) and a sound one (top row)
export async function atlasUnstable(page, base, out) {
  await page.goto(`${base}#atlas`);
  await page.waitForFunction(() => document.querySelectorAll('#at-x option').length > 0);
  // a long atlas cancelled by the user: a plain message, no error in red
  await page.fill('#at-x-n', '8');
  await page.fill('#at-y-n', '8');
  await page.selectOption('#at-tile', '64');
  await page.fill('#at-steps', '10000');
  await page.click('#at-go');
  await page.waitForSelector('#at-cancel:not([hidden])');
  await page.click('#at-cancel');
  await page.waitForFunction(() => !document.getElementById('at-go').disabled, null, { timeout: 120000 });
  const cancelled = await x(page, () => ({ error: document.getElementById('at-error').hidden
    ? '' : document.getElementById('at-error').textContent, message: document.getElementById('at-message').textContent }));
  await page.selectOption('#at-x', 'F');
  await page.fill('#at-x-lo', '0.01');
  await page.fill('#at-x-hi', '0.07');
  await page.fill('#at-x-n', '2');
  await page.selectOption('#at-y', 'k');
  await page.fill('#at-y-lo', '0');
  await page.fill('#at-y-hi', '0.05');
  await page.fill('#at-y-n', '2');
  await page.selectOption('#at-tile', '32');
  await page.fill('#at-steps', '1500');
  await page.click('#at-go');
  await page.waitForFunction(() => !document.getElementById('at-result').hidden
    || !document.getElementById('at-error').hidden, null, { timeout: 120000 });
  const error = await page.textContent('#at-error');
  if (error.trim()) throw new Error(`the atlas failed: ${error}`);
  const res = await x(page, () => window.morphogenAtlas.result);
  const box = await page.locator('#at-image').boundingBox();
  const cell = (res.tile + res.pad) / (res.x.n * (res.tile + res.pad) + res.pad);
  const hover = async (i) => {
    await page.mouse.move(box.x + box.width * (0.5 * cell), box.y + box.height * ((i + 0.5) * cell));
    return page.textContent('#at-hover');
  };
  const hovers = [await hover(0), await hover(1)];
  await page.screenshot({ path: join(out, 'atlas-unstable.png') });
  const line = await x(page, () => { const p = document.getElementById('at-unstable'); return { hidden: p.hidden, text: p.textContent, title: p.title }; });
  // the mosaic's file gone from the server (a restart forgets jobs): its download says so
  const [saved] = await Promise.all([page.waitForEvent('download'), page.click('#at-save')]);
  await x(page, () => { document.getElementById('at-save').href = '/api/jobs/forgotten/files/atlas.png'; });
  await page.click('#at-save');
  await page.waitForSelector('#at-error:not([hidden])');
  const gone = { saved: saved.suggestedFilename(), error: await page.textContent('#at-error') };
  return { valid: res.valid, line, hovers, cancelled, gone };
}
