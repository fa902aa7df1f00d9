// Evolve: Skaggs's user-guided GA (choose favourites, next generation) or an automatic
// fitness with progress; or reaction networks (Yamamoto §4: rates of the Table-2 network, or the
// reactions themselves) scored by the cluster-head fitness, showing the fittest networks.
// Runs land in the same archive as `morphogen evolve` / `morphogen networks`.

import { api, el, fillSelect, fmt, showError } from './api.js';

// The run this tab is showing, so a reload (or the Runs page) can bring it back.
const RUN_KEY = 'morphogen.evolve.run';
// the favourites picked so far in the generation on show, `{ run, gen, picks }`: they survive a
// reload of the page and a restart of the server (which takes the waiting run up again)
const PICKS_KEY = 'morphogen.evolve.picks';

export class Evolve {
  constructor(root, app) {
    this.root = root;
    this.app = app;
    this.picked = new Set();
    this.status = null;
    window.morphogenEvolve = this;
  }

  async init() {
    const c = this.root.querySelector('#ev-controls');
    const s = this.root.querySelector('#ev-stage');
    this.ui = {
      kind: el('select', { id: 'ev-kind', 'aria-label': 'what to evolve' }),
      model: el('select', { id: 'ev-model', 'aria-label': 'evolve model' }),
      tStart: el('input', { id: 'ev-t-start', type: 'number', min: 0, step: 'any' }),
      interval: el('input', { id: 'ev-interval', type: 'number', min: 0, step: 'any' }),
      rounds: el('input', { id: 'ev-rounds', type: 'number', min: 1, max: 10 }),
      fitness: el('select', { id: 'ev-fitness' }),
      strategy: el('select', { id: 'ev-strategy' }),
      population: el('input', { id: 'ev-population', type: 'number', min: 2, max: 36 }),
      generations: el('input', { id: 'ev-generations', type: 'number', min: 1, max: 200 }),
      size: el('input', { id: 'ev-size', type: 'number', min: 16, max: 128 }),
      steps: el('input', { id: 'ev-steps', type: 'number', min: 1 }),
      dt: el('input', { id: 'ev-dt', type: 'number', step: 'any' }),
      seed: el('input', { id: 'ev-seed', type: 'number', min: 0, value: 0 }),
      genes: el('div', { id: 'ev-genes' }),
      start: el('button', { id: 'ev-start', type: 'button', class: 'primary', text: 'Start run' }),
      stop: el('button', { id: 'ev-stop', type: 'button', text: 'Stop', hidden: '' }),
      next: el('button', { id: 'ev-next', type: 'button', class: 'primary', text: 'Next generation', disabled: '' }),
      error: el('div', { id: 'ev-error', class: 'error', hidden: '' }),
      bar: el('progress', { id: 'ev-progress', max: 1, value: 0, hidden: '' }),
      message: el('p', { id: 'ev-message', class: 'muted' }),
      netNote: el('p', { id: 'ev-net-note', class: 'muted small', hidden: '' }),
      grid: el('div', { id: 'ev-grid', class: 'grid-pop' }),
      elites: el('div', { id: 'ev-elites', hidden: '' }),
      log: el('pre', { id: 'ev-log', class: 'mono muted' }),
    };
    const u = this.ui;
    fillSelect(u.kind, [['params', 'model parameters'], ['rates', 'reaction network: rates (Table 2)'],
      ['network', 'reaction network: reactions']], 'params');
    fillSelect(u.model, this.app.info.models.map((m) => m.name), 'gray-scott');
    fillSelect(u.fitness, [['user', 'choose favourites (Skaggs eq. 3.9)'], ['dirichlet', 'automatic: modified Dirichlet energy']], 'user');
    fillSelect(u.strategy, [['ga', 'genetic algorithm'], ['cmaes', 'CMA-ES'],
      ['map-elites', 'MAP-Elites'], ['cvt-map-elites', 'MAP-Elites (CVT)']], 'ga');
    const row = (label, input) => el('label', {}, label, input);
    const stacked = (label, input) => el('label', { class: 'stack' }, label, input);
    // shown for parameter searches only / for network runs only
    this.paramOnly = [stacked('Fitness', u.fitness), stacked('Strategy', u.strategy), row('Steps', u.steps),
      el('fieldset', {}, el('legend', { text: 'Genes (searched parameters)' }), u.genes)];
    this.networkOnly = [row('First score at t', u.tStart), row('then every', u.interval), row('Rounds', u.rounds),
      el('p', { class: 'muted small', text: 'Cluster-head fitness (Yamamoto §3.3): isolated peaks of A score most.' })];
    c.append(
      el('fieldset', {}, el('legend', { text: 'Evolve' }), u.kind, u.model),
      el('fieldset', {}, el('legend', { text: 'Search' }), this.paramOnly[0], this.paramOnly[1],
        row('Population', u.population), row('Generations', u.generations), row('Seed', u.seed)),
      el('fieldset', {}, el('legend', { text: 'Simulation' }), row('Grid', u.size), this.paramOnly[2], row('dt', u.dt),
        ...this.networkOnly),
      this.paramOnly[3],
      u.start, u.stop,
    );
    this.toolbar = el('div', { class: 'toolbar' }, u.next, el('span', { class: 'muted small', text: 'Click tiles to choose favourites.' }));
    s.append(
      this.toolbar,
      u.error, u.bar, u.message, u.netNote, u.grid, u.elites, u.log,
    );
    u.model.addEventListener('change', () => this.setup());
    u.kind.addEventListener('change', () => this.setup());
    u.start.addEventListener('click', () => this.start());
    u.stop.addEventListener('click', () => this.stop());
    u.next.addEventListener('click', () => this.next());
    await this.setup();
    await this.attach(sessionStorage.getItem(RUN_KEY));
  }

