"""Settings and pictures of batched runs (Atlas, Evolve): validated run settings, tile mosaics."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.render.colour import colour_limits, colourise, parse_cmap
from morphogen.render.mosaic import frame_tiles
from morphogen.web.limits import Limits, choice, integer, number
from morphogen.web.live import INITIAL_KINDS

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


def mosaic(states: np.ndarray, model: Model, species: str, cmap: str,
           shape: tuple[int, int], pad: int, valid: np.ndarray | None = None,
           labels: np.ndarray | None = None,
           colours: Mapping[str, str] | None = None) -> np.ndarray:
    """Members ``(B, S, n, n)`` laid out row-major in a ``(rows, cols)`` grid with ``pad`` white
    pixels between tiles: ``(rows (n + pad) + pad, cols (n + pad) + pad, 3)`` uint8.

    All tiles share one colour scale, the range of the valid members (``valid`` ``(B,)``);
    blown-up members show in the NaN colour. With ``labels`` ``(B,)`` (e.g. pattern families)
    every tile is framed in its label's colour from ``colours``
    (:func:`morphogen.render.mosaic.frame_tiles`, frames only: the page names them).
    """
    fields = np.asarray(states[:, model.species_index(species)], np.float64)
    ok = np.ones(len(fields), bool) if valid is None else np.asarray(valid, bool)
    lo, hi = colour_limits(fields[ok] if ok.any() else fields)
    tiles = np.stack([colourise(f, cmap, lo, hi) for f in fields])
    if labels is not None:
        tiles = frame_tiles(tiles, np.asarray(labels), colours or {}, text=False)
    rows, cols = shape
    n = fields.shape[1]
    out = np.full((rows * (n + pad) + pad, cols * (n + pad) + pad, 3), 255, np.uint8)
    for idx in range(rows * cols):
        r, c = divmod(idx, cols)
        y, x = pad + r * (n + pad), pad + c * (n + pad)
        out[y:y + n, x:x + n] = tiles[idx]
    return out
