// Atlas: a map over two parameters, computed on the server as one batched run (a job with
// progress). Clicking a tile opens that parameter pair in Explore. With "families" ticked the
// server names each tile's pattern family (framed in its colour; legend, hover, families.csv).

import { api, el, fillSelect, fmt, showError, waitForJob } from './api.js';

const DEFAULT_AXES = {
  'gray-scott': { x: ['k', 0.045, 0.07], y: ['F', 0.01, 0.08] },
};

const MAX_CELL_STEPS = 3.0e9; // the server's budget of one batched job (morphogen.web.limits)

export class Atlas {
  constructor(root, app) {
    this.root = root;
    this.app = app;
    this.$ = (id) => root.querySelector(`#${id}`);
    window.morphogenAtlas = this;
  }

  async init() {
    const info = this.app.info;
    fillSelect(this.$('at-model'), info.models.map((m) => m.name), 'gray-scott');
    fillSelect(this.$('at-cmap'), info.colormaps, 'viridis');
    this.$('at-model').addEventListener('change', () => this.chooseModel());
    this.$('at-x').addEventListener('change', () => this.axisDefaults('x'));
    this.$('at-y').addEventListener('change', () => this.axisDefaults('y'));
    this.$('at-go').addEventListener('click', () => this.compute());
    this.$('at-cancel').addEventListener('click', () => this.cancel());
    for (const id of ['at-save', 'at-csv']) {
      this.$(id).addEventListener('click', (ev) => this.download(ev, this.$(id)));
    }
    const img = this.$('at-image');
    img.addEventListener('click', (ev) => this.open(ev));
    img.addEventListener('mousemove', (ev) => this.hover(ev));
    img.addEventListener('keydown', (ev) => this.tileKey(ev));
    for (const id of ['at-x-n', 'at-y-n', 'at-tile']) this.$(id).addEventListener('input', () => this.stepLimit());
    this.$('at-tile').addEventListener('change', () => this.stepLimit());
    await this.chooseModel();
    this.stepLimit();
  }

  // the most steps the server takes for these tiles (cells x steps x tiles <= its budget,
  // morphogen.web.limits.Limits.max_cell_steps), said beside the Steps box before the click
  stepLimit() {
    const tiles = Number(this.$('at-x-n').value) * Number(this.$('at-y-n').value);
    const tile = Number(this.$('at-tile').value);
    const most = Math.floor(MAX_CELL_STEPS / (tiles * tile * tile));
    const box = this.$('at-steps');
    if (Number.isFinite(most) && most > 0) {
      box.max = String(most);
      box.title = `at most ${most} steps for ${tiles} tiles of ${tile}²`;
      this.$('at-steps-limit').textContent = `at most ${most} steps for these tiles`;
    }
  }

  async chooseModel() {
    const name = this.$('at-model').value;
    try {
      this.model = await api(`/api/models/${name}`);
    } catch (err) { showError(this.$('at-error'), err.message); return; }
    const names = this.model.params.map((p) => p.name);
    const axes = DEFAULT_AXES[name] || { x: [names[0]], y: [names[1] || names[0]] };
    fillSelect(this.$('at-x'), names, axes.x[0]);
    fillSelect(this.$('at-y'), names, axes.y[0]);
    this.axisDefaults('x', axes.x);
    this.axisDefaults('y', axes.y);
    this.$('at-steps').value = '';
    this.$('at-steps').placeholder = 'model default';
  }

  axisDefaults(which, preset) {
    const name = this.$(`at-${which}`).value;
    const p = this.model.params.find((q) => q.name === name);
    const lo = preset && preset[0] === name && preset.length > 1 ? preset[1] : p.min;
    const hi = preset && preset[0] === name && preset.length > 2 ? preset[2] : p.max;
    this.$(`at-${which}-lo`).value = fmt(lo);
    this.$(`at-${which}-hi`).value = fmt(hi);
  }

