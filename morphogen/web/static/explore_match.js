// Explore's Match panel: drop (or choose) a picture, and the server runs `morphogen match` on it
// as a background job (POST /api/match, morphogen.web.match_routes) with a progress bar; the
// candidates come back best first, each with its picture, model, parameters, grid spacing and
// descriptor distance to the picture, and "Open in Explore" runs it here from its run.json
// (model, parameters, dx, grid, dt, initial condition and seed).

import { api, el, fmt, showError, waitForJob } from './api.js';
import { settingsFromRunFile } from './urlstate.js';

const MAX_BYTES = 4 * 1024 * 1024; // the server's largest picture (morphogen.web.image_input)

export class MatchPanel {
  constructor(x) {
    this.x = x;
    this.$ = x.$;
    this.image = null; // the chosen picture as a data: URL
    this.job = null;
    this.result = null; // what the end-to-end tests read
  }

  async bind() {
    const drop = this.$('ex-match-drop');
    this.$('ex-match-file').addEventListener('change', (ev) => this.choose(ev.target.files[0]));
    drop.addEventListener('dragover', (ev) => { ev.preventDefault(); drop.classList.add('over'); });
    drop.addEventListener('dragleave', () => drop.classList.remove('over'));
    drop.addEventListener('drop', (ev) => {
      ev.preventDefault();
      drop.classList.remove('over');
      this.choose(ev.dataTransfer.files[0]);
    });
    this.$('ex-match-go').addEventListener('click', () => this.run());
    this.$('ex-match-cancel').addEventListener('click', () => this.cancel());
    try {
      const o = await api('/api/match');
      const boxes = o.models.map((name) => {
        const box = el('input', { type: 'checkbox', value: name, 'aria-label': `match with ${name}` });
        box.checked = o.default_models.includes(name);
        return el('label', {}, box, name);
      });
      this.$('ex-match-models').replaceChildren(...boxes);
      for (const [key, id] of [['budget', 'ex-match-budget'], ['minutes', 'ex-match-minutes'], ['top', 'ex-match-top']]) {
        const input = this.$(id);
        input.min = o[key].min;
        input.max = o[key].max;
        input.value = o[key].default;
      }
    } catch (err) { showError(this.$('ex-match-error'), err.message); }
  }

  // a picture from the file box or a drop: shown, and kept as base64 for the request
  choose(file) {
    if (!file) return;
    showError(this.$('ex-match-error'), '');
    if (file.size > MAX_BYTES) {
      showError(this.$('ex-match-error'), `the picture is over ${MAX_BYTES / 2 ** 20} MiB; use a smaller one`);
      return;
    }
    const reader = new FileReader();
    reader.onload = () => {
      this.image = reader.result;
      const img = this.$('ex-match-picture');
      img.src = this.image;
      img.hidden = false;
      this.$('ex-match-go').disabled = false;
      this.$('ex-match-message').textContent = `${file.name}: press Find models`;
    };
    reader.onerror = () => showError(this.$('ex-match-error'), `${file.name} could not be read`);
    reader.readAsDataURL(file);
  }

  request() {
    const models = [...this.$('ex-match-models').querySelectorAll('input:checked')].map((b) => b.value);
    return {
      image: this.image, models,
      budget: Number(this.$('ex-match-budget').value), minutes: Number(this.$('ex-match-minutes').value),
      top: Number(this.$('ex-match-top').value),
    };
  }

  async run() {
    const bar = this.$('ex-match-progress');
    const message = this.$('ex-match-message');
    showError(this.$('ex-match-error'), '');
    this.$('ex-match-go').disabled = true;
    this.$('ex-match-results').replaceChildren();
    this.result = null;
    try {
      const { job } = await api('/api/match', { method: 'POST', body: this.request() });
      this.job = job;
      bar.hidden = false;
      bar.removeAttribute('value');
      this.$('ex-match-cancel').hidden = false;
      const result = await waitForJob(job, (j) => {
        if (j.progress > 0) bar.value = j.progress;
        const eta = j.eta_s == null ? '' : `, about ${Math.ceil(j.eta_s)} s left`;
        message.textContent = `${j.message || 'waiting for the server'} (${j.elapsed_s.toFixed(0)} s${eta})`;
      }, { intervalMs: 500 });
      this.show(result);
    } catch (err) {
      message.textContent = '';
      if (err.body?.status === 'cancelled') message.textContent = 'match cancelled';
      else showError(this.$('ex-match-error'), err.message);
    } finally {
      this.job = null;
      bar.hidden = true;
      this.$('ex-match-cancel').hidden = true;
      this.$('ex-match-go').disabled = !this.image;
    }
  }

  async cancel() {
    if (this.job) await api(`/api/jobs/${this.job}`, { method: 'DELETE' }).catch(() => {});
  }

  show(res) {
    this.result = res;
    const t = res.target;
    this.$('ex-match-message').textContent = `the picture: ${t.family}, wavelength ${fmt(t.wavelength_px)} px; `
      + `${res.simulations} simulations in ${fmt(res.seconds)} s`;
    const cards = res.candidates.map((c) => {
      const params = Object.entries(c.params).map(([k, v]) => `${k} = ${fmt(v)}`).join(', ');
      const open = el('button', { type: 'button', class: 'match-open', 'data-rank': c.rank, text: 'Open in Explore' });
      open.addEventListener('click', () => this.open(c));
      return el('div', { class: 'match-card', 'data-rank': c.rank },
        el('img', { src: c.image, alt: `candidate ${c.rank}: ${c.model}, ${c.family}` }),
        el('div', {},
          el('p', { text: `#${c.rank} ${c.model} · ${c.family}` }),
          el('p', { class: 'mono', text: params }),
          el('p', { class: 'muted small', text: `dx = ${fmt(c.dx)}, grid ${c.size[1]} × ${c.size[0]}, dt = ${fmt(c.dt)}` }),
          el('p', { class: 'muted small', text: `distance ${c.distance == null ? '–' : fmt(c.distance)}`
            + (c.invert ? ' (picture inverted)' : '') }),
          open));
    });
    const sheet = el('a', { class: 'button', href: res.sheet, download: 'match-sheet.png', text: 'answer sheet (PNG)' });
    this.$('ex-match-results').replaceChildren(...cards, sheet);
  }

  // the candidate's run.json in Explore: its model, parameters, dx, grid, dt, start and seed;
  // the page's own colour map stays (the run file's grey is for comparing with the picture)
  open(c) {
    showError(this.$('ex-match-error'), '');
    try {
      const settings = settingsFromRunFile(c.run);
      if (this.x.state?.cmap) settings.view = { ...settings.view, cmap: this.x.state.cmap };
      return this.x.load(settings);
    } catch (err) {
      showError(this.$('ex-match-error'), err.message);
      return undefined;
    }
  }
}
