// Explore's settings as one object, so that nothing the designer set is lost: a server restart
// (the session is gone), a grid change or a refused request all go back through these.

export const EQUATIONS = '__equations__';
export const EXAMPLE = `# a model file (TOML): parameters stay runtime values, lap() is diffusion
name = "schnakenberg-pasted"
species = ["u", "v"]
display = "u"
dt = 0.005
t_end = 60.0
init = "noise"

[parameters]
a = 0.1
b = 0.9
Du = 1.0
Dv = 40.0

[equations]
u = "a - u + u**2*v + Du*lap(u)"
v = "b - u**2*v + Dv*lap(v)"

[initial]
u = "a + b"
v = "b / (a + b)**2"
`;

// the view settings of a live state (the server's describe()): species, colours, steps per
// frame and a fixed colour range
export function viewOf(state) {
  const view = { cmap: state.cmap, species: state.show, steps_per_frame: state.steps_per_frame };
  if (Array.isArray(state.range)) view.range = [...state.range];
  return view;
}

// everything the page knows about a running simulation, as settings for Explore.load()
export function settingsOf(state, spec) {
  return {
    model: spec, params: { ...state.params }, dt: state.dt, size: state.size,
    height: state.height, dx: state.dx, boundary: state.boundary, scheme: state.scheme, init: state.init,
    seed: state.seed, view: viewOf(state),
  };
}

// Cost of one step of each scheme relative to explicit Euler on the same grid, from the
// server's scheme registry (`/api/models`' `scheme_costs`: periodic, and no flux, whose implicit
// solves are cosine transforms), used only to warn before a set-up that could not keep up.
const cost = (costs, scheme, boundary) => (costs?.[scheme]?.[boundary]) || 1;

// Seconds per frame to expect from `scheme` on `boundary` at `cells` cells and `steps` steps per
// frame, from the server's time per cell-step of the frames seen so far (null before any frame).
export function frameEstimate(seen, scheme, boundary, cells, steps, costs) {
  if (!seen) return null;
  const perCellStep = seen.ms / 1000 / (seen.cells * seen.steps)
    / cost(costs, seen.scheme, seen.boundary);
  return perCellStep * cost(costs, scheme, boundary) * cells * steps;
}

// The "Web page" button: the live view as one HTML file that runs without the server (WebGL2;
// morphogen export-web), from the state shown now; a setting it cannot run is named instead.
export async function downloadPage(x) {
  const button = x.$('ex-save-page');
  button.disabled = true;
  try {
    const res = await fetch(`/api/live/${x.sid}/page.html`);
    if (!res.ok) {
      const body = await res.json().catch(() => ({}));
      throw new Error(body.error || `${res.status} ${res.statusText}`);
    }
    const url = URL.createObjectURL(await res.blob());
    const a = document.createElement('a');
    a.href = url;
    a.download = `${x.state.model}.html`;
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 10000);
    x.pageExported = (x.pageExported || 0) + 1;
  } catch (err) {
    x.$('ex-error').textContent = `web page: ${err.message}`;
    x.$('ex-error').hidden = false;
  } finally {
    button.disabled = false;
  }
}

// The painted state, kept in the page once a stroke has reached the server whole (the
// checkpoint's bytes and its time), so that a server restart does not lose it: recover() puts
// both back.
export async function keepCheckpoint(x) {
  const sid = x.sid;
  try {
    const res = await fetch(`/api/live/${sid}/state.npz`);
    if (res.ok && sid === x.sid) {
      x.kept = await res.arrayBuffer();
      x.keptTime = Number(res.headers.get('X-Morphogen-Time') ?? 0);
    }
  } catch { /* the server is away: the last kept state stays */ }
}

export function toBase64(buf) {
  const bytes = new Uint8Array(buf);
  let text = '';
  for (let i = 0; i < bytes.length; i += 0x8000) text += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(text);
}

// put checkpoint bytes back into the live view (one undo step), at time `t` when given; the
// server's undo count
export async function putCheckpoint(x, buf, t = undefined) {
  const body = { npz: toBase64(buf), ...(Number.isFinite(t) ? { t } : {}) };
  const res = await fetch(`/api/live/${x.sid}/state`, {
    method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body),
  });
  const answer = await res.json().catch(() => ({}));
  if (!res.ok) throw new Error(answer.error || `${res.status} ${res.statusText}`);
  x.tools.setUndo(answer.undo);
  return answer.undo;
}

// A checkpoint chosen in the file box (a state.npz the Checkpoint link or `morphogen simulate`
// wrote) replaces the whole state, one undo step like a stroke.
export async function restoreCheckpoint(x) {
  const input = x.$('ex-restore');
  const file = input.files[0];
  input.value = '';
  if (!file || !x.sid) return;
  try {
    await putCheckpoint(x, await file.arrayBuffer());
    x.$('ex-error').hidden = true;
    x.restored = (x.restored || 0) + 1;
    if (!x.running) x.request(true, true);
  } catch (err) {
    x.$('ex-error').textContent = `${file.name}: ${err.message}`;
    x.$('ex-error').hidden = false;
  }
}
