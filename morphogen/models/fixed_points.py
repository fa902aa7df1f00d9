"""Homogeneous fixed points of any model: batched multi-start Newton, deduplicated.

A homogeneous steady state of :math:`\\partial_t u = R(u) + D\\nabla^2 u` is a root of the
reaction, :math:`R(u^*) = 0` (Murray, Mathematical Biology II, ch. 2.3: the state the linear
stability analysis of :mod:`morphogen.models.linear` is taken about). A model may have several
(Gray-Scott has ``(1, 0)`` and, for :math:`F > 4(F + k)^2`, two more), and for a mass-action
network (Yamamoto et al. eqs. 2-3) they may lie decades away from 1, where Newton in ``u`` from
a unit start stalls. The finder therefore runs, for every parameter set:

1. **Newton in u** from each start, :math:`u \\leftarrow u - J(u)^{+} R(u)` (least squares, so
   a singular ``J`` makes no NaN), :data:`NEWTON` steps;
2. **Newton in log-concentrations** from ``u = 1`` with each subset of the species held at 0
   (the empty one first; every subset while ``S <= 4``, else only the empty one): Newton on
   ``x = log u`` of a residual that is linear in ``x`` where one term dominates, steps clipped
   to 5 (a factor 150), :data:`LOG_NEWTON` steps, each result then polished by
   :data:`POLISH` Newton steps in ``u`` (both kept, polished first). The residual is the
   :class:`Balance`'s: for a generic model the per-capita rate ``R_i(u) / u_i``; for a padded
   mass-action genome (:func:`padded_balance`) ``log P_i - log C_i`` with ``P = ν⁺v`` and
   ``C = ν⁻v`` the gross production and consumption;

and keeps a candidate if it is finite (and non-negative, for a chemistry) with every
``|R_i(u)| <= rtol * g_i(u)``, ``g`` the balance's gross rate of species ``i`` (for a network
``Σ_j |ν_ij| v_j``; generic: ``Σ_j |J_ij u_j|``), ``rtol`` :data:`RESIDUAL` (float64) or
:data:`RESIDUAL_32` (float32). A candidate equal to an earlier one within
``DEDUP * (|u| + 1e-12)`` is a duplicate. Candidates keep their order: the first start, the
log-Newton results, the remaining starts, so ``first_found`` prefers the caller's first start.

Everything is pure JAX in the dtype of the parameters: ``jit`` and ``vmap`` it over a
population (:func:`fixed_points_batch`: one program for every genome of a
:func:`morphogen.search.networks.reaction.padded_model`). Float64 where the caller enables it
(``jax.enable_x64``), else float32 with the looser stated tolerances.
"""

from __future__ import annotations

import itertools
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.models.model import CENTRE, Array, Model, Params, reaction_jacobian

NEWTON = 60
LOG_NEWTON = 100
POLISH = 10
RESIDUAL = 1e-8
"""Relative residual a float64 fixed point must reach (``|R_i| <= RESIDUAL * g_i``)."""
RESIDUAL_32 = 2e-5
"""The same in float32 (about 170 units of rounding, ``2^-23 = 1.2e-7``)."""
DEDUP = 1e-6
DEDUP_32 = 1e-3
"""Two candidates closer than this times ``|u| + 1e-12`` (every species) are one fixed point."""
MAX_SUBSET_SPECIES = 4
"""Up to this many species every subset is tried held at 0 in log-Newton (``2^S`` runs)."""


class FixedPoints(NamedTuple):
    """Candidates of one parameter set (a leading population axis under ``vmap``). The Newton
    runs from the starts, and the log-Newton runs, are each one loop vmapped over its starts
    (one small program; unrolled per start, a 26-start search took seconds to compile).

    Attributes:
        u: the candidates, shape ``(K, S)`` (meaningless where not ``found``).
        found: converged and no duplicate of an earlier candidate, shape ``(K,)``.
        converged: converged (duplicates included), shape ``(K,)``.
    """

    u: Array
    found: Array
    converged: Array


