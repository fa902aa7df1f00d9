// Steps of browser.mjs's scenarios for the Atlas's pattern families.

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
