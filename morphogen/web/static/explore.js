// Explore: a live simulation owned by this tab. Frames come over a WebSocket, one in flight
// at a time (send "next", receive a binary frame); controls are small JSON requests.

import { api, colourTable, el, fillSelect, fmt, showError } from './api.js';
import { ExploreTools } from './explore_tools.js';
import { frameMethods } from './explore_frames.js';
import { ParamMaps } from './explore_maps.js';
import { MatchPanel } from './explore_match.js';
import {
  EQUATIONS, EXAMPLE, downloadPage, frameEstimate, keepCheckpoint, putCheckpoint, restoreCheckpoint,
  settingsOf, viewOf,
} from './explore_session.js';
import { currentQuery, decodeSettings, encodeState, settingsFromRunFile } from './urlstate.js';

const FRAME_BUDGET_S = 30; // the server's limit on one frame (morphogen.web.limits)
const MIN_DEFAULT_STEPS = 4; // the fewest steps per frame the server picks for a new scheme
const NOTICE_S = 4; // how long a passing notice ("dt back up") stays

export class Explore {
  constructor(root, app) {
    this.root = root;
    this.app = app;
    this.$ = (id) => root.querySelector(`#${id}`);
    this.sid = null;
    this.state = null;
    this.running = true;
    this.inflight = false;
    this.frames = 0;
    this.fps = 0;
    this.fpsWindow = [];
    this.pending = {}; // parameter changes not yet sent
    this.pendingExtra = {}; // dt not yet sent
    this.sending = false;
    this.ordered = Promise.resolve(); // the session's changes, one after another (inOrder)
    this.visible = true;
    this.lastQuery = null; // the address's query this page last wrote or loaded
    this.tools = new ExploreTools(this);
    this.maps = new ParamMaps(this); // parameters as fields from images
    this.match = new MatchPanel(this); // a picture -> models that grow it (morphogen match)
    // what the end-to-end tests read
    window.morphogenExplore = this;
  }

  async init() {
    const info = this.app.info;
    const models = info.models.map((m) => [m.name, m.name]);
    models.push([EQUATIONS, 'pasted equations…']);
    fillSelect(this.$('ex-model'), models, 'gray-scott');
    fillSelect(this.$('ex-cmap'), info.colormaps, 'viridis');
    fillSelect(this.$('ex-steps'), info.step_choices.map(String));
    fillSelect(this.$('ex-init'), info.init_kinds);
    fillSelect(this.$('ex-scheme'), info.schemes, 'euler');
    this.schemeCosts = info.scheme_costs;
    this.$('ex-equations').value = EXAMPLE;
    this.canvas = this.$('ex-canvas');
    // the picture's height, for the phone layout's scroll margin: a control the keyboard
    // focuses comes to rest below the sticky picture, not under it (app.css)
    const stage = this.canvas.closest('.stage');
    new ResizeObserver(() => document.documentElement.style.setProperty(
      '--explore-stage-h', `${stage.getBoundingClientRect().height}px`)).observe(stage);
    this.ctx = this.canvas.getContext('2d');
    this.bindControls();
    this.tools.bind(); // brush, readout, colour bar, recording
    this.maps.bind();
    this.match.bind();
    const query = currentQuery();
    this.lastQuery = query;
    const fromUrl = decodeSettings(query);
    const fallback = { model: { library: 'gray-scott' } };
    await this.load(fromUrl || fallback);
    if (!this.sid && fromUrl) { // refused settings in a link: say so, and run the default
      const why = this.$('ex-error').textContent;
      await this.load(fallback);
      showError(this.$('ex-error'), `the settings in the page address were refused: ${why}`);
    }
  }

  show() {
    this.visible = true;
    const query = currentQuery();
    if (query && query !== this.lastQuery && decodeSettings(query)) {
      this.lastQuery = query; // a link opened in this tab
      this.load(decodeSettings(query));
    } else {
      this.writeUrl();
    }
    this.request();
  }

  // the settings into the address (replacing it: no history entry per slider move)
  writeUrl() {
    if (!this.visible || !this.state || !this.spec || this.app.current !== 'explore') return;
    const query = encodeState(this.state, this.spec);
    this.lastQuery = query;
    window.history.replaceState(null, '', `#explore?${query}`);
  }

  hide() {
    this.visible = false;
  }

  // (Re)start with settings {model, params, preset, init, seed, size, height, dx, boundary,
  // scheme}, then optionally {view: {cmap, species, steps_per_frame, range}, dt} (from a link).
  load(settings) {
    return this.whileLoading(() => this.loadNow(settings));
  }

