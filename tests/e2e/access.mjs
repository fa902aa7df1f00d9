// Scenarios of browser.mjs for reaching the app: axe-core on every page, the keyboard (run
// rows, atlas tiles, both canvases) and a phone (picture first, 44 px touch targets).

import { readFileSync } from 'node:fs';
import { join } from 'node:path';

const AXE = readFileSync(new URL('./node_modules/axe-core/axe.min.js', import.meta.url), 'utf8');
const PAGES = ['explore', 'atlas', 'evolve', 'runs', 'mesh'];

async function ready(page, base, name) {
  await page.goto(`${base}#${name}`);
  await page.waitForSelector(`#page-${name}:not([hidden])`);
  if (name === 'explore') await page.waitForFunction(() => window.morphogenExplore?.frames >= 2, null, { timeout: 60000 });
  if (name === 'evolve') await page.waitForFunction(() => document.querySelectorAll('#ev-genes input').length > 0);
  if (name === 'atlas') await page.waitForFunction(() => document.querySelectorAll('#at-x option').length > 0);
  if (name === 'mesh') await page.waitForSelector('#me-go');
}

// a small atlas, computed from the page's controls
async function smallAtlas(page) {
  await page.fill('#at-x-n', '4');
  await page.fill('#at-y-n', '4');
  await page.selectOption('#at-tile', '32');
  await page.fill('#at-steps', '300');
  await page.click('#at-go');
  await page.waitForSelector('#at-result:not([hidden])', { timeout: 120000 });
}

// axe-core (from node_modules, evaluated in the page: nothing is fetched) on each page: the
// critical and serious violations, and each page's visible h1
export async function axe(page, base, out) {
  const found = {};
  const h1 = {};
  let stepLimit = null;
  for (const name of PAGES) {
    await ready(page, base, name);
    if (name === 'atlas') {
      stepLimit = await page.textContent('#at-steps-limit'); // said before any click
      await smallAtlas(page);
    }
    if (!(await page.evaluate(() => Boolean(window.axe)))) await page.evaluate(`${AXE};0`);
    const res = await page.evaluate(() => window.axe.run(document, { resultTypes: ['violations'] }));
    found[name] = res.violations.filter((v) => v.impact === 'critical' || v.impact === 'serious')
      .map((v) => ({ id: v.id, impact: v.impact, nodes: v.nodes.slice(0, 5).map((n) => n.target.join(' ')) }));
    h1[name] = await page.evaluate((n) => [...document.querySelectorAll(`#page-${n} h1`)].map((e) => e.textContent), name);
  }
  return { found, h1, stepLimit };
}

// Tab reaches the thing; the keys do what the pointer does
async function tabTo(page, test, limit = 120, arg = undefined) {
  for (let i = 0; i < limit; i += 1) {
    await page.keyboard.press('Tab');
    if (await page.evaluate(test, arg)) return i + 1;
  }
  return 0;
}

export async function keyboard(page, base, out) {
  const seen = {};
  // Explore: Tab to the picture, arrows move the brush (the readout follows), Enter paints
  await ready(page, base, 'explore');
  await page.click('#ex-run'); // paused: the painted disc stays as it was painted
  await page.waitForFunction(() => !window.morphogenExplore.inflight);
  seen.canvasTabs = await tabTo(page, () => document.activeElement?.id === 'ex-canvas');
  await page.keyboard.press('ArrowRight');
  await page.waitForFunction(() => window.morphogenExplore.tools.readout?.col === 136, null, { timeout: 30000 });
  const undo = () => page.evaluate(() => window.morphogenExplore.state.undo ?? 0);
  const before = await page.textContent('#ex-undo');
  await page.keyboard.press('Enter');
  await page.waitForFunction((b) => document.getElementById('ex-undo').textContent !== b, before, { timeout: 30000 });
  seen.canvasUndo = await page.textContent('#ex-undo');
  seen.readout = await page.textContent('#ex-readout');
  seen.undo = await undo();
  // the three file choosers (run file, picture to match, checkpoint) are in the tab order
  seen.fileTabs = {};
  for (const id of ['ex-open', 'ex-match-file', 'ex-restore']) {
    await page.focus('#ex-model');
    seen.fileTabs[id] = await tabTo(page, (want) => document.activeElement?.id === want, 200, id);
  }
  // Atlas: Tab to the mosaic, arrows choose a tile, Enter opens it in Explore
  await ready(page, base, 'atlas');
  await smallAtlas(page);
  await page.focus('#at-go');
  seen.atlasTabs = await tabTo(page, () => document.activeElement?.id === 'at-image');
  await page.keyboard.press('ArrowRight');
  seen.atlasHover = await page.textContent('#at-hover');
  const want = await page.evaluate(() => window.morphogenAtlas.result.x.values[1]);
  await page.keyboard.press('Enter');
  await page.waitForFunction((k) => !document.getElementById('page-explore').hidden
    && window.morphogenExplore?.state?.params?.k === k, want, { timeout: 60000 });
  seen.atlasOpened = { want, k: await page.evaluate(() => window.morphogenExplore.state.params.k) };
  // Mesh: Tab to the flower, arrows turn it
  await ready(page, base, 'mesh');
  await page.focus('#me-go');
  seen.meshTabs = await tabTo(page, () => document.activeElement?.id === 'me-canvas');
  const turn = await page.evaluate(() => window.morphogenMesh.rot.a);
  await page.keyboard.press('ArrowRight');
  seen.meshTurned = (await page.evaluate(() => window.morphogenMesh.rot.a)) - turn;
  // Runs: a row takes the focus and Enter opens it (the archive holds the atlas? no: any run)
  await ready(page, base, 'runs');
  await page.locator('tr[data-run]').first().waitFor(); // the list arrives after the page
  const rows = await page.locator('tr[data-run]').count();
  seen.runRows = rows;
  if (rows) {
    await page.focus('#runs-root button');
    seen.runTabs = await tabTo(page, () => document.activeElement?.matches('tr[data-run]'));
    await page.keyboard.press('Enter');
    await page.waitForFunction(() => document.querySelector('tr[data-run].sel')
      && document.getElementById('runs-detail').textContent.length > 0, null, { timeout: 30000 });
    seen.runOpened = await page.evaluate(() => document.querySelector('tr[data-run].sel').dataset.run
      === document.activeElement.dataset.run);
  }
  await page.screenshot({ path: join(out, 'keyboard.png') });
  return seen;
}

