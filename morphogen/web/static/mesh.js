// Mesh: a pattern grown on a flower mesh on the server, shown on a canvas you can rotate
// (drag) and zoom (wheel); the server's still rendering is shown beside it.

import { api, el, fillSelect, fmt, showError, waitForJob } from './api.js';

export class Mesh {
  constructor(root, app) {
    this.root = root.querySelector('#mesh-root');
    this.app = app;
    this.rot = { a: -0.6, b: 0.9 }; // azimuth, elevation (radians)
    this.zoom = 1;
    window.morphogenMesh = this;
  }

  async init() {
    const u = {
      model: el('select', { id: 'me-model' }),
      shape: el('select', { id: 'me-shape' }),
      petals: el('input', { id: 'me-petals', type: 'number', min: 2, max: 12, value: 5 }),
      size: el('input', { id: 'me-size', type: 'number', min: 20, max: 240, value: 120 }),
      detail: el('input', { id: 'me-detail', type: 'number', min: 0.2, max: 1.5, step: 0.1, value: 0.7,
        title: 'vertices per unit length: more detail, finer triangles' }),
      steps: el('input', { id: 'me-steps', type: 'number', min: 1, placeholder: 'model default' }),
      cmap: el('select', { id: 'me-cmap' }),
      go: el('button', { id: 'me-go', type: 'button', class: 'primary', text: 'Grow pattern' }),
      error: el('div', { class: 'error', hidden: '' }),
      bar: el('progress', { max: 1, hidden: '' }),
      message: el('p', { class: 'muted small' }),
      canvas: el('canvas', { id: 'me-canvas', class: 'mesh', width: 640, height: 640 }),
      still: el('img', { id: 'me-still', alt: 'server rendering', class: 'mesh-still', hidden: '' }),
    };
    this.ui = u;
    fillSelect(u.model, this.app.info.models.map((m) => m.name), 'gray-scott');
    fillSelect(u.shape, [['corolla', 'corolla (fused petals)'], ['petal', 'single petal']], 'corolla');
    fillSelect(u.cmap, this.app.info.colormaps, 'magma');
    const row = (label, input) => el('label', {}, label, input);
    this.root.append(el('div', { class: 'layout' },
      el('aside', { class: 'controls' },
        el('fieldset', {}, el('legend', { text: 'Flower' }), row('Shape', u.shape), row('Petals', u.petals), row('Size', u.size),
          row('Detail', u.detail)),
        el('fieldset', {}, el('legend', { text: 'Pattern' }), row('Model', u.model), row('Steps', u.steps), row('Colours', u.cmap)),
        u.go),
      el('div', { class: 'stage' }, u.error, u.bar, u.message,
        u.canvas,
        el('p', { class: 'muted small', text: 'Drag to rotate, scroll to zoom. Below: the same state rendered on the server.' }), u.still)));
    this.limits = await api('/api/mesh/limits');
    u.detail.addEventListener('input', () => this.fitSize());
    this.fitSize();
    u.go.addEventListener('click', () => this.grow());
    this.bindView();
  }

  // the largest size the server accepts at this detail (size x detail <= max_across)
  maxSize() {
    const detail = Number(this.ui.detail.value);
    return Math.min(this.limits.size[1], Math.floor(this.limits.max_across / detail));
  }

  fitSize() {
    this.ui.size.max = this.maxSize();
  }

  // one line for a value the server would refuse, before anything is sent
  checkInputs() {
    const u = this.ui;
    const [dlo, dhi] = this.limits.detail;
    const detail = Number(u.detail.value);
    if (!(detail >= dlo && detail <= dhi)) return `detail must be between ${dlo} and ${dhi}`;
    const size = Number(u.size.value);
    if (!(size >= this.limits.size[0])) return `size must be at least ${this.limits.size[0]}`;
    if (size > this.maxSize()) return `with detail ${detail} the size can be at most ${this.maxSize()} (or lower the detail)`;
    return '';
  }

  async grow() {
    const u = this.ui;
    const refused = this.checkInputs();
    showError(u.error, refused);
    if (refused) return;
    u.go.disabled = true;
    u.bar.hidden = false;
    const body = {
      model: { library: u.model.value }, shape: u.shape.value, petals: Number(u.petals.value),
      size: Number(u.size.value), detail: Number(u.detail.value), cmap: u.cmap.value,
    };
    if (u.steps.value !== '') body.steps = Number(u.steps.value);
    try {
      const { job } = await api('/api/mesh', { method: 'POST', body });
      const res = await waitForJob(job, (j) => {
        u.bar.value = j.progress;
        u.message.textContent = `${j.message} (${j.elapsed_s.toFixed(1)} s)`;
      });
      this.setMesh(res);
      u.still.src = res.image;
      u.still.hidden = false;
      u.message.textContent = `${res.model} on ${res.n_vertices} vertices, ${res.steps} steps of dt = ${fmt(res.dt)} `
        + `(${res.wall_time_s} s); ${res.species} from ${res.range[0].toPrecision(3)} to ${res.range[1].toPrecision(3)}`;
    } catch (err) {
      showError(u.error, err.message);
    } finally {
      u.go.disabled = false;
      u.bar.hidden = true;
    }
  }

