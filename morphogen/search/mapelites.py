"""MAP-Elites: keep the best genome of every kind of pattern, not one best overall.

Skaggs (seed 000, §6.1) saw his GA trade the variety of generation 1 for one high-scoring kind of
pattern. MAP-Elites (Mouret & Clune 2015) keeps an archive of elites, one per cell of a grid over
pattern descriptors (:mod:`morphogen.patterns.descriptors`): each generation it mutates elites
drawn uniformly from the filled cells (uniform samples while the archive is empty, and for a
share ``explore`` of every later batch, so that cells far from the elites keep being tried),
evaluates
them as one batch on the usual ``evaluate(genomes, key)`` path, and puts each evaluated genome in
its cell if that cell is empty or its elite is less fit. An elite is only ever replaced by a
strictly fitter genome of the same cell, so every cell's fitness never decreases.

Cells: for descriptors ``d_1 … d_D`` with ranges ``[lo_i, hi_i]`` and ``B`` bins each, a genome
falls in cell ``Σ_i b_i B^(i-1)`` with ``b_i = clip(floor(B (d_i − lo_i)/(hi_i − lo_i)), 0,
B − 1)``. Coverage is the share of filled cells, the QD-score the sum of their fitness.

The descriptors are computed from the final display field the evaluator returns
(``metrics["fields"]``, shape ``(P, H, W)``), passed to :meth:`MapElites.tell` as ``fields``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.patterns.descriptors import SPATIAL, describe
from morphogen.search.strategy import State, Strategy

Array = Any

RANGES = {"spot_index": (-1.5, 1.5), "coherence": (0.0, 1.0), "wavelength": (2.0, 64.0),
          "covered": (0.0, 1.0), "order": (0.0, 1.0), "contrast": (0.0, 0.5)}
"""Default descriptor ranges for the cell grid (values outside fall in the edge bins)."""


class MapElitesState(NamedTuple):
    """The archive: ``genomes (C, G)``, ``fitness (C,)`` (``-inf``: empty), ``descriptors
    (C, D)`` of the elites, and ``cells (P,)``: the cells of the genomes being told."""

    genomes: Array
    fitness: Array
    descriptors: Array
    cells: Array


@jax.jit
def _describe_fields(fields: Array) -> dict[str, Array]:
    return jax.vmap(describe)(fields)


@dataclass(frozen=True)
class MapElites(Strategy):
    """MAP-Elites over ``descriptors`` with ``bins`` bins each.

    Args:
        descriptors: names of spatial descriptors (default ``spot_index``, ``coherence``:
            spots / holes / stripes against locally parallel or radial).
        bins: bins per descriptor (``bins ** len(descriptors)`` cells).
        ranges: ``(lo, hi)`` per descriptor; default from :data:`RANGES`.
        mutation: scale of the genes' ``sigma`` for the Gaussian mutation of an elite.
        explore: share of each batch drawn uniformly within the bounds once the archive holds
            elites (the last ``round(explore * P)`` genomes).
    """

    descriptors: tuple[str, ...] = ("spot_index", "coherence")
    bins: int = 8
    ranges: tuple[tuple[float, float], ...] | None = None
    mutation: float = 1.0
    explore: float = 0.25

    needs_fields: ClassVar[bool] = True
    """``tell`` needs ``fields``: the final display field of every genome, ``(P, H, W)``."""

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "descriptors", tuple(self.descriptors))
        unknown = [d for d in self.descriptors if d not in SPATIAL]
        if unknown or not self.descriptors:
            raise MorphogenError(f"map-elites descriptors {unknown or 'none'}: use names from "
                                 f"{', '.join(SPATIAL)}")
        if int(self.bins) < 1 or int(self.bins) ** len(self.descriptors) > 1_000_000:
            raise MorphogenError(f"map-elites bins {self.bins}: use 1 or more, with at most "
                                 "a million cells in all")
        ranges = self.ranges
        if ranges is None:
            missing = [d for d in self.descriptors if d not in RANGES]
            if missing:
                raise MorphogenError(f"map-elites: no default range for {missing}; give ranges")
            ranges = tuple(RANGES[d] for d in self.descriptors)
        ranges = tuple((float(lo), float(hi)) for lo, hi in ranges)
        if len(ranges) != len(self.descriptors) or any(hi <= lo for lo, hi in ranges):
            raise MorphogenError("map-elites ranges: one (low, high) with low < high per "
                                 "descriptor")
        object.__setattr__(self, "ranges", ranges)
        if not self.mutation > 0:
            raise MorphogenError(f"map-elites mutation must be > 0, got {self.mutation}")
        if not 0 <= self.explore <= 1:
            raise MorphogenError(f"map-elites explore must be in [0, 1], got {self.explore}")

    @property
    def cell_count(self) -> int:
        """Number of cells ``bins ** D``."""
        return int(self.bins) ** len(self.descriptors)

    def cells_of(self, values: Array) -> Array:
        """Cell index of descriptor values ``(P, D)`` -> ``(P,)`` int32."""
        lo = jnp.asarray([r[0] for r in self.ranges], jnp.float32)
        hi = jnp.asarray([r[1] for r in self.ranges], jnp.float32)
        b = jnp.floor(self.bins * (jnp.asarray(values, jnp.float32) - lo) / (hi - lo))
        b = jnp.clip(jnp.nan_to_num(b), 0, self.bins - 1).astype(jnp.int32)
        weights = jnp.asarray([self.bins**i for i in range(len(self.descriptors))], jnp.int32)
        return jnp.sum(b * weights, axis=-1)

    def measure(self, fields: Array) -> Array:
        """The chosen descriptors of final fields ``(P, H, W)`` -> ``(P, D)``."""
        fields = jnp.asarray(fields, jnp.float32)
        if fields.ndim != 3:
            raise MorphogenError(f"map-elites describes 2D grid fields (P, H, W); got shape "
                                 f"{fields.shape}")
        d = _describe_fields(fields)
        return jnp.stack([d[n] for n in self.descriptors], axis=-1)

    def tell(self, genomes: Array, fitness: Array, state: State,
             fields: Array | None = None) -> tuple[State, dict]:
        """As :meth:`Strategy.tell`, with ``fields``: the final display field of each genome,
        ``(P, H, W)`` (``metrics["fields"]`` of the evaluator)."""
        if fields is None:
            raise MorphogenError("map-elites needs the final fields to place genomes in cells: "
                                 "pass fields=metrics['fields']")
        values = self.measure(fields)
        if values.shape[0] != self.population_size:
            raise MorphogenError(f"got {values.shape[0]} fields for a population of "
                                 f"{self.population_size}")
        inner = state.inner._replace(cells=self.cells_of(values),
                                     descriptors=_stage(state.inner.descriptors, values))
        return super().tell(genomes, fitness, state._replace(inner=inner))

    def _init(self, key: Array, low: Array, high: Array, sigma: Array) -> MapElitesState:
        c, g, d = self.cell_count, low.shape[0], len(self.descriptors)
        return MapElitesState(
            genomes=jnp.full((c, g), jnp.nan, jnp.float32),
            fitness=jnp.full((c,), -jnp.inf, jnp.float32),
            descriptors=jnp.full((c + self.population_size, d), jnp.nan, jnp.float32),
            cells=jnp.zeros((self.population_size,), jnp.int32),
        )

    def _ask(self, key: Array, state: State) -> tuple[Array, MapElitesState]:
        inner = state.inner
        p, g = self.population_size, state.low.shape[0]
        k_pick, k_noise, k_uniform = jax.random.split(key, 3)
        filled = jnp.isfinite(inner.fitness)
        weights = jnp.where(filled.any(), filled / jnp.maximum(filled.sum(), 1),
                            1.0 / self.cell_count)
        parents = jax.random.choice(k_pick, self.cell_count, (p,), p=weights)
        mutated = (jnp.nan_to_num(inner.genomes[parents])
                   + self.mutation * state.sigma * jax.random.normal(k_noise, (p, g)))
        uniform = jax.random.uniform(k_uniform, (p, g), minval=state.low, maxval=state.high)
        fresh = jnp.arange(p) >= p - round(self.explore * p)
        use_elite = filled.any() & ~fresh
        return jnp.where(use_elite[:, None], mutated, uniform), inner

    def _tell(self, genomes: Array, fitness: Array, state: State) -> MapElitesState:
        inner = state.inner
        c = self.cell_count
        cells = inner.cells
        values = inner.descriptors[c:]
        best = jax.ops.segment_max(fitness, cells, num_segments=c)
        index = jnp.arange(fitness.shape[0])
        top = jnp.where(fitness == best[cells], index, fitness.shape[0])
        winner = jax.ops.segment_min(top, cells, num_segments=c)
        improved = best > inner.fitness
        pick = jnp.clip(winner, 0, fitness.shape[0] - 1)
        archive = inner.descriptors[:c]
        return MapElitesState(
            genomes=jnp.where(improved[:, None], genomes[pick], inner.genomes),
            fitness=jnp.where(improved, best, inner.fitness),
            descriptors=jnp.concatenate(
                [jnp.where(improved[:, None], values[pick], archive), values]),
            cells=cells,
        )


def _stage(descriptors: Array, values: Array) -> Array:
    """Put the told genomes' descriptor values in the staging rows after the archive's."""
    p = values.shape[0]
    return descriptors.at[-p:].set(values.astype(descriptors.dtype))


def coverage(state: State) -> float:
    """Share of the archive's cells that hold an elite."""
    return float(np.mean(np.isfinite(np.asarray(state.inner.fitness))))


def qd_score(state: State, offset: float = 0.0) -> float:
    """``Σ_c (f_c − offset)`` over the filled cells (empty cells count 0).

    With ``offset`` at or below the lowest fitness a genome can get (the staged fitness of
    :mod:`morphogen.search.fitness` is never below ``INVALID = −1``), every elite adds a
    non-negative amount and the score never decreases."""
    f = np.asarray(state.inner.fitness)
    return float(np.sum(f[np.isfinite(f)] - offset))
