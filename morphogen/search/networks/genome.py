"""Reaction-network genomes (Yamamoto et al. §2, §3.1, §4.2).

A genome is the rate vector ``k`` (``m`` rates), the educt and product stoichiometric matrices
``M_e``, ``M_p`` (``n × m``) and the diffusion coefficients ``D`` (``n``, fixed during evolution,
§3.2 last paragraph, so they live in the :class:`NetworkSpec` shared by a population). Every
genome has the same number of reaction slots ``m_max``, laid out as

==========================  ==============================================================
columns ``0 .. n-1``        static inflow ``∅ → S_i`` (structure fixed, rate evolvable)
columns ``n .. 2n-1``       static decay ``S_i → ∅`` (structure fixed, rate evolvable)
columns ``2n .. m_max-1``   evolvable reactions, used or not (``active``)
==========================  ==============================================================

so a population of different topologies is a batch of arrays of one shape: the structure is
runtime data, not Python fixed at trace time.

Rates are stored in scientific notation with integer fields (§3.2): ``k = (mantissa / 10) ·
10^exponent`` with ``mantissa ∈ [0, 99]`` (two significant digits, as in Table 2; ``0`` is the
rate 0 of Table 3) and ``exponent ∈ [exp_min, exp_max]``; ``exp_max = 2`` keeps ``k < 1000``
(§4.1).

Constraints (§4.2): every entry of ``M_e``, ``M_p`` is at most :data:`MAX_ENTRY` = 3 and at most
:data:`MAX_SIDE` = 4 molecules stand on either side of a reaction.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError

Array = Any

MAX_ENTRY = 3
MAX_SIDE = 4
MANTISSA_MAX = 99


class Genome(NamedTuple):
    """One genome, or a population with a leading axis ``P`` on every field (a pytree).

    Attributes:
        mantissa: int32 ``(m_max,)`` in ``[0, 99]``.
        exponent: int32 ``(m_max,)`` in ``[exp_min, exp_max]``.
        educts: int32 ``(n, m_max)``, ``M_e``.
        products: int32 ``(n, m_max)``, ``M_p``.
        active: bool ``(m_max,)``; static reactions are always active.
    """

    mantissa: Array
    exponent: Array
    educts: Array
    products: Array
    active: Array


@dataclass(frozen=True)
class NetworkSpec:
    """What a population shares: species, slots, diffusion, imposed rates and rate bounds.

    Attributes:
        species: names, length ``n``.
        m_max: reaction slots, at least ``2n`` (the static inflow and decay reactions).
        diffusion: ``D``, length ``n``.
        fixed: rate indices whose value is imposed (never mutated, §4.2).
        fixed_rates: the imposed values, same length as ``fixed``.
        exp_min, exp_max: exponent bounds.
    """

    species: tuple[str, ...]
    m_max: int
    diffusion: tuple[float, ...]
    fixed: tuple[int, ...] = ()
    fixed_rates: tuple[float, ...] = ()
    exp_min: int = -6
    exp_max: int = 2

    def __post_init__(self) -> None:
        n = len(self.species)
        if n < 1 or len(set(self.species)) != n:
            raise MorphogenError("a network needs at least one species, each named once")
        if self.m_max < 2 * n:
            raise MorphogenError(
                f"m_max = {self.m_max} leaves no room for the {2 * n} static inflow and decay "
                f"reactions; use m_max >= {2 * n}"
            )
        if len(self.diffusion) != n or any(d < 0 for d in self.diffusion):
            raise MorphogenError(f"need {n} non-negative diffusion coefficients")
        if len(self.fixed) != len(self.fixed_rates):
            raise MorphogenError("fixed and fixed_rates must have the same length")
        if any(not 0 <= j < self.m_max for j in self.fixed):
            raise MorphogenError(f"fixed rate indices must lie in [0, {self.m_max})")
        if self.exp_min > self.exp_max:
            raise MorphogenError("exp_min must not exceed exp_max")

    @property
    def n(self) -> int:
        return len(self.species)

    @property
    def static(self) -> np.ndarray:
        """Bool ``(m_max,)``: the static inflow/decay slots."""
        out = np.zeros(self.m_max, bool)
        out[: 2 * self.n] = True
        return out

    @property
    def fixed_mask(self) -> np.ndarray:
        """Bool ``(m_max,)``: rates that are imposed."""
        out = np.zeros(self.m_max, bool)
        out[list(self.fixed)] = True
        return out

    def static_structure(self) -> tuple[np.ndarray, np.ndarray]:
        """``(M_e, M_p)`` of the static slots (zeros in the evolvable ones), int32."""
        n = self.n
        me = np.zeros((n, self.m_max), np.int32)
        mp = np.zeros((n, self.m_max), np.int32)
        mp[np.arange(n), np.arange(n)] = 1
        me[np.arange(n), n + np.arange(n)] = 1
        return me, mp


def encode_rates(k: Array, exp_min: int = -6, exp_max: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Nearest ``(mantissa, exponent)`` of rates ``k >= 0`` (two significant digits).

    ``k = 0`` encodes as mantissa 0; values beyond the bounds are clipped to them.
    """
    k = np.asarray(k, np.float64)
    if (k < 0).any() or not np.isfinite(k).all():
        raise MorphogenError("rates must be finite and non-negative")
    safe = np.where(k > 0, k, 1.0)
    e = np.floor(np.log10(safe)).astype(np.int64)
    mant = np.rint(safe / 10.0 ** e * 10).astype(np.int64)
    e = np.where(mant >= 100, e + 1, e)
    mant = np.where(mant >= 100, 10, mant)
    low = e < exp_min
    mant = np.where(low, np.rint(safe / 10.0 ** exp_min * 10), mant).astype(np.int64)
    e = np.clip(e, exp_min, exp_max)
    mant = np.where(k > 0, np.clip(mant, 0, MANTISSA_MAX), 0)
    e = np.where(k > 0, e, exp_min)
    return mant.astype(np.int32), e.astype(np.int32)


