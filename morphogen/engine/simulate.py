"""Run a model on a domain: the one place that loops over time.

- :func:`integrate` is pure JAX (``lax.scan``): jit-, vmap- and grad-friendly, no host checks.
- :func:`simulate` and :func:`simulate_batch` drive it in compiled chunks; between chunks their
  monitors (:mod:`morphogen.engine.monitors`, shared with the adaptive loop of
  :mod:`morphogen.engine.adaptive_loop`) take snapshots, update the progress bar and check for
  blow-up (NaN, Inf or overflow), which is reported with the step and species, never silently
  clamped. Unless ``unsafe``, they also stop a run that is diverging before it overflows (a
  growing checkerboard mode, values far outside the starting range;
  :func:`morphogen.solvers.stability.divergence_flags`), with a suggested ``dt``.

On a CPU, :func:`simulate` advances a long explicit-Euler run of one state on a 2D grid by the
fused step of :mod:`morphogen.solvers.fused` (one Numba loop generated from the model's jaxpr,
2.1x the JAX step per core on Gray-Scott 256²) where it computes what the JAX step does, within
float32 rounding; the checks between chunks and the replay that names a blow-up's first step
are the same. ``MORPHOGEN_FUSED=off`` keeps every run on the JAX path.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from functools import lru_cache, partial
from typing import Any

import jax
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
    first_failure,
)
from morphogen.engine.solve_watch import SolveWatch
from morphogen.errors import DivergenceError, MorphogenError, MorphogenWarning, round_down
from morphogen.models.model import Array, Model, Params
from morphogen.solvers.auto import choose_error_controlled, choose_scheme
from morphogen.solvers.base import Stepper, scheme_name
from morphogen.solvers.fused import fused_step
from morphogen.solvers.policy import plan_run
from morphogen.solvers.registry import ERROR_CONTROLLED, IMPLICIT_DIFFUSION
from morphogen.solvers.stability import observed_scale
from morphogen.solvers.step import Noise, Step, check_stability, make_step, max_stable_dt


def integrate(
    step: Step | Callable[[Array, Params, Array, Array, Array], Array], u0: Array,
    params: Params, *, steps: int, dt: Any, t0: Any = 0.0, key: Array
) -> tuple[Array, Array, Array]:
    """Apply ``step`` ``steps`` times with ``lax.scan``; returns ``(u, t, key)``.

    ``step`` is a :class:`~morphogen.solvers.step.Step` (:func:`morphogen.solvers.step.make_step`),
    whose ``invariants(params, t0, dt)`` (ETDRK4's exponentials and φ-coefficients) are computed
    once, before the loop, and passed to every step as ``aux``; or any function
    ``(u, p, t, dt, key) -> u``. Pure and differentiable: ``jax.grad`` of a function of the
    final state with respect to ``params`` (or ``u0``) works through it.
    """
    dt = jnp.asarray(dt, u0.dtype)
    aux = (step.invariants(params, jnp.asarray(t0, u0.dtype), dt) if isinstance(step, Step)
           else None)

    def body(carry, _):
        u, t, k = carry
        t_next, k, sub = _tick(t, k, dt)
        new = step(u, params, t, dt, sub) if aux is None else step(u, params, t, dt, sub, aux)
        return (new, t_next, k), None

    (u, t, key), _ = jax.lax.scan(body, (u0, jnp.asarray(t0, u0.dtype), key), None, length=steps)
    return u, t, key


def _tick(t: Array, key: Array, dt: Array) -> tuple[Array, Array, Array]:
    """One step of the clock and the key sequence: ``(t + dt, next key, this step's key)``."""
    key, sub = jax.random.split(key)
    return t + dt, key, sub


def batch_block(members: int) -> int:
    """Members advanced together (``vmap``) in each block of a batch; blocks run one after
    another (``lax.map``).

    On an accelerator the whole batch is one ``vmap``. On CPU, one member at a time: with the
    whole-array grid operator it measured fastest at every size tried on 2 cores, in three runs
    (``bench/results/grid.json`` and docs/schemes.md: 150 members of 3 × 32² and of 3 × 16²,
    against blocks of 15 and one ``vmap``).
    """
    if jax.default_backend() != "cpu":
        return members
    return 1


@lru_cache(maxsize=32)
def _compiled(step: Step, block: int) -> Callable:
    """``run(u, p, t, dt, key, steps)``: one state (``block == 0``) or a batch advanced in
    blocks of ``block`` members (:func:`batch_block`)."""
    def run(u, p, t, dt, key, steps):
        return integrate(step, u, p, steps=steps, dt=dt, t0=t, key=key)

    if not block:
        return jax.jit(run, static_argnums=5)

    def run_b(u, p, t, dt, key, steps):
        def member(m):
            return run(m[0], m[1], t, dt, m[2], steps)[0]

        u = jax.lax.map(member, (u, p, key), batch_size=block)
        # The clock and key sequence of `integrate` (`_tick`), advanced outside the members' loop:
        # the same values, and mapping only the state measured 3x faster (150 x 3 x 16²).
        dt = jnp.asarray(dt, u.dtype)

        def tick(carry, _):
            tt, k = carry
            tt, k, _ = jax.vmap(_tick, in_axes=(None, 0, None), out_axes=(None, 0, 0))(tt, k, dt)
            return (tt, k), None

        (t, key), _ = jax.lax.scan(tick, (jnp.asarray(t, u.dtype), key), None, length=steps)
        return u, jnp.broadcast_to(t, u.shape[:1]), key

    return jax.jit(run_b, static_argnums=5)


@lru_cache(maxsize=32)
def _cached_step(model: Model, domain: Any, scheme: str | Stepper, noise: Noise | None, clamp
                 ) -> Step:
    return make_step(model, domain, scheme=scheme, noise=noise, clamp=clamp)


@dataclass
class Solution:
    """The result of a run.

    Attributes:
        state: final state, shape ``(S, *spatial)`` (``(B, S, *spatial)`` for a batch).
        t: final time.
        steps: number of steps taken.
        snapshots: saved states, shape ``(F, S, *spatial)`` (``(F, B, S, ...)``), or ``None``.
        snapshot_steps: the step number of each snapshot.
        valid: for a batch, whether each member stayed finite and bounded, shape ``(B,)``.
        blowup_step: for a batch, the end of the chunk in which a member first blew up (0 if
            never), shape ``(B,)``.
        wall_time: seconds spent, compile time included.
        scheme: the scheme that ran (``auto`` resolved).
        rejected_steps: steps the error controller rejected (``adaptive`` only; ``steps`` then
            counts the accepted ones).
        snapshot_times: the time of each snapshot.
        warnings: one line per problem that did not stop the run (an implicit solve that
            stopped at its iteration cap: :mod:`morphogen.engine.solve_watch`).
        dt: the step (the first step for an error-controlled scheme).
    """

    state: np.ndarray
    t: float
    steps: int
    snapshots: np.ndarray | None = None
    snapshot_steps: list[int] = field(default_factory=list)
    valid: np.ndarray | None = None
    blowup_step: np.ndarray | None = None
    wall_time: float = 0.0
    scheme: str = ""
    rejected_steps: int | None = None
    snapshot_times: list[float] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    dt: float = 0.0


def simulate(
    model: Model,
    domain: Any,
    u0: Array,
    params: Params,
    *,
    steps: int | None = None,
    dt: float | None = None,
    scheme: str | Stepper = "euler",
    noise: Noise | None = None,
    clamp: tuple[float, float] | None | str = "model",
    seed: int = 0,
    every: int | None = None,
    max_snapshots: int = 240,
    progress: bool = False,
    unsafe: bool = False,
    rtol: float | None = None,
    atol: float | None = None,
    on_chunk: Callable[[int], None] | None = None,
    t_end: float | None = None,
) -> Solution:
    """Simulate one state ``u0`` (shape ``(S, *spatial)``) for ``steps`` steps of ``dt``.

    ``dt`` and ``steps`` may be left out: the run policy every front end uses fills them in
    (:func:`morphogen.solvers.policy.plan_run`: ``auto`` resolved once; the model's ``dt``
    within an explicit scheme's stability limit, the limit of a scheme with implicit or exact
    diffusion; ``steps = round(t_end / dt)``, ``t_end`` the model's suggested end time unless
    given). The ``dt`` used is ``Solution.dt``.

    Args:
        params: parameter values (scalars or fields broadcastable to the spatial shape).
        clamp: bounds applied after every step: ``"model"`` (default) uses ``model.clamp``
            (``None`` for most models), ``None`` none, or ``(lo, hi)``.
        every: take a snapshot every ``every`` steps (and of the initial state); memory stays
            bounded by ``max_snapshots`` (older snapshots are thinned to every other one:
            :class:`morphogen.engine.monitors.Snapshots`).
        unsafe: skip the stability check and the early divergence detection (NaN, Inf and
            overflow are still reported).
        scheme: a fixed-step scheme (:data:`morphogen.solvers.registry.FIXED_STEP`) by name or
            as a :class:`~morphogen.solvers.base.Stepper` object (a user's own scheme), ``auto``
            (:func:`morphogen.solvers.auto.choose_scheme`; with ``rtol``/``atol``:
            :func:`morphogen.solvers.auto.choose_error_controlled`), ``adaptive``
            (:mod:`morphogen.solvers.adaptive`) or ``etdrk4-adaptive``
            (:mod:`morphogen.solvers.etd_adaptive`): error control by ``rtol``/``atol``, ``dt``
            is the first step and ``steps * dt`` the end time.
        on_chunk: called with ``n`` after each compiled chunk of ``n`` steps (nominal ones,
            ``t / dt``, for ``adaptive``); an exception it raises stops the run there (a
            server's cancel button).

    Raises:
        UnstableTimeStepError: ``dt`` above the stability limit (unless ``unsafe``).
        BlowUpError: NaN/Inf/overflow, naming the first bad step and species.
        DivergenceError: a growing checkerboard mode or values ``RANGE_FACTOR`` beyond the
            starting scale, naming the step, species and a ``dt`` to retry with.
    """
    return _drive(
        model, domain, u0, params, batched=False, steps=steps, dt=dt, t_end=t_end,
        scheme=scheme, noise=noise, clamp=clamp, seed=seed, every=every,
        max_snapshots=max_snapshots, progress=progress, unsafe=unsafe, rtol=rtol, atol=atol,
        on_chunk=on_chunk,
    )


def simulate_batch(
    model: Model,
    domain: Any,
    u0: Array,
    params: Params,
    *,
    steps: int | None = None,
    dt: float | None = None,
    scheme: str | Stepper = "euler",
    noise: Noise | None = None,
    clamp: tuple[float, float] | None | str = "model",
    seed: int = 0,
    every: int | None = None,
    max_snapshots: int = 240,
    progress: bool = False,
    unsafe: bool = False,
    on_chunk: Callable[[int], None] | None = None,
    t_end: float | None = None,
) -> Solution:
    """Simulate a batch as one jitted program (vmapped on accelerators; on CPU in blocks of
    members sized by :func:`batch_block`, which measures faster there).

    ``u0`` has shape ``(B, S, *spatial)`` and every parameter a leading axis ``B`` (see
    :func:`morphogen.solvers.step.batch_params`). Members that blow up do not stop the run: they
    are marked in ``Solution.valid`` (search strategies score them worst). ``on_chunk(n)`` is
    called after each compiled chunk of ``n`` steps; an exception it raises stops the run there
    (a server's cancel button). ``dt`` and ``steps`` left out come from the run policy, over
    every member, as in :func:`simulate`.
    """
    return _drive(
        model, domain, u0, params, batched=True, steps=steps, dt=dt, t_end=t_end,
        scheme=scheme, noise=noise, clamp=clamp, seed=seed, every=every,
        max_snapshots=max_snapshots, progress=progress, unsafe=unsafe, on_chunk=on_chunk,
    )


def _drive(model, domain, u0, params, *, batched: bool, steps: int | None, dt: float | None,
           t_end: float | None, scheme: str | Stepper, noise, clamp, seed: int, every,
           max_snapshots: int, progress: bool, unsafe: bool, rtol: float | None = None,
           atol: float | None = None, on_chunk: Callable[[int], None] | None = None
           ) -> Solution:
    start = time.perf_counter()
    if dt is None and steps is not None and t_end is not None:
        dt, t_end = float(t_end) / steps, None
    planned = False  # a step the policy chose is checked against the limit there
    if dt is None or steps is None:
        planned = True
        plan = plan_run(model, domain, {k: jnp.asarray(v) for k, v in params.items()},
                        scheme=scheme, dt=dt, steps=steps, t_end=t_end, unsafe=unsafe,
                        rtol=rtol, atol=atol, batched=batched, where="simulate")
        scheme, dt, steps = plan.scheme, plan.dt, plan.steps
    elif t_end is not None:
        raise MorphogenError("give at most two of steps, dt and t_end")
    if steps < 0:
        raise MorphogenError(f"steps must be >= 0, got {steps}")
    if not (np.isfinite(dt) and dt > 0):
        raise MorphogenError(f"dt must be a positive number, got {dt}")
    if every is not None and every < 1:
        raise MorphogenError(f"--every must be >= 1, got {every}")
    dtype = jnp.result_type(float)
    u = jnp.asarray(u0, dtype)
    expected = (len(model.species), *domain.spatial_shape)
    got = tuple(u.shape[1:] if batched else u.shape)
    if got != expected:
        raise MorphogenError(f"initial state has shape {got}, expected {expected}")
    p = {k: jnp.asarray(v, dtype) for k, v in params.items()}
    if scheme == "auto":
        scheme = (choose_error_controlled(model, domain, p, batched=batched)
                  if rtol is not None or atol is not None
                  else choose_scheme(model, domain, p, batched=batched))
    if isinstance(clamp, str):
        clamp = model.clamp
    if isinstance(scheme, Stepper) and (rtol is not None or atol is not None):
        raise MorphogenError(f"scheme {scheme.name} is a fixed-step scheme: give dt, not "
                             "rtol/atol")
    if not isinstance(scheme, Stepper) and (scheme in ERROR_CONTROLLED or rtol is not None
                                            or atol is not None):
        return _adaptive(model, domain, u, p, batched=batched, steps=steps, dt=dt,
                         scheme=scheme, noise=noise, clamp=clamp, every=every,
                         max_snapshots=max_snapshots, progress=progress, unsafe=unsafe,
                         rtol=rtol, atol=atol, start=start, on_chunk=on_chunk)
    if not unsafe and not planned:
        check_stability(model, domain, p, dt, scheme, batched=batched)
    step = _cached_step(model, domain, scheme, noise, tuple(clamp) if clamp else None)
    block = batch_block(u.shape[0]) if batched else 0
    run = _compiled(step, block)
    fused = None if batched else fused_step(
        model, domain, p, scheme=scheme, noise=noise, clamp=tuple(clamp) if clamp else None,
        dtype=dtype, steps=steps)
    key = jax.random.PRNGKey(seed)
    if batched:
        key = jax.random.split(key, u.shape[0])
    chunk = every or max(1, min(steps, 250))
    shots = Snapshots(max_snapshots, u) if every else None
    members = u.shape[0] if batched else None
    checks: list[BlowUp | Divergence] = [BlowUp(model.species, members)]
    if not unsafe:
        checks.append(Divergence(
            model.species, members, observed_scale(u, model, p, batched),
            checkerboard=domain.kind == "grid",
            report=partial(_diverging, model, domain, p, dt, scheme)))
    solves = SolveWatch.for_run(model, domain, p, scheme_name(scheme), batched)
    t = jnp.asarray(0.0, dtype)
    done = 0
    with Monitors(*checks, solves, shots, Progress(steps, enabled=progress),
                  Cancel(on_chunk) if on_chunk is not None else None) as monitors:
        while done < steps:
            n = min(chunk, steps - done)
            replay = None if batched else partial(_replay, step, p, dt, u, t, key, n)
            if fused is not None:
                u, t = fused(u, t, dt, n)
            else:
                u, t_b, key = run(u, p, t, dt, key, n)
                t = t_b[0] if batched else t_b
            done += n
            monitors.check(Chunk(u=u, t=t, step=done, n=n, dt=dt, taken=done, replay=replay))
    first_bad = first_failure(*checks)
    warning = solves.warning() if solves is not None else None
    if warning:
        warnings.warn(warning, MorphogenWarning, stacklevel=3)
    state = np.asarray(u)
    snaps, snap_steps = shots.result() if shots else (None, [])
    return Solution(
        state=state,
        t=float(t),
        steps=steps,
        snapshots=snaps,
        snapshot_steps=snap_steps,
        valid=(first_bad == 0) if batched else None,
        blowup_step=first_bad if batched else None,
        wall_time=time.perf_counter() - start,
        scheme=scheme_name(scheme),
        snapshot_times=[k * dt for k in snap_steps],
        warnings=[warning] if warning else [],
        dt=float(dt),
    )


def _adaptive(model, domain, u, p, *, batched: bool, steps: int, dt: float, scheme: str,
              rtol, atol, start: float, clamp, **options) -> Solution:
    """``scheme="adaptive"`` or ``"etdrk4-adaptive"``: error-controlled steps
    (:mod:`morphogen.solvers.adaptive`) in the loop of :mod:`morphogen.engine.adaptive_loop`."""
    if scheme not in ERROR_CONTROLLED:
        raise MorphogenError(f"--rtol/--atol control --scheme {' or '.join(ERROR_CONTROLLED)}, "
                             f"not {scheme}; drop them or use one of those")
    if batched:
        raise MorphogenError(f"scheme {scheme} runs one state at a time (simulate); use euler, "
                             "rk4, imex or etdrk4 for a batch")
    from morphogen.engine.adaptive_loop import simulate_adaptive
    from morphogen.solvers.adaptive import DEFAULT_ATOL, DEFAULT_RTOL

    run = simulate_adaptive(
        model, domain, u, p, steps=steps, dt=dt, clamp=tuple(clamp) if clamp else None,
        rtol=DEFAULT_RTOL if rtol is None else rtol, atol=DEFAULT_ATOL if atol is None else atol,
        scheme=scheme, **options)
    return Solution(state=run.state, t=run.t, steps=run.accepted, snapshots=run.snapshots,
                    snapshot_steps=run.snapshot_steps, wall_time=time.perf_counter() - start,
                    scheme=scheme, rejected_steps=run.rejected,
                    snapshot_times=run.snapshot_times, dt=float(dt))


def _replay(step: Step, p: Params, dt: float, u: Array, t: Array, key: Array, n: int
            ) -> Iterator[tuple[Array, Array]]:
    """A chunk of ``n`` steps from ``(u, t, key)`` again, one step at a time: ``(u, t)`` after
    each (to name the first step of a blow-up)."""
    one = jax.jit(lambda u, t, k: integrate(step, u, p, steps=1, dt=dt, t0=t, key=k))
    for _ in range(n):
        u, t, key = one(u, t, key)
        yield u, t


def _diverging(model: Model, domain: Any, p: Params, dt: float, scheme: str | Stepper,
               chunk: Chunk,
               names: tuple[str, ...], why: str) -> DivergenceError:
    """The error that stops a diverging fixed-step run, with a ``dt`` to retry with."""
    try:
        limit = max_stable_dt(model, domain, p, scheme)
    except MorphogenError:
        limit = float("inf")
    suggested = limit if limit < dt else 0.5 * dt
    alternative = ""
    if scheme_name(scheme) in IMPLICIT_DIFFUSION:
        # the limit of these schemes comes from the reaction at the ground state; a reaction
        # that grows stiff along the run (a^2/h as h decays) can need an explicit step
        try:
            explicit = max_stable_dt(model, domain, p, "euler")
        except MorphogenError:
            explicit = float("inf")
        if explicit < suggested:
            alternative = (f", or --scheme euler with --dt {round_down(explicit):.6g} (its "
                           "limit)")
    return DivergenceError(chunk.step, names, float(chunk.t), why, suggested, alternative)
