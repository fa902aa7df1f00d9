// Mesh: a pattern grown on a flower mesh on the server, shown on a canvas you can rotate
// (drag) and zoom (wheel); the server's still rendering is shown beside it. Ringham's modelling
// loop: paint a prepattern on the flower (a species' start or a parameter's value at the painted
// vertices), watch the pattern grow segment by segment, continue with new parameters from the
// last state, and download the PLY and PNG the pipeline writes. A Case study menu runs the
// shipped flower pipelines (mesh_cases.js).

import { api, el, fillSelect, fmt, showError, waitForJob } from './api.js';
import { CaseStudies } from './mesh_cases.js';

const MAX_TILT = 1.2; // radians from face-on (69 degrees)

export class Mesh {
  constructor(root, app) {
    this.root = root.querySelector('#mesh-root');
    this.app = app;
    this.resetView();
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
      paintOn: el('input', { id: 'me-paint', type: 'checkbox', title: 'drag on the flower paints instead of rotating' }),
      field: el('select', { id: 'me-field', title: 'a species (sources, sinks) or a parameter (production)' }),
      value: el('input', { id: 'me-value', type: 'number', step: 'any', value: 1 }),
      radius: el('input', { id: 'me-radius', type: 'number', min: 2, max: 80, value: 14, title: 'brush radius in pixels' }),
      clear: el('button', { id: 'me-clear', type: 'button', text: 'Clear paint' }),
      params: el('div', { id: 'me-params' }),
      more: el('button', { id: 'me-continue', type: 'button', text: 'Continue', disabled: '',
        title: 'run on from the last state with these parameters' }),
      ply: el('a', { id: 'me-ply', download: 'out.ply', text: 'PLY', hidden: '' }),
      png: el('a', { id: 'me-png', download: 'out.png', text: 'PNG', hidden: '' }),
    };
    this.painted = new Set();
    this.ui = u;
    fillSelect(u.model, this.app.info.models.map((m) => m.name), 'gray-scott');
    fillSelect(u.shape, [['corolla', 'corolla (fused petals)'], ['petal', 'single petal']], 'corolla');
    fillSelect(u.cmap, this.app.info.colormaps, 'magma');
    const row = (label, input) => el('label', {}, label, input);
    this.root.append(el('div', { class: 'layout' },
      el('aside', { class: 'controls' },
        el('fieldset', {}, el('legend', { text: 'Flower' }), row('Shape', u.shape), row('Petals', u.petals), row('Size', u.size),
          row('Detail', u.detail)),
        el('fieldset', {}, el('legend', { text: 'Pattern' }), row('Model', u.model), row('Steps', u.steps), row('Colours', u.cmap),
          u.params),
        el('fieldset', {}, el('legend', { text: 'Prepattern' }), row('Paint', u.paintOn), row('Field', u.field),
          row('Value', u.value), row('Brush', u.radius), u.clear),
        u.go, u.more, el('p', { class: 'small' }, 'Download: ', u.ply, ' ', u.png)),
      el('div', { class: 'stage' }, u.error, u.bar, u.message,
        u.canvas,
        el('p', { class: 'muted small', text: 'Drag to rotate (with Paint ticked: to paint the prepattern; Grow or Continue applies it), scroll to zoom. Below: the same state rendered on the server.' }), u.still)));
    this.limits = await api('/api/mesh/limits');
    u.detail.addEventListener('input', () => this.fitSize());
    this.fitSize();
    u.go.addEventListener('click', () => this.grow());
    u.more.addEventListener('click', () => this.grow(true));
    u.model.addEventListener('change', () => this.loadModel());
    u.clear.addEventListener('click', () => { this.painted.clear(); this.draw(); });
    await this.loadModel();
    this.bindView();
    this.cases = new CaseStudies(this); // Ringham's flowers, run as the CLI's pipelines
    await this.cases.init(this.root.querySelector('aside.controls'));
  }

  // the model's species and parameters: paint targets, and boxes for the parameter values
  async loadModel() {
    const m = await api(`/api/models/${this.ui.model.value}`);
    this.model = m;
    fillSelect(this.ui.field, [...m.species, ...m.params.map((p) => p.name)], m.species[m.species.length - 1]);
    this.ui.params.replaceChildren(...m.params.map((p) => el('label', {}, p.name,
      el('input', { type: 'number', step: 'any', value: p.value, 'data-param': p.name }))));
    this.ui.more.disabled = true; // another model cannot continue this flower's state
  }

  params() {
    const out = {};
    for (const box of this.ui.params.querySelectorAll('input')) if (box.value !== '') out[box.dataset.param] = Number(box.value);
    return out;
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

  async grow(resume = false) {
    const u = this.ui;
    const refused = this.checkInputs();
    showError(u.error, refused);
    if (refused) return;
    u.go.disabled = true;
    u.more.disabled = true;
    u.bar.hidden = false;
    const body = {
      model: { library: u.model.value }, shape: u.shape.value, petals: Number(u.petals.value),
      size: Number(u.size.value), detail: Number(u.detail.value), cmap: u.cmap.value, params: this.params(),
    };
    if (u.steps.value !== '') body.steps = Number(u.steps.value);
    if (resume && this.lastJob) body.from = this.lastJob;
    else this.resetView(); // a new flower: the default view
    if (this.painted.size) body.paint = { name: u.field.value, value: Number(u.value.value), vertices: [...this.painted] };
    try {
      const { job } = await api('/api/mesh', { method: 'POST', body });
      let seen = 0;
      const res = await waitForJob(job, (j) => {
        u.bar.value = j.progress;
        u.message.textContent = `${j.message} (${j.elapsed_s.toFixed(1)} s)`;
        if (j.status === 'running' && j.progress > seen && j.progress > 0.05) {
          seen = j.progress;
          this.showLive(job);
        }
      });
      this.setMesh(res);
      this.lastJob = res.job;
      this.painted.clear();
      u.still.src = res.image;
      u.still.hidden = false;
      u.ply.href = res.ply; u.ply.hidden = false;
      u.png.href = res.png; u.png.hidden = false;
      u.more.disabled = false;
      u.message.textContent = `${res.model} on ${res.n_vertices} vertices, ${res.steps} steps of dt = ${fmt(res.dt)} `
        + `(${res.wall_time_s} s); ${res.species} from ${res.range[0].toPrecision(3)} to ${res.range[1].toPrecision(3)}`;
    } catch (err) {
      // the error replaces the previous flower: it must not look like this request's result
      this.mesh = null;
      this.lastJob = null;
      u.ply.hidden = true; u.png.hidden = true;
      u.canvas.getContext('2d').clearRect(0, 0, u.canvas.width, u.canvas.height);
      u.still.hidden = true;
      u.message.textContent = '';
      showError(u.error, err.message);
    } finally {
      u.go.disabled = false;
      u.bar.hidden = true;
    }
  }

  // the colours of the segment just simulated, on the flower's geometry (fetched once per job)
  async showLive(job) {
    if (this.liveBusy) return;
    this.liveBusy = true;
    try {
      if (this.liveJob !== job) {
        const geo = await api(`/api/jobs/${job}/files/geometry.json`);
        this.setMesh({ ...geo, colours: new Uint8Array(geo.vertices.length) });
        this.liveJob = job;
      }
      const bytes = new Uint8Array(await (await fetch(`/api/jobs/${job}/files/live.bin`)).arrayBuffer());
      if (this.mesh && bytes.length === this.mesh.c.length) {
        this.mesh.c = bytes;
        this.live = (this.live || 0) + 1;
        this.draw();
      }
    } catch (err) {
      // a segment not simulated yet: the next poll tries again
    } finally {
      this.liveBusy = false;
    }
  }

  // the view a new flower starts with (the previous one's zoom and tilt are not kept)
  resetView() {
    this.rot = { a: -0.6, b: 0.9 }; // azimuth, elevation (radians)
    this.zoom = 1;
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
    cv.style.touchAction = 'none'; // a finger paints or turns the flower instead of scrolling
    cv.addEventListener('pointerdown', (e) => {
      last = [e.clientX, e.clientY];
      cv.setPointerCapture(e.pointerId);
      if (this.ui.paintOn.checked) this.paintAt(e);
    });
    cv.addEventListener('pointermove', (e) => {
      if (!last) return;
      if (this.ui.paintOn.checked) { this.paintAt(e); return; }
      // half a degree per pixel, and never quite edge-on: a flower seen edge-on shows nothing
      this.rot.a += (e.clientX - last[0]) * 0.01;
      this.rot.b = Math.max(-MAX_TILT, Math.min(MAX_TILT, this.rot.b + (e.clientY - last[1]) * 0.005));
      last = [e.clientX, e.clientY];
      this.draw();
    });
    cv.addEventListener('pointerup', () => { last = null; });
    cv.tabIndex = 0; // keyboard: arrows turn and tilt the flower, + and - zoom
    cv.setAttribute('aria-label', 'the flower: arrow keys turn and tilt it, + and - zoom');
    cv.addEventListener('keydown', (e) => {
      const turn = { ArrowLeft: [-0.1, 0], ArrowRight: [0.1, 0], ArrowUp: [0, -0.05], ArrowDown: [0, 0.05] }[e.key];
      const zoom = { '+': 1.1, '=': 1.1, '-': 1 / 1.1 }[e.key];
      if (!turn && !zoom) return;
      e.preventDefault();
      if (turn) {
        this.rot.a += turn[0];
        this.rot.b = Math.max(-MAX_TILT, Math.min(MAX_TILT, this.rot.b + turn[1]));
      } else this.zoom = Math.max(0.3, Math.min(5, this.zoom * zoom));
      this.draw();
    });
    cv.addEventListener('wheel', (e) => {
      e.preventDefault();
      this.zoom = Math.max(0.3, Math.min(5, this.zoom * Math.exp(-e.deltaY * 0.001)));
      this.draw();
    }, { passive: false });
  }

  // marks the vertices facing the viewer within the brush radius of the pointer
  paintAt(e) {
    if (!this.proj) return;
    const cv = this.ui.canvas;
    const box = cv.getBoundingClientRect();
    const x = (e.clientX - box.left) * (cv.width / box.width);
    const y = (e.clientY - box.top) * (cv.height / box.height);
    const r = Number(this.ui.radius.value) * (cv.width / box.width);
    const p = this.proj;
    for (let i = 0; i < p.length / 3; i += 1) {
      const dx = p[3 * i] - x; const dy = p[3 * i + 1] - y;
      if (dx * dx + dy * dy > r * r) continue;
      const xi = Math.round(p[3 * i]); const yi = Math.round(p[3 * i + 1]);
      const at = yi * cv.width + xi;
      // hidden behind another part of the flower: not painted
      if (this.depth && xi >= 0 && yi >= 0 && xi < cv.width && yi < cv.height && this.depth[at] > p[3 * i + 2] + 2) continue;
      this.painted.add(i);
    }
    this.draw();
  }

  // orthographic view rasterised into one ImageData with a depth buffer (no per-triangle
  // canvas paths, which redrew at ~9 frames/s), two-sided Lambert shading from the camera
  draw() {
    const m = this.mesh;
    if (!m) return;
    const cv = this.ui.canvas;
    const ctx = cv.getContext('2d');
    const W = cv.width; const H = cv.height;
    const { a, b } = this.rot;
    const ca = Math.cos(a); const sa = Math.sin(a); const cb = Math.cos(b); const sb = Math.sin(b);
    const s = (W / 2) * 0.9 * this.zoom;
    const n = m.v.length / 3;
    const p = new Float32Array(n * 3); // screen x, screen y, depth towards the viewer
    for (let i = 0; i < n; i += 1) {
      const x = m.v[3 * i]; const y = m.v[3 * i + 1]; const z = m.v[3 * i + 2];
      const x1 = ca * x - sa * y; const y1 = sa * x + ca * y; // turn about z
      p[3 * i] = W / 2 + s * x1;
      p[3 * i + 1] = H / 2 - s * (cb * y1 - sb * z); // tilt about x
      p[3 * i + 2] = s * (sb * y1 + cb * z); // in pixels too, so normals are true
    }
    this.proj = p;
    if (!this.frame || this.frame.width !== W || this.frame.height !== H) {
      this.frame = ctx.createImageData(W, H);
      this.depth = new Float32Array(W * H);
    }
    const px = new Uint32Array(this.frame.data.buffer);
    px.fill(0xff100d0c); // background #0c0d10 (ABGR in little-endian memory)
    const zbuf = this.depth;
    zbuf.fill(-Infinity);
    const f = m.f;
    for (let t = 0; t < f.length; t += 3) {
      const i = f[t]; const j = f[t + 1]; const k = f[t + 2];
      const x0 = p[3 * i]; const y0 = p[3 * i + 1]; const z0 = p[3 * i + 2];
      const x1 = p[3 * j]; const y1 = p[3 * j + 1]; const z1 = p[3 * j + 2];
      const x2 = p[3 * k]; const y2 = p[3 * k + 1]; const z2 = p[3 * k + 2];
      const area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
      if (area === 0) continue;
      const ux = x1 - x0; const uy = y1 - y0; const uz = z1 - z0;
      const vx = x2 - x0; const vy = y2 - y0; const vz = z2 - z0;
      const nx = uy * vz - uz * vy; const ny = uz * vx - ux * vz;
      const light = 0.4 + 0.6 * Math.abs(area) / (Math.hypot(nx, ny, area) || 1);
      const r = Math.round(light * (m.c[3 * i] + m.c[3 * j] + m.c[3 * k]) / 3);
      const g = Math.round(light * (m.c[3 * i + 1] + m.c[3 * j + 1] + m.c[3 * k + 1]) / 3);
      const bl = Math.round(light * (m.c[3 * i + 2] + m.c[3 * j + 2] + m.c[3 * k + 2]) / 3);
      const colour = (0xff000000 | (bl << 16) | (g << 8) | r) >>> 0;
      const xa = Math.max(0, Math.floor(Math.min(x0, x1, x2)));
      const xb = Math.min(W - 1, Math.ceil(Math.max(x0, x1, x2)));
      const ya = Math.max(0, Math.floor(Math.min(y0, y1, y2)));
      const yb = Math.min(H - 1, Math.ceil(Math.max(y0, y1, y2)));
      const inv = 1 / area;
      for (let yy = ya; yy <= yb; yy += 1) {
        const cy = yy + 0.5;
        for (let xx = xa; xx <= xb; xx += 1) {
          const cx = xx + 0.5;
          // barycentric weights; a small tolerance closes the seams between triangles
          const w0 = ((x1 - cx) * (y2 - cy) - (x2 - cx) * (y1 - cy)) * inv;
          const w1 = ((x2 - cx) * (y0 - cy) - (x0 - cx) * (y2 - cy)) * inv;
          const w2 = 1 - w0 - w1;
          if (w0 < -1e-3 || w1 < -1e-3 || w2 < -1e-3) continue;
          const depth = w0 * z0 + w1 * z1 + w2 * z2;
          const at = yy * W + xx;
          if (depth > zbuf[at]) { zbuf[at] = depth; px[at] = colour; }
        }
      }
    }
    ctx.putImageData(this.frame, 0, 0);
    // the painted prepattern: a white dot on each painted vertex
    ctx.fillStyle = 'rgba(255,255,255,0.85)';
    for (const i of this.painted) ctx.fillRect(p[3 * i] - 1.5, p[3 * i + 1] - 1.5, 3, 3);
    this.drawn = (this.drawn || 0) + 1;
  }
}