@dataclass(frozen=True)
class Balance:
    """How residuals are measured and where log-Newton works.

    Attributes:
        log_residual: ``(x, zero, p) -> (S,)``, zero where ``u = exp(x)`` (species in ``zero``
            held at 0) is a fixed point; for held species it must be ``x_i``.
        gross: ``(u, p) -> (S,)``, the scale of ``R_i`` at ``u`` (non-negative).
        nonnegative: fixed points must have ``u >= 0`` (concentrations).
    """

    log_residual: Callable[[Array, Array, Params], Array]
    gross: Callable[[Array, Params], Array]
    nonnegative: bool = False


def _rate(model: Model) -> Callable[[Array, Params], Array]:
    def f(u: Array, p: Params) -> Array:
        return model.reaction(u.reshape(-1, 1), p, CENTRE).reshape(-1)

    return f


def generic_balance(model: Model) -> Balance:
    """Any model: the per-capita rate ``R_i(u) / u_i`` in log-Newton, and the gross rate
    ``g_i = Σ_j |J_ij u_j|`` (for a monomial ``k u^e``, ``u ∂/∂u`` is ``e`` times the term)."""
    f = _rate(model)

    def log_residual(x: Array, zero: Array, p: Params) -> Array:
        u = jnp.where(zero, 0.0, jnp.exp(x))
        return jnp.where(zero, x, f(u, p) / jnp.where(zero, 1.0, u))

    def gross(u: Array, p: Params) -> Array:
        return jnp.abs(reaction_jacobian(model, u, p) * u[None, :]).sum(axis=1)

    return Balance(log_residual, gross)


def padded_balance(model: Model) -> Balance:
    """A padded mass-action genome (parameters ``k``, ``Me``, ``Mp``;
    :func:`morphogen.search.networks.reaction.genome_params`, Yamamoto et al. eqs. 2-3):
    ``log P_i - log C_i`` with ``P = ν⁺ v``, ``C = ν⁻ v``, ``ν^± = max(±(M_p - M_e), 0)`` (a
    catalyst's own molecules cancel), ``v_j = k_j exp(Σ_l M_e(l, j) x_l)`` with the reactions
    that consume a held species dropped; sums of monomials in ``u``, so ``log P`` is linear in
    ``x`` where one monomial dominates. Gross rate ``Σ_j |ν_ij| |v_j|``; concentrations are
    non-negative."""
    del model

    def log_residual(x: Array, zero: Array, p: Params) -> Array:
        me = p["Me"].astype(x.dtype)
        nu = (p["Mp"] - p["Me"]).astype(x.dtype)
        gain, loss = jnp.maximum(nu, 0.0), jnp.maximum(-nu, 0.0)
        k = p["k"] * jnp.all(~zero[:, None] | (p["Me"] == 0), axis=0)
        v = k * jnp.exp(me.T @ jnp.where(zero, 0.0, x))
        tiny = _tiny(x.dtype)
        return jnp.where(zero, x, jnp.log(gain @ v + tiny) - jnp.log(loss @ v + tiny))

    def gross(u: Array, p: Params) -> Array:
        flux = p["k"] * jnp.prod(jnp.where(p["Me"] > 0, u[:, None] ** p["Me"], 1.0), axis=0)
        return jnp.abs((p["Mp"] - p["Me"]).astype(u.dtype)) @ jnp.abs(flux)

    return Balance(log_residual, gross, nonnegative=True)


def _tiny(dtype: Any) -> float:
    return 1e-300 if jnp.dtype(dtype) == jnp.float64 else 1e-37


def _solve(a: Array, b: Array) -> Array:
    """Least-squares solve with non-finite entries zeroed first (NaN input made LAPACK spin)."""
    return jnp.nan_to_num(jnp.linalg.lstsq(jnp.nan_to_num(a), jnp.nan_to_num(b))[0])


BALANCES: dict[str, Callable[[Model], Balance]] = {"generic": generic_balance,
                                                   "mass-action": padded_balance}
