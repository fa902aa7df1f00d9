"""ETDRK4 with its step set by accuracy: an embedded second-order solution under a PI controller.

The fixed-step ``etdrk4`` (:mod:`morphogen.solvers.etd`) integrates diffusion exactly, but its
step limit comes from the reaction's Jacobian at the ground state (the Euler disc, margin 0.5),
not from what the run needs. ``etdrk4-adaptive`` takes the same Cox-Matthews step and, from
stages it has already computed, the exponential midpoint solution of order 2 (Hochbruck and
Ostermann, Acta Numerica 19, 2010, §2.3: two stages, ``c_2 = 1/2``):

.. math::
    u_2 = E v + h(\\varphi_1 - 2\\varphi_2)(z) N(v) + 2h\\varphi_2(z) N(a),

with ``a = E_2 v + Q N(v)`` ETDRK4's first stage and ``φ_1(z) = (e^z - 1)/z``,
``φ_2(z) = (e^z - 1 - z)/z²``, ``z = h D λ(k)``. Both solutions integrate the linear diffusion
exactly, so their difference ``u_4 - u_2`` is the reaction's local error only, of order
``h³``. What the controller reads is that error as it leaves the step, damped by the step's own
diffusion, ``e = E (u_4 - u_2)`` with ``E = exp(z)`` (Fourier space, one multiply): an error in a
mode that diffusion shrinks by ``E`` over a step is shrunk as much over every later step, so the
grid-scale modes of a rough state do not hold the step down (on the Schnakenberg benchmark,
256², T = 30: 22-25 % fewer steps at rtol 1e-3 and 1e-4, the global error 5.6e-2 -> 5.7e-2 and
2.1e-3 -> 2.5e-3; docs/schemes.md). ``damped=False`` (:func:`make_pair`) gives the plain
estimate. The step ``u_4`` is accepted when

.. math:: \\Big\\| \\frac{e}{atol + rtol\\,\\max(|u|, |u'|)} \\Big\\|_{\\mathrm{RMS}} \\le 1

and the next step is set by diffrax's ``PIDController`` (``β_P = β_I = 0.3``, as for
``adaptive``) with the estimate's order 3 (:meth:`EtdRk4Pair.error_order`). The accepted
solution is the fourth-order one (local extrapolation), so the error is usually well below
the tolerance; the step is the largest the tolerance allows for the embedded estimate, with no
linear stability bound: a step that diverges is rejected by the controller.

The exponentials and φ-coefficients depend on ``h`` and are recomputed at every step, from
series and closed forms (:func:`morphogen.solvers.etd.phi_coefficients`, a few elementwise
passes). Dense output between steps is linear (diffrax's ``LocalLinearInterpolation``); the
run loop (:func:`morphogen.engine.adaptive_loop.simulate_adaptive`) lands on every output time
instead. Domains as for ``etdrk4``: grids with periodic or no-flux species (not mixed) and
constant isotropic diffusion.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, ClassVar

import diffrax
import equinox as eqx
import jax.numpy as jnp
import numpy as np

from morphogen.domains.base import Domain
from morphogen.errors import MorphogenError
from morphogen.models.model import Array, Model, Params
from morphogen.solvers.etd import (
    SERIES_CUT,
    _require_constant_in_time,
    etdrk4_stages,
    phi_coefficients,
)
from morphogen.solvers.fourier import SpectralDiffusion, require_spectral_grid

NAME = "etdrk4-adaptive"

ERROR_ORDER = 3
"""Order of the local error estimate ``u_4 - u_2`` in the step (that of the second-order
solution's local error)."""


def _phi12(z: Array, h: Array) -> tuple[Array, Array]:
    """``h φ_1(z)`` and ``h φ_2(z)``: closed forms where ``|z| >= SERIES_CUT``, Taylor series
    (16 terms) below."""
    small = jnp.abs(z) < SERIES_CUT
    zs = jnp.where(small, z, 0.0)
    zl = jnp.where(small, -SERIES_CUT, z)
    em1 = jnp.expm1(zl)
    inv = 1.0 / np.cumprod(np.arange(1.0, 20.0))  # 1/1!, 1/2!, ...

    def series(k: int) -> Array:
        acc = jnp.full_like(zs, float(inv[k + 15]))
        for n in range(14, -1, -1):
            acc = acc * zs + float(inv[n + k])
        return acc

    p1 = jnp.where(small, series(0), em1 / zl)
    p2 = jnp.where(small, series(1), (em1 - zl) / (zl * zl))
    return h * p1, h * p2


def make_pair(model: Model, domain: Domain, *, damped: bool = True
              ) -> Callable[[Array, Params, Array, Array], tuple[Array, Array]]:
    """``pair(u, p, t, h) -> (u_4, ε)``: one ETDRK4 step and its embedded estimate, ``ε = E (u_4 -
    u_2)`` with ``damped`` (the default, module docstring), else ``u_4 - u_2``.

    Raises:
        MorphogenError: the domain or coefficients cannot carry an exact Fourier diffusion.
    """
    require_spectral_grid(domain, model.species, NAME)
    _require_constant_in_time(model, domain)
    spec = SpectralDiffusion(domain, model.species)
    groups = spec.groups()
    if len(groups) != 1:
        raise MorphogenError(
            f"scheme {NAME} needs all species periodic or all no-flux; use etdrk4 or adaptive "
            "for mixed boundaries")
    mirror = groups[0][1]
    coords = {k: jnp.asarray(v) for k, v in domain.coords.items()}

    def pair(u: Array, p: Params, t: Array, h: Array) -> tuple[Array, Array]:
        d = tuple(model.diffusion(p, {**coords, "t": t}))
        spec.check(d, NAME)
        lam = jnp.asarray(spec.symbols[mirror], u.dtype)
        dd = jnp.stack([jnp.asarray(x, u.dtype) for x in d]).reshape((-1,) + (1,) * lam.ndim)
        z = h * dd * lam
        q, f1, f2, f3 = phi_coefficients(z, h)
        p1, p2 = _phi12(z, h)
        e, e2 = jnp.exp(z), jnp.exp(z / 2)

        def reaction(x, tt):
            return jnp.asarray(model.reaction(x, p, {**coords, "t": tt}), x.dtype)

        n = u.shape[0]
        v, nv, na, nb, nc = etdrk4_stages(spec, mirror, e2, q, u, t, h, reaction)
        u4 = e * v + f1 * nv + 2.0 * f2 * (na + nb) + f3 * nc
        err = (f1 - p1 + 2.0 * p2) * nv + 2.0 * (f2 - p2) * na + 2.0 * f2 * nb + f3 * nc
        if damped:
            err = e * err
        out = spec.inverse_stack(jnp.concatenate([u4, err]), mirror, u.dtype)
        return out[:n], out[n:]

    return pair


class EtdRk4Pair(diffrax.AbstractAdaptiveSolver):
    """ETDRK4 with the embedded exponential midpoint estimate, as a diffrax solver, so that
    diffrax's ``PIDController``, step budget and output times drive it (module docstring).
    ``diffeqsolve``'s ``args`` are the model's parameters; its term is the full right-hand side
    (used only to pick a first step when none is given)."""

    pair: Callable = eqx.field(static=True)
    term_structure: ClassVar = diffrax.AbstractTerm
    interpolation_cls: ClassVar = diffrax.LocalLinearInterpolation

    def order(self, terms: Any) -> int:
        return 4

    def error_order(self, terms: Any) -> int:
        return ERROR_ORDER

    def init(self, terms: Any, t0: Any, t1: Any, y0: Array, args: Any) -> None:
        return None

    def step(self, terms: Any, t0: Any, t1: Any, y0: Array, args: Any, solver_state: None,
             made_jump: Any) -> tuple[Array, Array, dict, None, Any]:
        del solver_state, made_jump
        y1, err = self.pair(y0, args, t0, t1 - t0)
        return y1, err, {"y0": y0, "y1": y1}, None, diffrax.RESULTS.successful

    def func(self, terms: Any, t0: Any, y0: Array, args: Any) -> Array:
        return terms.vf(t0, y0, args)


def embedded_pair(model: Model, domain: Domain) -> EtdRk4Pair:
    """The ``etdrk4-adaptive`` scheme's embedded pair for ``model`` on ``domain``, as
    :func:`morphogen.solvers.adaptive.solve` and the run loop take it from the registry.

    Raises:
        MorphogenError: the domain or coefficients cannot carry an exact Fourier diffusion.
    """
    return EtdRk4Pair(make_pair(model, domain))
