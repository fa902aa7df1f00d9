"""Adaptive step size: an embedded Runge-Kutta pair under a PI step-size controller.

Skaggs §3.2 hand-tunes a fixed ``dt`` per model ("the largest dt which resulted in consistently
stable simulations", Table 3.3) and Ringham §2.2 (eqs. 2-4) steps forward Euler; here the step
follows the local error instead. The right-hand side ``f(u) = R(u, p, x, t) + ∇·(D∇u)``
(:func:`morphogen.solvers.step.make_rhs`: any grid in 2D or 3D, any mesh, any coefficients; held
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

Output times do not depend on the step sequence: :func:`simulate_adaptive` integrates from one
output time to the next, the last step of each segment shortened to land on it exactly, and
checks the state between segments (NaN, overflow, values far beyond the starting range); the
pure :func:`solve` reads requested times off the pair's 4th-order dense output
(``SaveAt(ts=...)``). Every run has a budget of steps, accepted and rejected: a stiff or
diverging model stops with a one-line error instead of shrinking its step forever.

Stochastic terms (noise, a mesh's stochastic diffusion) have no error estimate that a
deterministic pair could control; they are refused with a one-line error naming ``euler``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import diffrax
import jax
import jax.numpy as jnp
import numpy as np

from morphogen.errors import BlowUpError, MorphogenError
from morphogen.models.model import Array, Model, Params
from morphogen.solvers.stability import RANGE_FACTOR, observed_scale
from morphogen.solvers.step import Noise, make_rhs
from morphogen.util import guard
from morphogen.util.progress import ProgressBar

DEFAULT_RTOL = 1e-3
"""Relative tolerance when none is given."""

DEFAULT_ATOL = 1e-6
"""Absolute tolerance when none is given."""

MAX_STEPS = 100_000
"""Default budget of steps (accepted and rejected) for one run."""

OVERFLOW = 1e15
"""Magnitude beyond which a value counts as blown up (as in :mod:`morphogen.engine.simulate`)."""


@dataclass
class AdaptiveRun:
    """What :func:`simulate_adaptive` returns.

    Attributes:
        state: final state, shape ``(S, *spatial)``; ``t`` the final time.
        snapshots: states at ``snapshot_times`` (``(F, S, *spatial)``) or ``None``.
        snapshot_steps: the nominal step number ``t / dt`` of each snapshot.
        accepted, rejected: steps the controller accepted and rejected.
    """

    state: np.ndarray
    t: float
    snapshots: np.ndarray | None
    snapshot_steps: list[int]
    snapshot_times: list[float]
    accepted: int
    rejected: int


def check_tolerances(rtol: float, atol: float) -> None:
    """Refuse tolerances that are not positive finite numbers (one line)."""
    for name, value in (("rtol", rtol), ("atol", atol)):
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise MorphogenError(f"--{name} must be a positive number, got {value}")


def check_deterministic(domain: Any, noise: Noise | None) -> None:
    """Refuse stochastic terms, naming a scheme that carries them."""
    if noise is not None and noise.amplitude > 0:
        raise MorphogenError(
            "scheme adaptive controls the error of deterministic models only; use --scheme "
            "euler (or rk4, imex) for a run with noise")
    if getattr(domain, "stochastic", False):
        raise MorphogenError(
            "scheme adaptive controls the error of deterministic models only; use --scheme "
            "euler (or rk4) for stochastic mesh diffusion (omega)")


def vector_field(model: Model, domain: Any) -> Any:
    """``f(t, u, p)`` for diffrax: the model's right-hand side, zero on held Dirichlet values
    (:func:`morphogen.solvers.step.make_rhs`)."""
    rhs = make_rhs(model, domain)

    def f(t: Array, u: Array, p: Params) -> Array:
        return rhs(u, p, t)

    return f


def _controller(rtol: Any, atol: Any) -> diffrax.PIDController:
    return diffrax.PIDController(rtol=rtol, atol=atol, pcoeff=0.3, icoeff=0.3)


def solve(
    model: Model, domain: Any, u0: Array, params: Params, ts: Array, *,
    rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL, dt0: float | None = None,
    t0: float = 0.0, max_steps: int = MAX_STEPS,
) -> tuple[Array, dict[str, Array]]:
    """States at the times ``ts`` (increasing, ``>= t0``), shape ``(len(ts), S, *spatial)``.

    Pure JAX (jit-, vmap- and grad-friendly: gradients flow through the accepted steps by
    diffrax's checkpointed adjoint). The second value holds ``accepted`` and ``rejected``
    step counts and ``ok`` (false when ``max_steps`` ran out; the states are then ``inf``).
    No host checks: use :func:`simulate_adaptive` for user runs.
    """
    u0 = jnp.asarray(u0)
    ts = jnp.asarray(ts, u0.dtype)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(vector_field(model, domain)), diffrax.Tsit5(), t0, ts[-1], dt0,
        domain.hold(u0, domain.boundaries(model.species)), args=params,
        saveat=diffrax.SaveAt(ts=ts), stepsize_controller=_controller(rtol, atol),
        max_steps=max_steps, throw=False,
    )
    return sol.ys, {"accepted": sol.stats["num_accepted_steps"],
                    "rejected": sol.stats["num_rejected_steps"],
                    "ok": sol.result == diffrax.RESULTS.successful}


@lru_cache(maxsize=16)
def _segment(model: Model, domain: Any, max_steps: int) -> Any:
    """Compiled ``(u, p, ta, tb, dt0, rtol, atol, state) -> (u(tb), state, acc, rej, ok)``."""
    term = diffrax.ODETerm(vector_field(model, domain))

    def run(u, p, ta, tb, dt0, rtol, atol, state):
        sol = diffrax.diffeqsolve(
            term, diffrax.Tsit5(), ta, tb, dt0, u, args=p,
            saveat=diffrax.SaveAt(t1=True, controller_state=True),
            stepsize_controller=_controller(rtol, atol), max_steps=max_steps, throw=False,
            controller_state=state,
        )
        return (sol.ys[0], sol.controller_state, sol.stats["num_accepted_steps"],
                sol.stats["num_rejected_steps"], sol.result == diffrax.RESULTS.successful)

    return jax.jit(run)


def simulate_adaptive(
    model: Model, domain: Any, u0: Array, params: Params, *, steps: int, dt: float,
    rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL, noise: Noise | None = None,
    clamp: tuple[float, float] | None = None, every: int | None = None,
    max_snapshots: int = 240, max_steps: int = MAX_STEPS, progress: bool = False,
    unsafe: bool = False,
) -> AdaptiveRun:
    """Integrate ``u0`` to ``t = steps · dt`` with error control; ``dt`` is the first step.

    Segments end every ``every · dt`` (snapshots, exactly at those times) or every ``250 dt``;
    between segments the state is checked and ``clamp`` applied. Raises a one-line
    :class:`MorphogenError` for noise, a spent step budget, blow-up or (unless ``unsafe``)
    values :data:`~morphogen.solvers.stability.RANGE_FACTOR` beyond the starting scale.
    """
    check_tolerances(rtol, atol)
    check_deterministic(domain, noise)
    species = len(model.species)
    guard.check_steps(max_steps, math.prod(domain.spatial_shape), species)
    u = jnp.asarray(u0)
    dtype = u.dtype
    u = domain.hold(u, domain.boundaries(model.species))
    p = {k: jnp.asarray(v, dtype) for k, v in params.items()}
    run = _segment(model, domain, int(max_steps))
    chunk = every or max(1, min(steps, 250))
    ends = [*range(chunk, steps, chunk), steps] if steps > 0 else []
    saved = _thin([0, *ends], max_snapshots) if every else set()
    shots = [(0, np.asarray(u))] if every else []
    scale = observed_scale(u, model, p, False)
    state = (jnp.asarray(1.0, dtype), jnp.asarray(1.0, dtype), jnp.asarray(False))
    h, accepted, rejected, start = float(dt), 0, 0, 0
    bar = ProgressBar(len(ends), enabled=progress, unit="segment")
    try:
        for end in ends:
            ta, tb = start * dt, end * dt
            u, state, acc, rej, ok = run(u, p, jnp.asarray(ta, dtype), jnp.asarray(tb, dtype),
                                         jnp.asarray(min(h, tb - ta), dtype), rtol, atol,
                                         state)
            acc, rej = int(acc), int(rej)
            accepted, rejected = accepted + acc, rejected + rej
            if not bool(ok) or accepted + rejected > max_steps:
                raise _budget_error(max_steps, ta, tb, accepted, rejected)
            if clamp is not None:
                u = jnp.clip(u, clamp[0], clamp[1])
            _check_state(model, u, scale, accepted, tb, unsafe)
            h = (tb - ta) / max(acc, 1)
            if end in saved:
                shots.append((end, np.asarray(u)))
            start = end
            bar.update(1)
    finally:
        bar.close()
    return AdaptiveRun(
        state=np.asarray(u), t=steps * dt,
        snapshots=np.stack([s for _, s in shots]) if shots else None,
        snapshot_steps=[k for k, _ in shots], snapshot_times=[k * dt for k, _ in shots],
        accepted=accepted, rejected=rejected,
    )


def _thin(steps: list[int], limit: int) -> set[int]:
    """Keep every ``2^j``-th snapshot, ``j`` the smallest that fits ``limit`` (and the last)."""
    stride = 1
    while len(steps[::stride]) > max(2, limit):
        stride *= 2
    return set(steps[::stride]) | {steps[-1]}


def _budget_error(max_steps: int, ta: float, tb: float, accepted: int, rejected: int
                  ) -> MorphogenError:
    return MorphogenError(
        f"scheme adaptive used its budget of {max_steps} steps ({accepted} accepted, "
        f"{rejected} rejected) before reaching t={tb:g} from t={ta:g}: the model is stiff or "
        "diverging; use --scheme imex or etdrk4 for stiff diffusion, a looser --rtol, or "
        "check the parameters")


def _check_state(model: Model, u: Array, scale: np.ndarray, step: int, t: float,
                 unsafe: bool) -> None:
    """Blow-up (NaN, Inf, overflow) always; values far beyond the start unless ``unsafe``."""
    axes = tuple(range(1, u.ndim))
    peak = np.asarray(jnp.max(jnp.where(jnp.isfinite(u), jnp.abs(u), jnp.inf), axis=axes))
    bad = peak > OVERFLOW
    if bad.any():
        raise BlowUpError(step, tuple(s for s, b in zip(model.species, bad, strict=True) if b), t)
    far = peak > RANGE_FACTOR * scale[0]
    if far.any() and not unsafe:
        names = ", ".join(s for s, b in zip(model.species, far, strict=True) if b)
        raise MorphogenError(
            f"run diverging at t={t:g} (after {step} accepted steps) in species {names}: values "
            f"are {RANGE_FACTOR:g} times beyond the range the run started from; check the "
            "parameters (or --unsafe to run anyway)")
