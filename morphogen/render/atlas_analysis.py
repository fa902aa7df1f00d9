"""An atlas's tiles with the linear analysis' boundaries drawn over them.

Each tile of a two-parameter atlas is a square coloured by its pattern family (or valid and
blown-up only); over them, on a finer grid of the same plane, the lines where the homogeneous
states change (:mod:`morphogen.models.stability_map`): the saddle-node line where the number of
fixed points changes, the edge of the region with a Hopf-unstable (oscillatory) state and the
edge of the region with a Turing-unstable state. Axes in parameter units, ``y`` upwards.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from morphogen.util.io import atomic_path

LINES = {"saddle-node": ("black", "-"), "Hopf": ("#d000d0", "--"), "Turing": ("#ffd700", "-")}
"""Colour and style of each boundary."""


def _edges(values: np.ndarray) -> tuple[float, float]:
    """The outer edges of tiles centred on evenly spaced ``values``."""
    step = (values[-1] - values[0]) / max(len(values) - 1, 1) if len(values) > 1 else 1.0
    return float(values[0] - step / 2), float(values[-1] + step / 2)


DEGENERATE = 8
"""More fixed points than this at one parameter set: a continuum (e.g. Gray-Scott at F = 0,
where every ``(u, 0)`` is one), left out of the saddle-node line."""


def _more_states(count: np.ndarray) -> np.ndarray:
    """1 where there are more fixed points than the fewest found in the window, 0 elsewhere,
    NaN where they form a continuum: its 0.5 contour is the saddle-node line."""
    field = count.astype(float)
    field[count > DEGENERATE] = np.nan
    if np.isnan(field).all():
        return field
    return np.where(np.isnan(field), np.nan, (field > np.nanmin(field)).astype(float))


def atlas_analysis_png(path: str | Path, x: tuple[str, np.ndarray], y: tuple[str, np.ndarray],
                       tiles: np.ndarray, legend: Mapping[str, str],
                       fine: tuple[np.ndarray, np.ndarray], count: np.ndarray,
                       regions: Mapping[str, np.ndarray], title: str, dpi: int = 110) -> Path:
    """Write the picture.

    Args:
        x, y: each axis' parameter name and tile values.
        tiles: ``(ny, nx, 3)`` uint8, the tile colours, row 0 at the smallest ``y``.
        legend: tile colour (``#rrggbb``) by label, for the families present.
        fine: the finer grid's ``x`` and ``y`` values.
        count: fixed points found, ``(len(fine y), len(fine x))``.
        regions: ``"Hopf"`` and ``"Turing"`` masks of the same shape.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    fig, ax = plt.subplots(figsize=(7.2, 6.4), dpi=dpi)
    (xl, xv), (yl, yv) = x, y
    ax.imshow(tiles, origin="lower", extent=(*_edges(xv), *_edges(yv)), aspect="auto",
              interpolation="nearest")
    fx, fy = fine
    handles = [Patch(color=c, label=name) for name, c in legend.items()]
    fields = {"saddle-node": _more_states(count), **{k: v.astype(float) for k, v in
                                                     regions.items()}}
    for name, field in fields.items():
        colour, style = LINES[name]
        if not (np.nanmax(field) > 0.5 > np.nanmin(field)):
            continue  # no boundary in this window
        ax.contour(fx, fy, np.ma.masked_invalid(field), levels=[0.5], colors=colour,
                   linestyles=style, linewidths=1.6)
        handles.append(Line2D([], [], color=colour, linestyle=style, lw=1.6, label=name))
    ax.set_xlabel(xl)
    ax.set_ylabel(yl)
    ax.set_title("\n".join(textwrap.wrap(title, 90)), fontsize=8)
    ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0),
              frameon=False)
    fig.tight_layout()
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)
    return Path(path)
