r"""The run policy: what the user gave (or did not give) → the concrete scheme, ``dt`` and steps.

Every front end (each command, each web route, search, match, flowers stages, presets, the
demo) asks :func:`plan_run` — through :func:`morphogen.runs.policy.resolve_run` where the layer
rule allows, directly from here where it does not (``flowers/`` and ``patterns/`` sit beside or
below ``runs/``) — so the same settings give the same run everywhere. The rule:

1. **Scheme.** ``auto`` is resolved once, here: :func:`morphogen.solvers.auto.choose_scheme`
   (``imex`` when the stiffness ratio pays for it, else ``euler``), with ``rtol``/``atol``
   :func:`~morphogen.solvers.auto.choose_error_controlled`; a population (``batched``) gets
   :func:`~morphogen.solvers.auto.population_scheme`, which also refuses the error-controlled
   schemes.
2. **Limit.** ``limit = max_stable_dt(model, domain, params, scheme)``
   (:func:`morphogen.solvers.step.max_stable_dt`: each scheme's own limit, with its margin;
   ``inf`` for the error-controlled schemes), of the parameters as the engine will hold them
   (:func:`scheme_limit`), so a step at the limit passes the engine's check.
3. **Step.** A given ``dt`` is used as given; above ``limit`` it is refused with
   :class:`~morphogen.errors.UnstableTimeStepError` (one line naming the limit) unless
   ``unsafe``. Without one,

   .. math:: dt = \min(h,\ \mathrm{limit}),\qquad
             h = \begin{cases} dt_{model} & \text{explicit diffusion (euler, rk4)} \\
                               \infty & \text{implicit or exact diffusion (imex1, imex, etdrk4)}
                 \end{cases}

   The model's ``dt`` (Skaggs Table 3.3 hand-tunes it per model for explicit Euler, §3.2;
   Gray-Scott's 1 is Richard et al.'s) is an explicit step: it stays the default wherever the
   scheme's limit allows it, and the limit (which keeps its own margin,
   :data:`morphogen.solvers.stability.SAFETY`) takes over where the domain (a finer grid, a 3D
   grid, a larger ``D``) needs a shorter step. A scheme that solves diffusion implicitly or
   exactly is chosen to take the reaction's long steps, so it runs at its limit, which keeps
   the implicit margin and covers the pattern's own Jacobian
   (:mod:`morphogen.solvers.pattern_limit`). The error-controlled schemes have no limit: the
   model's ``dt`` is their first step.
4. **Steps.** Given ``steps`` are used as given (``t_end = steps · dt``); otherwise the end
   time (given, else the model's ``t_end``) becomes :func:`step_count` steps, ``max(1,
   round(t_end / dt))``: one rounding rule (Python's, half to even) for every front end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from morphogen.domains.base import Domain
from morphogen.errors import MorphogenError, UnstableTimeStepError
from morphogen.models.model import Model, Params
from morphogen.solvers.base import Stepper, scheme_name
from morphogen.solvers.registry import SCHEMES


@dataclass(frozen=True)
class RunPlan:
    """A run's time stepping, decided once (:func:`plan_run`).

    Attributes:
        scheme: the concrete scheme (``auto`` resolved).
        dt: the step (the first step of an error-controlled scheme).
        steps: the number of steps (nominal ``t_end / dt`` for an error-controlled scheme).
        t_end: the simulated time, ``steps · dt``.
        limit: the scheme's stability limit for these parameters (``inf``: none).
        reason: one line saying why this ``dt``.
    """

    scheme: str | Stepper
    dt: float
    steps: int
    t_end: float
    limit: float
    reason: str


def step_count(t_end: float, dt: float) -> int:
    """Steps to reach ``t_end`` with ``dt``: ``max(1, round(t_end / dt))`` (half to even).

    Raises:
        MorphogenError: the quotient is not finite (an infinite end time, a zero step).
    """
    ratio = float(t_end) / float(dt)
    if not math.isfinite(ratio):
        raise MorphogenError(f"the run would take {ratio} steps; give a finite --time or --steps")
    return max(1, round(ratio))


def resolve_scheme(model: Model, domain: Domain, params: Params,
                   scheme: str | Stepper = "euler", *,
                   rtol: float | None = None, atol: float | None = None,
                   batched: bool = False, population: bool = False,
                   where: str = "search") -> str | Stepper:
    """``scheme`` with ``auto`` resolved (step 1 of :func:`plan_run`); for a ``population`` (or
    ``batched`` parameters) as a population advances (the error-controlled schemes refused,
    naming ``where``)."""
    from morphogen.solvers.auto import (
        choose_error_controlled,
        choose_scheme,
        population_scheme,
    )

    if batched or population:
        return population_scheme(scheme, model, domain, params, batched=batched, where=where)
    if scheme != "auto":
        return scheme
    if rtol is not None or atol is not None:
        return choose_error_controlled(model, domain, params)
    return choose_scheme(model, domain, params)


def scheme_limit(model: Model, domain: Domain, params: Params, scheme: str | Stepper, *,
                 batched: bool = False) -> float:
    """:func:`morphogen.solvers.step.max_stable_dt` of ``params`` cast as the engine casts them
    (``jnp.result_type(float)``: float32 unless x64 is on), so that a step at the limit passes
    the engine's own check bit for bit (a limit from float64 parameters can sit one float32
    rounding above it)."""
    import jax.numpy as jnp

    from morphogen.solvers.step import max_stable_dt

    dtype = jnp.result_type(float)
    cast = {k: jnp.asarray(v, dtype) for k, v in params.items()}
    return float(max_stable_dt(model, domain, cast, scheme, batched=batched))


def default_dt(model: Model, scheme: str | Stepper, limit: float) -> tuple[float, str]:
    """Step 3 of :func:`plan_run` without a given ``dt``: ``(dt, reason)``; a scheme given as a
    :class:`~morphogen.solvers.base.Stepper` object by its :attr:`~Stepper.info`."""
    info = scheme.info if isinstance(scheme, Stepper) else SCHEMES.get(scheme)
    scheme = scheme_name(scheme)
    if info is not None and info.implicit_diffusion and info.fixed_step:
        if math.isfinite(limit):
            return float(limit), f"{scheme}'s stability limit (diffusion implicit or exact)"
        return float(model.dt), f"the model's dt ({scheme} reports no limit here)"
    if model.dt <= limit:
        return float(model.dt), f"the model's dt, within {scheme}'s limit {limit:.4g}"
    return float(limit), f"{scheme}'s stability limit (the model suggests {model.dt:g})"


def plan_run(
    model: Model,
    domain: Domain,
    params: Params,
    *,
    scheme: str | Stepper = "euler",
    dt: float | None = None,
    steps: int | None = None,
    t_end: float | None = None,
    unsafe: bool = False,
    rtol: float | None = None,
    atol: float | None = None,
    batched: bool = False,
    population: bool = False,
    where: str = "search",
) -> RunPlan:
    """The concrete scheme, ``dt``, steps and end time of a run (the module's rule).

    Args:
        params: parameter values (with a leading batch axis when ``batched``: the limit is then
            over every member, and the scheme one a population can advance with).
        scheme: a scheme name or ``auto``.
        dt, steps, t_end: what the user gave; ``None`` for what they did not. ``steps`` wins
            over ``t_end``; without either the model's ``t_end`` is the end time.
        unsafe: run a given ``dt`` above the limit.
        population: the run advances a population in lock-step (search, atlas): the scheme is
            one a population can take; implied by ``batched``.

    Raises:
        UnstableTimeStepError: a given ``dt`` above the limit, without ``unsafe``.
        MorphogenError: ``dt``, ``steps`` or ``t_end`` not positive and finite.
    """
    scheme = resolve_scheme(model, domain, params, scheme, rtol=rtol, atol=atol,
                            batched=batched, population=population, where=where)
    limit = scheme_limit(model, domain, params, scheme, batched=batched)
    if dt is not None:
        dt = float(dt)
        if not (math.isfinite(dt) and dt > 0):
            raise MorphogenError(f"dt must be a positive number, got {dt:g}")
        if dt > limit and not unsafe:
            raise UnstableTimeStepError(dt, limit, scheme_name(scheme))
        reason = "given"
    else:
        dt, reason = default_dt(model, scheme, limit)
    if steps is not None:
        n = int(steps)
        if n < 1 or n != steps:
            raise MorphogenError(f"steps must be a whole number >= 1, got {steps}")
    else:
        total = float(model.t_end if t_end is None else t_end)
        if not total > 0:
            raise MorphogenError(f"the simulated time must be positive, got {total:g}")
        n = step_count(total, dt)
    return RunPlan(scheme, dt, n, n * dt, limit, reason)
