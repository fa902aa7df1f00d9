// Explore's settings in the page address: #explore?model=gray-scott&p.F=0.037&size=256&...
// so a copied link or a reload starts the same run (same model, parameters, grid, its spacing dx
// when not 1, boundary, scheme, initial condition and seed) with the same view. Pasted equations
// travel as `eq`.
// Everything read back goes to the server's checks like any control's value.

const VIEW = { cmap: 'cmap', species: 'show', steps_per_frame: 'spf' };

// the query string of a live state (the server's describe()) and the model spec
export function encodeState(state, spec) {
  const q = new URLSearchParams();
  if (spec.library) q.set('model', spec.library);
  else q.set('eq', spec.equations);
  for (const [name, v] of Object.entries(state.params)) q.set(`p.${name}`, String(v));
  q.set('dt', String(state.dt));
  q.set('size', String(state.size));
  if (state.height !== state.size) q.set('height', String(state.height));
  if (state.dx !== undefined && state.dx !== 1) q.set('dx', String(state.dx));
  q.set('boundary', state.boundary);
  q.set('scheme', state.scheme);
  q.set('init', state.init);
  q.set('seed', String(state.seed));
  for (const [key, short] of Object.entries(VIEW)) {
    const v = key === 'species' ? state.show : state[key];
    q.set(short, String(v));
  }
  if (Array.isArray(state.range)) q.set('range', state.range.join(','));
  return q.toString();
}

// settings for Explore.load() from a query string; null when it names no model
export function decodeSettings(query) {
  const q = new URLSearchParams(query);
  const model = q.get('model') ? { library: q.get('model') }
    : (q.get('eq') ? { equations: q.get('eq') } : null);
  if (!model) return null;
  const params = {};
  for (const [k, v] of q) if (k.startsWith('p.')) params[k.slice(2)] = Number(v);
  const num = (k) => (q.has(k) ? Number(q.get(k)) : undefined);
  const view = {};
  for (const [key, short] of Object.entries(VIEW)) {
    if (q.has(short)) view[key] = key === 'steps_per_frame' ? Number(q.get(short)) : q.get(short);
  }
  if (q.has('range')) view.range = q.get('range').split(',').map(Number);
  return {
    model, params, dt: num('dt'), size: num('size'), height: num('height') ?? num('size'), dx: num('dx'),
    boundary: q.get('boundary') ?? undefined, scheme: q.get('scheme') ?? undefined,
    init: q.get('init') ?? undefined, seed: num('seed'), view,
  };
}

// the query part of the address's #explore?... (empty when there is none)
export function currentQuery() {
  const hash = window.location.hash;
  const at = hash.indexOf('?');
  return at < 0 ? '' : hash.slice(at + 1);
}

// settings for Explore.load() from a run file or run record (`run.json`: `{"config": {...}}`,
// morphogen.runs.runfile) that the command line or the Save button wrote
export function settingsFromRunFile(data) {
  const c = data?.config;
  if (!c || typeof c !== 'object' || Array.isArray(c)) {
    throw new Error('not a run file: it has no "config" object (see docs/equations.md)');
  }
  if (c.mesh) throw new Error('this run is on a mesh; the Explore page runs grids only');
  if (c.boundary !== undefined && typeof c.boundary !== 'string') {
    throw new Error('this run gives each species its own boundary; Explore takes one for all');
  }
  const size = Array.isArray(c.size) ? c.size : [256, 256];
  if (size.length !== 2) throw new Error(`Explore runs 2D grids; this run's size is ${JSON.stringify(size)}`);
  const resolved = data.resolved || {};
  const scheme = c.scheme === 'auto' ? resolved.scheme : c.scheme;
  const view = {};
  if (c.cmap) view.cmap = c.cmap;
  if (c.species) view.species = c.species;
  if (Number.isFinite(c.vmin) && Number.isFinite(c.vmax)) view.range = [c.vmin, c.vmax];
  return {
    model: c.model_source ? { equations: c.model_source } : { library: c.model },
    preset: c.preset || undefined, params: c.params || {}, dt: c.dt ?? resolved.dt,
    height: size[0], size: size[1], dx: c.dx ?? undefined, boundary: c.boundary, scheme,
    init: c.init ?? undefined,
    seed: c.seed ?? 0, view,
  };
}
