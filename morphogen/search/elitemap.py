"""The picture of a MAP-Elites archive: one tile per filled cell, framed by pattern family.

The elites are re-evaluated as one batch on the usual ``evaluate(genomes, key)`` path (their
final fields are not stored), placed on the ``bins × bins`` grid of the two descriptors with the
first descriptor across and the second up, and framed in the colour of the family their final
field is classified as (spatial rules only: one state has no dynamics, see
:mod:`morphogen.patterns.classify`). Empty cells are left blank.
"""

from __future__ import annotations

from typing import Any

import jax
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.patterns.classify import COLOURS, classify
from morphogen.patterns.descriptors import TEMPORAL, describe
from morphogen.render.mosaic import atlas_image, frame_tiles
from morphogen.search.mapelites import MapElites
from morphogen.search.report import tiles
from morphogen.search.strategy import Evaluate, State


def elite_map(strategy: MapElites, state: State, evaluate: Evaluate, key: Any, *,
              cmap: str = "viridis") -> tuple[np.ndarray, dict[int, str]]:
    """An RGB image of the archive and the family of each filled cell (``cell -> family``).

    Raises:
        MorphogenError: the archive is empty, or does not have two descriptors.
    """
    if len(strategy.descriptors) != 2:
        raise MorphogenError("an elite map needs a MAP-Elites archive over two descriptors")
    fitness = np.asarray(state.inner.fitness)
    cells = np.flatnonzero(np.isfinite(fitness))
    if cells.size == 0:
        raise MorphogenError("the MAP-Elites archive is empty: no elite to draw")
    genomes = np.asarray(state.inner.genomes)[cells]
    _, metrics = evaluate(genomes, key)
    fields = np.asarray(metrics["fields"])
    rgb = tiles(fields, cmap)
    desc = {k: np.asarray(v) for k, v in jax.vmap(describe)(fields.astype(np.float32)).items()}
    desc.update({k: np.zeros(len(cells)) for k in TEMPORAL})
    labels = classify(desc, metrics.get("valid"))
    b = int(strategy.bins)
    h, w = rgb.shape[1:3]
    grid = np.full((b, b, h, w, 3), 255, np.uint8)
    names = np.full((b, b), "", object)
    for tile, cell, label in zip(rgb, cells, labels, strict=True):
        grid[cell // b, cell % b], names[cell // b, cell % b] = tile, label
    filled = names != ""
    grid[filled] = frame_tiles(grid[filled], names[filled], COLOURS)
    centres = [lo + (hi - lo) * (np.arange(b) + 0.5) / b for lo, hi in strategy.ranges]
    image = atlas_image(grid, strategy.descriptors[0], centres[0], strategy.descriptors[1],
                        centres[1], title=f"MAP-Elites: {cells.size} of {b * b} cells")
    return image, {int(c): str(n) for c, n in zip(cells, labels, strict=True)}
