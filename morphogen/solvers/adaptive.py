"""Adaptive step size: an embedded Runge-Kutta pair under a PI step-size controller.

Skaggs §3.2 hand-tunes a fixed ``dt`` per model ("the largest dt which resulted in consistently
stable simulations", Table 3.3) and Ringham §2.2 (eqs. 2-4) steps forward Euler; here the step
follows the local error instead. The right-hand side ``f(u) = R(u, p, x, t) + ∇·(D∇u)``
(:func:`morphogen.solvers.base.make_rhs`: any grid in 2D or 3D, any mesh, any coefficients; held
Dirichlet values get ``f = 0``) is advanced by Tsitouras' 5(4) pair (Tsit5, diffrax's
``Tsit5``). Each step ``h`` gives ``u'`` (order 5) and an embedded error estimate ``e``
(order 4); with

.. math:: \\varepsilon = \\Big\\| \\frac{e}{atol + rtol\\,\\max(|u|, |u'|)} \\Big\\|_{\\mathrm{RMS}}

the step is accepted when ``ε <= 1`` and retried smaller (a *rejected* step) otherwise. The
next step is ``h' = h · clip(0.9 ε_n^{-(β_P + β_I)/5} ε_{n-1}^{β_P/5}, 0.2, 10)``: a PI
controller (Gustafsson 1991; diffrax's ``PIDController`` with ``β_P = β_I = 0.3``), which keeps
an explicit pair whose step is limited by stability (stiff diffusion) from alternating between
accepted and rejected steps. On a stiff model the step settles near the explicit stability
limit with some rejections; :mod:`morphogen.solvers.imex` schemes are then cheaper
(``scheme="auto"``).

Output times do not depend on the step sequence: a run
(:func:`morphogen.engine.adaptive_loop.simulate_adaptive`) integrates from one output time to
the next (:func:`segment`), the last step of each segment shortened to land on it exactly; the
pure :func:`solve` reads requested times off the pair's 4th-order dense output
(``SaveAt(ts=...)``). Both have a budget of steps, accepted and rejected: a stiff or diverging
model stops instead of shrinking its step forever.

Stochastic terms (noise, a mesh's stochastic diffusion) have no error estimate that a
deterministic pair could control; they are refused with a one-line error naming ``euler``.
"""

from __future__ import annotations

import importlib
import math
from functools import lru_cache
from typing import Any

import diffrax
import jax
import jax.numpy as jnp

from morphogen.domains.base import Domain
from morphogen.errors import MorphogenError
from morphogen.models.model import Array, Model, Params
from morphogen.solvers.base import make_rhs
from morphogen.solvers.registry import ERROR_CONTROLLED, SCHEMES
from morphogen.solvers.step import Noise

DEFAULT_RTOL = 1e-3
"""Relative tolerance when none is given."""

DEFAULT_ATOL = 1e-6
"""Absolute tolerance when none is given."""

MAX_STEPS = 100_000
"""Default budget of steps (accepted and rejected) for one run."""

def check_tolerances(rtol: float, atol: float) -> None:
    """Refuse tolerances that are not positive finite numbers (one line)."""
    for name, value in (("rtol", rtol), ("atol", atol)):
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise MorphogenError(f"--{name} must be a positive number, got {value}")


def check_deterministic(domain: Domain, noise: Noise | None, scheme: str = "adaptive") -> None:
    """Refuse stochastic terms, naming a scheme that carries them."""
    if noise is not None and noise.amplitude > 0:
        raise MorphogenError(
            f"scheme {scheme} controls the error of deterministic models only; use --scheme "
            "euler (or rk4, imex) for a run with noise")
    if domain.stochastic:
        raise MorphogenError(
            f"scheme {scheme} controls the error of deterministic models only; use --scheme "
            "euler (or rk4) for stochastic mesh diffusion (omega)")


def vector_field(model: Model, domain: Domain) -> Any:
    """``f(t, u, p)`` for diffrax: the model's right-hand side, zero on held Dirichlet values
    (:func:`morphogen.solvers.base.make_rhs`)."""
    rhs = make_rhs(model, domain)

    def f(t: Array, u: Array, p: Params) -> Array:
        return rhs(u, p, t)

    return f


