"""Random points on meshes (Ringham et al. §3.4.4).

Uniform points pick vertices with equal probability (uniform over the surface when the vertex
density is nearly constant, as for the generated flowers). Points with a probability density
``f: vertex -> [0, 1]`` use the rejection method: draw a uniform candidate ``P`` and a uniform
``p`` in [0, 1], accept ``P`` if ``p < f(P)``, until enough points are chosen. Points are
distinct vertices; every draw comes from an explicit seed.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from morphogen.errors import MorphogenError

MAX_DRAWS_PER_POINT = 10_000


def random_vertices(
    n_vertices: int,
    count: int,
    *,
    density: np.ndarray | None = None,
    seed: int = 0,
) -> np.ndarray:
    """``count`` distinct vertex indices, uniform or with acceptance probability ``density``.

    Args:
        n_vertices: number of vertices ``V``.
        density: ``(V,)`` values in [0, 1] (values outside are clipped), or ``None``.

    Raises:
        MorphogenError: more points than eligible vertices, or a density too small to reach
            ``count`` within ``MAX_DRAWS_PER_POINT`` draws per point.
    """
    if count < 0:
        raise MorphogenError(f"point count must be >= 0, got {count}")
    rng = np.random.default_rng(seed)
    if density is None:
        if count > n_vertices:
            raise MorphogenError(f"cannot choose {count} distinct points from {n_vertices}")
        return np.sort(rng.choice(n_vertices, size=count, replace=False))
    f = np.clip(np.asarray(density, np.float64), 0.0, 1.0)
    if f.shape != (n_vertices,):
        raise MorphogenError(f"density has shape {f.shape}, expected ({n_vertices},)")
    eligible = int((f > 0).sum())
    if count > eligible:
        raise MorphogenError(f"density is positive on only {eligible} vertices; cannot choose "
                             f"{count} distinct points")
    chosen: list[int] = []
    seen = np.zeros(n_vertices, bool)
    draws = 0
    while len(chosen) < count:
        batch = max(2 * (count - len(chosen)), 64)
        cand = rng.integers(0, n_vertices, size=batch)
        accept = rng.random(batch) < f[cand]
        for v in cand[accept]:
            if not seen[v]:
                seen[v] = True
                chosen.append(int(v))
                if len(chosen) == count:
                    break
        draws += batch
        if draws > MAX_DRAWS_PER_POINT * max(count, 1):
            raise MorphogenError(f"density too small: only {len(chosen)} of {count} points "
                                 f"accepted after {draws} draws")
    return np.sort(np.asarray(chosen, np.int64))


def seed_field(
    n_vertices: int,
    count: int,
    *,
    density: np.ndarray | None = None,
    low: float = 0.0,
    high: float = 1.0,
    seed: int = 0,
) -> np.ndarray:
    """A ``(V,)`` field that is 0 except at ``count`` random points, where it is uniform in
    ``[low, high]`` (Ringham et al. §4.9: 5 000 seeds with activator in [0, 1])."""
    idx = random_vertices(n_vertices, count, density=density, seed=seed)
    out = np.zeros(n_vertices)
    out[idx] = np.random.default_rng(seed + 1).uniform(low, high, size=len(idx))
    return out


def surface_points(
    mesh: Any,
    count: int,
    *,
    density: np.ndarray | None = None,
    seed: int = 0,
) -> np.ndarray:
    """``(count, 3)`` points on the surface, uniform by area, or with acceptance probability
    ``density`` (per vertex, interpolated linearly over each triangle) by the rejection method
    of §3.4.4: a face is chosen with probability proportional to its area, a point in it
    uniformly (``sqrt`` trick on barycentric coordinates), accepted if ``p < f``.

    Raises:
        MorphogenError: ``count < 1``, or a density too small to reach ``count`` within
            ``MAX_DRAWS_PER_POINT`` draws per point.
    """
    if count < 1:
        raise MorphogenError(f"need at least one surface point, got {count}")
    f = None
    if density is not None:
        f = np.clip(np.asarray(density, np.float64), 0.0, 1.0)
        if f.shape != (mesh.n_vertices,):
            raise MorphogenError(f"density has shape {f.shape}, expected ({mesh.n_vertices},)")
        if not (f > 0).any():
            raise MorphogenError("density is zero everywhere; no point can be accepted")
    tri = mesh.vertices[mesh.faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    cdf = np.cumsum(area) / area.sum()
    rng = np.random.default_rng(seed)
    out: list[np.ndarray] = []
    have, draws = 0, 0
    while have < count:
        batch = max(2 * (count - have), 64)
        face = np.minimum(np.searchsorted(cdf, rng.random(batch)), len(cdf) - 1)
        r1, r2 = np.sqrt(rng.random(batch)), rng.random(batch)
        bary = np.stack([1 - r1, r1 * (1 - r2), r1 * r2], 1)
        pts = (bary[:, :, None] * tri[face]).sum(1)
        if f is not None:
            accept = rng.random(batch) < (bary * f[mesh.faces[face]]).sum(1)
            pts = pts[accept]
        out.append(pts)
        have += len(pts)
        draws += batch
        if have < count and draws > MAX_DRAWS_PER_POINT * count:
            raise MorphogenError(f"density too small: only {have} of {count} points accepted "
                                 f"after {draws} draws")
    return np.concatenate(out)[:count]
