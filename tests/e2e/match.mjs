// Steps of browser.mjs's Match scenario: Explore runs another model; a picture chosen in the
// Match panel is matched against Gray-Scott with the smallest budget (progress shown while it
// runs); the first candidate opens in Explore with its model, parameters and grid spacing.

import { join } from 'node:path';

const x = (page, f, arg) => page.evaluate(f, arg);

export async function matchPanel(page, base, out) {
  await page.goto(`${base}#explore`);
  await page.waitForFunction(() => window.morphogenExplore?.frames >= 2, null, { timeout: 60000 });
  await page.selectOption('#ex-model', 'schnakenberg');
  await page.waitForFunction(() => window.morphogenExplore.state?.model === 'schnakenberg'
    && !window.morphogenExplore.loading, null, { timeout: 60000 });
  await page.waitForSelector('#ex-match-models input[value="gray-scott"]');
  await page.selectOption('#ex-cmap', 'magma'); // the designer's colour map, kept by Open
  await page.waitForFunction(() => window.morphogenExplore.state?.cmap === 'magma');
  const panel = await x(page, () => ({
    models: [...document.querySelectorAll('#ex-match-models input')].map((b) => [b.value, b.checked]),
    budget: document.getElementById('ex-match-budget').value,
    go: document.getElementById('ex-match-go').disabled,
  }));
  for (const [name] of panel.models) {
    if (name === 'gray-scott') await page.check(`#ex-match-models input[value="${name}"]`);
    else await page.uncheck(`#ex-match-models input[value="${name}"]`);
  }
  await page.fill('#ex-match-minutes', '0.1');
  await page.fill('#ex-match-top', '1');
  await page.setInputFiles('#ex-match-file', join(out, 'match-target.png'));
  await page.waitForSelector('#ex-match-go:not([disabled])');
  const shown = await x(page, () => document.getElementById('ex-match-picture').naturalWidth);
  await page.click('#ex-match-go');
  // the progress bar while the job runs, and what its line says
  await page.waitForSelector('#ex-match-progress:not([hidden])', { timeout: 30000 });
  const messages = new Set();
  const done = () => x(page, () => document.querySelectorAll('#ex-match-results .match-card').length > 0
    || !document.getElementById('ex-match-error').hidden);
  while (!(await done())) {
    messages.add(await page.textContent('#ex-match-message'));
    await page.waitForFunction((m) => document.getElementById('ex-match-message').textContent !== m
      || document.querySelector('#ex-match-results .match-card') || !document.getElementById('ex-match-error').hidden,
    [...messages].pop(), { timeout: 300000 });
  }
  const error = await page.textContent('#ex-match-error');
  if (error.trim()) throw new Error(`the match failed: ${error}`);
  await page.waitForFunction(() => [...document.querySelectorAll('#ex-match-results img')]
    .every((i) => i.complete && i.naturalWidth > 0), null, { timeout: 30000 });
  const result = await x(page, () => window.morphogenExplore.match.result);
  const cards = await x(page, () => [...document.querySelectorAll('#ex-match-results .match-card')]
    .map((c) => ({ text: c.innerText, image: c.querySelector('img').naturalWidth, button: c.querySelector('button').textContent })));
  const best = result.candidates[0];
  await page.click('#ex-match-results .match-open[data-rank="1"]');
  await page.waitForFunction((c) => {
    const s = window.morphogenExplore.state;
    return s?.model === c.model && Math.abs(s.params.F - c.params.F) < 1e-9 && !window.morphogenExplore.loading
      && window.morphogenExplore.frames >= 2;
  }, best, { timeout: 60000 });
  // the candidate growing in Explore beside the panel (docs/web.md's picture)
  const f0 = await x(page, () => window.morphogenExplore.frames);
  await page.waitForFunction((f) => window.morphogenExplore.frames >= f + 60, f0, { timeout: 120000 });
  await x(page, () => document.getElementById('ex-match').scrollIntoView());
  await page.screenshot({ path: join(out, 'match-panel.png') });
  const opened = await x(page, () => {
    const s = window.morphogenExplore.state;
    return { model: s.model, params: s.params, dx: s.dx, size: s.size, height: s.height, dt: s.dt, init: s.init,
      cmap: s.cmap };
  });
  return { panel, shown, messages: [...messages], result, cards, opened, best };
}
