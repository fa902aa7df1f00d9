// Explore's tools around the picture: the brush (a stroke is one undo step), the colour bar
// (automatic or fixed range), the value readout under the cursor, undo, and recording the view
// as GIF/MP4. `x` is the Explore page; requests go to its live simulation's routes.

import { api, fmt, showError } from './api.js';

export class ExploreTools {
  constructor(x) {
    this.x = x;
    this.$ = x.$;
    this.readout = null; // what the end-to-end tests read: {row, col, values}
    this.probing = false;
    this.probeAt = null;
    this.recorded = 0;
    this.paintQueue = [];
  }

  bind() {
    const { $ } = this;
    this.bindBrush();
    this.bar = $('ex-cb').getContext('2d');
    $('ex-range-mode').addEventListener('change', () => this.rangeMode());
    for (const id of ['ex-range-lo', 'ex-range-hi']) $(id).addEventListener('change', () => this.sendRange());
    $('ex-undo').addEventListener('click', () => this.undo());
    $('ex-record').addEventListener('click', () => this.toggleRecording());
    for (const id of ['ex-rec-every', 'ex-rec-fps']) $(id).addEventListener('change', () => this.recordingLinks());
    const canvas = this.x.canvas;
    canvas.addEventListener('pointermove', (ev) => this.probe(ev));
    canvas.addEventListener('pointerleave', () => { this.probeAt = null; $('ex-readout').innerHTML = '&nbsp;'; });
  }

  // after every state from the server: range controls, undo button, recording state
  onState(state) {
    const fixed = Array.isArray(state.range);
    this.$('ex-range-mode').value = fixed ? 'fixed' : 'auto';
    this.$('ex-range-box').hidden = !fixed;
    if (fixed) [this.$('ex-range-lo').value, this.$('ex-range-hi').value] = state.range.map(fmt);
    if (state.undo !== undefined) this.setUndo(state.undo);
    this.drawBar();
  }

  // -- colour bar ---------------------------------------------------------------------------
  drawBar() {
    const lut = this.x.lut;
    if (!lut) return;
    const img = this.bar.createImageData(256, 1);
    for (let i = 0; i < 256; i += 1) {
      img.data.set([lut[3 * i], lut[3 * i + 1], lut[3 * i + 2], 255], 4 * i);
    }
    this.bar.putImageData(img, 0, 0);
    this.$('ex-cb-name').textContent = this.x.state?.show ?? '';
  }

  // each frame: the range its colours were scaled to
  onFrame(f) {
    this.$('ex-cb-lo').textContent = fmt(f.lo);
    this.$('ex-cb-hi').textContent = fmt(f.hi);
    const ticks = this.$('ex-cb-ticks').children; // the values at 1/6, 1/2 and 5/6 of the bar
    for (let i = 0; i < 3; i += 1) ticks[i].textContent = fmt(f.lo + ((f.hi - f.lo) * (2 * i + 1)) / 6);
    if (this.recording) {
      this.recorded += 1;
      this.$('ex-record').textContent = `Stop recording (${this.recorded} frames)`;
    }
  }

  rangeMode() {
    const fixed = this.$('ex-range-mode').value === 'fixed';
    this.$('ex-range-box').hidden = !fixed;
    if (fixed) {
      const f = this.x.last;
      this.$('ex-range-lo').value = fmt(f ? f.lo : 0);
      this.$('ex-range-hi').value = fmt(f ? f.hi : 1);
      this.sendRange();
    } else {
      this.x.setView({ range: 'auto' });
    }
  }

  sendRange() {
    this.x.setView({ range: [Number(this.$('ex-range-lo').value), Number(this.$('ex-range-hi').value)] });
  }

  // -- value readout ------------------------------------------------------------------------
  probe(ev) {
    const r = this.x.canvas.getBoundingClientRect();
    this.probeAt = [
      Math.min(Math.max((ev.clientX - r.left) / r.width, 0), 1),
      Math.min(Math.max((ev.clientY - r.top) / r.height, 0), 1),
    ];
    if (!this.probing) this.sendProbe();
  }

  // one request at a time; the latest cursor position wins
  async sendProbe() {
    if (!this.probeAt || !this.x.sid) return;
    const [px, py] = this.probeAt;
    this.probing = true;
    try {
      const data = await api(`/api/live/${this.x.sid}/probe?x=${px}&y=${py}`);
      this.readout = data;
      const values = Object.entries(data.values).map(([k, v]) => `${k} = ${fmt(v)}`).join(' · ');
      this.$('ex-readout').textContent = `cell (${data.col}, ${data.row}) · ${values}`;
    } catch { /* the cursor left a grid that changed; the next move asks again */ }
    this.probing = false;
    if (this.probeAt && (this.probeAt[0] !== px || this.probeAt[1] !== py)) this.sendProbe();
  }

