"""Settings and pictures of batched runs (Atlas, Evolve): validated run settings, tile mosaics."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from morphogen.models.model import Model
from morphogen.render.colour import colour_limits, colourise
from morphogen.render.mosaic import frame_tiles
from morphogen.web.limits import Limits
from morphogen.web.settings import INITIAL_KINDS, read_settings

BATCH_SETTINGS = ("size", "dx", "boundary", "stencil", "dt", "seed", "init", "species")
"""The run settings of a batched web run read from its body (``steps`` follows ``dt``)."""


def settings(body: Mapping[str, Any], model: Model, base: Mapping[str, float], limits: Limits,
             *, tile_default: int) -> dict[str, Any]:
    """Validated ``tile`` (the body's ``tile``: cells per side), ``dx``, ``boundary``,
    ``stencil``, ``dt``, ``steps``, ``init``, ``seed`` and shown ``species``
    (:func:`morphogen.web.settings.read_settings`).

    ``dt`` and ``steps`` are ``None`` where the body gives none: the run policy fills them in
    once the grid and the batch are known (:func:`morphogen.runs.atlas.plan_atlas`); the
    initial condition defaults to the model's.
    """
    run = read_settings(
        body, BATCH_SETTINGS, keys={"size": "tile"}, labels={"size": "tile size"},
        bounds={"size": (8, limits.max_tile_size)},
        defaults={"size": tile_default, "species": model.display_species,
                  "init": model.init if model.init in INITIAL_KINDS else "square"})
    steps = read_settings(body, ("steps",))
    model.species_index(run["species"])
    tile = run.pop("size")
    dt = None if run["dt"] is None else float(run["dt"])
    return {**run, "tile": tile, "dt": dt, **steps}


HATCH = (6, 2)
"""Hatching of a tile drawn as not a pattern: white diagonal stripes, ``2`` pixels of every
``6`` (pixels with ``(row + col) mod 6 < 2``)."""


def hatch(tiles: np.ndarray, marked: np.ndarray) -> np.ndarray:
    """A copy of ``tiles`` ``(B, H, W, 3)`` uint8 with the ``marked`` ``(B,)`` ones hatched in
    white (:data:`HATCH`)."""
    period, width = HATCH
    h, w = tiles.shape[1:3]
    stripes = (np.add.outer(np.arange(h), np.arange(w)) % period) < width
    out = np.array(tiles, copy=True)
    out[np.asarray(marked, bool)[:, None, None] & stripes[None]] = 255
    return out


def mosaic(states: np.ndarray, model: Model, species: str, cmap: str,
           shape: tuple[int, int], pad: int, valid: np.ndarray | None = None,
           labels: np.ndarray | None = None,
           colours: Mapping[str, str] | None = None) -> np.ndarray:
    """Members ``(B, S, n, n)`` laid out row-major in a ``(rows, cols)`` grid with ``pad`` white
    pixels between tiles: ``(rows (n + pad) + pad, cols (n + pad) + pad, 3)`` uint8.

    All tiles share one colour scale, the range of the valid members (``valid`` ``(B,)``);
    blown-up members show in the NaN colour, and every member that is not valid (blown up, or
    numerically unstable) is hatched (:func:`hatch`), so it never passes for a pattern. With
    ``labels`` ``(B,)`` (e.g. pattern families) every tile is framed in its label's colour from
    ``colours`` (:func:`morphogen.render.mosaic.frame_tiles`, frames only: the page names them).
    """
    fields = np.asarray(states[:, model.species_index(species)], np.float64)
    ok = np.ones(len(fields), bool) if valid is None else np.asarray(valid, bool)
    lo, hi = colour_limits(fields[ok] if ok.any() else fields)
    tiles = hatch(np.stack([colourise(f, cmap, lo, hi) for f in fields]), ~ok)
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
