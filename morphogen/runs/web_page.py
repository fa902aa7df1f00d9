"""``morphogen export-web``: a run as one self-contained HTML page that runs in WebGL2.

The page needs nothing but a browser: no server, no network, no CDN. It holds the model's
step as a fragment shader generated from the model's own equations
(:func:`morphogen.render.webgl.step_shader`), the run's parameters, ``dt``, grid, stencil,
boundary and colour map, and the initial state itself (float32, so a painted or loaded state
travels too). It offers a slider per parameter, a brush (the model's excited state), pause,
step and reset, and works with a finger on a phone. ``window.morphogenPage`` lets a test step
it and read the state back.

Scope: 2D grids with explicit Euler, 5- or 9-point stencils, periodic or no-flux boundaries,
up to four species, scalar parameters, float32. Anything else is refused in one line naming it.
"""

from __future__ import annotations

import base64
from importlib import resources

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.render.colour import colourise, is_transfer
from morphogen.render.webgl import step_shader
from morphogen.runs.config import RunConfig
from morphogen.runs.prepare import prepare
from morphogen.util.markup import fill, html_text, script_json

STEPS_CHOICES = (1, 2, 4, 8, 16, 32, 64)


def check_exportable(config: RunConfig) -> None:
    """Refuse, in one line, what the exported page cannot run."""
    if config.mesh:
        raise MorphogenError("export-web: meshes are not supported; the page runs 2D grids")
    if len(config.size) != 2:
        raise MorphogenError(f"export-web: a {len(config.size)}D grid is not supported; "
                             "the page runs 2D grids")
    if config.scheme not in ("euler", "auto"):
        raise MorphogenError(f"export-web: scheme {config.scheme!r} is not supported; the page "
                             "steps with explicit Euler (--scheme euler)")
    if not isinstance(config.boundary, str) or config.boundary not in ("periodic", "neumann"):
        raise MorphogenError(f"export-web: boundary {config.boundary!r} is not supported; use "
                             "periodic or neumann")
    if config.stencil not in (None, 5, 9):
        raise MorphogenError(f"export-web: stencil {config.stencil!r} is not supported; use 5 "
                             "or 9")
    if config.noise:
        raise MorphogenError("export-web: noise is not supported")
    if config.clamp != "model":
        raise MorphogenError("export-web: --clamp is not supported; the page keeps the model's "
                             "own bounds")
    if config.threshold is not None:
        raise MorphogenError("export-web: --threshold is not supported; use a colour map")
    if config.precision != "float32":
        raise MorphogenError("export-web: float64 is not supported; the page computes in "
                             "float32")
    if config.cmap and is_transfer(config.cmap):
        raise MorphogenError("export-web: transfer-function colour maps are not supported; "
                             "use a colour map name or ramp")


def export_page(config: RunConfig, state: np.ndarray | None = None) -> str:
    """The HTML text of the page for ``config`` (``state``, shape ``(S, h, w)``: start from it
    instead of the configured initial condition)."""
    check_exportable(config)
    prep = prepare(config)
    model = prep.model
    h, w = prep.domain.spatial_shape
    stencil = config.stencil or 5
    for name, value in prep.params.items():
        if np.ndim(value) != 0:
            raise MorphogenError(f"export-web: parameter {name} is a field (a map); the page "
                                 "takes one number per parameter")
    values = {k: float(v) for k, v in prep.params.items()}
    shader = step_shader(model, values, boundary=config.boundary, stencil=stencil,
                         dx=config.dx)
    u0 = np.asarray(prep.u0 if state is None else state, np.float32)
    if u0.shape != (len(model.species), h, w):
        raise MorphogenError(f"export-web: the state has shape {u0.shape}, expected "
                             f"{(len(model.species), h, w)}")
    rgba = np.zeros((h, w, 4), np.float32)
    rgba[..., : len(model.species)] = np.moveaxis(u0, 0, -1)
    cmap = config.cmap or "viridis"
    lut = colourise(np.linspace(0.0, 1.0, 256), cmap, 0.0, 1.0)
    show = model.species_index(config.species or model.display_species)
    excited = [float(v) for v in model.excited_state(prep.params)]
    spf = max(1, min(64, round(model.t_end / prep.dt / 300))) if np.isfinite(model.t_end) else 8
    spf = min(STEPS_CHOICES, key=lambda n: abs(np.log(n / spf)))
    data = {
        "model": model.name, "species": list(model.species), "show": show,
        "params": values, "names": list(shader.params), "dt": prep.dt, "width": w, "height": h,
        "boundary": config.boundary, "stencil": stencil, "dx": config.dx, "cmap": cmap,
        "range": [config.vmin, config.vmax] if config.vmin is not None and
        config.vmax is not None else None,
        "excited": excited, "stepsPerFrame": spf, "stepsChoices": list(STEPS_CHOICES),
        "state": base64.b64encode(rgba.tobytes()).decode("ascii"),
        "lut": base64.b64encode(np.ascontiguousarray(lut, np.uint8).tobytes()).decode("ascii"),
    }
    title = f"{model.name}: {', '.join(f'{k} = {v:.4g}' for k, v in values.items())}"
    here = resources.files("morphogen.runs")
    template = here.joinpath("web_page.html").read_text(encoding="utf-8")
    script = here.joinpath("web_page.js").read_text(encoding="utf-8")
    # one pass over the template, each value escaped for where it lands: a name holding
    # "@DATA@" or "</script>" stays text (morphogen.util.markup)
    try:
        data_json = script_json(data)
    except ValueError:
        raise MorphogenError("export-web: a setting or the state is not a finite number; the "
                             "page holds finite numbers only") from None
    return fill(template, {"TITLE": html_text(title), "DATA": data_json,
                           "STEP": script_json(shader.source), "SCRIPT": script})
