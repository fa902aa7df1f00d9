// The exported page's program (morphogen export-web, morphogen/runs/web_page.py): WebGL2
// ping-pong of float textures, one step shader generated from the model's equations.
'use strict';
const D = JSON.parse(document.getElementById('data').textContent);
const $ = (id) => document.getElementById(id);
const bytes = (b64) => Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
const VERT = `#version 300 es
in vec2 p; void main() { gl_Position = vec4(p, 0.0, 1.0); }`;
const SHOW = `#version 300 es
precision highp float; precision highp sampler2D;
uniform sampler2D u_state; uniform sampler2D u_lut; uniform int u_show; uniform vec2 u_range;
out vec4 o;
void main() {
  ivec2 n = textureSize(u_state, 0);
  ivec2 q = ivec2(int(gl_FragCoord.x), n.y - 1 - int(gl_FragCoord.y));
  float v = texelFetch(u_state, q, 0)[u_show];
  float t = clamp((v - u_range.x) / max(u_range.y - u_range.x, 1e-30), 0.0, 1.0);
  o = vec4(texelFetch(u_lut, ivec2(int(t * 255.0 + 0.5), 0), 0).rgb, 1.0);
}`;
const PAINT = `#version 300 es
precision highp float; precision highp sampler2D;
uniform sampler2D u_state; uniform vec2 u_at; uniform float u_r; uniform vec4 u_value;
out vec4 o;
void main() {
  vec4 c = texelFetch(u_state, ivec2(gl_FragCoord.xy), 0);
  o = distance(gl_FragCoord.xy, u_at) <= u_r ? u_value : c;
}`;
const page = { ready: false, steps: 0, t: 0, running: true, frames: 0, renderer: '' };
window.morphogenPage = page;
function fail(msg) { $('err').textContent = msg; $('err').hidden = false; page.error = msg; }
const canvas = $('view');
canvas.width = D.width; canvas.height = D.height;
const gl = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true });
if (!gl) fail('this browser has no WebGL2');
else if (!gl.getExtension('EXT_color_buffer_float')) fail('this browser cannot render to float textures (EXT_color_buffer_float)');
else start();

function program(src) {
  const p = gl.createProgram();
  for (const [type, text] of [[gl.VERTEX_SHADER, VERT], [gl.FRAGMENT_SHADER, src]]) {
    const s = gl.createShader(type);
    gl.shaderSource(s, text); gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
    gl.attachShader(p, s);
  }
  gl.bindAttribLocation(p, 0, 'p');
  gl.linkProgram(p);
  if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
  const u = (name) => gl.getUniformLocation(p, name);
  return { p, u };
}

function texture(w, h, internal, format, type, data) {
  const t = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, t);
  gl.texImage2D(gl.TEXTURE_2D, 0, internal, w, h, 0, format, type, data);
  for (const k of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, k, gl.NEAREST);
  for (const k of [gl.TEXTURE_WRAP_S, gl.TEXTURE_WRAP_T]) gl.texParameteri(gl.TEXTURE_2D, k, gl.CLAMP_TO_EDGE);
  return t;
}

