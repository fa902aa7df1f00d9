"""Files a simulation run writes: ``state.npz``, ``final.png``, slices, an animation.

- ``state.npz``: one array per species, named by species (readable by ``--init FILE.npz``).
- ``final.png``: the display species through the colour map (or a two-colour threshold map),
  or the model's own colours (a neural model's RGB channels) when it has them and no species,
  colour map or threshold is asked for; 3D states show their mid-plane and add
  ``montage.png`` with a grid of slices.
- ``animation.gif`` / ``animation.mp4``: the snapshots on one colour scale.
- on a mesh: ``out.ply`` and a rendered picture (see :mod:`morphogen.domains.mesh`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from morphogen.models.model import Model
from morphogen.render import (
    colour_limits,
    slice_indices,
    slice_montage,
    state_image,
    threshold_map,
    to_uint8,
    write_animation,
    write_png,
)
from morphogen.render.mosaic import mosaic
from morphogen.util.io import write_npz

if TYPE_CHECKING:
    from morphogen.engine.simulate import Solution
    from morphogen.runs.config import RunConfig
    from morphogen.runs.prepare import Prepared

DEFAULT_CMAP = "viridis"
"""Colour map of a species when none is given."""


def write_outputs(out_dir: Path, prep: Prepared, solution: Solution) -> list[Path]:
    """Write every output of a single run; returns the paths written."""
    model, c = prep.model, prep.config
    arrays = {s: solution.state[i] for i, s in enumerate(model.species)}
    written = [write_npz(out_dir / "state.npz", arrays)]
    species = c.species or model.display_species
    index = model.species_index(species)
    own = model.colours if uses_own_colours(model, c) else None
    cmap = c.cmap or DEFAULT_CMAP
    if c.mesh:
        from morphogen.render.mesh_outputs import write_mesh_outputs

        rgb = None if own is None else to_uint8(own(solution.state))
        written += write_mesh_outputs(out_dir, prep.domain, model, solution.state, cmap,
                                      rgb=rgb)
        return written
    if own is not None:
        return written + write_own_colours(out_dir, own, solution, c)
    field = solution.state[index]
    written.append(write_png(out_dir / "final.png", picture(field, cmap, c.vmin, c.vmax,
                                                            c.threshold)))
    if field.ndim == 3:
        montage = slice_montage(field, 9, cmap, c.vmin, c.vmax)
        written.append(write_png(out_dir / "montage.png", montage))
    if solution.snapshots is not None and len(solution.snapshots) > 1:
        frames = solution.snapshots[:, index]
        lo, hi = colour_limits(frames, c.vmin, c.vmax)
        rgb = np.stack([picture(f, cmap, lo, hi, c.threshold) for f in frames])
        name = f"animation.{c.animation}"
        written.append(write_animation(out_dir / name, rgb, fps=c.fps))
    return written


def uses_own_colours(model: Model, config: RunConfig) -> bool:
    """Whether images show the model's own colours: it has them, and the run asks for no
    species, colour map or threshold."""
    asked = config.species or config.cmap or config.threshold is not None
    return model.colours is not None and not asked


def write_own_colours(out_dir: Path, colours: Callable, solution: Solution,
                      c: RunConfig) -> list[Path]:
    """``final.png`` (mid-plane of a volume), ``montage.png`` of a volume's ``z``-slices and
    the animation, all through the model's ``colours(state)``."""
    state = np.asarray(solution.state)
    volume = state.ndim == 4

    def flat(s: np.ndarray) -> np.ndarray:
        return to_uint8(colours(s[:, s.shape[1] // 2] if volume else s))

    written = [write_png(out_dir / "final.png", flat(state))]
    if volume:
        zs = slice_indices(state.shape[1], 9)
        tiles = to_uint8(colours(state[:, zs]))
        ncols = int(np.ceil(np.sqrt(len(zs))))
        montage = mosaic(tiles, ncols, labels=[f"z={z}" for z in zs])
        written.append(write_png(out_dir / "montage.png", montage))
    if solution.snapshots is not None and len(solution.snapshots) > 1:
        frames = np.stack([flat(np.asarray(s)) for s in solution.snapshots])
        written.append(write_animation(out_dir / f"animation.{c.animation}", frames, fps=c.fps))
    return written


def picture(field: np.ndarray, cmap: str, vmin: float | None, vmax: float | None,
            threshold: float | None = None) -> np.ndarray:
    """One species as RGB: colour-mapped, or two colours split at ``threshold``."""
    if threshold is not None:
        from morphogen.render import mid_slice

        flat = mid_slice(field) if field.ndim == 3 else field
        return threshold_map(flat, threshold)
    return state_image(field, cmap, vmin, vmax)