  // counted in this.loading while it runs: what the end-to-end tests wait on
  async whileLoading(task) {
    this.loading = (this.loading || 0) + 1;
    try { return await task(); } finally { this.loading -= 1; }
  }

  async loadNow(settings) {
    this.presetName = settings.preset || '';
    const body = {
      model: settings.model,
      params: settings.params,
      preset: settings.preset,
      init: settings.init,
      seed: settings.seed ?? 0,
      size: settings.size ?? Number(this.$('ex-size').value), dx: settings.dx,
      boundary: settings.boundary ?? this.$('ex-boundary').value,
      height: settings.height ?? (this.$('ex-height').value ? Number(this.$('ex-height').value) : undefined),
      scheme: settings.scheme ?? this.$('ex-scheme').value,
    };
    if ('size' in settings && !('height' in settings)) body.height = undefined; // square
    if (settings.model.library) this.$('ex-model').value = settings.model.library;
    else {
      this.$('ex-model').value = EQUATIONS;
      this.$('ex-equations').value = settings.model.equations;
    }
    this.$('ex-eq-box').hidden = this.$('ex-model').value !== EQUATIONS;
    try {
      let state;
      if (this.sid) {
        state = await api(`/api/live/${this.sid}/configure`, { method: 'POST', body });
      } else {
        state = await api('/api/live', { method: 'POST', body });
        this.sid = state.id;
        const old = this.ws;
        this.ws = null;
        if (old) old.close();
        this.openSocket();
      }
      this.tools.forget();
      if (JSON.stringify(settings.model) !== JSON.stringify(this.spec)) this.handDt = undefined;
      this.model = settings.model.library
        ? await api(`/api/models/${settings.model.library}`)
        : await api('/api/models/parse', { method: 'POST', body: { equations: settings.model.equations } });
      this.spec = settings.model;
      const refused = []; // the run started; a view or dt it cannot take is named, not fatal
      if (settings.view && Object.keys(settings.view).length) {
        state = await api(`/api/live/${this.sid}/view`, { method: 'POST', body: settings.view })
          .catch((err) => { refused.push(err.message); return state; });
      }
      if (settings.dt) {
        const body = { params: {}, dt: Math.min(settings.dt, state.dt_max) };
        state = await api(`/api/live/${this.sid}/params`, { method: 'POST', body })
          .catch((err) => { refused.push(err.message); return state; });
      }
      await this.applyState(state, true);
      showError(this.$('ex-error'), refused.join('\n'));
      this.kept = null; // a new start: nothing painted yet
      this.setRunning(!settings.paused);
    } catch (err) {
      if (err.body?.gone) { this.sid = null; return this.loadNow(settings); }
      showError(this.$('ex-error'), err.message);
      showError(this.$('ex-notice'), ''); // no frame estimate for a start that was refused
      this.tools.markLine(settings.model?.equations ? err.message : '');
      await this.resync(Boolean(settings.model?.equations));
    }
    return undefined;
  }

  // After a refusal: every control shows what the server is actually running (a pasted model
  // the parser refused keeps its box open, to be corrected).
  async resync(keepModelBox = false) {
    if (!this.sid) return;
    try {
      const state = await api(`/api/live/${this.sid}`);
      if (!keepModelBox && this.spec) {
        this.$('ex-model').value = this.spec.library || EQUATIONS;
        this.$('ex-eq-box').hidden = Boolean(this.spec.library);
      }
      await this.applyState(state, false);
    } catch (err) {
      if (err.body?.gone) this.recover();
    }
  }

  // The session is gone (the server restarted or forgot it): start it again with everything
  // the page knows, so the parameters, view, grid, scheme and the address stay as they were.
  // The painted state at the last stroke is kept in the page and put back; a paused view stays
  // paused.
  recover() {
    if (this.recovering) return this.recovering;
    const kept = this.kept;
    const keptTime = this.keptTime;
    const maps = this.state && Object.keys(this.state.maps || {}).length;
    const settings = this.state && this.spec ? settingsOf(this.state, this.spec)
      : { model: this.spec || { library: 'gray-scott' } };
    settings.paused = !this.running;
    this.sid = null;
    this.recovering = this.load(settings).then(async () => {
      const painted = kept && this.sid
        ? await putCheckpoint(this, kept, keptTime).then(() => true, () => false) : false;
      if (!this.running) this.request(true, true);
      showError(this.$('ex-notice'), `the server was restarted: the same settings run again${
        painted ? ', from the painted state of the last stroke' : ' from the start'}${
        maps ? ' (parameter maps are not kept)' : ''}`);
    }).finally(() => { this.recovering = null; });
    return this.recovering;
  }

