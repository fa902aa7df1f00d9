"""Batched runs shared by the Atlas and Evolve pages: settings, chunked simulation, tile images.

A batch of ``B`` parameter sets on small ``tile x tile`` periodic grids is one vmapped, jitted
program (:func:`morphogen.simulate.simulate_batch`). It runs in :data:`CHUNKS` compiled pieces so
that the job reports progress and stops at its deadline between pieces; each piece continues
from the previous state.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from morphogen.domains.grid import Grid
from morphogen.errors import MorphogenError
from morphogen.initial import make_initial
from morphogen.models.model import Model
from morphogen.render.colour import colourise, parse_cmap
from morphogen.simulate import simulate_batch
from morphogen.steppers import batch_params
from morphogen.web.limits import Limits, choice, integer, number
from morphogen.web.live import INITIAL_KINDS

CHUNKS = 8
MAX_STEPS = 200_000


def settings(body: Mapping[str, Any], model: Model, base: Mapping[str, float], limits: Limits,
             *, tile_default: int) -> dict[str, Any]:
    """Validated ``tile``, ``dt``, ``steps``, ``init``, ``seed`` and shown ``species``.

    Defaults are the model's suggestions (``model.dt``, ``model.t_end / dt``, ``model.init``).
    """
    tile = integer(body.get("tile", tile_default), "tile size", 8, limits.max_tile_size)
    dt = body.get("dt")
    dt = model.dt if dt is None else number(dt, "dt", 1e-6, 1e3)
    steps = body.get("steps")
    steps = int(round(model.t_end / dt)) if steps is None else steps
    steps = integer(steps, "steps", 1, MAX_STEPS)
    init = body.get("init") or (model.init if model.init in INITIAL_KINDS else "square")
    init = choice(init, "initial condition", INITIAL_KINDS)
    seed = integer(body.get("seed", 0), "seed", 0, 2**31 - 1)
    species = body.get("species") or model.display_species
    model.species_index(species)
    return {"tile": tile, "dt": float(dt), "steps": steps, "init": init, "seed": seed,
            "species": species}


def colour_map(name: Any) -> str:
    """A validated colour-map name or ramp."""
    if not isinstance(name, str) or len(name) > 200:
        raise MorphogenError("colour map must be a name such as 'viridis'")
    parse_cmap(name)
    return name


def run(model: Model, base: Mapping[str, float], values: Mapping[str, np.ndarray],
        settings: Mapping[str, Any], progress, what: str) -> tuple[np.ndarray, np.ndarray]:
    """Simulate ``B`` members whose parameters ``values[name]`` ``(B,)`` override ``base``.

    Every member starts from the same initial condition kind and seed, built from its own
    parameters (its own ground state). Returns the final states ``(B, S, n, n)`` and a validity
    mask ``(B,)`` (false for members that blew up).
    """
    sizes = {len(v) for v in values.values()}
    if len(sizes) != 1:
        raise MorphogenError("every batched parameter needs the same number of values")
    b = sizes.pop()
    n = settings["tile"]
    grid = Grid((n, n))
    members = [{**base, **{k: float(v[i]) for k, v in values.items()}} for i in range(b)]
    progress(0.0, f"{what}: preparing {b} runs")
    u = np.stack([make_initial(settings["init"], model, grid, m, seed=settings["seed"])
                  for m in members])
    params = batch_params(base, b)
    params.update({k: np.asarray(v, np.float32) for k, v in values.items()})
    valid = np.ones(b, bool)
    steps, done = settings["steps"], 0
    chunk = max(1, -(-steps // CHUNKS))
    while done < steps:
        k = min(chunk, steps - done)
        sol = simulate_batch(model, grid, u, params, steps=k, dt=settings["dt"],
                             seed=settings["seed"] + done, clamp=model.clamp)
        u, valid = sol.state, valid & sol.valid
        done += k
        progress(done / steps, f"{what}: {done} of {steps} steps, {b} runs at once")
    return np.asarray(u), valid


def tiles(states: np.ndarray, model: Model, species: str, cmap: str) -> np.ndarray:
    """Each member's ``species`` through ``cmap`` with its own colour scale:
    ``(B, S, n, n)`` -> ``(B, n, n, 3)`` uint8 (blown-up members in the NaN colour)."""
    i = model.species_index(species)
    return np.stack([colourise(s[i], cmap) for s in states])


def mosaic(states: np.ndarray, model: Model, species: str, cmap: str,
           shape: tuple[int, int], pad: int) -> np.ndarray:
    """Tiles laid out row-major in a ``(rows, cols)`` grid with ``pad`` white pixels between
    them: ``(rows (n + pad) + pad, cols (n + pad) + pad, 3)`` uint8."""
    rgb = tiles(states, model, species, cmap)
    rows, cols = shape
    n = rgb.shape[1]
    out = np.full((rows * (n + pad) + pad, cols * (n + pad) + pad, 3), 255, np.uint8)
    for idx in range(rows * cols):
        r, c = divmod(idx, cols)
        y, x = pad + r * (n + pad), pad + c * (n + pad)
        out[y:y + n, x:x + n] = rgb[idx]
    return out