  // Show a run this server knows (after a reload, or from Runs): its settings in the controls,
  // then its tiles; a stopped or finished run stays shown with what it evaluated.
  async attach(run) {
    if (!run || this.status?.run === run) return;
    try {
      const st = await api(`/api/evolve/${run}`);
      await this.restore(st.settings);
      this.status = st;
      this.shownGen = 0;
      this.shownNetworks = null;
      this.elitesShown = null;
      this.ui.grid.replaceChildren();
      this.ui.elites.hidden = true;
      this.ui.netNote.hidden = true;
      sessionStorage.setItem(RUN_KEY, run);
      await this.poll();
    } catch (err) {
      if (sessionStorage.getItem(RUN_KEY) === run) sessionStorage.removeItem(RUN_KEY);
    }
  }

  // the controls as the run was started: what to evolve, model, search and simulation, genes
  async restore(s) {
    if (!s) return;
    const u = this.ui;
    u.kind.value = s.kind;
    const library = s.model?.library;
    if (library && [...u.model.options].some((o) => o.value === library)) u.model.value = library;
    await this.setup();
    for (const key of ['population', 'generations', 'size', 'dt', 'seed']) u[key].value = s[key];
    if (s.kind !== 'params') {
      u.tStart.value = s.t_start;
      u.interval.value = s.interval;
      u.rounds.value = s.rounds;
      return;
    }
    u.fitness.value = s.fitness;
    u.strategy.value = s.strategy;
    u.steps.value = s.steps;
    this.init_kind = s.init;
    const genes = new Map(s.genes.map((g) => [g.name, g]));
    for (const box of u.genes.querySelectorAll('input[data-gene]')) {
      const g = genes.get(box.dataset.gene);
      box.checked = Boolean(g);
      if (!g) continue;
      u.genes.querySelector(`input[data-low="${g.name}"]`).value = fmt(g.low);
      u.genes.querySelector(`input[data-high="${g.name}"]`).value = fmt(g.high);
    }
    this.sigma = new Map(s.genes.map((g) => [g.name, g.sigma]));
  }

  get networkMode() { return this.ui.kind.value !== 'params'; }

