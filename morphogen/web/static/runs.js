// Runs: browse the archive shared with `morphogen evolve` and `morphogen runs` — runs,
// generations with their contact sheets, best individuals; open any individual in Explore;
// resume a stopped or interrupted run, delete a run (after a confirmation).

import { api, el, fmt, showError } from './api.js';

export class Runs {
  constructor(root, app) {
    this.root = root.querySelector('#runs-root');
    this.app = app;
    this.view = 0;
    window.morphogenRuns = this;
  }

  async init() {
    this.error = el('div', { class: 'error', hidden: '' });
    this.list = el('div', { id: 'runs-list' });
    this.detail = el('div', { id: 'runs-detail' });
    this.root.append(
      el('div', { class: 'toolbar' }, el('button', { type: 'button', text: 'Refresh', onclick: () => this.refresh() }),
        el('span', { id: 'runs-archive', class: 'muted small' })),
      this.error, this.list, this.detail,
    );
  }

  // coming back to the page refreshes the list and the run on show, which may have moved on
  show() {
    this.refresh();
    if (this.run) this.open(this.run.id);
  }

  async refresh() {
    try {
      const data = await api('/api/runs');
      this.root.querySelector('#runs-archive').textContent = `archive: ${data.archive}`;
      if (!data.runs.length) {
        this.list.replaceChildren(el('p', { class: 'muted', text: 'No runs yet: start one on the Evolve page or with `morphogen evolve`.' }));
        return;
      }
      const head = el('tr', {}, ...['run', 'model', 'strategy', 'fitness', 'population', 'generations', 'best', 'status']
        .map((h) => el('th', { text: h })));
      const rows = data.runs.map((r) => {
        const tr = el('tr', { 'data-run': r.id },
          el('td', { class: 'mono', text: r.id }), el('td', { text: r.model }), el('td', { text: r.strategy }),
          el('td', { text: r.fitness }), el('td', { text: r.population }),
          el('td', { text: `${r.done}/${r.generations}` }), el('td', { text: r.best == null ? '–' : fmt(r.best) }),
          el('td', { text: r.status }));
        tr.addEventListener('click', () => this.open(r.id));
        tr.tabIndex = 0; // keyboard: Tab to a run, Enter or Space opens it
        tr.addEventListener('keydown', (ev) => {
          if (ev.key === 'Enter' || ev.key === ' ') { ev.preventDefault(); this.open(r.id); }
        });
        return tr;
      });
      this.list.replaceChildren(el('table', { class: 'runs' }, el('thead', {}, head), el('tbody', {}, ...rows)));
      showError(this.error, '');
    } catch (err) { showError(this.error, err.message); }
  }

  // Each open or delete takes a new view number; an open whose answers arrive after a newer
  // view began (a second click, a deletion) leaves the detail alone instead of overwriting it.
  async open(id) {
    for (const tr of this.list.querySelectorAll('tr[data-run]')) tr.classList.toggle('sel', tr.dataset.run === id);
    const view = ++this.view;
    try {
      const run = await api(`/api/runs/${id}`);
      if (view !== this.view) return;
      this.run = run;
      if (run.kind === 'networks') {
        this.detail.replaceChildren(...this.network(run));
        return;
      }
      const genes = run.genes.map((g) => `${g.name} ∈ [${fmt(g.low)}, ${fmt(g.high)}]`).join(', ');
      const p = run.problem;
      const picker = el('select', { id: 'runs-gen', 'aria-label': 'generation' },
        ...run.history.map((g) => el('option', { value: g.gen, text: `generation ${g.gen} (best ${fmt(g.best ?? NaN)})` })));
      this.sheet = el('div', { id: 'runs-sheet' });
      const live = await api(`/api/evolve/${id}`).catch(() => null);
      if (view !== this.view) return;
      const waiting = live && ['running', 'choose'].includes(live.state);
      const resume = waiting ? el('button', {
        type: 'button', id: 'runs-continue', class: 'primary',
        text: live.state === 'choose' ? 'Continue choosing on the Evolve page' : 'Follow on the Evolve page',
        onclick: () => this.app.continueEvolve(id),
      }) : null;
      const resumable = !waiting && run.history.length < run.generations;
      const actions = el('div', { class: 'toolbar' },
        resumable ? el('button', { type: 'button', id: 'runs-resume', class: 'primary',
          text: `Resume at generation ${run.history.length + 1} of ${run.generations}`,
          onclick: () => this.resume(id) }) : null,
        waiting ? null : el('button', { type: 'button', id: 'runs-delete', text: 'Delete run…',
          onclick: () => this.remove(id) }));
      picker.addEventListener('change', () => this.generation(Number(picker.value)));
      this.detail.replaceChildren(...[
        el('h3', { text: `${run.model} · ${run.strategy} · ${run.fitness}` }),
        resume,
        actions,
        el('p', { class: 'muted small', text: `genes: ${genes}; grid ${p.size.join('×')}, ${p.steps} steps of dt = ${fmt(p.dt)}, initial ${p.init}` }),
        run.fitness_plot ? el('img', { src: run.fitness_plot, alt: 'fitness over generations', class: 'sheet' }) : null,
        el('h4', { text: 'Best individuals' }),
        this.tiles(run.best, run.explore),
        this.mapElites(run.map_elites, run.explore),
        el('h4', { text: 'Generations' }),
        run.history.length ? picker : el('p', { class: 'muted', text: 'no generation recorded yet' }),
        this.sheet,
      ].filter((node) => node != null)); // replaceChildren would write "null" for a missing part
      if (run.history.length) {
        picker.value = run.history[run.history.length - 1].gen;
        await this.generation(Number(picker.value));
      }
    } catch (err) { if (view === this.view) showError(this.error, err.message); }
  }

