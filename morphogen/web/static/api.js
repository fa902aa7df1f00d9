// Small helpers shared by the pages: JSON requests with a time limit, error boxes, colour
// lookup tables, job polling.

export class ApiError extends Error {
  constructor(message, status, body) {
    super(message);
    this.status = status;
    this.body = body || {};
  }
}

// fetch JSON (or bytes with {binary: true}); any failure becomes an ApiError with the
// server's one-line message, and a request that takes too long is aborted.
export async function api(path, { method = 'GET', body, binary = false, timeoutMs = 60000 } = {}) {
  const ctrl = new AbortController();
  const timer = setTimeout(() => ctrl.abort(), timeoutMs);
  let res;
  try {
    res = await fetch(path, {
      method,
      headers: body !== undefined ? { 'Content-Type': 'application/json' } : {},
      body: body !== undefined ? JSON.stringify(body) : undefined,
      signal: ctrl.signal,
    });
  } catch (err) {
    throw new ApiError(ctrl.signal.aborted
      ? `the server did not answer within ${timeoutMs / 1000} s`
      : `cannot reach the server (${err.message})`, 0);
  } finally {
    clearTimeout(timer);
  }
  if (!res.ok) {
    let data = {};
    try { data = await res.json(); } catch { /* not JSON */ }
    throw new ApiError(data.error || `${res.status} ${res.statusText}`, res.status, data);
  }
  return binary ? res.arrayBuffer() : res.json();
}

export function showError(el, message) {
  el.textContent = message;
  el.hidden = !message;
}

export function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'class') node.className = v;
    else if (k === 'text') node.textContent = v;
    else if (k.startsWith('on')) node.addEventListener(k.slice(2), v);
    else node.setAttribute(k, v);
  }
  for (const c of children) if (c != null) node.append(c);
  return node;
}

export function fillSelect(select, options, value) {
  select.replaceChildren(...options.map((o) => {
    const [v, label] = Array.isArray(o) ? o : [o, o];
    return el('option', { value: v, text: label });
  }));
  if (value !== undefined) select.value = value;
}

const lutCache = new Map();

// 256 x RGB lookup table of a colour map, as a Uint8Array of 768 bytes.
export async function colourTable(name) {
  if (!lutCache.has(name)) {
    const buf = await api(`/api/colormap?name=${encodeURIComponent(name)}`, { binary: true });
    lutCache.set(name, new Uint8Array(buf));
  }
  return lutCache.get(name);
}

// Poll a background job until it finishes; onProgress(job) after each poll.
// Resolves with the finished job's result; rejects with its error.
export async function waitForJob(id, onProgress, { intervalMs = 300 } = {}) {
  for (;;) {
    const job = await api(`/api/jobs/${id}`);
    onProgress(job);
    if (job.status === 'done') return job.result;
    if (job.status === 'error' || job.status === 'cancelled') {
      throw new ApiError(job.error || job.status, 0, job);
    }
    await new Promise((r) => setTimeout(r, intervalMs));
  }
}

export function fmt(x) {
  if (!Number.isFinite(x)) return String(x);
  const a = Math.abs(x);
  if (a !== 0 && (a < 1e-3 || a >= 1e5)) return x.toExponential(3);
  return String(Number(x.toPrecision(4)));
}
