// Scenarios of browser.mjs for a designer's work surviving what happens around it: a server
// that forgets the session (a restart), refused or changed settings, schemes at their own
// step. Each returns what it saw; tests/e2e/test_browser.py makes the checks.

import { join } from 'node:path';

const x = (page, f, arg) => page.evaluate(f, arg);

async function openExplore(page, base, hash = '') {
  await page.goto(`${base}#explore${hash}`);
  await page.waitForFunction(() => window.morphogenExplore && window.morphogenExplore.frames >= 2, null, { timeout: 60000 });
}

// wait until no request of the page is pending and a frame came after `frames`
async function settled(page, frames = 0) {
  await page.waitForFunction((f) => {
    const e = window.morphogenExplore;
    return e.sid && !e.recovering && !e.loading && !e.sending && !e.paramTimer && e.frames > f;
  }, frames, { timeout: 120000 });
}

// what the controls show, next to what the server runs
const controls = (page) => x(page, async () => {
  const e = window.morphogenExplore;
  const v = (id) => document.getElementById(id).value;
  const server = await (await fetch(`/api/live/${e.sid}`)).json();
  return {
    shown: { model: v('ex-model'), size: v('ex-size'), height: v('ex-height'), scheme: v('ex-scheme'),
      boundary: v('ex-boundary'), species: v('ex-species'), steps: v('ex-steps'), cmap: v('ex-cmap'),
      F: Number(document.querySelector('input[data-param="F"] + input').value), dt: Number(v('ex-dt-num')),
      range: v('ex-range-mode') },
    server: { model: server.model, size: String(server.size), height: server.height === server.size ? '' : String(server.height),
      scheme: server.scheme, boundary: server.boundary, species: server.show, steps: String(server.steps_per_frame),
      cmap: server.cmap, F: server.params.F, dt: server.dt, range: Array.isArray(server.range) ? 'fixed' : 'auto' },
    rawServer: server,
  };
});

async function choose(page, selector, value) {
  const f = await x(page, () => window.morphogenExplore.frames);
  await page.selectOption(selector, value);
  await settled(page, f);
}

// 1. The session disappears under the page (what a server restart does): the page starts it
// again with every setting it had, and the address stays the same.
export async function restart(page, base, out) {
  await openExplore(page, base, '?model=gray-scott&p.F=0.05&p.k=0.061&p.Du=0.2&p.Dv=0.1&size=128&boundary=neumann&scheme=rk4&init=noise&seed=7&cmap=magma&show=u&spf=8&range=0,1');
  await settled(page);
  // paused after some time has passed, one stroke dragged from the middle to the right for
  // longer than the page waits before keeping the painted state (it keeps the whole stroke)
  await page.click('#ex-run');
  await page.waitForFunction(() => !window.morphogenExplore.running && !window.morphogenExplore.inflight);
  const box = await page.locator('#ex-canvas').boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.down();
  for (let i = 1; i <= 10; i += 1) {
    await page.mouse.move(box.x + box.width * (0.5 + 0.025 * i), box.y + box.height / 2);
    await page.waitForTimeout(80);
  }
  await page.mouse.up();
  await page.waitForFunction(() => !window.morphogenExplore.tools.busy() && window.morphogenExplore.kept
    && document.getElementById('ex-undo').textContent === 'Undo stroke (1)', null, { timeout: 30000 });
  await page.waitForTimeout(400); // the kept state follows the last batch after 200 ms
  await page.waitForFunction(() => window.morphogenExplore.kept && !window.morphogenExplore.tools.busy());
  const probe = () => x(page, async () => {
    const e = window.morphogenExplore;
    const at = async (px) => (await (await fetch(`/api/live/${e.sid}/probe?x=${px}&y=0.5`)).json()).values;
    const t = (await (await fetch(`/api/live/${e.sid}`)).json()).t;
    return { start: await at(0.5), end: await at(0.75), t };
  });
  const paintedBefore = await probe();
  const hashBefore = await x(page, () => window.location.hash);
  const before = await controls(page);
  const sid = await x(page, () => window.morphogenExplore.sid);
  // what a restart does: the server forgets the session and the socket drops
  await x(page, async (id) => {
    await fetch(`/api/live/${id}`, { method: 'DELETE' });
    window.morphogenExplore.ws.close();
  }, sid);
  await page.waitForFunction((id) => window.morphogenExplore.sid && window.morphogenExplore.sid !== id
    && !window.morphogenExplore.recovering && !window.morphogenExplore.loading, sid, { timeout: 120000 });
  const after = await controls(page);
  const paintedAfter = await probe();
  await page.screenshot({ path: join(out, 'restart.png') });
  return { hashBefore, hashAfter: await x(page, () => window.location.hash), before, after,
    paintedBefore, paintedAfter, running: await x(page, () => window.morphogenExplore.running),
    notice: await page.textContent('#ex-notice'), error: await page.textContent('#ex-error') };
}

