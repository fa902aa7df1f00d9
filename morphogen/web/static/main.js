// Page router: #explore, #atlas, #evolve, #runs, #mesh. Each page is built the first time it
// is shown; pages talk to each other through `app` (e.g. app.openInExplore(settings)).

import { api } from './api.js';
import { Explore } from './explore.js';
import { Atlas } from './atlas.js';
import { Evolve } from './evolve.js';
import { Runs } from './runs.js';
import { Mesh } from './mesh.js';

const PAGES = { explore: Explore, atlas: Atlas, evolve: Evolve, runs: Runs, mesh: Mesh };

const app = {
  info: null, // /api/models: library models, colour maps, initial conditions
  pages: {},
  current: null,

  async show(name) {
    if (!PAGES[name]) name = 'explore';
    for (const key of Object.keys(PAGES)) {
      document.getElementById(`page-${key}`).hidden = key !== name;
    }
    for (const a of document.querySelectorAll('#nav a')) {
      a.classList.toggle('active', a.dataset.page === name);
    }
    if (this.current && this.current !== name && this.pages[this.current]?.hide) {
      this.pages[this.current].hide();
    }
    this.current = name;
    if (!this.pages[name]) {
      this.pages[name] = new PAGES[name](document.getElementById(`page-${name}`), this);
      await this.pages[name].init();
    }
    if (this.pages[name].show) this.pages[name].show();
  },

  // settings: {model: {library|equations}, params, init, seed, size}
  async openInExplore(settings) {
    window.location.hash = '#explore';
    await this.show('explore');
    await this.pages.explore.load(settings);
  },

  // a run the server is still running or waiting on, shown on the Evolve page
  async continueEvolve(run) {
    window.location.hash = '#evolve';
    await this.show('evolve');
    const page = this.pages.evolve;
    // a run the page shows as stopped and that was resumed since: read it afresh
    if (page.status?.run === run && !['running', 'choose'].includes(page.status.state)) page.status = null;
    await page.attach(run);
  },
};

window.morphogenApp = app;

// the app cannot start without the server's list of models: say so where the page would be,
// with a button that asks again (instead of a blank page)
function startFailed(err) {
  document.getElementById('status').textContent = `server error: ${err.message}`;
  const box = document.getElementById('start-error') ?? document.createElement('div');
  box.id = 'start-error';
  box.className = 'error';
  box.setAttribute('role', 'alert');
  const retry = document.createElement('button');
  retry.type = 'button';
  retry.textContent = 'Try again';
  retry.addEventListener('click', () => { box.remove(); start(); });
  box.replaceChildren(`The server could not list its models (${err.message}), so no page can be shown. `, retry);
  document.querySelector('main')?.prepend(box) ?? document.body.append(box);
}

async function start() {
  try {
    app.info = await api('/api/models');
  } catch (err) {
    startFailed(err);
    return;
  }
  // #page, or #explore?settings (see urlstate.js)
  const route = () => app.show(window.location.hash.replace('#', '').split('?')[0] || 'explore');
  window.addEventListener('hashchange', route);
  await route();
}

start();
