"""Exponential time differencing: ETDRK4 with diffusion integrated exactly in Fourier space.

For :math:`\\partial_t u = c\\,u + N(u)` mode by mode, with ``c = D lambda(k)`` the diffusion
coefficient times the grid stencil's own symbol (:mod:`morphogen.solvers.fourier`) and ``N`` the
reaction, Cox & Matthews' fourth-order scheme (J. Comput. Phys. 176, 2002, eqs. 26-29) is, with
``h = dt``, ``E = e^{hc}`` and ``E_2 = e^{hc/2}``:

.. math::
    a = E_2 v + Q N(v),\\quad b = E_2 v + Q N(a),\\quad c' = E_2 a + Q (2 N(b) - N(v)),

    v' = E v + f_1 N(v) + 2 f_2 (N(a) + N(b)) + f_3 N(c')

where ``Q = h phi(hc/2)/2``-type coefficients

.. math::
    Q = h\\,\\frac{e^{z/2} - 1}{z},\\;
    f_1 = h\\,\\frac{-4 - z + e^z (4 - 3z + z^2)}{z^3},\\;
    f_2 = h\\,\\frac{2 + z + e^z (z - 2)}{z^3},\\;
    f_3 = h\\,\\frac{-4 - 3z - z^2 + e^z (4 - z)}{z^3},\\qquad z = hc,

are evaluated from their closed forms where ``|z| >= 2`` and from their Taylor series below,
where the closed forms cancel (:func:`phi_coefficients`; Kassam & Trefethen, SIAM J. Sci.
Comput. 26, 2005, avoid the cancellation by a contour mean instead, which costs 32 complex
exponentials per mode).
Pure diffusion is integrated exactly (``v' = E v``, :meth:`EtdRk4.amplification`). The step is
limited by the reaction only.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.base import Domain
from morphogen.errors import MorphogenError
from morphogen.models.model import Array, Model, Params
from morphogen.solvers.base import Advance, Stepper
from morphogen.solvers.fourier import SpectralDiffusion, require_spectral_grid
from morphogen.solvers.stability import linear_limit

SERIES_CUT = 2.0
"""Below this ``|z|`` the φ-coefficients are summed as Taylor series, above it from their closed
forms (:func:`phi_coefficients`)."""

SERIES_TERMS = 20
"""Terms of each Taylor series: ``2^20 / 21! < 1e-13``."""


def _series() -> np.ndarray:
    """Taylor coefficients of ``f1/h, f2/h, f3/h`` in ``z`` (rows), from
    ``phi_k(z) = sum_n z^n / (n + k)!``: ``f1 = phi_1 - 3 phi_2 + 4 phi_3``,
    ``f2 = phi_2 - 2 phi_3``, ``f3 = -phi_2 + 4 phi_3``."""
    inv = 1.0 / np.array([math.factorial(k) for k in range(SERIES_TERMS + 3)], np.float64)
    n = np.arange(SERIES_TERMS)
    return np.stack([inv[n + 1] - 3 * inv[n + 2] + 4 * inv[n + 3],
                     inv[n + 2] - 2 * inv[n + 3], -inv[n + 2] + 4 * inv[n + 3]])


_SERIES = _series()


def phi_coefficients(z: Array, h: Array) -> tuple[Array, Array, Array, Array]:
    """``(Q, f1, f2, f3)`` for real ``z = h c`` (any shape), elementwise and in ``z``'s dtype.

    ``Q = h expm1(z/2) / z`` (``h/2`` at ``z = 0``); ``f1, f2, f3`` from their closed forms
    where ``|z| >=`` :data:`SERIES_CUT` and from their Taylor series below, where the closed
    forms cancel. Against 120-digit values over ``z`` in ``[-1e4, 0]`` this is within 1.9e-6
    (relative) in float32, where Kassam and Trefethen's 32-point contour mean in complex64 was
    within 1.2e-3, and it costs a few elementwise passes instead of 32 complex exponentials per
    mode (375 ms for the coefficients of two species at 256², one thread), so the coefficients
    can be recomputed whenever the step changes (:mod:`morphogen.solvers.etd_adaptive`).
    """
    small = jnp.abs(z) < SERIES_CUT
    zs = jnp.where(small, z, 0.0)  # both branches finite, so gradients are too
    zl = jnp.where(small, -SERIES_CUT, z)
    e, z3 = jnp.exp(zl), zl * zl * zl

    def series(row: np.ndarray) -> Array:
        acc = jnp.full_like(zs, float(row[-1]))
        for c in row[-2::-1]:
            acc = acc * zs + float(c)
        return acc

    closed = ((-4.0 - zl + e * (4.0 - 3.0 * zl + zl * zl)) / z3,
              (2.0 + zl + e * (zl - 2.0)) / z3,
              (-4.0 - 3.0 * zl - zl * zl + e * (4.0 - zl)) / z3)
    f1, f2, f3 = (h * jnp.where(small, series(row), c)
                  for row, c in zip(_SERIES, closed, strict=True))
    zq = jnp.where(z == 0, 1.0, z)
    q = h * jnp.where(z == 0, 0.5, jnp.expm1(zq / 2) / zq)
    return q, f1, f2, f3


class EtdRk4(Stepper):
    """Cox-Matthews ETDRK4 (module docstring)."""

    name = "etdrk4"

    def limit(self, model: Model, domain: Domain, params: Params, *,
              batched: bool = False) -> float:
        require_spectral_grid(domain, model.species, self.name)
        return linear_limit(model, domain, params, None, batched=batched)

    def amplification(self, z: np.ndarray) -> np.ndarray:
        """Exactly ``e^z`` on a pure-diffusion mode, ``z = dt D lambda(k)``."""
        return np.exp(np.asarray(z, np.float64))

    def advance(self, model: Model, domain: Domain) -> Advance:
        return make_etd_advance(model, domain)


def make_etd_advance(model: Model, domain: Domain) -> Advance:
    """The deterministic update ``(u, p, t, dt, coef) -> u`` of ETDRK4.

    ``coef`` are the exponentials and φ-coefficients, stacked over the species that share a
    transform (all of them unless periodic and no-flux species are mixed), which depend only on
    ``dt`` and the (constant) diffusion coefficients; the update's ``invariants(p, t, dt)``
    computes them, and :func:`morphogen.engine.simulate.integrate` does so once, before its time
    loop, instead of at every step (XLA does not lift the contour mean, an array ``M`` times the
    grid's size, out of the loop by itself: a 128² Schnakenberg step took 170 ms with it inside,
    1.2 ms without). With ``coef=None`` the step computes them itself.

    Each stage is one batched real transform of all species (``rfftn`` over the spatial axes of
    the ``(S, *spatial)`` stack; for no-flux species the cosine transform on the grid's own size,
    :mod:`morphogen.solvers.cosine`), and the step opens with one transform of ``u`` and ``N(u)``
    together; the final combination is one elementwise pass (``2 f_2`` precomputed).

    Raises:
        MorphogenError: a diffusion coefficient changes with ``t`` (the exponentials would be
            those of the first step's coefficient).
    """
    require_spectral_grid(domain, model.species, "etdrk4")
    _require_constant_in_time(model, domain)
    spec = SpectralDiffusion(domain, model.species)
    coords = {k: jnp.asarray(v) for k, v in domain.coords.items()}
    groups = spec.groups()
    whole = len(groups) == 1

    def invariants(p: Params, t: Array, dt: Array) -> list[tuple[Array, ...]]:
        d = tuple(model.diffusion(p, {**coords, "t": t}))
        spec.check(d, "etdrk4")
        coef = []
        for idx, mirror in groups:
            lam = jnp.asarray(spec.symbols[mirror], jnp.result_type(dt))
            z = dt * jnp.stack([jnp.asarray(d[i], jnp.result_type(dt)) for i in idx]).reshape(
                (-1,) + (1,) * lam.ndim) * lam
            q, f1, f2, f3 = phi_coefficients(z, dt)
            coef.append((jnp.exp(z), jnp.exp(z / 2), q, f1, 2.0 * f2, f3))
        return coef

    def update(u: Array, p: Params, t: Array, dt: Array,
               coef: list[tuple[Array, ...]] | None = None) -> Array:
        if coef is None:
            coef = invariants(p, t, dt)

        def reaction(x, tt):
            return jnp.asarray(model.reaction(x, p, {**coords, "t": tt}), x.dtype)

        if whole:
            return _etdrk4_stack(spec, groups[0][1], coef[0], u, t, dt, reaction)
        return _etdrk4_groups(spec, groups, coef, u, t, dt, reaction)

    return Advance(update, invariants)


def etdrk4_stages(spec: SpectralDiffusion, mirror: bool, e2: Array, q: Array, u: Array,
                  t: Array, dt: Array, reaction) -> tuple[Array, ...]:
    """The Cox-Matthews ETDRK4 stages of the whole ``(S, *spatial)`` state, every species in
    one transform: the state and the reaction at ``u``, ``a``, ``b`` and ``c``, all in Fourier
    space, ``(v, N(u), N(a), N(b), N(c))``; ``e2 = exp(z/2)``, ``q = dt φ₁(z/2)/2``. ETDRK4 and
    its error-controlled form combine them with their own weights."""
    n = u.shape[0]
    both = spec.forward_stack(jnp.concatenate([u, reaction(u, t)]), mirror)
    v, nv = both[:n], both[n:]
    a_hat = e2 * v + q * nv
    na = spec.forward_stack(reaction(spec.inverse_stack(a_hat, mirror, u.dtype), t + dt / 2),
                            mirror)
    b = spec.inverse_stack(e2 * v + q * na, mirror, u.dtype)
    nb = spec.forward_stack(reaction(b, t + dt / 2), mirror)
    c = spec.inverse_stack(e2 * a_hat + q * (2.0 * nb - nv), mirror, u.dtype)
    nc = spec.forward_stack(reaction(c, t + dt), mirror)
    return v, nv, na, nb, nc


def _etdrk4_stack(spec: SpectralDiffusion, mirror: bool, k: tuple[Array, ...], u: Array,
                  t: Array, dt: Array, reaction) -> Array:
    """One ETDRK4 step of the whole ``(S, *spatial)`` state, every species in one transform."""
    e, e2, q, f1, f2x2, f3 = k
    v, nv, na, nb, nc = etdrk4_stages(spec, mirror, e2, q, u, t, dt, reaction)
    return spec.inverse_stack(e * v + f1 * nv + f2x2 * (na + nb) + f3 * nc, mirror, u.dtype)


def _etdrk4_groups(spec: SpectralDiffusion, groups, coef, u: Array, t: Array, dt: Array,
                   reaction) -> Array:
    """ETDRK4 with periodic and no-flux species mixed: one transform per group per stage."""
    order = np.argsort(np.concatenate([np.asarray(idx) for idx, _ in groups]))

    def fwd(x):
        return [spec.forward_stack(x[np.asarray(idx)], m) for idx, m in groups]

    def inv(xs):
        return jnp.concatenate([spec.inverse_stack(x, m, u.dtype)
                                for x, (_, m) in zip(xs, groups, strict=True)])[order]

    v, nv = fwd(u), fwd(reaction(u, t))
    a_hat = [k[1] * vi + k[2] * ni for k, vi, ni in zip(coef, v, nv, strict=True)]
    na = fwd(reaction(inv(a_hat), t + dt / 2))
    b = inv([k[1] * vi + k[2] * ni for k, vi, ni in zip(coef, v, na, strict=True)])
    nb = fwd(reaction(b, t + dt / 2))
    c = inv([k[1] * ai + k[2] * (2.0 * bi - ni)
             for k, ai, bi, ni in zip(coef, a_hat, nb, nv, strict=True)])
    nc = fwd(reaction(c, t + dt))
    return inv([k[0] * vi + k[3] * n0 + k[4] * (n1 + n2) + k[5] * n3
                for k, vi, n0, n1, n2, n3 in zip(coef, v, nv, na, nb, nc, strict=True)])


def _require_constant_in_time(model: Model, domain: Domain) -> None:
    """Refuse diffusion coefficients that change with ``t`` (at the model's own parameters)."""
    p = {k: np.asarray(v, np.float64) for k, v in model.parameters().items()}
    coords = {k: np.asarray(v) for k, v in domain.coords.items()}
    with jax.ensure_compile_time_eval():
        early, late = (model.diffusion(p, {**coords, "t": t}) for t in (0.0, 997.0))
    for name, a, b in zip(model.species, early, late, strict=True):
        if np.ndim(a) == 0 and np.ndim(b) == 0 and not np.isclose(float(a), float(b)):
            raise MorphogenError(
                f"scheme etdrk4 integrates constant diffusion exactly, but the diffusion of "
                f"{name} changes with t; use imex for time-dependent diffusion")