  // -- brush: click or drag paints discs; each stroke is one undo step ------------------
  bindBrush() {
    let down = false;
    let start = false; // the next point begins a stroke (one undo step)
    const point = (ev) => {
      const r = this.x.canvas.getBoundingClientRect();
      const x = Math.min(Math.max((ev.clientX - r.left) / r.width, 0), 1);
      const y = Math.min(Math.max((ev.clientY - r.top) / r.height, 0), 1);
      this.paintQueue.push([x, y, start]);
      start = false;
      if (!this.paintTimer) this.paintTimer = setTimeout(() => this.flushPaint(), 30);
    };
    this.x.canvas.addEventListener('pointerdown', (ev) => {
      down = true;
      start = true;
      this.x.canvas.setPointerCapture(ev.pointerId);
      point(ev);
    });
    this.x.canvas.addEventListener('pointermove', (ev) => { if (down) point(ev); });
    const up = () => { down = false; };
    this.x.canvas.addEventListener('pointerup', up);
    this.x.canvas.addEventListener('pointercancel', up);
    this.keyAt = [0.5, 0.5]; // the keyboard's brush: arrows move it, Enter paints there
    this.x.canvas.addEventListener('keydown', (ev) => this.brushKey(ev));
    this.$('ex-brush').addEventListener('input', () => this.brushCursor());
    this.$('ex-image').addEventListener('change', () => this.loadImage());
    window.addEventListener('resize', () => this.brushCursor());
  }