function start() {
  const dbg = gl.getExtension('WEBGL_debug_renderer_info');
  page.renderer = dbg ? gl.getParameter(dbg.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
  let step, show, paint;
  try { step = program(STEP_SHADER); show = program(SHOW); paint = program(PAINT); } catch (err) { fail(`shader: ${err.message}`); return; }
  const buf = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, buf);
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 1, -1, -1, 1, 1, 1]), gl.STATIC_DRAW);
  gl.enableVertexAttribArray(0);
  gl.vertexAttribPointer(0, 2, gl.FLOAT, false, 0, 0);
  const init = new Float32Array(bytes(D.state).buffer);
  const lutRgb = bytes(D.lut);
  const lutRgba = new Uint8Array(256 * 4);
  for (let i = 0; i < 256; i += 1) { lutRgba.set(lutRgb.subarray(3 * i, 3 * i + 3), 4 * i); lutRgba[4 * i + 3] = 255; }
  const lut = texture(256, 1, gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE, lutRgba);
  const tex = [0, 1].map(() => texture(D.width, D.height, gl.RGBA32F, gl.RGBA, gl.FLOAT, init));
  const fbo = tex.map((t) => { const f = gl.createFramebuffer(); gl.bindFramebuffer(gl.FRAMEBUFFER, f); gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, t, 0); return f; });
  let cur = 0;
  const params = { ...D.params };
  let dt = D.dt;
  let range = D.range ? [...D.range] : null;
  let auto = [0, 1];
  const pass = (prog, setup) => {
    gl.useProgram(prog.p);
    gl.activeTexture(gl.TEXTURE0); gl.bindTexture(gl.TEXTURE_2D, tex[cur]);
    gl.uniform1i(prog.u('u_state'), 0);
    setup(prog.u);
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbo[1 - cur]);
    gl.viewport(0, 0, D.width, D.height);
    gl.drawArrays(gl.TRIANGLE_STRIP, 0, 4);
    cur = 1 - cur;
  };
  page.advance = (n) => {
    for (let i = 0; i < n; i += 1) {
      pass(step, (u) => {
        gl.uniform1f(u('u_dt'), dt); gl.uniform1f(u('u_t'), page.t);
        D.names.forEach((name, k) => gl.uniform1f(u(`p_${k}`), params[name]));
      });
      page.steps += 1; page.t += dt;
    }
  };
  page.read = () => {
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbo[cur]);
    const out = new Float32Array(D.width * D.height * 4);
    gl.readPixels(0, 0, D.width, D.height, gl.RGBA, gl.FLOAT, out);
    return out;
  };
  // the state as species-major rows (row 0 at the top, like numpy's (S, h, w))
  page.state = () => {
    const px = page.read();
    return D.species.map((_, s) => Array.from({ length: D.width * D.height }, (_, i) => px[4 * i + s]));
  };
  const draw = () => {
    if (!range && page.frames % 15 === 0) {
      const px = page.read();
      let lo = Infinity; let hi = -Infinity;
      for (let i = D.show; i < px.length; i += 4) { if (px[i] < lo) lo = px[i]; if (px[i] > hi) hi = px[i]; }
      if (Number.isFinite(lo) && Number.isFinite(hi)) auto = [lo, hi > lo ? hi : lo + 1e-6];
    }
    const r = range || auto;
    gl.useProgram(show.p);
    gl.activeTexture(gl.TEXTURE0); gl.bindTexture(gl.TEXTURE_2D, tex[cur]);
    gl.uniform1i(show.u('u_state'), 0);
    gl.activeTexture(gl.TEXTURE1); gl.bindTexture(gl.TEXTURE_2D, lut);
    gl.uniform1i(show.u('u_lut'), 1);
    gl.uniform1i(show.u('u_show'), D.show);
    gl.uniform2f(show.u('u_range'), r[0], r[1]);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, D.width, D.height);
    gl.drawArrays(gl.TRIANGLE_STRIP, 0, 4);
    page.frames += 1;
    page.firstFrameAt ??= performance.now();
  };
  page.draw = draw;
  page.reset = () => {
    for (const t of tex) { gl.bindTexture(gl.TEXTURE_2D, t); gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, D.width, D.height, 0, gl.RGBA, gl.FLOAT, init); }
    cur = 0; page.steps = 0; page.t = 0; draw();
  };
  page.paint = (fx, fy) => { // fractions of the picture from its top left
    const value = [0, 0, 0, 0];
    D.excited.forEach((v, i) => { value[i] = v; });
    pass(paint, (u) => {
      gl.uniform2f(u('u_at'), fx * D.width, fy * D.height); // texel row = numpy row
      gl.uniform1f(u('u_r'), Number($('brush').value) * D.width);
      gl.uniform4f(u('u_value'), ...value);
    });
    draw();
  };
  // controls
  const box = $('params');
  for (const name of D.names) {
    const v = params[name];
    const lo = v > 0 ? 0 : v < 0 ? 2 * v : -1;
    const hi = v > 0 ? 2 * v : v < 0 ? 0 : 1;
    const row = document.createElement('div'); row.className = 'p';
    const label = document.createElement('span'); label.textContent = name;
    const slider = document.createElement('input');
    Object.assign(slider, { type: 'range', min: lo, max: hi, step: (hi - lo) / 1000, value: v });
    slider.setAttribute('aria-label', name);
    const num = document.createElement('input');
    Object.assign(num, { type: 'number', step: 'any', value: Number(v.toPrecision(6)) });
    num.setAttribute('aria-label', `${name} value`);
    slider.addEventListener('input', () => { params[name] = Number(slider.value); num.value = Number(Number(slider.value).toPrecision(6)); });
    num.addEventListener('change', () => { params[name] = Number(num.value); slider.value = num.value; });
    row.append(label, slider, num); box.append(row);
  }
  const spf = $('spf');
  for (const n of D.stepsChoices) spf.add(new Option(String(n), String(n)));
  spf.value = String(D.stepsPerFrame);
  $('about').textContent = `${D.model} on ${D.width} × ${D.height} (${D.boundary}, ${D.stencil}-point stencil), explicit Euler, dt = ${Number(dt.toPrecision(4))}; `
    + `showing ${D.species[D.show]}. Made by morphogen export-web; runs on this device (${page.renderer}).`;
  $('run').addEventListener('click', () => { page.running = !page.running; $('run').textContent = page.running ? 'Pause' : 'Run'; });
  $('step').addEventListener('click', () => { page.advance(Number(spf.value)); draw(); });
  $('reset').addEventListener('click', () => page.reset());
  let down = false;
  const at = (ev) => { const r = canvas.getBoundingClientRect(); page.paint((ev.clientX - r.left) / r.width, (ev.clientY - r.top) / r.height); };
  canvas.addEventListener('pointerdown', (ev) => { down = true; canvas.setPointerCapture(ev.pointerId); at(ev); });
  canvas.addEventListener('pointermove', (ev) => { if (down) at(ev); });
  canvas.addEventListener('pointerup', () => { down = false; });
  let last = performance.now(); let count = 0;
  const loop = () => {
    if (page.running) {
      page.advance(Number(spf.value));
      count += Number(spf.value);
      draw();
    }
    const now = performance.now();
    if (now - last > 1000) {
      $('stats').textContent = `${(count * 1000 / (now - last)).toFixed(0)} steps/s · t = ${page.t.toFixed(2)}`;
      count = 0; last = now;
    }
    requestAnimationFrame(loop);
  };
  draw();
  page.ready = true;
  requestAnimationFrame(loop);
}
