"""Genetic operators on network genomes (Yamamoto et al. §3.2, Table 1).

Pure functions of arrays with explicit PRNG keys; a whole generation is one jitted call
(:func:`next_generation`, ``vmap`` over children), with no Python loop over individuals.

- **Rate mutation**: a mutated reaction changes its rate's mantissa *or* exponent (equal odds)
  by ``±1``, clipped to the field's range; imposed rates (``spec.fixed``) never change.
- **Structure mutation** (network mode): a mutated *evolvable, active* reaction, with equal odds
  to a rate field, instead increments or decrements one entry of its ``M_e`` or ``M_p``
  column. A change that would break the §4.2 constraints is tried with the opposite sign, and
  dropped if that breaks them too, so no child ever breaks them.
- **Circular crossover**: the ``m_max`` slots form a ring; a segment ``[a, a + L) mod m_max``
  (``1 <= L < m_max``) is exchanged between the parents at the same positions. In parameter
  mode only the rate fields move; in network mode whole reactions move (both columns, the
  rate and the active flag). Static slots have the same structure in every genome, so they
  stay static; the two children of a pair hold exactly the parents' genes at every slot.
- **Gene duplication** (network mode): an active evolvable reaction is copied into a free
  evolvable slot, where later mutations let it diverge.
- **Tournament selection**: the fittest of ``size`` individuals drawn with replacement.

Probabilities (Table 1): a mating event mutates its child with probability 0.2, and then each
reaction with probability 0.1; crossover 0.8 per mating; duplication 0.04 per mating.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp

from morphogen.errors import MorphogenError
from morphogen.search.networks.genome import (
    MANTISSA_MAX,
    MAX_ENTRY,
    MAX_SIDE,
    Genome,
    NetworkSpec,
)

Array = Any
MODES = ("rates", "network")
DRAWS = ("log-uniform", "decade")
"""Initial rate draws of :func:`random_population`."""


@dataclass(frozen=True)
class Operators:
    """Operator settings (Table 1 defaults).

    Attributes:
        mode: ``"rates"`` (parameter sweeping, §4.1) or ``"network"`` (§4.2).
        p_mutate: probability that a mating event mutates its child.
        p_mutate_reaction: probability that a reaction of a mutated child changes.
        p_crossover: probability of crossover per mating event.
        p_duplicate: probability of gene duplication per mating event (network mode only).
        tournament: tournament size.
        elite: best individuals copied unchanged into the next generation.
        draw: the initial population's rates (:func:`random_population`): ``"log-uniform"``
            over every exponent, or ``"decade"`` within one decade of the template's.
    """

    mode: str = "network"
    p_mutate: float = 0.2
    p_mutate_reaction: float = 0.1
    p_crossover: float = 0.8
    p_duplicate: float = 0.04
    tournament: int = 2
    elite: int = 1
    draw: str = "log-uniform"

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise MorphogenError(f"unknown mode {self.mode!r}; use one of {', '.join(MODES)}")
        if self.draw not in DRAWS:
            raise MorphogenError(f"unknown rate draw {self.draw!r}; use one of "
                                 f"{', '.join(DRAWS)}")
        for name in ("p_mutate", "p_mutate_reaction", "p_crossover", "p_duplicate"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise MorphogenError(f"{name} must lie in [0, 1]")
        if self.tournament < 1:
            raise MorphogenError("tournament size must be at least 1")
        if self.elite < 0:
            raise MorphogenError("elite must be non-negative")


def _evolvable(spec: NetworkSpec) -> Array:
    return ~jnp.asarray(spec.static)


def _column_ok(col: Array) -> Array:
    """Columns ``(n, m)`` -> bool ``(m,)``: entries in ``[0, 3]``, at most 4 per side."""
    return (jnp.all((col >= 0) & (col <= MAX_ENTRY), axis=0)
            & (col.sum(axis=0) <= MAX_SIDE))


def mutate(key: Array, g: Genome, spec: NetworkSpec, ops: Operators) -> Genome:
    """Mutate each reaction of one genome with probability ``ops.p_mutate_reaction``."""
    n, m = spec.n, spec.m_max
    k_hit, k_kind, k_sign, k_mat, k_sp = jax.random.split(key, 5)
    hit = jax.random.uniform(k_hit, (m,)) < ops.p_mutate_reaction
    hit = hit & g.active & ~jnp.asarray(spec.fixed_mask)
    kinds = 3 if ops.mode == "network" else 2
    kind = jax.random.randint(k_kind, (m,), 0, kinds)
    structural = _evolvable(spec)
    kind = jnp.where((kind == 2) & ~structural, jax.random.randint(k_kind, (m,), 0, 2), kind)
    sign = jnp.where(jax.random.bernoulli(k_sign, 0.5, (m,)), 1, -1).astype(jnp.int32)
    mantissa = jnp.where(hit & (kind == 0),
                         jnp.clip(g.mantissa + sign, 0, MANTISSA_MAX), g.mantissa)
    exponent = jnp.where(hit & (kind == 1),
                         jnp.clip(g.exponent + sign, spec.exp_min, spec.exp_max), g.exponent)
    change = hit & (kind == 2)
    on_products = jax.random.bernoulli(k_mat, 0.5, (m,))
    species = jax.random.randint(k_sp, (m,), 0, n)
    delta = jax.nn.one_hot(species, n, dtype=jnp.int32).T * sign[None, :]
    educts, products = g.educts, g.products
    target = jnp.where(on_products[None, :], products, educts)
    up, down = target + delta, target - delta
    new = jnp.where(_column_ok(up)[None, :], up, jnp.where(_column_ok(down)[None, :], down, target))
    new = jnp.where(change[None, :], new, target)
    educts = jnp.where(on_products[None, :], educts, new)
    products = jnp.where(on_products[None, :], new, products)
    return Genome(mantissa, exponent, educts, products, g.active)


def crossover(key: Array, a: Genome, b: Genome, spec: NetworkSpec,
              ops: Operators) -> tuple[Genome, Genome]:
    """Circular two-point crossover of one pair; returns both children."""
    m = spec.m_max
    k_start, k_len = jax.random.split(key)
    start = jax.random.randint(k_start, (), 0, m)
    length = jax.random.randint(k_len, (), 1, max(m, 2))
    seg = jnp.mod(jnp.arange(m) - start, m) < length

    def swap(x, y, structural):
        if ops.mode == "rates" and structural:
            return x, y
        s = seg.reshape((1,) * (x.ndim - 1) + (m,))
        return jnp.where(s, y, x), jnp.where(s, x, y)

    fields = [swap(x, y, i >= 2) for i, (x, y) in enumerate(zip(a, b, strict=True))]
    return Genome(*(f[0] for f in fields)), Genome(*(f[1] for f in fields))


def duplicate(key: Array, g: Genome, spec: NetworkSpec) -> Genome:
    """Copy a random active evolvable reaction into a random free evolvable slot (no-op when
    there is none of either)."""
    evo = _evolvable(spec)
    k_src, k_dst = jax.random.split(key)
    src_ok = evo & g.active
    dst_ok = evo & ~g.active
    src = jax.random.categorical(k_src, jnp.where(src_ok, 0.0, -jnp.inf))
    dst = jax.random.categorical(k_dst, jnp.where(dst_ok, 0.0, -jnp.inf))
    can = jnp.any(src_ok) & jnp.any(dst_ok)
    src = jnp.where(can, src, 0)
    dst = jnp.where(can, dst, 0)

    def copy(x):
        return jnp.where(can, x.at[..., dst].set(x[..., src]), x)

    return Genome(copy(g.mantissa), copy(g.exponent), copy(g.educts), copy(g.products),
                  jnp.where(can, g.active.at[dst].set(True), g.active))


def tournament(key: Array, fitness: Array, count: int, size: int = 2) -> Array:
    """Indices ``(count,)`` of tournament winners: each the fittest of ``size`` individuals
    drawn uniformly with replacement (ties to the first drawn). NaN fitness loses."""
    f = jnp.where(jnp.isnan(fitness), -jnp.inf, fitness)
    draws = jax.random.randint(key, (count, size), 0, f.shape[0])
    return jnp.take_along_axis(draws, jnp.argmax(f[draws], axis=1)[:, None], axis=1)[:, 0]


def _take(pop: Genome, idx: Array) -> Genome:
    return Genome(*(x[idx] for x in pop))


def next_generation(key: Array, pop: Genome, fitness: Array, spec: NetworkSpec,
                    ops: Operators) -> Genome:
    """The next population (same size): ``ops.elite`` best survive unchanged; every other child
    comes from a mating event of two tournament winners (crossover, mutation, duplication)."""
    size = fitness.shape[0]
    k_sel, k_child = jax.random.split(key)
    parents = tournament(k_sel, fitness, 2 * size, ops.tournament).reshape(size, 2)
    mothers, fathers = _take(pop, parents[:, 0]), _take(pop, parents[:, 1])

    def child(k, a, b):
        k_c, k_pc, k_pm, k_m, k_pd, k_d = jax.random.split(k, 6)
        c, _ = crossover(k_c, a, b, spec, ops)
        c = _select(jax.random.uniform(k_pc) < ops.p_crossover, c, a)
        c = _select(jax.random.uniform(k_pm) < ops.p_mutate, mutate(k_m, c, spec, ops), c)
        if ops.mode == "network":
            c = _select(jax.random.uniform(k_pd) < ops.p_duplicate, duplicate(k_d, c, spec), c)
        return c

    children = jax.vmap(child)(jax.random.split(k_child, size), mothers, fathers)
    elite = min(ops.elite, size)
    if elite:
        best = jnp.argsort(-jnp.where(jnp.isnan(fitness), -jnp.inf, fitness))[:elite]
        children = Genome(*(c.at[:elite].set(x[best]) for c, x in zip(children, pop,
                                                                       strict=True)))
    return children


def _select(flag: Array, x: Genome, y: Genome) -> Genome:
    return Genome(*(jnp.where(flag, a, b) for a, b in zip(x, y, strict=True)))


@partial(jax.jit, static_argnames=("spec", "size", "ops"))
def random_population(key: Array, template: Genome, spec: NetworkSpec, size: int,
                      ops: Operators) -> Genome:
    """An initial population around ``template`` (one genome).

    Rates of every non-imposed slot are drawn (``ops.draw``):

    - ``"log-uniform"``: mantissa uniform in ``[10, 99]``, exponent uniform in
      ``[exp_min, exp_max]`` (roughly log-uniform from ``10^exp_min`` to ``990``: nine decades
      for Table 1's bounds), the literal reading of "0 ≤ k < 1000" (Yamamoto §4.1);
    - ``"decade"``: ``log10 k`` uniform within one decade of the template's rate,
      ``k_t · 10^U(-1, 1)``, then written with two significant digits (mantissa
      ``⌊10^(1 + frac)⌋``), exponent clipped to its bounds; a slot whose template rate is 0
      draws as ``"log-uniform"``. The reading of §4.1's "find matching rate coefficients"
      around the hand-made network (rates mode's template is Table 2).

    In network mode each genome instead gets a single random evolvable
    reaction (§4.2) in its first evolvable slot: each side draws 4 molecules among the ``n``
    species or none, entries clipped to 3, so the constraints hold. One compiled program per
    (spec, size, operators): drawn op by op, each random draw compiled apart (seconds).
    """
    n, m = spec.n, spec.m_max
    fixed = jnp.asarray(spec.fixed_mask)
    k_m, k_e, k_ed, k_pr = jax.random.split(key, 4)
    mant = jax.random.randint(k_m, (size, m), 10, MANTISSA_MAX + 1)
    expo = jax.random.randint(k_e, (size, m), spec.exp_min, spec.exp_max + 1)
    if ops.draw == "decade":
        kt = template.mantissa.astype(jnp.float32) / 10.0 * jnp.power(
            10.0, template.exponent.astype(jnp.float32))
        logk = jnp.log10(jnp.where(kt > 0, kt, 1.0)) + jax.random.uniform(
            jax.random.fold_in(key, 5), (size, m), jnp.float32, -1.0, 1.0)
        e = jnp.floor(logk)
        near_mant = jnp.clip(jnp.floor(jnp.power(10.0, logk - e + 1.0)), 10, MANTISSA_MAX)
        near = kt > 0
        mant = jnp.where(near, near_mant.astype(mant.dtype), mant)
        expo = jnp.where(near, jnp.clip(e, spec.exp_min, spec.exp_max).astype(expo.dtype), expo)
    mant = jnp.where(fixed, template.mantissa, mant).astype(jnp.int32)
    expo = jnp.where(fixed, template.exponent, expo).astype(jnp.int32)
    educts = jnp.broadcast_to(template.educts, (size, n, m))
    products = jnp.broadcast_to(template.products, (size, n, m))
    active = jnp.broadcast_to(template.active, (size, m))
    if ops.mode == "network":
        def side(k):
            draws = jax.random.randint(k, (size, MAX_SIDE), 0, n + 1)
            counts = jax.nn.one_hot(draws, n + 1, dtype=jnp.int32).sum(1)[:, :n]
            return jnp.minimum(counts, MAX_ENTRY)

        j = 2 * n
        if j >= m:
            raise MorphogenError("network mode needs at least one evolvable slot (m_max > 2n)")
        st = jnp.asarray(spec.static)
        educts = jnp.where(st, educts, 0).at[:, :, j].set(side(k_ed))
        products = jnp.where(st, products, 0).at[:, :, j].set(side(k_pr))
        active = jnp.broadcast_to(st, (size, m)).at[:, j].set(True)
    return Genome(mant, expo, jnp.asarray(educts, jnp.int32), jnp.asarray(products, jnp.int32),
                  jnp.asarray(active))