  // the picture focused: arrows (Shift: larger steps) move a point whose cell the readout
  // reads, Enter paints one disc there (one undo step)
  brushKey(ev) {
    const move = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, -1], ArrowDown: [0, 1] }[ev.key];
    if (!move && ev.key !== 'Enter') return;
    ev.preventDefault();
    ev.stopPropagation();
    const step = ev.shiftKey ? 1 / 8 : 1 / 32;
    if (move) {
      this.keyAt = this.keyAt.map((v, i) => Math.min(Math.max(v + move[i] * step, 0), 1));
    } else {
      this.paintQueue.push([...this.keyAt, true]);
      if (!this.paintTimer) this.paintTimer = setTimeout(() => this.flushPaint(), 30);
    }
    this.probeAt = [...this.keyAt];
    if (!this.probing) this.sendProbe();
  }

  // a PNG's grey levels (0 to the Value box) become the chosen species' state; undo takes it back
  async loadImage() {
    const file = this.$('ex-image').files[0];
    if (!file || !this.x.sid) return;
    const png = await new Promise((resolve) => {
      const reader = new FileReader();
      reader.onload = () => resolve(reader.result);
      reader.readAsDataURL(file);
    });
    try {
      const res = await api(`/api/live/${this.x.sid}/image`, {
        method: 'POST',
        body: { png, species: this.$('ex-paint-species').value || this.$('ex-species').value,
          lo: 0, hi: Number(this.$('ex-paint-value').value) },
      });
      this.setUndo(res.undo);
      showError(this.$('ex-error'), '');
      if (!this.x.running) this.x.request(true, true);
    } catch (err) { this.x.fail(err); }
    this.$('ex-image').value = '';
  }

  // the species a stroke may paint (all, or one), after each model change
  brushSpecies(species) {
    const box = this.$('ex-paint-species');
    const keep = box.value;
    box.replaceChildren(new Option('all species', ''), ...species.map((s) => new Option(s, s)));
    box.value = species.includes(keep) ? keep : '';
    this.brushCursor();
  }

  // the mouse pointer is a ring the size of the brush (browsers refuse cursors over 128 px:
  // larger brushes keep the crosshair)
  brushCursor() {
    const canvas = this.x.canvas;
    const d = Math.round(2 * Number(this.$('ex-brush').value) * canvas.getBoundingClientRect().width);
    if (!(d >= 4 && d <= 128)) { canvas.style.cursor = 'crosshair'; return; }
    const c = d / 2;
    const ring = document.createElement('canvas');
    ring.width = d; ring.height = d;
    const g = ring.getContext('2d');
    for (const [colour, width] of [['black', 3], ['white', 1]]) {
      g.strokeStyle = colour; g.lineWidth = width;
      g.beginPath(); g.arc(c, c, c - 1.5, 0, 2 * Math.PI); g.stroke();
    }
    this.cursor = d;
    canvas.style.cursor = `url(${ring.toDataURL()}) ${c} ${c}, crosshair`;
  }

  // the equations box marks the line a parse error names ("line L, column C: ..."): the line
  // is selected in the box and shown under it with a caret at the column; '' clears the mark
  markLine(message) {
    const box = this.$('ex-equations');
    let mark = this.$('ex-eq-mark');
    if (!mark) {
      mark = document.createElement('pre');
      mark.id = 'ex-eq-mark';
      mark.className = 'error mono small';
      box.after(mark);
    }
    const m = /^line (\d+), column (\d+)/.exec(message || '');
    const lines = box.value.split('\n');
    const line = m ? Number(m[1]) : 0;
    mark.hidden = !(line >= 1 && line <= lines.length);
    box.classList.toggle('bad', !mark.hidden);
    this.badLine = mark.hidden ? null : line;
    if (mark.hidden) return;
    const start = lines.slice(0, line - 1).reduce((n, l) => n + l.length + 1, 0);
    box.focus();
    box.setSelectionRange(start, start + lines[line - 1].length);
    const prefix = `${line} | `;
    mark.textContent = `${prefix}${lines[line - 1]}\n${' '.repeat(prefix.length + Number(m[2]) - 1)}^`;
  }

  // strokes not yet on the server (the end-to-end tests wait for none)
  busy() {
    return this.paintQueue.length > 0 || this.painting > 0 || Boolean(this.paintTimer);
  }

  async flushPaint() {
    this.paintTimer = null;
    // one request holds at most one stroke's start, as its first point
    let n = 1;
    while (n < Math.min(64, this.paintQueue.length) && !this.paintQueue[n][2]) n += 1;
    const batch = this.paintQueue.splice(0, n);
    if (this.paintQueue.length) this.paintTimer = setTimeout(() => this.flushPaint(), 30);
    if (!batch.length || !this.x.sid) return;
    const previous = this.paintDone;
    this.painting = (this.painting || 0) + 1;
    let done;
    this.paintDone = new Promise((resolve) => { done = resolve; });
    try {
      await previous; // strokes reach the server in order
      const res = await api(`/api/live/${this.x.sid}/paint`, {
        method: 'POST',
        body: { points: batch.map(([x, y]) => [x, y]), stroke: batch[0][2],
          radius: Number(this.$('ex-brush').value), mode: this.$('ex-paint-mode').value,
          species: this.$('ex-paint-species').value || null, value: Number(this.$('ex-paint-value').value) },
      });
      this.setUndo(res.undo);
      this.x.strokesChanged?.(res.undo); // every batch of a drag: keep the state after its last
      showError(this.$('ex-error'), '');
      if (!this.x.running) this.x.request(true, true); // show the stroke while paused
    } catch (err) { this.x.fail(err); } finally { this.painting -= 1; done(); }
  }

  // -- undo ---------------------------------------------------------------------------------
  setUndo(n) {
    if (n !== this.undoCount) { // a stroke, an undo or a reset: the page keeps the painted state
      this.undoCount = n;
      this.x.strokesChanged?.(n);
    }
    this.$('ex-undo').disabled = !(n > 0);
    this.$('ex-undo').textContent = n > 0 ? `Undo stroke (${n})` : 'Undo stroke';
  }

  async undo() {
    if (!this.x.sid) return;
    try {
      await this.paintDone;
      const res = await api(`/api/live/${this.x.sid}/undo`, { method: 'POST' });
      this.setUndo(res.undo);
      showError(this.$('ex-error'), '');
      if (!this.x.running) this.x.request(true, true); // show it while paused
    } catch (err) { this.x.fail(err); }
  }

  // -- recording ----------------------------------------------------------------------------
  async toggleRecording() {
    const on = !this.recording;
    try {
      const res = await api(`/api/live/${this.x.sid}/record`, { method: 'POST', body: { on } });
      this.recording = res.on;
      this.recorded = res.frames;
      this.$('ex-record').textContent = on ? 'Stop recording (0 frames)' : 'Record again';
      this.$('ex-recorded').hidden = on || !res.frames;
      this.recordingLinks();
      if (on && !this.x.running) this.x.setRunning(true);
    } catch (err) { this.x.fail(err); }
  }

  // the downloads at the chosen size and frame rate
  recordingLinks() {
    const base = `/api/live/${this.x.sid}/recording`;
    const opts = `every=${this.$('ex-rec-every').value}&fps=${this.$('ex-rec-fps').value}`;
    this.$('ex-save-gif').href = `${base}?format=gif&${opts}`;
    this.$('ex-save-mp4').href = `${base}?format=mp4&${opts}`;
  }

  // a new simulation (model or grid changed): nothing recorded, nothing to undo
  forget() {
    this.recording = false;
    this.recorded = 0;
    this.$('ex-record').textContent = 'Record';
    this.$('ex-recorded').hidden = true;
    this.setUndo(0);
  }
}