  setMesh(res) {
    const v = Float32Array.from(res.vertices);
    const n = v.length / 3;
    const lo = [Infinity, Infinity, Infinity];
    const hi = [-Infinity, -Infinity, -Infinity];
    for (let i = 0; i < n; i += 1) {
      for (let k = 0; k < 3; k += 1) {
        lo[k] = Math.min(lo[k], v[3 * i + k]);
        hi[k] = Math.max(hi[k], v[3 * i + k]);
      }
    }
    const c = lo.map((l, k) => (l + hi[k]) / 2);
    const r = Math.max(...hi.map((h, k) => h - lo[k])) / 2 || 1;
    for (let i = 0; i < n; i += 1) for (let k = 0; k < 3; k += 1) v[3 * i + k] = (v[3 * i + k] - c[k]) / r;
    this.mesh = { v, f: Uint32Array.from(res.faces), c: Uint8Array.from(res.colours) };
    this.draw();
  }

  bindView() {
    const cv = this.ui.canvas;
    let last = null;
    cv.addEventListener('pointerdown', (e) => { last = [e.clientX, e.clientY]; cv.setPointerCapture(e.pointerId); });
    cv.addEventListener('pointermove', (e) => {
      if (!last) return;
      this.rot.a += (e.clientX - last[0]) * 0.01;
      this.rot.b = Math.max(-Math.PI / 2, Math.min(Math.PI / 2, this.rot.b + (e.clientY - last[1]) * 0.01));
      last = [e.clientX, e.clientY];
      this.draw();
    });
    cv.addEventListener('pointerup', () => { last = null; });
    cv.addEventListener('wheel', (e) => {
      e.preventDefault();
      this.zoom = Math.max(0.3, Math.min(5, this.zoom * Math.exp(-e.deltaY * 0.001)));
      this.draw();
    }, { passive: false });
  }

  // orthographic view, faces sorted back to front, two-sided Lambert shading from the camera
  draw() {
    const m = this.mesh;
    if (!m) return;
    const cv = this.ui.canvas;
    const ctx = cv.getContext('2d');
    const { a, b } = this.rot;
    const ca = Math.cos(a); const sa = Math.sin(a); const cb = Math.cos(b); const sb = Math.sin(b);
    const n = m.v.length / 3;
    const p = new Float32Array(n * 3);
    for (let i = 0; i < n; i += 1) {
      const x = m.v[3 * i]; const y = m.v[3 * i + 1]; const z = m.v[3 * i + 2];
      const x1 = ca * x - sa * y; const y1 = sa * x + ca * y; // turn about z
      p[3 * i] = x1;
      p[3 * i + 1] = cb * y1 - sb * z; // tilt about x: screen y
      p[3 * i + 2] = sb * y1 + cb * z; // depth towards the viewer
    }
    const nf = m.f.length / 3;
    const order = new Uint32Array(nf);
    const depth = new Float32Array(nf);
    for (let t = 0; t < nf; t += 1) {
      order[t] = t;
      depth[t] = p[3 * m.f[3 * t] + 2] + p[3 * m.f[3 * t + 1] + 2] + p[3 * m.f[3 * t + 2] + 2];
    }
    order.sort((i, j) => depth[i] - depth[j]);
    const s = (cv.width / 2) * 0.9 * this.zoom;
    const cx = cv.width / 2; const cy = cv.height / 2;
    ctx.fillStyle = '#0c0d10';
    ctx.fillRect(0, 0, cv.width, cv.height);
    for (const t of order) {
      const i = m.f[3 * t]; const j = m.f[3 * t + 1]; const k = m.f[3 * t + 2];
      const ux = p[3 * j] - p[3 * i]; const uy = p[3 * j + 1] - p[3 * i + 1]; const uz = p[3 * j + 2] - p[3 * i + 2];
      const vx = p[3 * k] - p[3 * i]; const vy = p[3 * k + 1] - p[3 * i + 1]; const vz = p[3 * k + 2] - p[3 * i + 2];
      const nx = uy * vz - uz * vy; const ny = uz * vx - ux * vz; const nz = ux * vy - uy * vx;
      const light = 0.4 + 0.6 * Math.abs(nz) / (Math.hypot(nx, ny, nz) || 1);
      const col = [0, 1, 2].map((q) => Math.round(light * (m.c[3 * i + q] + m.c[3 * j + q] + m.c[3 * k + q]) / 3));
      ctx.fillStyle = `rgb(${col[0]},${col[1]},${col[2]})`;
      ctx.strokeStyle = ctx.fillStyle;
      ctx.beginPath();
      ctx.moveTo(cx + s * p[3 * i], cy - s * p[3 * i + 1]);
      ctx.lineTo(cx + s * p[3 * j], cy - s * p[3 * j + 1]);
      ctx.lineTo(cx + s * p[3 * k], cy - s * p[3 * k + 1]);
      ctx.closePath();
      ctx.fill();
      ctx.stroke();
    }
  }
}