  async setup() {
    const u = this.ui;
    const net = this.networkMode;
    u.model.hidden = net;
    for (const node of this.paramOnly) node.hidden = net;
    for (const node of this.networkOnly) node.hidden = !net;
    this.toolbar.hidden = net;
    if (net) return this.setupNetwork();
    try {
      const d = await api(`/api/evolve/setup/${this.ui.model.value}`);
      u.population.value = d.population;
      u.generations.value = d.generations;
      u.size.value = d.size;
      u.steps.value = d.steps;
      u.dt.value = d.dt;
      this.init_kind = d.init;
      const chosen = new Map(d.genes.map((g) => [g.name, g]));
      u.genes.replaceChildren(...d.params.map((p) => {
        const g = chosen.get(p.name);
        const lo = g ? g.low : (p.value > 0 ? 0.5 * p.value : p.value < 0 ? 1.5 * p.value : -1);
        const hi = g ? g.high : (p.value > 0 ? 1.5 * p.value : p.value < 0 ? 0.5 * p.value : 1);
        const on = el('input', { type: 'checkbox', 'data-gene': p.name, 'aria-label': `gene ${p.name}` });
        on.checked = Boolean(g);
        return el('div', { class: 'param' },
          el('label', { class: 'pname', title: p.name }, on, p.name),
          el('input', { type: 'number', step: 'any', value: fmt(lo), class: 'pnum', 'data-low': p.name, 'aria-label': `${p.name} lowest` }),
          el('input', { type: 'number', step: 'any', value: fmt(hi), class: 'pnum', 'data-high': p.name, 'aria-label': `${p.name} highest` }));
      }));
      this.sigma = new Map(d.genes.map((g) => [g.name, g.sigma]));
      showError(u.error, '');
    } catch (err) { showError(this.ui.error, err.message); }
  }

  async setupNetwork() {
    try {
      const d = await api('/api/evolve/networks/defaults');
      const u = this.ui;
      u.population.value = d.population;
      u.generations.value = d.generations;
      u.size.value = d.size;
      u.dt.value = d.dt;
      u.tStart.value = d.t_start;
      u.interval.value = d.interval;
      u.rounds.value = d.rounds;
      showError(u.error, '');
    } catch (err) { showError(this.ui.error, err.message); }
  }

  genes() {
    const out = [];
    for (const box of this.ui.genes.querySelectorAll('input[data-gene]')) {
      if (!box.checked) continue;
      const name = box.dataset.gene;
      const low = Number(this.ui.genes.querySelector(`input[data-low="${name}"]`).value);
      const high = Number(this.ui.genes.querySelector(`input[data-high="${name}"]`).value);
      const gene = { name, low, high };
      if (this.sigma.has(name)) gene.sigma = this.sigma.get(name);
      out.push(gene);
    }
    return out;
  }

  async start() {
    const u = this.ui;
    showError(u.error, '');
    const common = {
      population: Number(u.population.value), generations: Number(u.generations.value),
      size: Number(u.size.value), dt: Number(u.dt.value), seed: Number(u.seed.value),
    };
    const body = this.networkMode
      ? { ...common, mode: u.kind.value, t_start: Number(u.tStart.value),
        interval: Number(u.interval.value), rounds: Number(u.rounds.value) }
      : { ...common, model: { library: u.model.value }, fitness: u.fitness.value,
        strategy: u.strategy.value, steps: Number(u.steps.value), init: this.init_kind,
        genes: this.genes() };
    try {
      const url = this.networkMode ? '/api/evolve/networks' : '/api/evolve';
      this.status = await api(url, { method: 'POST', body });
      sessionStorage.setItem(RUN_KEY, this.status.run);
      u.grid.replaceChildren();
      u.elites.hidden = true;
      u.netNote.hidden = true;
      this.shownGen = 0;
      this.shownNetworks = null;
      this.poll();
    } catch (err) { showError(u.error, err.message); }
  }

  async poll() {
    clearTimeout(this.timer);
    const run = this.status?.run;
    if (!run) return;
    try {
      this.status = await api(`/api/evolve/${run}`);
    } catch (err) {
      // a server restarting: keep asking while the run was active (it is taken up again)
      showError(this.ui.error, err.message);
      if (['running', 'choose'].includes(this.status.state)) {
        this.pollFailed = true;
        this.timer = setTimeout(() => this.poll(), 2000);
      }
      return;
    }
    if (this.pollFailed) showError(this.ui.error, ''); // the server is back
    this.pollFailed = false;
    await this.render();
    if (['running', 'choose'].includes(this.status.state)) {
      this.timer = setTimeout(() => this.poll(), this.status.state === 'choose' ? 1000 : 300);
    }
  }

