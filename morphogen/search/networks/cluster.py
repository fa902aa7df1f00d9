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
1.10× (``tests/search/networks/test_networks_cluster.py``). ``prominence = 0`` drops the test.
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
scores at least 0.25), so invalid < flat < patterned; the network evaluation also makes
grid-scale checkerboards invalid, tests homogeneity on the activator and grades the
non-homogeneous states without a peak (``stage2``, :func:`pattern_grade`).
Neighbourhoods are static offset lists (a convolution of the peak mask with a disc),
``O(d_max² · cells)`` per state, no pairwise distance matrix.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from morphogen.errors import MorphogenError
from morphogen.search.fitness import FLAT, INVALID, is_flat
from morphogen.solvers.stability import grid_scale, grid_scale_dominated

Array = Any

S_MAX = 100.0
A_PEAK = 3.0
PROMINENCE = 0.5
D_MAX = 6.0
PHI_DEAD, PHI_PEAK_CROWDED, PHI_PEAK_ALONE, PHI_ALIVE = 0.25, 0.5, 0.75, 1.0
STAGE2 = ("stationary", "graded", "activator", "literal")
"""Readings of stage two, "presence of any non-homogeneous pattern"
(:func:`cluster_head_fitness`)."""
GRADE_FLOOR = 1e-3
"""Smallest :func:`pattern_grade`, so a non-homogeneous state always ranks above a flat one."""
DRIFT_TOL = 0.1
"""Drift per scoring round (:func:`stationarity`) at which a graded state's grade reaches its
floor: a state whose largest change over a round is a tenth of its species' range is no pattern
yet (docs/networks.md, *A grade that asks for a settled state*)."""


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


def pattern_grade(a: Array, *, a_peak: float = A_PEAK, prominence: float = PROMINENCE,
                  floor: float = GRADE_FLOOR) -> Array:
    """How close the activator ``a`` ``(H, W)`` of a non-homogeneous state without a peak is to
    forming one, in ``[floor, 1]``: the height of its highest cell against the threshold times
    (``prominence > 0``) its standing above the field's mean against the prominence a peak needs,

    .. math:: g = \\max\\Big(\\text{floor},\\; \\min\\big(1, \\tfrac{\\max a}{a_{peak}}\\big)
              \\cdot \\min\\big(1, \\tfrac{\\max a - \\bar a}{p \\max a}\\big)\\Big).

    Both factors reach 1 only where a cell clears both tests of :func:`peaks` (with the global
    mean for the disc's), so a growing pattern climbs towards the first peak: ``±10 %`` noise on
    ``a = 1`` grades about 0.06, the same noise on ``a = 5`` about 0.18. Only the ordering of
    Yamamoto §3.3's stage two ("presence of any non-homogeneous pattern") is the seed's; the
    grade is ours (docs/networks.md)."""
    top = jnp.max(a)
    g = jnp.clip(top / a_peak, 0.0, 1.0)
    if prominence > 0:
        rise = (top - jnp.mean(a)) / jnp.where(top > 0, prominence * top, 1.0)
        g = g * jnp.clip(rise, 0.0, 1.0)
    return jnp.maximum(g, floor)


def stationarity(u: Array, previous: Array, rate: Array = 1.0, *,
                 tol: float = DRIFT_TOL) -> Array:
    """How settled a state ``u`` ``(S, H, W)`` is against the state ``previous`` one interval
    earlier, in ``[0, 1]``:

    .. math:: s = \\max\\Big(0,\\; 1 - \\frac{r}{tol}\\,\\max_i
              \\frac{\\max_x |u_i - u_i^{prev}|}{\\max(\\max_x |u_i|, 10^{-6})}\\Big),

    the largest change of any species over the interval against that species' own range,
    ``rate`` ``r`` scaling the interval to one scoring round. A stationary pattern gives 1; the
    slow runaway of a non-diffusing species (15-25 % per round, measured) gives 0."""
    drift = jnp.max(jnp.abs(u - previous), axis=(1, 2))
    top = jnp.maximum(jnp.max(jnp.abs(u), axis=(1, 2)), 1e-6)
    return jnp.clip(1.0 - rate * jnp.max(drift / top) / tol, 0.0, 1.0)