  request() {
    const axis = (w) => ({
      name: this.$(`at-${w}`).value,
      lo: Number(this.$(`at-${w}-lo`).value),
      hi: Number(this.$(`at-${w}-hi`).value),
      n: Number(this.$(`at-${w}-n`).value),
    });
    const body = {
      model: { library: this.$('at-model').value },
      x: axis('x'), y: axis('y'),
      tile: Number(this.$('at-tile').value),
      cmap: this.$('at-cmap').value,
      families: this.$('at-families').checked,
    };
    const steps = this.$('at-steps').value;
    if (steps !== '') body.steps = Number(steps);
    return body;
  }

  async compute() {
    showError(this.$('at-error'), '');
    const bar = this.$('at-progress');
    this.$('at-go').disabled = true;
    this.cancelled = false;
    try {
      const { job } = await api('/api/atlas', { method: 'POST', body: this.request() });
      this.job = job;
      bar.hidden = false;
      this.$('at-cancel').hidden = false;
      const result = await waitForJob(job, (j) => {
        if (j.progress > 0) bar.value = j.progress;
        else bar.removeAttribute('value');
        const done = j.progress > 0 ? `${Math.round(j.progress * 100)} %, ` : '';
        const eta = j.eta_s == null ? '' : `, about ${Math.ceil(j.eta_s)} s left`;
        this.$('at-message').textContent = `${j.message} (${done}${j.elapsed_s.toFixed(1)} s${eta})`;
      });
      this.showResult(result);
    } catch (err) {
      // the error replaces the previous atlas: it must not look like this request's result
      this.$('at-result').hidden = true;
      this.$('at-save').hidden = true;
      this.$('at-csv').hidden = true;
      this.$('at-legend').hidden = true;
      this.$('at-unstable').hidden = true;
      this.$('at-message').textContent = this.cancelled ? 'Cancelled: no atlas computed.' : '';
      this.result = null;
      // the user's own cancel is a plain message, not an error in red
      if (!this.cancelled) showError(this.$('at-error'), err.message);
    } finally {
      this.$('at-go').disabled = false;
      this.$('at-cancel').hidden = true;
      bar.hidden = true;
    }
  }

  // a download of the atlas's files, which live with the server's job: after a restart they
  // are gone, and the page says so instead of saving a 404
  async download(ev, link) {
    if (link.dataset.checked === link.href) return; // checked just now: the browser saves it
    ev.preventDefault();
    const res = await fetch(link.href).catch(() => null);
    if (!res?.ok) {
      showError(this.$('at-error'), 'this atlas is no longer on the server (it was restarted, '
        + 'or forgot old results): compute it again to download it');
      return;
    }
    link.dataset.checked = link.href;
    link.click();
    delete link.dataset.checked;
  }

  async cancel() {
    this.cancelled = true;
    if (this.job) await api(`/api/jobs/${this.job}`, { method: 'DELETE' }).catch(() => {});
  }

  showResult(res) {
    this.result = res;
    this.keyTile = null;
    const img = this.$('at-image');
    const cell = res.tile + res.pad;
    const zoom = Math.max(1, Math.floor(640 / (Math.max(res.x.n, res.y.n) * cell)));
    img.onload = () => {
      img.style.width = `${img.naturalWidth * zoom}px`;
      img.style.height = `${img.naturalHeight * zoom}px`;
      this.$('at-result').hidden = false;
      this.$('at-save').hidden = false;
    };
    img.src = res.image;
    this.$('at-save').href = res.image; // the mosaic as computed: one pixel per cell
    this.$('at-ylabels').replaceChildren(
      ...[...res.y.values].reverse().map((v) => el('span', { text: `${res.y.name}=${fmt(v)}` })),
    );
    this.$('at-xlabels').replaceChildren(
      ...res.x.values.map((v) => el('span', { text: `${res.x.name}=${fmt(v)}` })),
    );
    this.$('at-message').textContent = `${res.model_name}: ${res.x.n} × ${res.y.n} tiles of ${res.tile}², `
      + `${res.steps} steps of dt = ${fmt(res.dt)}`;
    // tiles that blew up or grew a grid-scale checkerboard are numerically unstable at this dt,
    // not patterns: hatched in the mosaic, counted here, named on hover (the full report as title)
    const unstable = res.valid.flat().filter((v) => !v).length;
    const line = this.$('at-unstable');
    line.hidden = !unstable;
    const why = [unstable > res.grid_scale ? `${unstable - res.grid_scale} blew up` : '',
      res.grid_scale ? `${res.grid_scale} grew a grid-scale checkerboard` : ''].filter(Boolean).join(', ');
    line.textContent = unstable ? `${unstable} of ${res.valid.flat().length} tiles numerically unstable `
      + `at dt = ${fmt(res.dt)} (hatched: ${why}); not patterns: a smaller dt shows what those parameters do` : '';
    line.title = res.unstable ?? '';
    this.showFamilies(res.families);
  }