"""Residual kinds by name: ``generic`` for any model, ``mass-action`` for padded genomes."""


def solver(model: Model, *, balance: str = "generic", newton: int = NEWTON,
           log_newton: int = LOG_NEWTON, polish: int = POLISH,
           subsets: bool | None = None) -> Callable[[Params, Array], FixedPoints]:
    """The fixed-point search of one parameter set, ``(params, starts (K0, S)) -> FixedPoints``
    with ``K = K0 + 2 * (number of held-at-0 subsets)`` candidates (module docstring); pure:
    ``jit`` and ``vmap`` it. ``subsets``: try every subset of species held at 0 (default:
    while ``S <` :data:`MAX_SUBSET_SPECIES` ``+ 1``); a start with a non-finite entry is
    replaced by ones."""
    bal = BALANCES[balance](model)
    f = _rate(model)
    n = len(model.species)
    every = n <= MAX_SUBSET_SPECIES if subsets is None else subsets
    zeros = list(itertools.product((False, True), repeat=n)) if every else [(False,) * n]

    def run(p: Params, starts: Array) -> FixedPoints:
        dtype = starts.dtype
        f64 = jnp.dtype(dtype) == jnp.float64
        rtol = RESIDUAL if f64 else RESIDUAL_32
        dedup = DEDUP if f64 else DEDUP_32
        xmax = 600.0 if f64 else 80.0

        def newton_in_u(u: Array, iters: int) -> Array:
            def step(_, u):
                return u - _solve(reaction_jacobian(model, u, p), f(u, p))

            return jax.lax.fori_loop(0, iters, step, u)

        def newton_in_log(zero: Array) -> Array:
            def g(x):
                return bal.log_residual(x, zero, p)

            def step(_, x):
                dx = jnp.clip(_solve(jax.jacfwd(g)(x), g(x)), -5.0, 5.0)
                return jnp.clip(x - dx, -xmax, xmax)

            x = jax.lax.fori_loop(0, log_newton, step, jnp.zeros(n, dtype))
            return jnp.where(zero, 0.0, jnp.exp(x))

        def clean(u: Array) -> Array:
            """Rounding's negative zeros (``> -1e-12`` of the largest entry) set to 0."""
            return jnp.where(u >= -1e-12 * (1 + jnp.max(jnp.abs(u))), jnp.maximum(u, 0.0), u)

        def converged(u: Array) -> Array:
            gross = bal.gross(u, p)
            r = jnp.abs(f(u, p))
            ok = (jnp.all(jnp.isfinite(u)) & jnp.all(jnp.isfinite(gross))
                  & jnp.all(jnp.isfinite(r)) & jnp.all(r <= rtol * gross))
            return ok & jnp.all(u >= 0) if bal.nonnegative else ok

        starts = jnp.where(jnp.all(jnp.isfinite(starts), axis=-1, keepdims=True), starts, 1.0)
        plain = jax.vmap(lambda s: newton_in_u(s, newton))(starts)
        far = jax.vmap(newton_in_log)(jnp.asarray(zeros))
        polished = jax.vmap(lambda v: newton_in_u(v, polish))(far)
        logs = jnp.stack([polished, far], axis=1).reshape(-1, n)
        u = jax.vmap(clean)(jnp.concatenate([plain[:1], logs, plain[1:]]))
        ok = jax.vmap(converged)(u)
        close = jnp.all(jnp.abs(u[:, None] - u[None]) <= dedup * (jnp.abs(u[None]) + 1e-12),
                        axis=-1)
        earlier = jnp.tril(close & ok[None, :], k=-1).any(axis=1)
        return FixedPoints(u, ok & ~earlier, ok)

    return run


