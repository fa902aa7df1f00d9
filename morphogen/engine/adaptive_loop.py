"""The time loop of an error-controlled run (``scheme="adaptive"`` or ``"etdrk4-adaptive"``).

The steps are Tsitouras' 5(4) pair (:mod:`morphogen.solvers.adaptive`) or ETDRK4 with an
embedded second-order estimate (:mod:`morphogen.solvers.etd_adaptive`) under a PI controller.
Output times do not depend on the step sequence: :func:`simulate_adaptive` integrates from one
output time to the next (a *segment*, :func:`morphogen.solvers.adaptive.segment`), the last step
of each segment shortened to land on it exactly, and hands the state to the same monitors as the
fixed-step loop (:mod:`morphogen.engine.monitors`: blow-up, values far beyond the starting range,
snapshots, progress, a caller's hook). Every run has a budget of steps, accepted and rejected:
a stiff or diverging model stops with a one-line error instead of shrinking its step forever.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import jax.numpy as jnp
import numpy as np

from morphogen.engine.monitors import (
    BlowUp,
    Cancel,
    Chunk,
    Divergence,
    Monitors,
    Progress,
    Snapshots,
)
from morphogen.errors import MorphogenError
from morphogen.models.model import Array, Model, Params
from morphogen.solvers.adaptive import (
    DEFAULT_ATOL,
    DEFAULT_RTOL,
    MAX_STEPS,
    check_deterministic,
    check_tolerances,
    segment,
)
from morphogen.solvers.stability import RANGE_FACTOR, observed_scale
from morphogen.solvers.step import Noise
from morphogen.util import guard


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


def simulate_adaptive(
    model: Model, domain: Any, u0: Array, params: Params, *, steps: int, dt: float,
    rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL, noise: Noise | None = None,
    clamp: tuple[float, float] | None = None, every: int | None = None,
    max_snapshots: int = 240, max_steps: int = MAX_STEPS, progress: bool = False,
    unsafe: bool = False, on_chunk: Callable[[int], None] | None = None,
    scheme: str = "adaptive",
) -> AdaptiveRun:
    """Integrate ``u0`` to ``t = steps · dt`` with error control; ``dt`` is the first step.

    Segments end every ``every · dt`` (snapshots, exactly at those times, thinned as
    :class:`~morphogen.engine.monitors.Snapshots` does, the last one always kept) or every
    ``250 dt``; after each, ``clamp`` is applied, the monitors run and ``on_chunk`` is called
    with the segment's nominal steps. Raises a one-line :class:`MorphogenError` for noise, a
    spent step budget, blow-up or (unless ``unsafe``) values
    :data:`~morphogen.solvers.stability.RANGE_FACTOR` beyond the starting scale.
    """
    check_tolerances(rtol, atol)
    check_deterministic(domain, noise, scheme)
    species = len(model.species)
    guard.check_steps(max_steps, math.prod(domain.spatial_shape), species)
    u = jnp.asarray(u0)
    dtype = u.dtype
    u = domain.hold(u, domain.boundaries(model.species))
    p = {k: jnp.asarray(v, dtype) for k, v in params.items()}
    run = segment(model, domain, int(max_steps), scheme)
    chunk = every or max(1, min(steps, 250))
    ends = [*range(chunk, steps, chunk), steps] if steps > 0 else []
    shots = Snapshots(max_snapshots, u, final=True) if every else None
    diverging = None if unsafe else Divergence(
        model.species, None, observed_scale(u, model, p, False), checkerboard=False,
        report=_diverging)
    state = (jnp.asarray(1.0, dtype), jnp.asarray(1.0, dtype), jnp.asarray(False))
    h, accepted, rejected, start = float(dt), 0, 0, 0
    with Monitors(BlowUp(model.species, None), diverging, shots,
                  Progress(len(ends), enabled=progress, unit="segment"),
                  Cancel(on_chunk) if on_chunk is not None else None) as monitors:
        for end in ends:
            ta, tb = start * dt, end * dt
            u, state, acc, rej, ok = run(u, p, jnp.asarray(ta, dtype), jnp.asarray(tb, dtype),
                                         jnp.asarray(min(h, tb - ta), dtype), rtol, atol,
                                         state)
            acc, rej = int(acc), int(rej)
            accepted, rejected = accepted + acc, rejected + rej
            if not bool(ok) or accepted + rejected > max_steps:
                raise _budget_error(max_steps, ta, tb, accepted, rejected, scheme)
            if clamp is not None:
                u = jnp.clip(u, clamp[0], clamp[1])
            h = (tb - ta) / max(acc, 1)
            monitors.check(Chunk(u=u, t=tb, step=end, n=end - start, dt=dt, taken=accepted))
            start = end
    snaps, snap_steps = shots.result() if shots else (None, [])
    return AdaptiveRun(
        state=np.asarray(u), t=steps * dt, snapshots=snaps, snapshot_steps=snap_steps,
        snapshot_times=[k * dt for k in snap_steps], accepted=accepted, rejected=rejected,
    )


def _diverging(chunk: Chunk, names: tuple[str, ...], why: str) -> MorphogenError:
    return MorphogenError(
        f"run diverging at t={chunk.t:g} (after {chunk.taken} accepted steps) in species "
        f"{', '.join(names)}: values are {RANGE_FACTOR:g} times beyond the range the run "
        "started from; check the parameters (or --unsafe to run anyway)")


def _budget_error(max_steps: int, ta: float, tb: float, accepted: int, rejected: int,
                  scheme: str = "adaptive") -> MorphogenError:
    return MorphogenError(
        f"scheme {scheme} used its budget of {max_steps} steps ({accepted} accepted, "
        f"{rejected} rejected) before reaching t={tb:g} from t={ta:g}: the model is stiff or "
        "diverging; use --scheme imex or etdrk4 for stiff diffusion, a looser --rtol, or "
        "check the parameters")