def rates(genome: Genome) -> Array:
    """``k = (mantissa / 10) · 10^exponent``, float32, with inactive slots set to 0."""
    k = genome.mantissa.astype(jnp.float32) / 10.0 * jnp.power(
        10.0, genome.exponent.astype(jnp.float32))
    return jnp.where(genome.active, k, 0.0)


def make_genome(
    spec: NetworkSpec,
    k: Sequence[float],
    educts: np.ndarray | None = None,
    products: np.ndarray | None = None,
) -> Genome:
    """A genome from rates and the evolvable reactions' matrices.

    Args:
        k: rates of all ``m_max`` slots (those of unused evolvable slots are kept for later).
        educts, products: ``(n, e)`` matrices of the first ``e`` evolvable reactions
            (``e <= m_max - 2n``); the remaining slots are inactive.

    Raises:
        MorphogenError: wrong shapes, negative entries, or broken constraints.
    """
    n, m = spec.n, spec.m_max
    me, mp = spec.static_structure()
    evo_e = np.zeros((n, 0), np.int64) if educts is None else np.asarray(educts, np.int64)
    evo_p = np.zeros((n, 0), np.int64) if products is None else np.asarray(products, np.int64)
    if evo_e.shape != evo_p.shape or evo_e.ndim != 2 or evo_e.shape[0] != n:
        raise MorphogenError(f"evolvable matrices must both have shape ({n}, reactions)")
    e = evo_e.shape[1]
    if e > m - 2 * n:
        raise MorphogenError(f"{e} evolvable reactions do not fit in {m - 2 * n} slots")
    check_constraints(evo_e, evo_p)
    me[:, 2 * n: 2 * n + e] = evo_e
    mp[:, 2 * n: 2 * n + e] = evo_p
    if len(k) != m:
        raise MorphogenError(f"need {m} rates (one per slot), got {len(k)}")
    k = np.asarray(k, np.float64).copy()
    k[list(spec.fixed)] = spec.fixed_rates
    mant, ex = encode_rates(k, spec.exp_min, spec.exp_max)
    active = np.zeros(m, bool)
    active[: 2 * n + e] = True
    return Genome(jnp.asarray(mant), jnp.asarray(ex), jnp.asarray(me), jnp.asarray(mp),
                  jnp.asarray(active))