  async render() {
    const st = this.status;
    const u = this.ui;
    const active = ['running', 'choose'].includes(st.state);
    u.start.disabled = active;
    u.stop.hidden = !active;
    u.bar.hidden = st.state !== 'running';
    u.bar.value = (st.gen - 1 + st.progress) / st.total;
    u.message.textContent = `run ${st.run} · ${st.state} · generation ${Math.min(st.gen, st.total)} of ${st.total}`
      + (st.message ? ` · ${st.message}` : '');
    u.log.textContent = st.log.join('\n');
    if (st.error) showError(u.error, st.error);
    if (st.kind === 'networks') {
      this.showNetworks(st);
    } else if (st.state === 'choose') {
      if (this.shownGen !== st.gen) {
        this.shownGen = st.gen;
        this.restorePicks(st.run, st.gen);
        this.showTiles(st.images.map((src, i) => ({ src, caption: `#${i}`, idx: i, params: st.params?.[i] })), true);
      }
    } else if (st.images) {
      // stopped while favourites were chosen: that generation was evaluated, never chosen;
      // its pictures stay, to look at and open in Explore
      if (this.shownGen !== `asked-${st.gen}`) {
        this.shownGen = `asked-${st.gen}`;
        this.picked.clear();
        this.showTiles(st.images.map((src, i) => ({
          src, caption: `#${i} (not chosen)`, idx: i, params: st.params?.[i],
          open: { ...st.explore, params: { ...st.explore.params, ...st.params?.[i] } },
        })), false);
      }
    } else if (st.fitness !== 'user' || !active) {
      // the last generation recorded: while an automatic fitness runs, and once a run ends
      const last = st.state === 'done' ? st.total : st.gen - 1;
      if (last >= 1 && this.shownGen !== -last) {
        this.shownGen = -last;
        const g = await api(`/api/runs/${st.run}/generations/${last}`);
        this.showTiles(g.individuals.map((ind) => ({
          src: ind.image, caption: `#${ind.idx} f=${fmt(ind.fitness ?? NaN)}`, idx: ind.idx,
          open: { ...g.explore, params: ind.params }, params: ind.params,
        })), false);
      }
    }
    if (st.state === 'done' && st.kind !== 'networks' && this.elitesShown !== st.run) {
      this.elitesShown = st.run;
      await this.showElites(st.run);
    }
    u.next.disabled = !(st.state === 'choose' && this.picked.size > 0);
  }

  // a finished MAP-Elites run: its elite map, and every elite (family, fitness) opening in Explore
  async showElites(run) {
    const d = await api(`/api/runs/${run}`);
    const me = d.map_elites;
    const box = this.ui.elites;
    box.hidden = !me;
    if (!me) return;
    const tiles = el('div', { class: 'grid-pop' });
    tiles.style.gridTemplateColumns = 'repeat(auto-fill, minmax(110px, 1fr))';
    tiles.append(...me.elites.map((e) => {
      const tile = el('button', { type: 'button', class: 'tile', title: 'open in Explore' },
        el('img', { src: e.image, alt: `elite of cell ${e.cell}` }),
        el('span', { class: 'cap', text: `${e.family ?? ''} f=${fmt(e.fitness ?? NaN)}` }));
      tile.addEventListener('click', () => this.app.openInExplore({ ...d.explore, params: e.params }));
      return tile;
    }));
    box.replaceChildren(...[
      el('h4', { text: `MAP-Elites archive: ${me.elites.length} of ${me.cells} cells` }),
      me.map ? el('img', { src: me.map, alt: 'elite map', class: 'sheet' }) : null,
      tiles,
    ].filter((node) => node != null));
  }

