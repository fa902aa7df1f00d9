// Open a page written by `morphogen export-web` in headless Chromium (WebGL2 through ANGLE's
// SwiftShader, software rendering: no GPU here), step it N times from its initial state and
// write what it holds, for tests/e2e/test_browser.py to compare with `morphogen simulate`.
// usage: node webpage.mjs PAGE.html STEPS OUT.json [SCREENSHOT.png]

import { writeFileSync } from 'node:fs';
import { pathToFileURL } from 'node:url';
import { chromium } from 'playwright-core';

const [file, steps, out, shot] = process.argv.slice(2);
const ARGS = ['--headless', '--no-sandbox', '--disable-background-networking',
  '--disable-component-update', '--disable-sync', '--no-first-run', '--disable-quic',
  '--disable-extensions', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'];
const browser = await chromium.launch({ executablePath: process.env.MORPHOGEN_CHROMIUM || '/usr/bin/chromium', args: ARGS });
const problems = [];
try {
  // a phone: 390 x 844, touch
  const ctx = await browser.newContext({ viewport: { width: 390, height: 844 }, hasTouch: true, isMobile: true, deviceScaleFactor: 1 });
  const page = await ctx.newPage();
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  page.on('request', (r) => { if (!r.url().startsWith('file:') && !r.url().startsWith('data:')) problems.push(`outside request: ${r.url()}`); });
  await page.goto(pathToFileURL(file).href);
  await page.waitForFunction(() => window.morphogenPage?.ready || window.morphogenPage?.error, null, { timeout: 120000 });
  const error = await page.evaluate(() => window.morphogenPage.error || null);
  if (error) throw new Error(error);
  const firstFrameMs = await page.evaluate(() => window.morphogenPage.firstFrameAt);
  await page.waitForFunction(() => window.morphogenPage.steps > 0);
  if (shot) await page.screenshot({ path: shot });
  const result = await page.evaluate((n) => {
    const p = window.morphogenPage;
    p.running = false;
    p.reset();
    p.advance(n);
    const state = p.state();
    // steps per second: 2000 steps, finished by a read back
    const t0 = performance.now();
    p.advance(2000);
    p.read();
    const rate = 2000 / ((performance.now() - t0) / 1000);
    return { state, renderer: p.renderer, stepsPerS: rate, steps: n };
  }, Number(steps));
  // a finger on the picture paints the model's excited state
  const box = await page.locator('#view').boundingBox();
  await page.evaluate(() => { window.morphogenPage.reset(); });
  const before = await page.evaluate(() => window.morphogenPage.state()[0].reduce((a, b) => a + b, 0));
  await page.touchscreen.tap(box.x + box.width / 2, box.y + box.height / 2);
  const after = await page.evaluate(() => window.morphogenPage.state()[0].reduce((a, b) => a + b, 0));
  writeFileSync(out, JSON.stringify({ ...result, firstFrameMs, painted: after !== before, problems }));
} catch (err) {
  console.error(err.message);
  process.exitCode = 1;
} finally {
  await browser.close();
}
