"""Near-equilateral planar triangulations of outlines, with a target edge length per place.

Ringham et al. §3.2 build flower meshes with Instant Meshes, "almost equilateral triangles of
approximately constant size". Here a planar domain (closed outlines, optional holes) is meshed
by Shewchuk's Triangle (the ``triangle`` package: quality constrained Delaunay refinement with a
per-triangle area bound), then relaxed by a few rounds of Laplacian smoothing with Delaunay
re-triangulation, which turns the 30-degree quality mesh into a nearly equilateral one. The
flower generators map the result into 3D with near-isometric (or conformal) maps and choose
the planar edge length so that edges have the requested length on the surface.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from morphogen.errors import MorphogenError

SizeFunction = Callable[[np.ndarray], np.ndarray]
"""Target edge length at planar points ``(N, 2) -> (N,)``."""

MAX_VERTICES = 2_000_000


def resample_loop(loop: np.ndarray, size: SizeFunction) -> np.ndarray:
    """Points along a closed polyline ``(N, 2)``, spaced by the local target edge length."""
    closed = np.vstack([loop, loop[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    mids = 0.5 * (closed[:-1] + closed[1:])
    # number of target edges along each segment: integrate 1/h
    density = seg / np.maximum(size(mids), 1e-12)
    steps = np.concatenate([[0.0], np.cumsum(density)])
    n = max(int(round(steps[-1])), 3)
    targets = np.linspace(0.0, steps[-1], n, endpoint=False)
    s = np.interp(targets, steps, arc)
    return np.stack([np.interp(s, arc, closed[:, k]) for k in range(2)], axis=1)


def triangulate(
    loops: Sequence[np.ndarray],
    size: SizeFunction,
    *,
    holes: Sequence[Sequence[float]] = (),
    smoothing: int = 6,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mesh the region bounded by ``loops`` (closed polylines, ``(N_i, 2)`` each).

    Args:
        loops: the outer outline and any inner outlines (holes, given a point in ``holes``).
        size: target edge length at each planar point.
        smoothing: rounds of Laplacian smoothing of interior vertices.

    Returns:
        ``(points (V, 2), triangles (F, 3) counter-clockwise, on_boundary (V,) bool)``.
    """
    import triangle

    pts, segs, start = [], [], 0
    for loop in loops:
        ring = resample_loop(np.asarray(loop, np.float64), size)
        k = len(ring)
        pts.append(ring)
        segs.append(np.stack([np.arange(k), (np.arange(k) + 1) % k], axis=1) + start)
        start += k
    pslg = {"vertices": np.concatenate(pts), "segments": np.concatenate(segs)}
    if len(holes):
        pslg["holes"] = np.asarray(holes, np.float64)
    h_max = float(size(pslg["vertices"]).max())
    mesh = triangle.triangulate(pslg, f"pq30Ya{_area(h_max):.12g}")
    for _ in range(6):
        tri = mesh["triangles"]
        centroids = mesh["vertices"][tri].mean(axis=1)
        wanted = _area(size(centroids))
        actual = _triangle_area(mesh["vertices"], tri)
        if np.all(actual <= 1.3 * wanted):
            break
        if len(mesh["vertices"]) > MAX_VERTICES:
            raise MorphogenError("mesh would exceed 2 million vertices; choose a larger edge")
        mesh["triangle_max_area"] = wanted
        mesh = triangle.triangulate(mesh, "rpq30Ya")
    points = mesh["vertices"]
    boundary = mesh["vertex_markers"].ravel() == 1
    segments = mesh["segments"]
    for _ in range(smoothing):
        tri = mesh["triangles"]
        points = _smooth(points, tri, boundary, size)
        inp = {"vertices": points, "segments": segments}
        if len(holes):
            inp["holes"] = pslg["holes"]
        mesh = triangle.triangulate(inp, "pY")
        points = mesh["vertices"]
    tri = mesh["triangles"]
    flip = _triangle_area(points, tri, signed=True) < 0
    tri[flip] = tri[flip][:, ::-1]
    return points, tri.astype(np.int64), boundary


AREA_SLACK = 1.6
"""Refinement stops once a triangle is below its bound, leaving triangles at 0.5-1 times it;
the bound is this factor above the equilateral area so that edges average the target."""


def _area(h):
    return AREA_SLACK * np.sqrt(3.0) / 4.0 * np.asarray(h) ** 2


def _triangle_area(points, tri, signed=False):
    p = points[tri]
    a = 0.5 * ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
               - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    return a if signed else np.abs(a)


def _smooth(points, tri, fixed, size):
    """One round of size-weighted Laplacian smoothing of the free vertices.

    Each free vertex moves to the average of its neighbours weighted by ``1 / h^2`` (points
    where the target size is small pull harder), a discrete form of centroidal relaxation.
    """
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    w = 1.0 / np.maximum(size(points), 1e-12) ** 2
    acc = np.zeros_like(points)
    tot = np.zeros(len(points))
    for a, b in ((0, 1), (1, 0)):
        i, j = edges[:, a], edges[:, b]
        np.add.at(acc, i, w[j, None] * points[j])
        np.add.at(tot, i, w[j])
    out = points.copy()
    free = ~fixed & (tot > 0)
    out[free] = acc[free] / tot[free, None]
    return out
