"""A mesh state's files: a coloured PLY and a rendered picture (Ringham et al. §3.1: PLY in,
coloured PLY out)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.colors import Colormap

from morphogen.domains.mesh import Mesh
from morphogen.domains.ply import save_ply
from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.render.colour import colourise
from morphogen.render.images import write_png
from morphogen.render.mesh import render_mesh
from morphogen.util.io import ensure_writable_dir


def write_mesh_outputs(
    out_dir: str | Path,
    mesh: Mesh,
    model: Model,
    state: np.ndarray,
    cmap: Any = "viridis",
    name: str = "out",
    *,
    species: str | None = None,
    view: Any = "oblique",
    size: tuple[int, int] = (800, 800),
    rgb: np.ndarray | None = None,
) -> list[Path]:
    """Write ``NAME.ply`` (vertex colours of the display species through ``cmap``, every
    species as a named property, the mesh's fields) and ``NAME.png`` (a rendered view).

    Args:
        state: ``(S, V)`` final concentrations in the mesh's vertex order.
        cmap: a colour map name or ramp (see :func:`morphogen.render.colourise`), or a callable
            ``values (V,) -> (V, 3) uint8`` such as a step transfer function.
        species: the species shown (default: the model's display species).
        rgb: vertex colours ``(V, 3)`` uint8 to use instead (e.g. the model's own colours).
    """
    state = np.asarray(state)
    if state.shape != (len(model.species), mesh.n_vertices):
        raise MorphogenError(f"state has shape {state.shape}, expected "
                             f"({len(model.species)}, {mesh.n_vertices})")
    out = ensure_writable_dir(out_dir)
    shown = state[model.species_index(species or model.display_species)]
    if rgb is not None:
        colours = np.asarray(rgb, np.uint8)
    elif isinstance(cmap, str | Colormap):
        colours = colourise(shown, cmap)
    else:
        colours = np.asarray(cmap(shown), np.uint8)
    species_fields = {s: state[i] for i, s in enumerate(model.species)}
    ply = save_ply(out / f"{name}.ply", mesh, colours=colours, fields=species_fields)
    image = render_mesh(mesh.vertices, mesh.faces, colours, view=view, size=size)
    png = write_png(out / f"{name}.png", image)
    return [ply, png]
