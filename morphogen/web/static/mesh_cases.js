// The Mesh page's case studies: Ringham et al.'s flowers (§4), each the pipeline that
// `morphogen gallery flowers` runs, run on the server as a background job (stage k of n, percent,
// time left, Cancel) and shown in the page's 3D viewer with the last stage's PLY and PNG.

import { api, el, fillSelect, showError, waitForJob } from './api.js';

export class CaseStudies {
  constructor(mesh) {
    this.mesh = mesh; // the Mesh page: its viewer, progress bar, message and download links
    this.job = null;
    window.morphogenCases = this;
  }

  async init(aside) {
    this.menu = el('select', { id: 'me-case', 'aria-label': 'case study' });
    this.go = el('button', { id: 'me-case-go', type: 'button', text: 'Run case study' });
    this.cancelButton = el('button', { id: 'me-case-cancel', type: 'button', text: 'Cancel', hidden: '' });
    aside.prepend(el('fieldset', {}, el('legend', { text: 'Case study (Ringham §4)' }), this.menu,
      this.go, this.cancelButton,
      el('p', { class: 'muted small', text: 'A flower pipeline as morphogen gallery flowers runs it; some take minutes.' })));
    const { cases } = await api('/api/mesh/cases');
    fillSelect(this.menu, cases.map((c) => [c.name, c.caption]));
    this.go.disabled = !cases.length;
    this.go.addEventListener('click', () => this.run());
    this.cancelButton.addEventListener('click', () => this.cancel());
  }

  async run() {
    const m = this.mesh;
    const u = m.ui;
    showError(u.error, '');
    this.go.disabled = true;
    u.go.disabled = true;
    u.more.disabled = true;
    u.bar.hidden = false;
    u.bar.removeAttribute('value');
    try {
      const { job } = await api('/api/mesh/cases', { method: 'POST', body: { name: this.menu.value } });
      this.job = job;
      this.cancelButton.hidden = false;
      const res = await waitForJob(job, (j) => {
        if (j.progress > 0) u.bar.value = j.progress;
        const eta = j.eta_s == null ? '' : `, about ${Math.ceil(j.eta_s)} s left`;
        u.message.textContent = `${j.message}; ${Math.round(j.progress * 100)} % in all (${j.elapsed_s.toFixed(1)} s${eta})`;
      });
      m.lastJob = null; // Continue grows the procedural flower, not a case study
      m.painted.clear();
      m.resetView();
      m.setMesh(res);
      u.still.src = res.image;
      u.still.hidden = false;
      u.ply.href = res.ply; u.ply.hidden = false;
      u.png.href = res.png; u.png.hidden = false;
      u.message.textContent = `${res.caption}: ${res.n_vertices} vertices, ${res.n_faces} faces, `
        + `${res.wall_time_s} s; shown: stage ${res.stage}`;
      this.result = res;
    } catch (err) {
      if (err.message === 'cancelled') { // the user's own cancel: no error, what was shown stays
        const shown = this.result ? `; still showing ${this.result.caption}` : '';
        u.message.textContent = `case study cancelled${shown}`;
        return;
      }
      m.mesh = null;
      u.ply.hidden = true; u.png.hidden = true;
      u.canvas.getContext('2d').clearRect(0, 0, u.canvas.width, u.canvas.height);
      u.still.hidden = true;
      u.message.textContent = '';
      showError(u.error, err.message);
    } finally {
      this.job = null;
      this.go.disabled = false;
      u.go.disabled = false;
      this.cancelButton.hidden = true;
      u.bar.hidden = true;
    }
  }

  async cancel() {
    if (this.job) await api(`/api/jobs/${this.job}`, { method: 'DELETE' }).catch(() => {});
  }
}