_PROGRAMS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def fixed_points_batch(model: Model, params: Params, starts: Array, *,
                       balance: str = "generic", **options: Any) -> FixedPoints:
    """:func:`solver` over a population: every parameter leaf has a leading axis ``P``;
    ``starts`` is ``(K0, S)`` (shared) or ``(P, K0, S)``. One compiled program per model and
    options (kept for the model's lifetime); returns ``FixedPoints`` with ``u`` ``(P, K, S)``.
    Computes in the dtype of ``starts`` (float64 inside ``jax.enable_x64``)."""
    key = (balance, tuple(sorted(options.items())))
    programs = _PROGRAMS.setdefault(model, {})
    if key not in programs:
        run = solver(model, balance=balance, **options)
        programs[key] = (jax.jit(jax.vmap(run, in_axes=(0, None))),
                         jax.jit(jax.vmap(run, in_axes=(0, 0))))
    shared, own = programs[key]
    starts = jnp.asarray(starts)
    return (own if starts.ndim == 3 else shared)(params, starts)


def first_found(points: FixedPoints) -> tuple[Array, Array]:
    """The first found candidate ``u`` ``(..., S)`` and whether there is one ``(...)``."""
    index = jnp.argmax(points.found, axis=-1)
    u = jnp.take_along_axis(points.u, index[..., None, None], axis=-2)[..., 0, :]
    return u, points.found.any(axis=-1)


def default_starts(model: Model, params: Params, count: int = 24, seed: int = 0) -> np.ndarray:
    """Starts for a model with unknown fixed points, shape ``(count + 2, S)``: its declared
    ground state (:attr:`Model.ground`; ones if it declares none), ones, then ``count`` fixed
    pseudo-random points, three quarters log-uniform in ``[1e-2, 1e2]`` and a quarter uniform
    in ``[-2, 2]`` (models whose states may be negative)."""
    n = len(model.species)
    rng = np.random.default_rng(seed)
    pos = 10.0 ** rng.uniform(-2, 2, (count - count // 4, n))
    signed = rng.uniform(-2, 2, (count // 4, n))
    ground = np.ones((1, n)) if model.ground is None else np.asarray(
        model.ground({k: float(v) for k, v in params.items()}), np.float64).reshape(1, n)
    return np.concatenate([ground, np.ones((1, n)), pos, signed])


def homogeneous_params(model: Model, params: Params, dtype: Any) -> dict[str, Array]:
    """One parameter set for the homogeneous problem: a parameter whose default is a number
    becomes its spatial mean in ``dtype``; one whose default is an array (a padded network's
    ``k``, ``Me``, ``Mp``) is kept as given (integer arrays keep their type)."""
    out = {}
    for name, value in params.items():
        if np.ndim(model.params.get(name, 0.0)):
            a = jnp.asarray(value)
            out[name] = a if jnp.issubdtype(a.dtype, jnp.integer) else a.astype(dtype)
        else:
            out[name] = jnp.asarray(np.mean(np.asarray(value, np.float64)), dtype)
    return out


def fixed_points(model: Model, params: Params, starts: np.ndarray | None = None, *,
                 balance: str = "generic", x64: bool = True) -> np.ndarray:
    """Every distinct homogeneous fixed point of one parameter set, shape ``(K, S)`` (``K`` may
    be 0), in float64 by default (``x64=False``: float32 and its tolerances), sorted by the
    first species. Starts default to :func:`default_starts`. Spatially varying parameters
    are replaced by their means (:func:`homogeneous_params`)."""
    dtype = jnp.float64 if x64 else jnp.float32
    with jax.enable_x64(x64):
        p = homogeneous_params(model, params, dtype)
        if starts is None:
            starts = default_starts(model, {k: v for k, v in p.items() if not jnp.ndim(v)})
            starts = starts if np.all(np.isfinite(starts)) else np.nan_to_num(starts, nan=1.0)
        p = jax.tree.map(lambda a: a[None], p)
        out = fixed_points_batch(model, p, jnp.asarray(starts, dtype), balance=balance)
        u = np.asarray(out.u[0], np.float64)[np.asarray(out.found[0])]
    return u[np.lexsort(u.T[::-1])] if len(u) else u.reshape(0, len(model.species))
