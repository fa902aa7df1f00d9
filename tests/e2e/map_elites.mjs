// Steps of browser.mjs's MAP-Elites scenarios: a run's elite map on the Runs page, and a run
// started on the Evolve page.

import { join } from 'node:path';
import { startEvolve } from './tools.mjs';

// a MAP-Elites run (made by the test with the CLI) on the Runs page: map, plot, elites
export async function mapElitesOnRuns(page, base, out) {
  const runs = await (await page.request.get(new URL('api/runs', base).href)).json();
  const run = runs.runs.find((r) => r.strategy === 'map-elites').id;
  await page.goto(`${base}#runs`);
  await page.click(`tr[data-run="${run}"]`);
  await page.waitForSelector('#runs-elites img');
  await page.waitForTimeout(800);
  await page.screenshot({ path: join(out, 'runs-map-elites.png'), fullPage: true });
  const shown = await page.evaluate(() => ({
    heading: document.querySelector('#runs-elites h4').textContent,
    images: [...document.querySelectorAll('#runs-elites img')].filter((i) => i.complete && i.naturalWidth > 0).length,
    tiles: document.querySelectorAll('#runs-elites .tile').length,
  }));
  const detail = await (await page.request.get(new URL(`api/runs/${run}`, base).href)).json();
  await page.click('#runs-elites .tile >> nth=0');
  await page.waitForFunction((f) => !document.getElementById('page-explore').hidden
    && window.morphogenExplore?.state?.params?.F === f && window.morphogenExplore.frames >= 2,
  detail.map_elites.elites[0].params.F, { timeout: 60000 });
  const params = await page.evaluate(() => window.morphogenExplore.state.params);
  return { ...shown, elites: detail.map_elites.elites.length, first: detail.map_elites.elites[0].params, params };
}

// a MAP-Elites run started on the Evolve page shows its elite map and elites when done
export async function mapElitesOnEvolve(page, base, out) {
  await startEvolve(page, base, { selects: { fitness: 'dirichlet', strategy: 'map-elites' },
                                 fields: { population: 4, generations: 2, size: 16, steps: 60 } });
  await page.waitForSelector('#ev-elites:not([hidden]) .tile', { timeout: 120000 });
  await page.waitForTimeout(500);
  await page.screenshot({ path: join(out, 'evolve-map-elites.png'), fullPage: true });
  const tiles = await page.locator('#ev-elites .tile').count();
  const run = await page.evaluate(() => window.morphogenEvolve.status.run);
  const detail = await (await page.request.get(new URL(`api/runs/${run}`, base).href)).json();
  await page.click('#ev-elites .tile >> nth=0');
  await page.waitForFunction((f) => !document.getElementById('page-explore').hidden
    && window.morphogenExplore?.state?.params?.F === f && window.morphogenExplore.frames >= 2,
  detail.map_elites.elites[0].params.F, { timeout: 60000 });
  const params = await page.evaluate(() => window.morphogenExplore.state.params);
  return { tiles, elites: detail.map_elites.elites.length, first: detail.map_elites.elites[0].params, params };
}