  // a parameter change's notices; "dt back up" is good news and goes after a few seconds,
  // "dt lowered" stays until the next change
  paramNotice(notices) {
    clearTimeout(this.noticeTimer);
    const text = notices.join('\n');
    showError(this.$('ex-notice'), text);
    if (text && notices.every((n) => n.startsWith('dt back up'))) {
      this.noticeTimer = setTimeout(() => {
        if (this.$('ex-notice').textContent === text) showError(this.$('ex-notice'), '');
      }, NOTICE_S * 1000);
    }
  }

  // after a stroke's points reached the server, an undo, image or reset: keep the painted
  // state 200 ms after the last of them (a drag sends points for as long as it lasts, so the
  // kept state holds the whole stroke)
  strokesChanged(n) {
    clearTimeout(this.keepTimer);
    if (!(n > 0)) { this.kept = null; return; }
    this.keepTimer = setTimeout(() => keepCheckpoint(this), 200);
  }

  async applyState(state, rebuild) {
    this.state = state;
    if (rebuild) this.buildParams();
    for (const [name, v] of Object.entries(state.params)) this.setParamUI(name, v);
    fillSelect(this.$('ex-species'), state.species, state.show);
    this.tools.brushSpecies(state.species);
    fillSelect(this.$('ex-preset'), [['', '—'], ...Object.keys(this.model.presets)], this.presetName);
    this.$('ex-desc').textContent = [this.model.description, this.model.reference]
      .filter(Boolean).join(' — ');
    this.$('ex-steps').value = String(state.steps_per_frame);
    this.$('ex-init').value = state.init;
    this.$('ex-seed').value = state.seed;
    const sizes = this.$('ex-size');
    if (![...sizes.options].some((o) => o.value === String(state.size))) {
      sizes.add(new Option(String(state.size), String(state.size)), 0);
    }
    sizes.value = String(state.size);
    this.$('ex-cmap').value = state.cmap;
    this.$('ex-height').value = state.height === state.size ? '' : String(state.height);
    if (![...this.$('ex-height').options].some((o) => o.value === this.$('ex-height').value)) {
      this.$('ex-height').add(new Option(String(state.height), String(state.height)));
      this.$('ex-height').value = String(state.height);
    }
    this.$('ex-scheme').value = state.scheme;
    this.$('ex-boundary').value = state.boundary;
    this.canvas.style.aspectRatio = `${state.size} / ${state.height}`;
    this.setDt(state.dt, state.dt_max);
    this.lut = await colourTable(state.cmap);
    this.tools.onState(state);
    this.maps.onState(state);
    this.updateLinks();
    this.writeUrl();
    if (state.error) showError(this.$('ex-error'), state.error);
  }

  buildParams() {
    const box = this.$('ex-params');
    box.replaceChildren();
    this.paramInputs = {};
    for (const p of this.model.params) {
      const range = el('input', {
        type: 'range', min: p.min, max: p.max, step: p.step, 'aria-label': p.name,
        'data-param': p.name,
      });
      const num = el('input', { type: 'number', class: 'pnum', step: 'any', 'aria-label': `${p.name} value` });
      range.addEventListener('input', () => { num.value = fmt(Number(range.value)); this.queueParam(p.name, Number(range.value)); });
      num.addEventListener('change', () => {
        const v = Number(num.value);
        this.fitRange(p.name, v);
        this.queueParam(p.name, v);
      });
      this.paramInputs[p.name] = { range, num, min: Number(p.min), max: Number(p.max) };
      box.append(el('div', { class: 'param' }, el('span', { class: 'pname', title: p.name, text: p.name }), range, num));
    }
  }

  // the slider spans the model's range, widened only as far as the value needs
  fitRange(name, v) {
    const inp = this.paramInputs[name];
    inp.range.min = Math.min(inp.min, v);
    inp.range.max = Math.max(inp.max, v);
    inp.range.value = v;
  }

  setParamUI(name, v) {
    const inp = this.paramInputs?.[name];
    if (!inp) return;
    this.fitRange(name, v);
    inp.num.value = fmt(v);
  }

  setDt(dt, dtMax) {
    const r = this.$('ex-dt');
    r.min = dtMax / 1000; r.max = dtMax; r.step = dtMax / 1000;
    r.value = dt;
    this.$('ex-dt-num').value = fmt(dt);
  }

