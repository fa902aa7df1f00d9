"""Positional information on meshes (Ringham et al. §3.4.5, eqs. 18 and 21).

A control morphogen ``G`` diffuses between source vertices (held at ``source_value``) and sink
vertices (held at ``sink_value``); its steady state ``g`` is the positional-information field,
found directly by one sparse solve of the discrete Laplace equation

.. math:: C_{ff}\\,g_f = -C_{fh}\\,g_h\\qquad(\\text{or } (C + \\mu M) g = 0
          \\text{ with decay } \\mu)

on the free vertices ``f`` given the held ones ``h`` (``C`` the cotangent stiffness matrix, ``M``
the vertex areas). Its per-face gradient orients anisotropic diffusion (eq. 18,
:func:`direction_field`), and parameters can be functions of it (eq. 21, e.g.
``alpha = lerp(alpha_min, alpha_max, g**gamma)`` in a pipeline).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import spsolve

from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError


def _indices(mesh: Mesh, where: str | np.ndarray) -> np.ndarray:
    if isinstance(where, str):
        return mesh.vertex_set(where)
    idx = np.unique(np.asarray(where, np.int64))
    if idx.size and (idx.min() < 0 or idx.max() >= mesh.n_vertices):
        raise MorphogenError(f"vertex indices must be in 0..{mesh.n_vertices - 1}")
    return idx


def positional_information(
    mesh: Mesh,
    sources: str | np.ndarray,
    sinks: str | np.ndarray,
    *,
    source_value: float = 1.0,
    sink_value: float = 0.0,
    decay: float = 0.0,
) -> np.ndarray:
    """Steady-state concentration of a morphogen diffusing from ``sources`` to ``sinks``.

    Args:
        sources, sinks: vertex set names (e.g. ``"margin"``, ``"throat"``) or index arrays.
        decay: first-order decay rate relative to diffusion (``mu / D``); 0 gives harmonic
            interpolation between the held values.

    Returns:
        ``(V,)`` float64 field ``g``.

    Raises:
        MorphogenError: empty or overlapping sets, or a piece of the mesh with no held vertex
            (its steady state would be undetermined) when ``decay`` is 0.
    """
    src, snk = _indices(mesh, sources), _indices(mesh, sinks)
    if len(src) == 0 or len(snk) == 0:
        raise MorphogenError("positional information needs non-empty source and sink sets")
    if np.intersect1d(src, snk).size:
        raise MorphogenError("source and sink sets overlap; choose disjoint vertex sets")
    if decay < 0:
        raise MorphogenError(f"decay must be >= 0, got {decay}")
    held = np.zeros(mesh.n_vertices, bool)
    held[src] = held[snk] = True
    g = np.zeros(mesh.n_vertices)
    g[src], g[snk] = source_value, sink_value
    system = (mesh.ops.stiffness + decay * sp.diags(mesh.areas)).tocsr()
    free = np.flatnonzero(~held)
    if decay == 0:
        _, labels = connected_components(abs(mesh.ops.stiffness) > 0, directed=False)
        reached = np.unique(labels[held])
        orphan = ~np.isin(labels, reached)
        if orphan.any():
            raise MorphogenError(
                f"{int(orphan.sum())} vertices lie on a piece of the mesh with no source or sink"
            )
    if len(free):
        rhs = -system[free][:, np.flatnonzero(held)] @ g[held]
        g[free] = spsolve(system[free][:, free].tocsc(), rhs)
    return g


def direction_field(mesh: Mesh, g: np.ndarray) -> np.ndarray:
    """Per-face gradient of ``g`` (Ringham et al. eq. 7), ``(F, 3)``: the first axis of the
    diffusion tensor frame in eq. 18 (``lambda_1`` along it, ``lambda_2`` across)."""
    return mesh.face_gradient(np.asarray(g, np.float64))
