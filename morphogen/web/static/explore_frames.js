// Explore's frames: the WebSocket that brings them (one in flight at a time: send "next",
// receive a binary frame) and the canvas they are drawn on. Methods of Explore.

import { fmt, showError } from './api.js';

const HEADER_BYTES = 28; // u16 w, u16 h, u32 frame, f32 t, u32 steps, f32 lo, f32 hi, f32 ms

export const frameMethods = {
  openSocket() {
    const proto = window.location.protocol === 'https:' ? 'wss' : 'ws';
    const ws = new WebSocket(`${proto}://${window.location.host}/api/live/${this.sid}/ws`);
    ws.binaryType = 'arraybuffer';
    ws.onopen = () => {
      this.inflight = false;
      const back = this.disconnected;
      if (back) showError(this.$('ex-error'), '');
      this.disconnected = false;
      this.request();
      // back after a lost connection while paused: one still frame asks whether the server
      // still has this simulation (after a restart it answers "gone" and the page recovers)
      if (back && !this.running) this.request(true, true);
    };
    ws.onmessage = (ev) => this.onMessage(ev.data);
    ws.onclose = () => {
      this.inflight = false;
      if (this.ws !== ws) return;
      this.disconnected = true;
      this.fps = 0;
      this.fpsWindow = [];
      this.$('ex-stats').textContent = 'no frames: the server is not answering';
      showError(this.$('ex-error'), 'lost the connection to the server; reconnecting every second…');
      setTimeout(() => this.openSocket(), 1000);
    };
    this.ws = ws;
  },

  // ask for the next frame (while running, or once with force; still: redraw, no steps)
  request(force = false, still = false) {
    const ws = this.ws;
    if (!(this.running || force) || !this.visible || this.inflight || !ws || ws.readyState !== WebSocket.OPEN) return;
    this.inflight = true;
    ws.send(still ? 'show' : 'next');
  },

  onMessage(data) {
    this.inflight = false;
    if (typeof data === 'string') {
      const msg = JSON.parse(data);
      if (msg.gone) { this.recover(); return; }
      showError(this.$('ex-error'), msg.error);
      this.setRunning(false);
      return;
    }
    this.draw(data);
    requestAnimationFrame(() => this.request());
  },

  draw(buf) {
    const head = new DataView(buf, 0, HEADER_BYTES);
    const w = head.getUint16(0, true);
    const h = head.getUint16(2, true);
    this.last = {
      w, h, frame: head.getUint32(4, true), t: head.getFloat32(8, true),
      steps: head.getUint32(12, true), lo: head.getFloat32(16, true), hi: head.getFloat32(20, true),
      ms: head.getFloat32(24, true), pixels: new Uint8Array(buf, HEADER_BYTES, w * h),
    };
    this.redraw();
    if (this.state && this.last.ms > 0) {
      // the fastest frame of this set-up: a frame that compiled its program, or one computed
      // under the previous set-up, is slower than the set-up's own and would inflate estimates
      const seen = { ms: this.last.ms, cells: w * h, steps: this.state.steps_per_frame,
        scheme: this.state.scheme, boundary: this.state.boundary };
      const same = this.seen && ['cells', 'steps', 'scheme', 'boundary'].every((k) => this.seen[k] === seen[k]);
      this.seen = same ? { ...seen, ms: Math.min(this.seen.ms, seen.ms) } : seen;
    }
    this.tools.onFrame(this.last);
    this.frames += 1;
    this.firstFrameAt ??= performance.now(); // ms after the page's navigation began
    const now = performance.now();
    this.fpsWindow.push(now);
    while (this.fpsWindow.length && now - this.fpsWindow[0] > 2000) this.fpsWindow.shift();
    if (this.fpsWindow.length > 1) {
      this.fps = (this.fpsWindow.length - 1) / ((now - this.fpsWindow[0]) / 1000);
    }
    const f = this.last;
    const rate = this.running ? `${this.fps.toFixed(1)} frames/s` : 'paused';
    this.$('ex-stats').textContent = `${rate} · t = ${fmt(f.t)} · `
      + `${f.steps} steps · ${f.ms.toFixed(1)} ms/frame on the server · range ${fmt(f.lo)}…${fmt(f.hi)}`;
  },

  redraw() {
    const f = this.last;
    if (!f || !this.lut) return;
    if (this.canvas.width !== f.w || this.canvas.height !== f.h) {
      this.canvas.width = f.w;
      this.canvas.height = f.h;
    }
    if (!this.image || this.image.width !== f.w || this.image.height !== f.h) {
      this.image = this.ctx.createImageData(f.w, f.h);
    }
    const out = this.image.data;
    const lut = this.lut;
    const px = f.pixels;
    for (let i = 0, j = 0; i < px.length; i += 1, j += 4) {
      const k = px[i] * 3;
      out[j] = lut[k]; out[j + 1] = lut[k + 1]; out[j + 2] = lut[k + 2]; out[j + 3] = 255;
    }
    this.ctx.putImageData(this.image, 0, 0);
  },
};