def _controller(rtol: Any, atol: Any) -> diffrax.PIDController:
    return diffrax.PIDController(rtol=rtol, atol=atol, pcoeff=0.3, icoeff=0.3)


def embedded_pair(model: Model, domain: Domain) -> diffrax.AbstractAdaptiveSolver:
    """The ``adaptive`` scheme's embedded pair: Tsitouras' 5(4) (diffrax's ``Tsit5``), the same
    for every model and domain."""
    return diffrax.Tsit5()


def _solver(model: Model, domain: Domain, scheme: str) -> diffrax.AbstractAdaptiveSolver:
    """The embedded pair of an error-controlled scheme: the ``embedded_pair(model, domain)`` of
    the module its registry row names (:data:`morphogen.solvers.registry.SCHEMES`), as a
    fixed-step scheme is the :class:`~morphogen.solvers.base.Stepper` of its row's module."""
    info = SCHEMES.get(scheme)
    if info is None or not info.error_control:
        raise MorphogenError(f"scheme {scheme} is not error-controlled; use one of "
                             f"{', '.join(ERROR_CONTROLLED)} with --rtol/--atol")
    pair: diffrax.AbstractAdaptiveSolver = importlib.import_module(info.module).embedded_pair(
        model, domain)
    return pair


def solve(
    model: Model, domain: Domain, u0: Array, params: Params, ts: Array, *,
    rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL, dt0: float | None = None,
    t0: float = 0.0, max_steps: int = MAX_STEPS, scheme: str = "adaptive",
) -> tuple[Array, dict[str, Array]]:
    """States at the times ``ts`` (increasing, ``>= t0``), shape ``(len(ts), S, *spatial)``.

    Pure JAX (jit-, vmap- and grad-friendly: gradients flow through the accepted steps by
    diffrax's checkpointed adjoint). The second value holds ``accepted`` and ``rejected``
    step counts and ``ok`` (false when ``max_steps`` ran out; the states are then ``inf``).
    No host checks: use :func:`morphogen.engine.adaptive_loop.simulate_adaptive` for user runs.
    ``scheme`` picks the pair (:func:`_solver`); ``etdrk4-adaptive`` reads the requested times
    off a linear interpolation between its steps.
    """
    u0 = jnp.asarray(u0)
    ts = jnp.asarray(ts, u0.dtype)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(vector_field(model, domain)), _solver(model, domain, scheme), t0,
        ts[-1], dt0,
        domain.hold(u0, domain.boundaries(model.species)), args=params,
        saveat=diffrax.SaveAt(ts=ts), stepsize_controller=_controller(rtol, atol),
        max_steps=max_steps, throw=False,
    )
    return sol.ys, {"accepted": sol.stats["num_accepted_steps"],
                    "rejected": sol.stats["num_rejected_steps"],
                    "ok": sol.result == diffrax.RESULTS.successful}


@lru_cache(maxsize=16)
def segment(model: Model, domain: Domain, max_steps: int, scheme: str = "adaptive") -> Any:
    """Compiled ``(u, p, ta, tb, dt0, rtol, atol, state) -> (u(tb), state, acc, rej, ok)``: one
    segment from ``ta`` to ``tb`` (its last step shortened to land on ``tb``), the controller's
    ``state`` carried from the previous one; ``ok`` is false when ``max_steps`` ran out.
    ``scheme`` picks the pair (:func:`_solver`)."""
    term = diffrax.ODETerm(vector_field(model, domain))
    solver = _solver(model, domain, scheme)

    def run(u, p, ta, tb, dt0, rtol, atol, state):
        sol = diffrax.diffeqsolve(
            term, solver, ta, tb, dt0, u, args=p,
            saveat=diffrax.SaveAt(t1=True, controller_state=True),
            stepsize_controller=_controller(rtol, atol), max_steps=max_steps, throw=False,
            controller_state=state,
        )
        return (sol.ys[0], sol.controller_state, sol.stats["num_accepted_steps"],
                sol.stats["num_rejected_steps"], sol.result == diffrax.RESULTS.successful)

    return jax.jit(run)
