// Steps of browser.mjs's scenarios for the Atlas's pattern families, Explore's parameter maps
// and the Mesh page's case studies.

import { join } from 'node:path';

const x = (page, f, arg) => page.evaluate(f, arg);

// Atlas with "families" ticked: the legend, the family in the hover text, families.csv
export async function atlasFamilies(page, out) {
  const res = await x(page, () => window.morphogenAtlas.result);
  await page.screenshot({ path: join(out, 'atlas-families.png') });
  const legend = await x(page, () => [...document.querySelectorAll('#at-legend [data-family]')]
    .map((e) => [e.dataset.family, e.textContent, getComputedStyle(e.firstChild).backgroundColor]));
  // hover the tile in the top row, second column
  const box = await page.locator('#at-image').boundingBox();
  const cell = (res.tile + res.pad) / (res.x.n * (res.tile + res.pad) + res.pad);
  await page.mouse.move(box.x + box.width * (1.5 * cell), box.y + box.height * (0.5 * cell));
  const hover = await page.textContent('#at-hover');
  const csv = await x(page, async () => {
    const link = document.getElementById('at-csv');
    return { shown: !link.hidden, text: await (await fetch(link.href)).text() };
  });
  return { families: res.families, legend, hover, csv };
}

// Explore: F from a left-to-right grey ramp (0.02 at black, 0.06 at white), its slider behind a
// "map" badge and the run-file link hidden; the badge clears it again
export async function parameterMap(page, out) {
  await page.selectOption('#ex-map-param', 'F');
  await page.fill('#ex-map-lo', '0.02');
  await page.fill('#ex-map-hi', '0.06');
  await page.setInputFiles('#ex-map-image', join(out, 'ramp.png'));
  await page.waitForSelector('.map-badge[data-map="F"]:not([hidden])', { timeout: 30000 });
  const shown = () => x(page, () => {
    const range = document.querySelector('input[data-param="F"]');
    const badge = document.querySelector('.map-badge[data-map="F"]');
    return { badge: badge && !badge.hidden ? badge.textContent : null, title: badge?.title ?? '',
      rangeDisabled: range.disabled, numHidden: range.nextElementSibling.hidden,
      runHidden: document.getElementById('ex-save-run').hidden,
      note: !document.getElementById('ex-map-norun').hidden, maps: window.morphogenExplore.state.maps };
  });
  const mapped = await shown();
  if (!await x(page, () => window.morphogenExplore.running)) await page.click('#ex-run');
  const f0 = await x(page, () => window.morphogenExplore.frames);
  await page.waitForFunction((s) => window.morphogenExplore.frames >= s + 40, f0, { timeout: 60000 });
  await x(page, () => document.getElementById('ex-params').closest('fieldset').scrollIntoView()); // the badge in view
  await page.screenshot({ path: join(out, 'explore-map.png') });
  await page.click('.map-badge[data-map="F"]');
  await page.waitForFunction(() => Object.keys(window.morphogenExplore.state.maps).length === 0);
  return { mapped, cleared: await shown() };
}

// Mesh: run a case study from the menu, then start another and cancel it
export async function caseStudy(page, out, name = 'tiny', cancel = 'endless') {
  await page.waitForFunction(() => document.querySelectorAll('#me-case option').length > 0);
  const menu = await x(page, () => [...document.querySelectorAll('#me-case option')].map((o) => [o.value, o.textContent]));
  await page.selectOption('#me-case', name);
  await page.click('#me-case-go');
  const progress = [];
  const message = () => x(page, () => window.morphogenMesh.ui.message.textContent);
  const watch = setInterval(() => message().then((t) => progress.push(t)).catch(() => {}), 200);
  await page.waitForFunction((n) => window.morphogenCases.result?.name === n
    || !document.querySelector('#mesh-root .error').hidden, name, { timeout: 600000 });
  clearInterval(watch);
  const error = await page.textContent('#mesh-root .error');
  if (error) throw new Error(`the case study showed an error: ${error}`);
  await page.waitForTimeout(300);
  await page.screenshot({ path: join(out, 'mesh-case.png') });
  const shown = await x(page, () => {
    const m = window.morphogenMesh;
    const res = window.morphogenCases.result;
    return { faces: m.mesh.f.length / 3, nFaces: res.n_faces, stage: res.stage, drawn: m.drawn,
      still: !document.getElementById('me-still').hidden, message: m.ui.message.textContent };
  });
  const plyHeader = await x(page, async () => {
    const text = new TextDecoder('latin1').decode(await (await fetch(document.getElementById('me-ply').href)).arrayBuffer());
    return text.slice(0, text.indexOf('end_header'));
  });
  if (!cancel) return { menu, shown, plyHeader, progress };
  await page.selectOption('#me-case', cancel);
  await page.click('#me-case-go');
  await page.waitForFunction(() => /stage \d+ of \d+/.test(window.morphogenMesh.ui.message.textContent)
    && !document.getElementById('me-case-cancel').hidden, null, { timeout: 120000 });
  const running = await message();
  await page.click('#me-case-cancel');
  await page.waitForFunction(() => /cancelled/.test(window.morphogenMesh.ui.message.textContent), null, { timeout: 60000 });
  return { menu, shown, plyHeader, progress, running, cancelled: await message(),
    errorShown: await page.isVisible('#mesh-root .error'),
    keptFaces: await x(page, () => (window.morphogenMesh.mesh ? window.morphogenMesh.mesh.f.length / 3 : 0)),
    cancelHidden: await x(page, () => document.getElementById('me-case-cancel').hidden) };
}
