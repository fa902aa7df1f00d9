"""The front ends' door to the one run policy.

Every command, web route, search and match asks :func:`resolve_run` for a run's scheme, ``dt``
and steps; the rule itself (``auto`` resolved once; a given ``dt`` checked against the scheme's
own limit; otherwise ``min(model.dt, limit)`` for an explicit scheme and the limit for one
with implicit or exact diffusion; ``steps = max(1, round(t_end / dt))``) is
:func:`morphogen.solvers.policy.plan_run`, kept in ``solvers/`` so that the layers beside or
below ``runs/`` (``flowers/`` stages, ``patterns/`` presets) call the same function.
"""

from __future__ import annotations

from typing import Any

from morphogen.models.model import Model, Params
from morphogen.solvers.policy import RunPlan, default_dt, plan_run, scheme_limit, step_count

__all__ = ["RunPlan", "default_dt", "resolve_run", "scheme_limit", "step_count"]


def resolve_run(
    model: Model,
    domain: Any,
    params: Params,
    *,
    scheme: str | None = None,
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
    """The run's :class:`~morphogen.solvers.policy.RunPlan` (scheme, dt, steps, t_end, limit,
    reason) from what the user gave; ``scheme=None`` is the default scheme, ``euler``. See
    :func:`morphogen.solvers.policy.plan_run` for the rule and its errors."""
    return plan_run(model, domain, params, scheme=scheme or "euler", dt=dt, steps=steps,
                    t_end=t_end, unsafe=unsafe, rtol=rtol, atol=atol, batched=batched,
                    population=population, where=where)
