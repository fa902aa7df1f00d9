"""Files a simulation run writes: ``state.npz``, ``final.png``, slices, an animation.

- ``state.npz``: one array per species, named by species (readable by ``--init FILE.npz``).
- ``final.png``: the display species through the colour map (or a two-colour threshold map);
  3D states show their mid-plane and add ``montage.png`` with a grid of slices.
- ``animation.gif`` / ``animation.mp4``: the snapshots on one colour scale.
- on a mesh: ``out.ply`` and a rendered picture (see :mod:`morphogen.domains.mesh`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from morphogen.io import write_npz
from morphogen.render import (
    colour_limits,
    slice_montage,
    state_image,
    threshold_map,
    write_animation,
    write_png,
)

if TYPE_CHECKING:
    from morphogen.runfile import Prepared
    from morphogen.simulate import Solution


def write_outputs(out_dir: Path, prep: Prepared, solution: Solution) -> list[Path]:
    """Write every output of a single run; returns the paths written."""
    model, c = prep.model, prep.config
    arrays = {s: solution.state[i] for i, s in enumerate(model.species)}
    written = [write_npz(out_dir / "state.npz", arrays)]
    species = c.species or model.display_species
    index = model.species_index(species)
    if c.mesh:
        from morphogen.domains.mesh import write_mesh_outputs

        written += write_mesh_outputs(out_dir, prep.domain, model, solution.state, c.cmap)
        return written
    field = solution.state[index]
    written.append(write_png(out_dir / "final.png", picture(field, c.cmap, c.vmin, c.vmax,
                                                            c.threshold)))
    if field.ndim == 3:
        montage = slice_montage(field, 9, c.cmap, c.vmin, c.vmax)
        written.append(write_png(out_dir / "montage.png", montage))
    if solution.snapshots is not None and len(solution.snapshots) > 1:
        frames = solution.snapshots[:, index]
        lo, hi = colour_limits(frames, c.vmin, c.vmax)
        rgb = np.stack([picture(f, c.cmap, lo, hi, c.threshold) for f in frames])
        name = f"animation.{c.animation}"
        written.append(write_animation(out_dir / name, rgb, fps=c.fps))
    return written


def picture(field: np.ndarray, cmap: str, vmin: float | None, vmax: float | None,
            threshold: float | None = None) -> np.ndarray:
    """One species as RGB: colour-mapped, or two colours split at ``threshold``."""
    if threshold is not None:
        from morphogen.render import mid_slice

        flat = mid_slice(field) if field.ndim == 3 else field
        return threshold_map(flat, threshold)
    return state_image(field, cmap, vmin, vmax)