  // legend (family, colour, tiles) and the families.csv download; nothing without families
  showFamilies(fam) {
    const legend = this.$('at-legend');
    const swatch = (colour) => { // a style set through the DOM: the page's CSP refuses inline style text
      const box = el('span', { class: 'swatch' });
      box.style.background = colour;
      return box;
    };
    legend.replaceChildren(...(fam ? Object.entries(fam.counts).map(([name, n]) => el('span', { 'data-family': name },
      swatch(fam.colours[name]), `${name} ${n}`)) : []));
    legend.hidden = !fam;
    this.$('at-csv').hidden = !fam;
    if (fam) this.$('at-csv').href = fam.csv;
  }

  // tile under the pointer: {i (row from the top), j (column)} or null
  tileAt(ev) {
    const res = this.result;
    const img = this.$('at-image');
    const r = img.getBoundingClientRect();
    const px = ((ev.clientX - r.left) / r.width) * img.naturalWidth - res.pad;
    const py = ((ev.clientY - r.top) / r.height) * img.naturalHeight - res.pad;
    const cell = res.tile + res.pad;
    const j = Math.floor(px / cell);
    const i = Math.floor(py / cell);
    if (i < 0 || j < 0 || i >= res.y.n || j >= res.x.n) return null;
    return { i, j, x: res.x.values[j], y: res.y.values[res.y.n - 1 - i] };
  }

  // keyboard: arrows choose a tile (read out like the pointer's), Enter opens it in Explore
  tileKey(ev) {
    const res = this.result;
    const move = { ArrowLeft: [0, -1], ArrowRight: [0, 1], ArrowUp: [-1, 0], ArrowDown: [1, 0] }[ev.key];
    if (!res || (!move && ev.key !== 'Enter')) return;
    ev.preventDefault();
    const [i, j] = this.keyTile || [res.y.n - 1, 0];
    const [di, dj] = move || [0, 0];
    const ni = Math.min(Math.max(i + di, 0), res.y.n - 1);
    const nj = Math.min(Math.max(j + dj, 0), res.x.n - 1);
    this.keyTile = [ni, nj];
    const t = { i: ni, j: nj, x: res.x.values[nj], y: res.y.values[res.y.n - 1 - ni] };
    if (move) this.showTile(t);
    else this.openTile(t);
  }

  hover(ev) {
    this.showTile(this.result && this.tileAt(ev));
  }

  showTile(t) {
    const family = t && this.result.families ? ` · ${this.result.families.labels[t.i][t.j]}` : '';
    const unstable = t && !this.result.valid[t.i][t.j] ? ' · numerically unstable (not a pattern)' : '';
    this.$('at-hover').textContent = t
      ? `${this.result.x.name} = ${fmt(t.x)}, ${this.result.y.name} = ${fmt(t.y)}${family}${unstable}` : '';
  }

  open(ev) {
    this.openTile(this.result && this.tileAt(ev));
  }

  openTile(t) {
    if (!t) return;
    const res = this.result;
    const params = { ...res.params, [res.x.name]: t.x, [res.y.name]: t.y };
    // the tile's own run: its grid and step (Explore would otherwise pick a step of its own)
    this.app.openInExplore({ model: res.model, params, init: res.init, seed: res.seed, size: res.tile,
      dt: res.dt, dx: res.dx, boundary: res.boundary, stencil: res.stencil });
  }
}
