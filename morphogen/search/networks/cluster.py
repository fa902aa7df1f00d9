"""The cluster-head task fitness (Yamamoto et al. §3.3, §4, Table 1).

Every cell of a 2D state is one of four types, judged on the activator species ``a``:

=========  ========================================================  ==============
invalid    some species is NaN, ±Inf or ``|s| > s_max`` (or, for a   Φ = 0
           mass-action network, ``s < 0``: ``nonnegative``)
peak       valid, ``a > a_peak``, ``a`` a local maximum (``>=`` all   Φ = 0.5 if another
           8 neighbours) and prominent: ``a - m >= prominence · a``   peak lies at distance
           with ``m`` the mean of ``a`` over the disc ``<= d_max``    ``< d_max``, else 0.75
alive      valid non-peak cell with a peak at distance ``<= d_max``   Φ = 1
dead       valid non-peak cell with no peak that close                Φ = 0.25
=========  ========================================================  ==============

*Peak* follows §4 ("points of maximum activator concentration, above a peak threshold"): a
local maximum over the 8-neighbourhood, ties allowed (a plateau of equal maxima is all peaks),
that also stands out of its surroundings: with the default :data:`PROMINENCE` = 0.5 the peak is
at least twice the mean of ``a`` over its disc of radius ``d_max`` (the cell included). The
seed's words alone would make every noise maximum of a nearly flat field above ``a_peak`` a
peak, and such a field ("all alive") then outscores real spots; measured on 32² states at the
last Table-1 round, the spots of the hand-made Table-2 network stand 6-11× above their disc's
mean and those of the seed's Fig. 4 rates 12-18×, while uniform noise of ±10 % around 5 reaches
1.10× (``tests/test_networks_cluster.py``). ``prominence = 0`` drops the test.
*Invalid* values are those the seed calls "outside bounds"; a mass-action network's
concentrations cannot be negative (its exact solution keeps them ``>= 0``; a negative value is
an integration that left the physical range, e.g. explicit Euler beyond its stability limit),
so with ``nonnegative`` (the network evaluation's setting) ``s < 0`` is invalid too. Nothing
is clamped.
*Distance* is Euclidean in cells on the periodic grid (a torus: offsets wrap around), the
metric of the seed's periodic 32 × 32 surface. The pattern's task score is ``Σ Φ`` over cells,
at most the number of cells (1024 on 32²).

:func:`cluster_head_fitness` stages it (§3.3): a state with any invalid value scores
:data:`~morphogen.search.fitness.INVALID`, a homogeneous one
:data:`~morphogen.search.fitness.FLAT`, any other ``Σ Φ`` (``> 0``, since every valid cell
scores at least 0.25), so invalid < flat < patterned. Neighbourhoods are static offset lists
(a convolution of the peak mask with a disc), ``O(d_max² · cells)`` per state, no pairwise
distance matrix.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from morphogen.search.fitness import staged

Array = Any

S_MAX = 100.0
A_PEAK = 3.0
PROMINENCE = 0.5
D_MAX = 6.0
PHI_DEAD, PHI_PEAK_CROWDED, PHI_PEAK_ALONE, PHI_ALIVE = 0.25, 0.5, 0.75, 1.0


def _offsets(radius: float, *, strict: bool, centre: bool) -> list[tuple[int, int]]:
    r = int(np.floor(radius))
    out = []
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            d2 = dy * dy + dx * dx
            inside = d2 < radius * radius if strict else d2 <= radius * radius
            if inside and (centre or d2 > 0):
                out.append((dy, dx))
    return out


def _any_near(mask: Array, offsets: list[tuple[int, int]]) -> Array:
    """``OR`` over the offsets of ``roll(mask, (dy, dx))`` on the torus, as one convolution of
    the wrap-padded mask with the offsets' 0/1 stencil (counts are exact in float32): a single
    operation to compile instead of one roll per offset."""
    r = max(max(abs(dy), abs(dx)) for dy, dx in offsets)
    stencil = np.zeros((2 * r + 1, 2 * r + 1), np.float32)
    for dy, dx in offsets:
        stencil[r - dy, r - dx] = 1.0  # out[i] = mask[i - d] = padded[i + (r - d)]
    padded = jnp.pad(mask.astype(jnp.float32), r, mode="wrap")
    count = lax.conv_general_dilated(padded[None, None], jnp.asarray(stencil)[None, None],
                                     (1, 1), "VALID")[0, 0]
    return count > 0.5


def _disc_mean(field: Array, offsets: list[tuple[int, int]]) -> Array:
    """Mean of ``field`` over the offsets around every cell of the torus (one convolution)."""
    r = max(max(abs(dy), abs(dx)) for dy, dx in offsets)
    stencil = np.zeros((2 * r + 1, 2 * r + 1), np.float32)
    for dy, dx in offsets:
        stencil[r + dy, r + dx] = 1.0 / len(offsets)
    padded = jnp.pad(field.astype(jnp.float32), r, mode="wrap")
    return lax.conv_general_dilated(padded[None, None], jnp.asarray(stencil)[None, None],
                                    (1, 1), "VALID")[0, 0]


def peaks(a: Array, a_peak: float = A_PEAK, *, prominence: float = 0.0,
          d_max: float = D_MAX) -> Array:
    """Bool ``(H, W)``: ``a > a_peak``, ``a >= `` its 8 neighbours (periodic) and, when
    ``prominence > 0``, ``a - m >= prominence · a`` with ``m`` the mean of ``a`` over the disc
    of radius ``d_max`` around the cell (non-finite values, e.g. the ``-inf`` of invalid cells,
    count as 0 in the mean)."""
    top = a > a_peak
    for dy, dx in _offsets(1.5, strict=False, centre=False):
        top = top & (a >= jnp.roll(a, (dy, dx), axis=(0, 1)))
    if prominence > 0:
        m = _disc_mean(jnp.where(jnp.isfinite(a), a, 0.0),
                       _offsets(d_max, strict=False, centre=True))
        top = top & (a - m >= prominence * a)
    return top


def valid_cells(u: Array, s_max: float = S_MAX, nonnegative: bool = False) -> Array:
    """Bool ``(*spatial)``: every species finite, ``|s| <= s_max`` and (``nonnegative``)
    ``s >= 0``; ``u`` is ``(S, *spatial)``."""
    ok = jnp.isfinite(u) & (jnp.abs(u) <= s_max)
    if nonnegative:
        ok = ok & (u >= 0)
    return jnp.all(ok, axis=0)


def cell_fitness(u: Array, *, species: int = 0, a_peak: float = A_PEAK, d_max: float = D_MAX,
                 s_max: float = S_MAX, prominence: float = PROMINENCE,
                 nonnegative: bool = False) -> Array:
    """Φ per cell, shape ``(H, W)``, of one state ``u`` ``(S, H, W)``."""
    valid = valid_cells(u, s_max, nonnegative)
    a = jnp.where(valid, u[species], -jnp.inf)
    peak = peaks(a, a_peak, prominence=prominence, d_max=d_max) & valid
    crowded = _any_near(peak, _offsets(d_max, strict=True, centre=False))
    near = _any_near(peak, _offsets(d_max, strict=False, centre=True))
    phi = jnp.where(near, PHI_ALIVE, PHI_DEAD)
    phi = jnp.where(peak, jnp.where(crowded, PHI_PEAK_CROWDED, PHI_PEAK_ALONE), phi)
    return jnp.where(valid, phi, 0.0).astype(jnp.float32)


def cluster_head_score(u: Array, **options: float) -> Array:
    """``Σ Φ`` over the cells of one state ``(S, H, W)`` (options as :func:`cell_fitness`)."""
    return jnp.sum(cell_fitness(u, **options))


def cluster_head_fitness(*, species: int = 0, a_peak: float = A_PEAK, d_max: float = D_MAX,
                         s_max: float = S_MAX, prominence: float = PROMINENCE,
                         nonnegative: bool = False, normalise: bool = False,
                         flat_tol: float = 1e-3) -> Callable[[Array], Array]:
    """Staged cluster-head fitness of a population ``(P, S, H, W) -> (P,)``.

    A state is invalid when any value is non-finite, beyond ``s_max`` or (``nonnegative``, the
    setting of the network evaluation) negative. ``normalise`` divides
    ``Σ Φ`` by the number of cells, giving a score in ``(0, 1]`` like the other fitnesses of
    :mod:`morphogen.search.fitness` (used when it serves an ordinary parameter search).
    """

    def score(u: Array) -> Array:
        total = cluster_head_score(u, species=species, a_peak=a_peak, d_max=d_max, s_max=s_max,
                                   prominence=prominence, nonnegative=nonnegative)
        return total / (u.shape[1] * u.shape[2]) if normalise else total

    inner = staged(score, flat_tol)

    def fitness(states: Array) -> Array:
        ok = jax.vmap(lambda u: jnp.all(valid_cells(u, s_max, nonnegative)))(states)
        return jnp.where(ok, inner(states), -1.0)

    return jax.jit(fitness)