  // the fittest valid networks of the last evaluated generation: activator pattern and reaction
  // graph; the invalid ones (left the bounds or blew up) are counted, never listed as fittest,
  // and a network whose activator ends uniform says so under its flat picture
  showNetworks(st) {
    const key = `${st.invalid}|${st.best.map((b) => `${b.pattern}|${b.network}`).join()}`;
    if (this.shownNetworks === key) return;
    this.shownNetworks = key;
    const note = this.ui.netNote;
    const none = st.best.length === 0 && st.invalid > 0;
    note.textContent = none
      ? `no valid network in this generation: all ${st.invalid} left the bounds or blew up`
      : st.invalid ? `${st.invalid} of ${st.population} networks were invalid (left the bounds or blew up) and are not listed` : '';
    note.hidden = !note.textContent;
    const grid = this.ui.grid;
    grid.style.gridTemplateColumns = 'repeat(auto-fill, minmax(250px, 1fr))';
    grid.replaceChildren(...st.best.map((b, rank) => {
      const flat = b.uniform ? ' · uniform field' : '';
      const tile = el('button', { type: 'button', class: 'tile', 'data-idx': b.idx,
        title: `${b.uniform ? 'the activator ends uniform: no pattern\n' : ''}${
          b.explore ? `${b.reactions.join('\n')}\n\nopen in Explore` : (b.note ?? '')}` },
      el('img', { src: b.pattern, alt: `pattern of network #${b.idx}${b.uniform ? ' (uniform field)' : ''}` }),
      b.network ? el('img', { src: b.network, alt: `reactions of network #${b.idx}` }) : null,
      el('span', { class: 'cap', text: `${rank + 1}. #${b.idx} f=${fmt(b.fitness)}${flat}` }));
      if (b.explore) tile.addEventListener('click', () => this.app.openInExplore(b.explore));
      return tile;
    }));
  }

  showTiles(items, choosing) {
    const grid = this.ui.grid;
    const cols = Math.ceil(Math.sqrt(items.length * 1.5));
    grid.style.gridTemplateColumns = `repeat(${cols}, minmax(60px, 160px))`;
    grid.replaceChildren(...items.map((it) => {
      // hovering a tile shows its parameter values
      const values = Object.entries(it.params ?? {}).map(([k, v]) => `${k} = ${fmt(v)}`).join('\n');
      const title = `${choosing ? 'choose' : 'open in Explore'}${values ? `\n${values}` : ''}`;
      const tile = el('button', { type: 'button', class: 'tile', 'data-idx': it.idx, title },
        el('img', { src: it.src, alt: it.caption }), el('span', { class: 'cap', text: it.caption }));
      if (choosing) tile.classList.toggle('picked', this.picked.has(it.idx));
      tile.addEventListener('click', () => {
        if (choosing) {
          if (this.picked.has(it.idx)) this.picked.delete(it.idx); else this.picked.add(it.idx);
          tile.classList.toggle('picked', this.picked.has(it.idx));
          this.ui.next.disabled = this.picked.size === 0;
          this.savePicks();
        } else if (it.open) {
          this.app.openInExplore(it.open);
        }
      });
      return tile;
    }));
  }

  // the picks of `gen` of `run` kept from before a reload or a server restart (else none)
  restorePicks(run, gen) {
    this.picked.clear();
    try {
      const kept = JSON.parse(sessionStorage.getItem(PICKS_KEY) ?? 'null');
      if (kept?.run === run && kept?.gen === gen) for (const i of kept.picks) this.picked.add(i);
    } catch { /* nothing kept */ }
  }

  savePicks() {
    sessionStorage.setItem(PICKS_KEY, JSON.stringify({
      run: this.status.run, gen: this.status.gen, picks: [...this.picked],
    }));
  }

  async next() {
    const u = this.ui;
    u.next.disabled = true;
    try {
      this.status = await api(`/api/evolve/${this.status.run}/select`, {
        method: 'POST', body: { indices: [...this.picked].sort((a, b) => a - b) },
      });
      this.poll();
    } catch (err) {
      showError(u.error, err.message);
      u.next.disabled = false;
      this.poll(); // e.g. a restarted server evaluating the generation again: its tiles return
    }
  }

  async stop() {
    try {
      this.status = await api(`/api/evolve/${this.status.run}/stop`, { method: 'POST' });
      this.poll();
    } catch (err) { showError(this.ui.error, err.message); }
  }
}