// A phone (390 x 844, touch): the picture in the first screen and still there after the
// controls scrolled; 44 px targets; no key hints; the Runs table and atlas inside the screen
export async function phone(page, base, out) {
  const ctx = await page.context().browser().newContext({
    viewport: { width: 390, height: 844 }, hasTouch: true, isMobile: true, deviceScaleFactor: 1,
  });
  const p = await ctx.newPage();
  const errors = [];
  p.on('pageerror', (e) => errors.push(e.message));
  await ready(p, base, 'explore');
  const box = async (sel) => p.locator(sel).boundingBox();
  const canvasTop = await box('#ex-canvas');
  await p.screenshot({ path: join(out, 'phone-explore-top.png') });
  // scroll the controls until the Boundary menu (Start again) sits at the bottom of the screen
  await p.evaluate(() => document.getElementById('ex-boundary').scrollIntoView({ block: 'end' }));
  const canvasScrolled = await box('#ex-canvas');
  const slider = await box('#ex-boundary');
  const scrollY = await p.evaluate(() => window.scrollY);
  await p.screenshot({ path: join(out, 'phone-explore-scrolled.png') });
  const small = await p.evaluate(() => [...document.querySelectorAll(
    '#page-explore button, #page-explore select, #page-explore input, #page-explore .button, nav a')]
    .filter((e) => e.offsetParent && getComputedStyle(e).visibility !== 'hidden')
    .filter((e) => !e.classList.contains('file-input')) // out of sight: its label is the target
    .map((e) => [e.id || e.getAttribute('aria-label') || e.textContent.trim(), e.getBoundingClientRect()])
    .filter(([, r]) => r.height < 44 || r.width < 44)
    .map(([n, r]) => `${n} ${Math.round(r.width)}x${Math.round(r.height)}`));
  const keysShown = await p.isVisible('#ex-keys');
  // Shift+Tab back through the controls from the last: none comes to rest under the picture
  const under = [];
  await p.evaluate(() => {
    const all = [...document.querySelectorAll('#page-explore .controls :is(button, select, input, textarea, a[href], summary)')]
      .filter((e) => e.offsetParent && !e.disabled);
    all.at(-1).focus();
  });
  for (let i = 0; i < 60; i += 1) {
    await p.keyboard.press('Shift+Tab');
    const seen = await p.evaluate(() => {
      const a = document.activeElement;
      if (!a?.closest('#page-explore .controls')) return null;
      const stage = document.querySelector('#page-explore .stage').getBoundingClientRect();
      const r = a.getBoundingClientRect();
      return { name: a.id || a.getAttribute('aria-label') || a.textContent.trim(), hidden: r.top < stage.bottom - 1 };
    });
    if (seen === null) break;
    if (seen.hidden) under.push(seen.name);
  }
  // the atlas: mosaic and labels inside the screen
  await ready(p, base, 'atlas');
  await smallAtlas(p);
  await p.locator('#at-result').scrollIntoViewIfNeeded();
  const atlas = await p.evaluate(() => {
    const inside = (e) => { const r = e.getBoundingClientRect(); return r.left >= 0 && r.right <= window.innerWidth + 0.5; };
    return { image: inside(document.getElementById('at-image')),
      labels: [...document.querySelectorAll('#at-ylabels span, #at-xlabels span')].every(inside),
      width: document.documentElement.scrollWidth };
  });
  await p.screenshot({ path: join(out, 'phone-atlas-mosaic.png') });
  // the runs table scrolls in its own box, the run column stays visible
  await ready(p, base, 'runs');
  await p.locator('#runs-list tbody td').first().waitFor(); // the list arrives after the page
  const runs = await p.evaluate(() => {
    const list = document.getElementById('runs-list');
    const cell = list.querySelector('tbody td');
    if (cell) list.scrollLeft = list.scrollWidth;
    const r = cell?.getBoundingClientRect();
    return { page: document.documentElement.scrollWidth, overflow: getComputedStyle(list).overflowX,
      firstCellInside: r ? r.left >= 0 && r.right <= window.innerWidth : null };
  });
  await p.screenshot({ path: join(out, 'phone-runs-table.png') });
  await ctx.close();
  return { canvasTop, canvasScrolled, slider, scrollY, small, keysShown, under, atlas, runs, errors };
}