def check_constraints(educts: np.ndarray, products: np.ndarray) -> None:
    """Raise :class:`MorphogenError` naming the first reaction (column) that breaks §4.2."""
    for name, mat in (("educt", educts), ("product", products)):
        mat = np.asarray(mat)
        if (mat < 0).any():
            raise MorphogenError(f"{name} stoichiometric entries must be non-negative")
        for j in range(mat.shape[1]):
            if mat[:, j].max(initial=0) > MAX_ENTRY:
                raise MorphogenError(
                    f"reaction {j + 1}: {name} coefficient above {MAX_ENTRY}; at most "
                    f"{MAX_ENTRY} molecules of one species per side")
            if mat[:, j].sum() > MAX_SIDE:
                raise MorphogenError(
                    f"reaction {j + 1}: more than {MAX_SIDE} {name} molecules; at most "
                    f"{MAX_SIDE} per side")


def satisfied(genome: Genome, spec: NetworkSpec) -> Array:
    """Bool per genome: constraints hold and static slots are untouched (for tests/guards)."""
    me, mp = spec.static_structure()
    st = jnp.asarray(spec.static)
    ok = (jnp.all(genome.educts <= MAX_ENTRY, axis=(-2, -1))
          & jnp.all(genome.products <= MAX_ENTRY, axis=(-2, -1))
          & jnp.all(genome.educts >= 0, axis=(-2, -1))
          & jnp.all(genome.products >= 0, axis=(-2, -1))
          & jnp.all(genome.educts.sum(-2) <= MAX_SIDE, axis=-1)
          & jnp.all(genome.products.sum(-2) <= MAX_SIDE, axis=-1)
          & jnp.all(jnp.where(st, genome.educts == me, True), axis=(-2, -1))
          & jnp.all(jnp.where(st, genome.products == mp, True), axis=(-2, -1))
          & jnp.all(jnp.where(st, genome.active, True), axis=-1)
          & jnp.all((genome.mantissa >= 0) & (genome.mantissa <= MANTISSA_MAX), axis=-1)
          & jnp.all((genome.exponent >= spec.exp_min) & (genome.exponent <= spec.exp_max),
                    axis=-1))
    return ok


def stack(genomes: Sequence[Genome]) -> Genome:
    """A population from single genomes (leading axis ``P``)."""
    return Genome(*(jnp.stack(f) for f in zip(*genomes, strict=True)))


def table2_spec() -> NetworkSpec:
    """The hand-made activator-inhibitor-catalyst network of Yamamoto §2.1 / Table 2 as a spec:
    species ``A, B, C``; inflow of ``A`` and ``B`` imposed at 0, decay of ``C`` imposed at 0
    (``μ_c = 0``); three evolvable slots; ``D = (0.005, 0.2, 0)``."""
    return NetworkSpec(("A", "B", "C"), 9, (0.005, 0.2, 0.0), fixed=(0, 1, 5),
                       fixed_rates=(0.0, 0.0, 0.0))


def table2_genome(spec: NetworkSpec | None = None) -> Genome:
    """Table 2's hand-made rates: ``2A + C → 3A + C`` (0.01), ``B + C → B`` (0.1),
    ``2A → 2A + B`` (0.02), ``∅ → C`` (0.1), ``A → ∅`` (0.01), ``B → ∅`` (0.02)."""
    spec = spec or table2_spec()
    #              R1 R2 R3
    me = np.array([[2, 0, 2],
                   [0, 1, 0],
                   [1, 1, 0]])
    mp = np.array([[3, 0, 2],
                   [0, 1, 1],
                   [1, 0, 0]])
    k = [0.0, 0.0, 0.1, 0.01, 0.02, 0.0, 0.01, 0.1, 0.02]
    return make_genome(spec, k, me, mp)


def reaction_text(educts: Sequence[int], products: Sequence[int], species: Sequence[str]) -> str:
    """``"2A + C -> 3A + C"``; an empty side is ``∅``."""

    def side(col):
        terms = [f"{c if c > 1 else ''}{s}" for c, s in zip(col, species, strict=True) if c]
        return " + ".join(terms) or "∅"

    return f"{side(educts)} -> {side(products)}"


def describe(genome: Genome, spec: NetworkSpec) -> list[dict[str, Any]]:
    """The active reactions of one genome: ``{"reaction", "k", "static", "fixed"}`` each."""
    k = np.asarray(rates(genome))
    me, mp = np.asarray(genome.educts), np.asarray(genome.products)
    out = []
    for j in np.flatnonzero(np.asarray(genome.active)):
        out.append({"reaction": reaction_text(me[:, j], mp[:, j], spec.species),
                    "k": float(f"{k[j]:.2g}"), "static": bool(spec.static[j]),
                    "fixed": bool(spec.fixed_mask[j])})
    return out
