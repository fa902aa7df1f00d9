"""Flat meshes built directly from lattices: test domains and grid counterparts.

- :func:`grid_mesh`: the cell centres of a ``(ny, nx)`` grid, each square split into two right
  triangles. Its vertex order is the grid's row-major order, and at interior vertices its
  cotangent Laplacian is exactly the 5-point stencil (the diagonals get weight ``cot 90° = 0``
  and each Voronoi region is a ``dx`` square), so grid and mesh runs can be compared.
- :func:`lattice_mesh`: an equilateral triangular lattice (every vertex has six neighbours in
  the interior), the ideal near-equilateral mesh of Ringham et al. §3.2.
"""

from __future__ import annotations

import numpy as np

from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError


def _quads(nx: int, ny: int) -> np.ndarray:
    idx = np.arange(nx * ny).reshape(ny, nx)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    return np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])


def grid_mesh(nx: int, ny: int, dx: float = 1.0, **mesh_args) -> Mesh:
    """A flat mesh on the ``ny x nx`` grid points ``(j dx, i dx, 0)``, vertex ``i * nx + j``."""
    if nx < 2 or ny < 2:
        raise MorphogenError(f"grid mesh needs at least 2x2 points, got {nx}x{ny}")
    iy, ix = np.mgrid[0:ny, 0:nx]
    vertices = np.stack([ix.ravel() * dx, iy.ravel() * dx, np.zeros(nx * ny)], axis=1)
    return Mesh(vertices, _quads(nx, ny), name=f"grid {nx}x{ny}", **mesh_args)


def lattice_mesh(nx: int, ny: int, spacing: float = 1.0, **mesh_args) -> Mesh:
    """An equilateral lattice of ``ny`` rows of ``nx`` points, rows offset by half a spacing,
    centred on the origin."""
    if nx < 2 or ny < 2:
        raise MorphogenError(f"lattice mesh needs at least 2x2 points, got {nx}x{ny}")
    iy, ix = np.mgrid[0:ny, 0:nx]
    x = (ix + 0.5 * (iy % 2)) * spacing
    y = iy * spacing * np.sqrt(3.0) / 2.0
    vertices = np.stack([x.ravel() - x.mean(), y.ravel() - y.mean(), np.zeros(nx * ny)], axis=1)
    idx = np.arange(nx * ny).reshape(ny, nx)
    faces = []
    for i in range(ny - 1):
        r0, r1 = idx[i], idx[i + 1]
        if i % 2 == 0:  # row i+1 is shifted right
            tris = [(r0[:-1], r0[1:], r1[:-1]), (r0[1:], r1[1:], r1[:-1])]
        else:
            tris = [(r0[:-1], r1[1:], r1[:-1]), (r0[:-1], r0[1:], r1[1:])]
        faces += [np.stack(t, axis=1) for t in tris]
    return Mesh(vertices, np.concatenate(faces), name=f"lattice {nx}x{ny}", **mesh_args)