// 3b. A diffusion raised past Euler's limit lowers dt (a notice that stays); lowered again, dt goes
// back up (a notice that goes by itself after a few seconds).
export async function dtNotices(page, base) {
  await openExplore(page, base, '?model=gray-scott&size=64');
  await settled(page);
  const notice = () => page.textContent('#ex-notice');
  await x(page, () => window.morphogenExplore.queueParam('Du', 2.0));
  await page.waitForFunction(() => document.getElementById('ex-notice').textContent.startsWith('dt lowered'));
  await page.waitForTimeout(5000);
  const lowered = await notice(); // still there
  await x(page, () => window.morphogenExplore.queueParam('Du', 0.2097));
  await page.waitForFunction(() => document.getElementById('ex-notice').textContent.startsWith('dt back up'));
  const up = await notice();
  await page.waitForFunction(() => document.getElementById('ex-notice').textContent === '', null, { timeout: 15000 });
  return { lowered, up, gone: await notice() };
}

// 4. Refusals leave every control showing what runs; a grid change keeps the view settings.
export async function refusals(page, base, out) {
  await openExplore(page, base);
  await settled(page);
  // view settings and a hand-set dt, then a new grid
  await choose(page, '#ex-species', 'u');
  await choose(page, '#ex-steps', '8');
  await choose(page, '#ex-cmap', 'magma');
  await page.selectOption('#ex-range-mode', 'fixed');
  await page.waitForFunction(() => Array.isArray(window.morphogenExplore.state.range));
  await page.fill('#ex-range-lo', '0');
  await page.fill('#ex-range-hi', '1');
  await page.press('#ex-range-hi', 'Enter');
  await page.waitForFunction(() => String(window.morphogenExplore.state.range) === '0,1');
  const dtMax = await x(page, () => window.morphogenExplore.state.dt_max);
  const handDt = Number((dtMax * 0.4).toPrecision(3));
  await page.fill('#ex-dt-num', String(handDt));
  await page.press('#ex-dt-num', 'Enter');
  await page.waitForFunction((d) => Math.abs(window.morphogenExplore.state.dt - d) < 1e-9, handDt);
  await choose(page, '#ex-size', '128');
  const afterGrid = await controls(page);
  // a width the server refuses (an option added by hand, as a stale menu could offer)
  await x(page, () => document.getElementById('ex-size').add(new Option('9999', '9999')));
  await page.selectOption('#ex-size', '9999');
  await page.waitForSelector('#ex-error:not([hidden])');
  await page.waitForFunction(() => !window.morphogenExplore.loading);
  const refusedGrid = { error: await page.textContent('#ex-error'), ...(await controls(page)) };
  // a parameter value the server refuses
  await page.fill('input[data-param="F"] + input', '5e6'); // beyond the server's ±1e6
  await page.press('input[data-param="F"] + input', 'Enter');
  await page.waitForFunction(() => !window.morphogenExplore.sending && !window.morphogenExplore.paramTimer);
  const refusedParam = { error: await page.textContent('#ex-error'), ...(await controls(page)) };
  await page.screenshot({ path: join(out, 'refusals.png') });
  return { handDt, afterGrid, refusedGrid, refusedParam };
}

