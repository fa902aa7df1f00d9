// Open a page written by `morphogen export-web` for a model with hostile names (markup, script,
// the template's own placeholders) in headless Chromium and report whether any injected code ran
// and whether the page still works; for tests/e2e/test_export_page_injection.py.
// usage: node hostile_page.mjs PAGE.html OUT.json
// The injected handlers would set window.__pwned and the document title; the page's own script
// never touches either.

import { writeFileSync } from 'node:fs';
import { pathToFileURL } from 'node:url';
import { chromium } from 'playwright-core';

const [file, out] = process.argv.slice(2);
const ARGS = ['--headless', '--no-sandbox', '--disable-background-networking',
  '--disable-component-update', '--disable-sync', '--no-first-run', '--disable-quic',
  '--disable-extensions', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'];
const browser = await chromium.launch({ executablePath: process.env.MORPHOGEN_CHROMIUM || '/usr/bin/chromium', args: ARGS });
const problems = [];
const dialogs = [];
try {
  const ctx = await browser.newContext({ viewport: { width: 1280, height: 800 } });
  const page = await ctx.newPage();
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  page.on('dialog', async (d) => { dialogs.push(d.message()); await d.dismiss(); });
  page.on('request', (r) => { if (!r.url().startsWith('file:') && !r.url().startsWith('data:')) problems.push(`outside request: ${r.url()}`); });
  await page.goto(pathToFileURL(file).href);
  // the page is ready, reports its own error, or never starts (its script was cut off)
  let started = true;
  try {
    await page.waitForFunction(() => window.morphogenPage?.ready || window.morphogenPage?.error, null, { timeout: 60000 });
  } catch {
    started = false;
  }
  // give an injected onerror (a broken image) time to fire before looking
  await page.evaluate(() => new Promise((resolve) => { requestAnimationFrame(() => setTimeout(resolve, 0)); }));
  await page.waitForLoadState('load');
  const seen = await page.evaluate(() => {
    const p = window.morphogenPage;
    let stepped = null;
    if (p?.ready) {
      p.running = false;
      const before = p.steps;
      p.advance(5);
      const s = p.state();
      stepped = { steps: p.steps - before, finite: s.every((row) => row.every(Number.isFinite)) };
    }
    return {
      pwned: window.__pwned ?? null,
      title: document.title,
      heading: document.querySelector('h1')?.textContent ?? null,
      about: document.getElementById('about')?.textContent ?? null,
      images: document.images.length,
      scripts: document.scripts.length,
      sliders: [...document.querySelectorAll('#params input[type=range]')].map((e) => e.getAttribute('aria-label')),
      error: p?.error ?? null,
      ready: Boolean(p?.ready),
      stepped,
    };
  });
  writeFileSync(out, JSON.stringify({ ...seen, started, dialogs, problems }));
} catch (err) {
  console.error(err.message);
  process.exitCode = 1;
} finally {
  await browser.close();
}