  queueParam(name, value) {
    this.presetName = '';
    this.$('ex-preset').value = '';
    this.pending[name] = value;
    if (!this.paramTimer) this.paramTimer = setTimeout(() => this.sendParams(), 40);
  }

  // The session's changes (view, parameters, parameter maps, a reset, a new grid) go one after
  // another, so each answer is the state after all earlier ones (overlapping requests could be
  // answered out of order).
  inOrder(task) {
    const run = this.ordered.then(task, task);
    this.ordered = run.catch(() => {});
    return run;
  }

  // one request at a time, so the server ends with the last value the slider showed
  async sendParams(extra = {}) {
    this.paramTimer = null;
    this.pendingExtra = { ...this.pendingExtra, ...extra };
    if (this.sending) {
      this.paramTimer = setTimeout(() => this.sendParams(), 20);
      return;
    }
    const params = this.pending;
    const more = this.pendingExtra;
    this.pending = {};
    this.pendingExtra = {};
    this.sending = true;
    try {
      const res = await this.inOrder(() => api(`/api/live/${this.sid}/params`,
        { method: 'POST', body: { params, ...more } }));
      this.state = { ...this.state, ...res };
      this.setDt(res.dt, res.dt_max);
      this.paramNotice(res.notices);
      this.updateLinks();
      this.writeUrl();
    } catch (err) {
      this.fail(err);
      if (this.state) { // a refused value leaves its box: the running values come back
        this.setDt(this.state.dt, this.state.dt_max);
        for (const [name, v] of Object.entries(this.state.params)) this.setParamUI(name, v);
      }
    } finally {
      this.sending = false;
    }
  }

  bindControls() {
    this.$('ex-model').addEventListener('change', () => {
      const v = this.$('ex-model').value;
      this.$('ex-eq-box').hidden = v !== EQUATIONS;
      if (v !== EQUATIONS) this.load({ model: { library: v } });
    });
    this.$('ex-open').addEventListener('change', () => this.openRunFile());
    this.$('ex-eq-apply').addEventListener('click', () => {
      this.tools.markLine('');
      this.load({ model: { equations: this.$('ex-equations').value } });
    });
    this.$('ex-preset').addEventListener('change', () => {
      const preset = this.$('ex-preset').value;
      if (preset) this.load({ model: this.spec, preset, init: this.$('ex-init').value });
    });
    this.$('ex-dt').addEventListener('input', () => {
      this.$('ex-dt-num').value = fmt(Number(this.$('ex-dt').value));
      this.handDt = Number(this.$('ex-dt').value);
      this.sendParams({ dt: this.handDt });
    });
    this.$('ex-dt-num').addEventListener('change', () => {
      this.handDt = Number(this.$('ex-dt-num').value);
      this.sendParams({ dt: this.handDt });
    });
    const view = (body) => this.setView(body);
    this.$('ex-png-scale').addEventListener('change', () => this.updateLinks());
    this.$('ex-species').addEventListener('change', () => view({ species: this.$('ex-species').value }));
    this.$('ex-cmap').addEventListener('change', () => view({ cmap: this.$('ex-cmap').value }));
    this.$('ex-steps').addEventListener('change', () => view({ steps_per_frame: Number(this.$('ex-steps').value) }));
    this.$('ex-reset').addEventListener('click', () => this.reset());
    this.$('ex-save-page').addEventListener('click', () => downloadPage(this));
    this.$('ex-restore').addEventListener('change', () => restoreCheckpoint(this));
    this.$('ex-size').addEventListener('change', () => this.restart());
    this.$('ex-boundary').addEventListener('change', () => this.restart());
    this.$('ex-height').addEventListener('change', () => this.restart());
    this.$('ex-scheme').addEventListener('change', () => this.restart());
    this.$('ex-run').addEventListener('click', () => this.setRunning(!this.running));
    this.$('ex-step').addEventListener('click', () => this.stepOnce());
    document.addEventListener('keydown', (ev) => this.onKey(ev));
  }

  // a run.json chosen in the file box: its model, parameters, grid, scheme and view
  async openRunFile() {
    const input = this.$('ex-open');
    const file = input.files[0];
    input.value = '';
    if (!file) return;
    let settings;
    try {
      settings = settingsFromRunFile(JSON.parse(await file.text()));
    } catch (err) {
      showError(this.$('ex-error'), `${file.name}: ${err.message}`);
      return;
    }
    await this.load(settings);
  }

