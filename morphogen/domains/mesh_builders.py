"""Vertices and faces of simple surfaces: a rectangle, a disc and a sphere.

The :class:`~morphogen.domains.mesh.Mesh` builders (``Mesh.plane``, ``Mesh.disc``,
``Mesh.sphere``) call these; they return plain arrays ``(vertices (V, 3), faces (F, 3))``, faces
counter-clockwise seen from ``+z`` (plane, disc) or from outside (sphere), so a mesh can also be
built from them by hand or handed to another tool.

- :func:`plane`: the points of a ``ny x nx`` lattice with spacing ``edge`` on ``[0, width] x
  [0, height]``, each square split into two right triangles: at interior vertices its cotangent
  Laplacian is the 5-point stencil, as for :func:`morphogen.flowers.planar.grid_mesh`.
- :func:`disc`: a quality Delaunay triangulation (Shewchuk's Triangle, minimum angle 30°) of the
  disc, boundary points every ``edge`` along the circle and triangles of about equilateral area.
- :func:`sphere`: the icosahedron with every triangle split into four ``subdivisions`` times,
  new points pushed out to the sphere (an icosphere; ``10 · 4^s + 2`` vertices, edges about
  ``1.1 r / 2^s``). Its spherical harmonics are the test bed of the heat kernel
  (``tests/domains/test_mesh.py``).
"""

from __future__ import annotations

import numpy as np

from morphogen.errors import MorphogenError

MAX_VERTICES = 2_000_000
"""The builders refuse a surface with more vertices than this (choose a larger ``edge``)."""


def _count_check(count: float) -> None:
    if not count <= MAX_VERTICES:
        raise MorphogenError(f"the mesh would have about {count:.3g} vertices, more than "
                             f"{MAX_VERTICES:,}; choose a larger edge or fewer subdivisions")


def _positive(**values: float) -> None:
    for name, value in values.items():
        if not (np.isfinite(value) and value > 0):
            raise MorphogenError(f"{name} must be a positive number, got {value}")


def plane(width: float, height: float, edge: float) -> tuple[np.ndarray, np.ndarray]:
    """A ``width x height`` rectangle at ``z = 0`` in right triangles of legs ``edge`` (rounded
    so the lattice fits the sides exactly)."""
    _positive(width=width, height=height, edge=edge)
    nx, ny = max(2, round(width / edge) + 1), max(2, round(height / edge) + 1)
    _count_check(float(nx) * ny)
    x, y = np.meshgrid(np.linspace(0.0, width, nx), np.linspace(0.0, height, ny))
    vertices = np.stack([x.ravel(), y.ravel(), np.zeros(nx * ny)], axis=1)
    idx = np.arange(nx * ny).reshape(ny, nx)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])
    return vertices, faces


def disc(radius: float, edge: float) -> tuple[np.ndarray, np.ndarray]:
    """A disc of ``radius`` centred on the origin at ``z = 0``, edges about ``edge`` long."""
    import triangle

    _positive(radius=radius, edge=edge)
    n = max(8, int(np.ceil(2 * np.pi * radius / edge)))
    _count_check(1.2 * np.pi * radius**2 / (np.sqrt(3) / 4 * edge**2) + n)
    theta = 2 * np.pi * np.arange(n) / n
    ring = radius * np.stack([np.cos(theta), np.sin(theta)], axis=1)
    segments = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    area = np.sqrt(3) / 4 * edge**2
    out = triangle.triangulate({"vertices": ring, "segments": segments}, f"pq30Ya{area:.12g}")
    points, faces = out["vertices"], out["triangles"].astype(np.int64)
    e1, e2 = points[faces[:, 1]] - points[faces[:, 0]], points[faces[:, 2]] - points[faces[:, 0]]
    flip = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] < 0
    faces[flip] = faces[flip][:, ::-1]
    return np.column_stack([points, np.zeros(len(points))]), faces


def _icosahedron() -> tuple[np.ndarray, np.ndarray]:
    g = (1.0 + np.sqrt(5.0)) / 2.0
    v = np.array([[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0], [0, -1, g], [0, 1, g],
                  [0, -1, -g], [0, 1, -g], [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]],
                 np.float64)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9],
                  [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2],
                  [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
                  [8, 6, 7], [9, 8, 1]], np.int64)
    return v / np.linalg.norm(v, axis=1, keepdims=True), f


def sphere(radius: float = 1.0, subdivisions: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """An icosphere of ``radius`` centred on the origin (module docstring)."""
    _positive(radius=radius)
    if int(subdivisions) != subdivisions or subdivisions < 0:
        raise MorphogenError(f"subdivisions must be a whole number >= 0, got {subdivisions}")
    _count_check(10.0 * 4.0 ** int(subdivisions) + 2)
    vertices, faces = _icosahedron()
    for _ in range(int(subdivisions)):
        edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        unique, inverse = np.unique(np.sort(edges, axis=1), axis=0, return_inverse=True)
        mid = vertices[unique].mean(axis=1)
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = len(vertices) + inverse.reshape(3, len(faces)).T  # midpoints of (01, 12, 20)
        a, b, c = faces.T
        faces = np.concatenate([np.stack([a, m[:, 0], m[:, 2]], 1),
                                np.stack([b, m[:, 1], m[:, 0]], 1),
                                np.stack([c, m[:, 2], m[:, 1]], 1), m])
        vertices = np.concatenate([vertices, mid])
    return radius * vertices, faces