  // a reaction-network run (`morphogen networks` or the Evolve page's network mode): its
  // evaluation, fitness per generation and fittest networks, each opening in Explore
  network(run) {
    const ev = run.evaluation;
    const rows = run.history.map((g) => el('tr', {},
      ...[g.gen, fmt(g.best ?? NaN), fmt(g.mean ?? NaN), g.valid, fmt(g.seconds)].map((v) => el('td', { text: v }))));
    const best = run.best.map((b) => {
      const config = b.run_file.config;
      const tile = el('button', { type: 'button', class: 'network-best', title: 'open in Explore' },
        el('strong', { text: `fitness ${fmt(b.fitness)} · generation ${b.gen} #${b.idx}` }),
        el('pre', { class: 'small', text: b.reactions.join('\n') }));
      tile.addEventListener('click', () => this.app.openInExplore({
        model: { equations: config.model_source }, init: 'noise', seed: 0, size: Math.max(64, config.size[0]),
      }));
      return tile;
    });
    return [
      el('h3', { text: `${run.model} · ${run.strategy} · ${run.fitness}` }),
      el('p', { class: 'muted small', text: `species ${run.species.join(', ')}; evaluation grid ${ev.size}×${ev.size}, dt = ${fmt(ev.dt)}, scored from t = ${fmt(ev.t_start)} every ${fmt(ev.interval)} (${ev.rounds} rounds); ${run.history.length}/${run.generations} generations` }),
      el('p', { class: 'muted small', id: 'runs-network-resume', text: run.history.length < run.generations ? run.resume.replace(/^.*; /, 'To continue: ') : '' }),
      el('h4', { text: 'Fittest networks' }),
      best.length ? el('div', { class: 'network-list' }, ...best) : el('p', { class: 'muted',
        text: run.history.length ? 'no valid network yet: every one left the bounds or blew up' : 'no generation recorded yet' }),
      el('h4', { text: 'Generations' }),
      el('table', { class: 'runs' }, el('thead', {}, el('tr', {}, ...['gen', 'best', 'mean', 'valid', 'seconds'].map((h) => el('th', { text: h })))),
        el('tbody', {}, ...rows)),
    ];
  }

  async resume(id) {
    try {
      await api(`/api/runs/${id}/resume`, { method: 'POST' });
      await this.app.continueEvolve(id);
    } catch (err) { showError(this.error, err.message); }
  }

  async remove(id) {
    if (!window.confirm(`Delete run ${id}: its archive entry and its folder of pictures? This cannot be undone.`)) return;
    this.view += 1;
    try {
      await api(`/api/runs/${id}`, { method: 'DELETE' });
      this.run = null;
      this.detail.replaceChildren(el('p', { class: 'muted', id: 'runs-deleted', text: `Deleted run ${id}.` }));
      await this.refresh();
    } catch (err) { showError(this.error, err.message); }
  }

  async generation(gen) {
    const g = await api(`/api/runs/${this.run.id}/generations/${gen}`);
    const sheet = this.run.history.find((h) => h.gen === gen).sheet;
    this.sheet.replaceChildren(
      el('img', { src: sheet, alt: `contact sheet of generation ${gen}`, class: 'sheet' }),
      el('p', { class: 'muted small', text: 'Click an individual to open it in Explore.' }),
      this.tiles(g.individuals, g.explore),
    );
  }

  mapElites(archive, explore) {
    if (!archive) return null;
    const axes = archive.grid ? archive.grid.descriptors.join(' × ') : '';
    const box = el('div', { id: 'runs-elites' },
      el('h4', { text: `MAP-Elites archive: ${archive.elites.length} of ${archive.cells} cells (${axes})` }),
      archive.map ? el('img', { src: archive.map, alt: 'elite map', class: 'sheet' }) : null,
      archive.qd_plot ? el('img', { src: archive.qd_plot, alt: 'coverage and QD-score', class: 'sheet' }) : null,
      el('p', { class: 'muted small', text: 'Click an elite to open it in Explore.' }),
      this.tiles(archive.elites, explore));
    return box;
  }

  tiles(individuals, explore) {
    const grid = el('div', { class: 'grid-pop' });
    grid.style.gridTemplateColumns = 'repeat(auto-fill, minmax(110px, 1fr))';
    grid.append(...individuals.map((ind) => {
      const tile = el('div', { class: 'tile', 'data-gen': ind.gen, 'data-idx': ind.idx },
        el('img', { src: ind.image, alt: `generation ${ind.gen} individual ${ind.idx}` }),
        el('span', { class: 'cap', text: `${ind.family ? `${ind.family} · ` : ''}g${ind.gen} #${ind.idx} f=${fmt(ind.fitness ?? NaN)}` }));
      tile.addEventListener('click', () => this.app.openInExplore({ ...explore, params: ind.params }));
      const link = el('a', { href: ind.config, download: '', class: 'small', text: 'run.json' });
      return el('div', {}, tile, link);
    }));
    return grid;
  }
}