  // species, colour map, steps per frame or colour range: no restart
  async setView(body) {
    try {
      const res = await this.inOrder(() => api(`/api/live/${this.sid}/view`, { method: 'POST', body }));
      this.state = res;
      this.writeUrl(); // with the state, in the same turn
      this.lut = await colourTable(res.cmap);
      this.tools.onState(res);
      this.updateLinks();
      this.redraw();
    } catch (err) {
      this.fail(err);
      if (this.state) this.tools.onState(this.state); // a refused range leaves the boxes
    }
  }

  stepOnce() {
    this.setRunning(false);
    this.request(true);
  }

  // Space pause/run, S one frame, R reset; not while typing in a field
  onKey(ev) {
    if (!this.visible || ev.ctrlKey || ev.metaKey || ev.altKey) return;
    if (ev.target.closest?.('input, textarea, select, [contenteditable]')) return;
    const action = { ' ': () => this.setRunning(!this.running), s: () => this.stepOnce(),
      r: () => this.reset(), u: () => this.tools.undo() }[ev.key.toLowerCase()];
    if (!action) return;
    ev.preventDefault();
    action();
  }

  // a new grid, boundary or scheme: the view (species, steps per frame, colours, a fixed range)
  // and a hand-set dt stay; a new scheme runs at its own stable step. A set-up whose frames
  // would take longer than the server allows is refused here, before it starts; after the
  // changes sent before it are answered.
  restart() {
    return this.whileLoading(() => this.inOrder(() => this.restartNow()));
  }

  restartNow() {
    const height = this.$('ex-height').value;
    const scheme = this.$('ex-scheme').value;
    const size = Number(this.$('ex-size').value);
    const h = height ? Number(height) : size;
    const boundary = this.$('ex-boundary').value;
    const view = viewOf(this.state);
    if (scheme !== this.state.scheme) { // a new step: the server picks dt and steps per frame
      this.handDt = undefined;
      delete view.steps_per_frame;
    }
    const steps = view.steps_per_frame ?? MIN_DEFAULT_STEPS;
    const est = frameEstimate(this.seen, scheme, boundary, size * h, steps, this.schemeCosts);
    if (est !== null && est > FRAME_BUDGET_S) {
      showError(this.$('ex-error'), `${scheme} at ${size} × ${h} with ${steps} steps per frame `
        + `would take about ${est.toFixed(0)} s a frame, over the server's ${FRAME_BUDGET_S} s limit: `
        + 'lower the steps per frame or the grid first');
      this.resync();
      return undefined;
    }
    showError(this.$('ex-notice'), est !== null && est > 1
      ? `expect about ${est.toFixed(1)} s per frame (${scheme}, ${size} × ${h})` : '');
    return this.load({
      model: this.spec, params: this.state.params, init: this.$('ex-init').value,
      seed: Number(this.$('ex-seed').value), size, height: height ? Number(height) : undefined,
      boundary, scheme, view, dt: this.handDt, dx: this.state.dx,
    });
  }

  async reset() {
    try {
      const res = await this.inOrder(() => api(`/api/live/${this.sid}/reset`, {
        method: 'POST', body: { init: this.$('ex-init').value, seed: Number(this.$('ex-seed').value) },
      }));
      this.state = res;
      this.tools.onState(res);
      this.writeUrl();
      showError(this.$('ex-error'), '');
      if (!this.running) this.request(true, true); // show the new start while paused
    } catch (err) { this.fail(err); }
  }

  setRunning(on) {
    this.running = on;
    this.$('ex-run').textContent = on ? 'Pause' : 'Run';
    if (!on) { // no frame rate while paused: say so instead of showing the last one
      this.fps = 0;
      this.fpsWindow = [];
      const f = this.last;
      this.$('ex-stats').textContent = f ? `paused · t = ${fmt(f.t)} · ${f.steps} steps` : 'paused';
    }
    this.request();
  }

  updateLinks() {
    if (!this.sid) return;
    const cmap = encodeURIComponent(this.$('ex-cmap').value);
    this.$('ex-save-png').href = `/api/live/${this.sid}/png?cmap=${cmap}&scale=${this.$('ex-png-scale').value}`;
    this.$('ex-save-run').href = `/api/live/${this.sid}/config`;
    this.$('ex-save-state').href = `/api/live/${this.sid}/state.npz`;
  }

  fail(err) {
    if (err.body?.gone) {
      this.recover();
      return;
    }
    showError(this.$('ex-error'), err.message);
  }
}

Object.assign(Explore.prototype, frameMethods); // the WebSocket and the canvas: explore_frames.js
