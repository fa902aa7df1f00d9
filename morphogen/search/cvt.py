"""CVT-MAP-Elites: MAP-Elites whose cells are the Voronoi regions of k-means centroids.

A grid of ``B`` bins per descriptor has ``B^D`` cells, too many for three or more descriptors.
CVT-MAP-Elites (Vassiliades, Chatzilygeroudis & Mouret 2018) fixes the number of cells ``K``
instead: the descriptor box, scaled to the unit cube (``x_i = (d_i − lo_i)/(hi_i − lo_i)``,
clipped to ``[0, 1]``), is cut into the Voronoi regions of ``K`` centroids, and a genome falls in
the cell of its nearest centroid. The centroids are a centroidal Voronoi tessellation of the
cube, computed once by Lloyd's k-means on ``samples`` uniform points drawn with ``cvt_seed``:
each iteration moves every centroid to the mean of the samples nearest to it, which lowers
``Σ_s min_c |x_s − c|²`` until each centroid is the centre of mass of its region (in 1D on
``[0, 1]`` with ``K`` centroids: ``(2j + 1)/(2K)``).

Everything else — the archive, the mutation of elites, the invariant that an elite is replaced
only by a strictly fitter genome of its cell — is :class:`~morphogen.search.mapelites.MapElites`
(Skaggs, seed 000, §6.1: keep the variety a single fitness loses).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.search.mapelites import MapElites

Array = Any

LLOYD_ITERATIONS = 50
"""k-means iterations; on 10⁴ samples the centroids move by less than 10⁻³ after these."""


def kmeans_centroids(count: int, dims: int, samples: int, seed: int,
                     iterations: int = LLOYD_ITERATIONS) -> np.ndarray:
    """``count`` centroids ``(K, D)`` of the unit cube by Lloyd's k-means on uniform samples."""
    key_samples, key_start = jax.random.split(jax.random.PRNGKey(seed))
    x = jax.random.uniform(key_samples, (samples, dims))
    start = x[jax.random.choice(key_start, samples, (count,), replace=False)]

    def lloyd(c: Array, _: Any) -> tuple[Array, None]:
        nearest = jnp.argmin(jnp.sum((x[:, None] - c[None]) ** 2, axis=-1), axis=1)
        total = jax.ops.segment_sum(x, nearest, num_segments=count)
        n = jax.ops.segment_sum(jnp.ones(samples), nearest, num_segments=count)
        return jnp.where(n[:, None] > 0, total / jnp.maximum(n, 1)[:, None], c), None

    centroids, _ = jax.lax.scan(lloyd, start, None, length=iterations)
    return np.asarray(centroids, np.float32)


@dataclass(frozen=True)
class CVTMapElites(MapElites):
    """MAP-Elites over ``centroids`` Voronoi cells of the descriptor box (see module doc).

    Args:
        centroids: number of cells ``K``.
        samples: uniform samples for k-means (at least ``K``).
        cvt_seed: seed of the samples, so a run's cells are the same when it resumes.
    """

    centroids: int = 64
    samples: int = 10_000
    cvt_seed: int = 0

    def __post_init__(self) -> None:
        super().__post_init__()
        if not 1 <= int(self.centroids) <= int(self.samples) <= 1_000_000:
            raise MorphogenError(f"cvt-map-elites: need 1 <= centroids ({self.centroids}) <= "
                                 f"samples ({self.samples}) <= 1000000")
        points = kmeans_centroids(int(self.centroids), len(self.descriptors),
                                  int(self.samples), int(self.cvt_seed))
        object.__setattr__(self, "_points", points)

    @property
    def cell_count(self) -> int:
        """Number of cells ``K``."""
        return int(self.centroids)

    @property
    def points(self) -> np.ndarray:
        """The centroids ``(K, D)`` in the unit cube."""
        return self._points

    def cells_of(self, values: Array) -> Array:
        """Cell (nearest centroid) of descriptor values ``(P, D)`` -> ``(P,)`` int32."""
        lo = jnp.asarray([r[0] for r in self.ranges], jnp.float32)
        hi = jnp.asarray([r[1] for r in self.ranges], jnp.float32)
        x = jnp.clip(jnp.nan_to_num((jnp.asarray(values, jnp.float32) - lo) / (hi - lo)), 0, 1)
        d = jnp.sum((x[:, None] - jnp.asarray(self._points)[None]) ** 2, axis=-1)
        return jnp.argmin(d, axis=1).astype(jnp.int32)