def cluster_head_fitness(*, species: int = 0, a_peak: float = A_PEAK, d_max: float = D_MAX,
                         s_max: float = S_MAX, prominence: float = PROMINENCE,
                         nonnegative: bool = False, normalise: bool = False,
                         flat_tol: float = 1e-3, stage2: str = "literal",
                         checkerboards_invalid: bool = False) -> Callable[..., Array]:
    """Staged cluster-head fitness of a population ``(P, S, H, W) -> (P,)`` (Yamamoto §3.3),
    called as ``score(states)`` or ``score(states, previous, rate)`` with the states one
    interval earlier (``stage2="stationary"``; without them every state counts as settled).

    Stage one: a state is invalid (:data:`~morphogen.search.fitness.INVALID`) when any value is
    non-finite, beyond ``s_max`` or (``nonnegative``, the setting of the network evaluation)
    negative, and with ``checkerboards_invalid`` when some species is dominated by the
    grid-scale mode (the atlas's test,
    :func:`morphogen.solvers.stability.grid_scale_dominated`: a numerical artefact of the
    step, not a pattern). Stage two, ``stage2`` (:data:`STAGE2`):

    - ``"literal"``: homogeneous (:data:`~morphogen.search.fitness.FLAT`) when every species is
      flat (:func:`~morphogen.search.fitness.is_flat`), else ``Σ Φ``;
    - ``"activator"``: homogeneous when the scored species is flat, else ``Σ Φ``;
    - ``"graded"``: as ``"activator"``, and a state without a peak (``Σ Φ = N/4``, every cell
      dead) scores ``N/4 · g`` with ``g`` its :func:`pattern_grade`, so invalid < homogeneous
      < graded non-homogeneous (``<= N/4``) < any state with a peak (``> N/4``: a peak cell
      scores at least 0.5);
    - ``"stationary"``: as ``"graded"``, the grade times the state's :func:`stationarity`
      against ``previous`` (floor :data:`GRADE_FLOOR`), so a state still drifting away
      (a runaway) is not ranked as a pattern about to form.

    ``normalise`` divides the score by the number of cells ``N``, giving a score in ``(0, 1]``
    like the other fitnesses of :mod:`morphogen.search.fitness` (used when it serves an
    ordinary parameter search). States are scored by ``lax.map``, so a score does not depend on
    how a population is batched.
    """
    if stage2 not in STAGE2:
        raise MorphogenError(f"unknown stage-2 test {stage2!r}; use one of {', '.join(STAGE2)}")

    def one(pair: tuple[Array, Array, Array]) -> Array:
        u, previous, rate = pair
        ok = jnp.all(valid_cells(u, s_max, nonnegative))
        safe = jnp.where(ok, u, 0.0)
        cells = u.shape[1] * u.shape[2]
        total = cluster_head_score(safe, species=species, a_peak=a_peak, d_max=d_max,
                                   s_max=s_max, prominence=prominence, nonnegative=nonnegative)
        a = safe[species]
        if stage2 in ("graded", "stationary"):
            g = pattern_grade(a, a_peak=a_peak, prominence=prominence)
            if stage2 == "stationary":
                settled = stationarity(safe, jnp.where(ok, previous, 0.0), rate)
                g = jnp.maximum(g * settled, GRADE_FLOOR)
            total = jnp.where(total > PHI_DEAD * cells, total, PHI_DEAD * cells * g)
        flat = is_flat(safe if stage2 == "literal" else a[None], flat_tol)
        value = jnp.where(flat, FLAT, total / cells if normalise else total)
        if checkerboards_invalid:
            g, dev = grid_scale(safe, False)
            scale = jnp.maximum(1.0, jnp.mean(jnp.abs(safe), axis=(1, 2)))
            ok = ok & ~jnp.any(grid_scale_dominated(g[0], dev[0], scale))
        return jnp.where(ok, value, INVALID)

    mapped = jax.jit(lambda states, previous, rate: jax.lax.map(
        one, (states, previous, jnp.broadcast_to(rate, states.shape[:1]))))

    def score(states: Array, previous: Array | None = None, rate: float = 1.0) -> Array:
        states = jnp.asarray(states)
        return mapped(states, states if previous is None else jnp.asarray(previous, states.dtype),
                      jnp.float32(rate))

    return score