// 3. Each scheme runs at its own stable step; a set-up beyond the frame budget is refused first.
export async function schemes(page, base, out) {
  await openExplore(page, base, '?model=gray-scott&size=128');
  await settled(page);
  const rows = [];
  for (const scheme of ['euler', 'imex1', 'imex', 'etdrk4', 'rk4']) {
    await choose(page, '#ex-scheme', scheme);
    const s = await x(page, () => window.morphogenExplore.state);
    rows.push({ scheme: s.scheme, dt: s.dt, dt_max: s.dt_max, shown: Number(await page.inputValue('#ex-dt-num')) });
  }
  await page.click('#ex-run');
  await page.waitForFunction(() => !window.morphogenExplore.running && !window.morphogenExplore.inflight);
  // frames of one set-up as the server times them: a slow first one (it compiled), then 20 and
  // 50 ms; the estimate keeps the set-up's fastest, 20 ms
  const framesMs = await x(page, () => {
    const e = window.morphogenExplore;
    const frame = (ms) => {
      const buf = new ArrayBuffer(28 + 128 * 128);
      const head = new DataView(buf);
      head.setUint16(0, 128, true); head.setUint16(2, 128, true); head.setFloat32(24, ms, true);
      e.draw(buf);
      return e.seen.ms;
    };
    e.seen = null; // as after a new set-up
    return [5000, 20, 50].map(frame);
  });
  // pretend the server was slow (paused, so no new frame measures it again): the next set-up
  // would take hours a frame, and the page says so first
  await x(page, () => { window.morphogenExplore.seen = { ms: 20000, cells: 128 * 128, steps: 1, scheme: 'rk4' }; });
  const posts = [];
  page.on('request', (r) => { if (r.method() === 'POST' && r.url().includes('/configure')) posts.push(r.url()); });
  await page.selectOption('#ex-size', '512');
  await page.waitForSelector('#ex-error:not([hidden])');
  const budget = { error: await page.textContent('#ex-error'), posts: posts.length };
  await page.waitForFunction(() => document.getElementById('ex-size').value === '128');
  budget.sizeShown = await page.inputValue('#ex-size');
  await page.screenshot({ path: join(out, 'schemes.png') });
  return { rows, budget, framesMs };
}

// 6. A checkpoint holds the painted state; restored, it comes back; the Web page button writes
// the page from the state as it is now, and names a setting the page cannot run.
export async function checkpoint(page, base, out) {
  await openExplore(page, base, '?model=gray-scott&size=64&init=uniform&scheme=euler');
  await settled(page);
  await page.click('#ex-run'); // pause
  await page.waitForFunction(() => !window.morphogenExplore.inflight);
  const box = await page.locator('#ex-canvas').boundingBox();
  await page.mouse.click(box.x + box.width / 2, box.y + box.height / 2);
  await page.waitForFunction(() => !window.morphogenExplore.tools.busy()
    && document.getElementById('ex-undo').textContent === 'Undo stroke (1)', null, { timeout: 30000 });
  const save = async (selector, name) => {
    const [d] = await Promise.all([page.waitForEvent('download'), page.click(selector)]);
    await d.saveAs(join(out, name));
    return d.suggestedFilename();
  };
  const names = [await save('#ex-save-state', 'checkpoint.npz'), await save('#ex-save-run', 'checkpoint-run.json'),
    await save('#ex-save-page', 'explore-page.html')];
  const probe = () => x(page, async () => {
    const e = window.morphogenExplore;
    return (await (await fetch(`/api/live/${e.sid}/probe?x=0.5&y=0.5`)).json()).values;
  });
  const painted = await probe();
  await page.click('#ex-reset');
  // the reset has reached the server once the probe reads a fresh uniform state (the click
  // alone may return before the request starts); a reset that never lands times out
  await page.waitForFunction(async () => {
    const e = window.morphogenExplore;
    if (e.inflight) return false;
    const r = await fetch(`/api/live/${e.sid}/probe?x=0.5&y=0.5`);
    return (await r.json()).values.v === 0;
  }, null, { timeout: 30000, polling: 200 });
  const afterReset = await probe();
  await page.setInputFiles('#ex-restore', join(out, 'checkpoint.npz'));
  await page.waitForFunction(() => window.morphogenExplore.restored === 1, null, { timeout: 30000 });
  const restored = await probe();
  // a scheme the exported page cannot run is named
  await choose(page, '#ex-scheme', 'imex');
  await page.click('#ex-save-page');
  await page.waitForSelector('#ex-error:not([hidden])');
  const refused = await page.textContent('#ex-error');
  return { names, painted, afterReset, restored, refused };
}
