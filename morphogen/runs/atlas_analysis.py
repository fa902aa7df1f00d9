"""An atlas and the linear analysis together (``morphogen atlas --analysis``): where the tiles'
patterns sit against the saddle-node, Hopf and Turing boundaries of the model's homogeneous
states (:mod:`morphogen.models.stability_map`), on a grid :data:`FINE` times finer than the
tiles, with the atlas's other parameters, grid and stencil. Richard et al.'s fig. 9 (seed 001,
§5.2.1) is such a map of Gray-Scott's ``(k, F)`` plane, without the lines.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.linear import lattice_modes
from morphogen.models.model import Model
from morphogen.models.stability_map import stability_map
from morphogen.render.atlas_analysis import atlas_analysis_png

FINE = 8
"""Analysis points per tile along each axis."""
MAX_FINE = 121
"""At most this many analysis points along an axis."""
MODES = 128
"""Grid modes sampled (evenly in ``κ²``, the homogeneous one first) for the Turing test."""
VALID, INVALID = "#9e9e9e", "#000000"
UNSTABLE = "numerically unstable"


def _fine(values: np.ndarray) -> np.ndarray:
    n = min(MAX_FINE, FINE * (len(values) - 1) + 1) if len(values) > 1 else 1
    return np.linspace(values[0], values[-1], n)


def plane_values(model: Model, grid: Any, params: dict[str, Any], x: str, y: str
                 ) -> dict[str, float]:
    """The atlas's other parameters as numbers (its axes at 0), checked before the atlas runs:
    a parameter that varies in space has no homogeneous state to analyse.

    Raises:
        MorphogenError: such a parameter.
    """
    from morphogen.engine.fields import resolve_params

    values = resolve_params(model, grid, model.parameters({**params, x: 0.0, y: 0.0}))
    for name, value in values.items():
        if np.ndim(value) != 0:
            raise MorphogenError(f"--analysis needs every parameter to be a number; {name} "
                                 "varies in space")
    return {k: float(v) for k, v in values.items()}


def analyse_atlas(model: Model, grid: Any, x: tuple[str, np.ndarray],
                  y: tuple[str, np.ndarray], values: dict[str, float]
                  ) -> tuple[tuple[np.ndarray, np.ndarray], np.ndarray, dict[str, np.ndarray]]:
    """``((fine x, fine y), count, {"Hopf": mask, "Turing": mask})`` over the atlas's plane,
    ``values`` the other parameters (:func:`plane_values`)."""
    fx, fy = _fine(x[1]), _fine(y[1])
    xx, yy = np.meshgrid(fx, fy)
    params = {k: np.full(xx.size, float(v)) for k, v in values.items()}
    params[x[0]], params[y[0]] = xx.ravel(), yy.ravel()
    kappa2 = np.unique(lattice_modes(grid.shape, grid.symbol).kappa2)
    pick = np.unique(np.linspace(0, len(kappa2) - 1, MODES).round().astype(int))
    smap = stability_map(model, params, kappa2[pick])
    shape = xx.shape
    return (fx, fy), smap.count.reshape(shape), {"Hopf": smap.hopf.reshape(shape),
                                                  "Turing": smap.turing.reshape(shape)}


def tile_colours(labels: np.ndarray | None, valid: np.ndarray,
                 colours: dict[str, str]) -> tuple[np.ndarray, dict[str, str]]:
    """``(ny, nx, 3)`` uint8 tile colours (row ``i`` the atlas's ``y.values[i]``, as it stores
    them) and the legend: each family's colour, or valid / numerically unstable (blew up or
    ended in a grid-scale checkerboard)."""
    if labels is None:
        names = np.where(valid, "valid", UNSTABLE)
        colours = {"valid": VALID, UNSTABLE: INVALID}
    else:
        names = labels
    present = {n: colours[n] for n in colours if (names == n).any()}
    rgb = {n: [int(c[i:i + 2], 16) for i in (1, 3, 5)] for n, c in present.items()}
    tiles = np.array([[rgb[n] for n in row] for row in names], np.uint8)
    return tiles, present


def write_atlas_analysis(out: Path, model: Model, grid: Any, x: tuple[str, np.ndarray],
                         y: tuple[str, np.ndarray], values: dict[str, float],
                         labels: np.ndarray | None, valid: np.ndarray,
                         colours: dict[str, str], title: str) -> dict[str, Any]:
    """Write ``out/analysis.png`` and return what ``atlas.json`` records of it."""
    fine, count, regions = analyse_atlas(model, grid, x, y, values)
    tiles, legend = tile_colours(labels, valid, colours)
    atlas_analysis_png(out / "analysis.png", x, y, tiles, legend, fine, count, regions, title)
    return {"points": [len(fine[0]), len(fine[1])],
            "fixed_points": {int(n): int((count == n).sum()) for n in np.unique(count)},
            "turing": round(float(regions["Turing"].mean()), 4),
            "hopf": round(float(regions["Hopf"].mean()), 4)}
