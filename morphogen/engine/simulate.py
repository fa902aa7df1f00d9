"""Run a model on a domain: the one place that loops over time.

- :func:`integrate` is pure JAX (``lax.scan``): jit-, vmap- and grad-friendly, no host checks.
- :func:`simulate` and :func:`simulate_batch` drive it in compiled chunks; between chunks they
  take snapshots, update the progress bar and check for blow-up (NaN, Inf or overflow), which
  is reported with the step and species, never silently clamped. Unless ``unsafe``, they also
  stop a run that is diverging before it overflows (a growing checkerboard mode, values far
  outside the starting range; :func:`morphogen.solvers.stability.divergence_flags`), with a
  suggested ``dt``.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.engine.solve_watch import SolveWatch
from morphogen.errors import BlowUpError, DivergenceError, MorphogenError, MorphogenWarning
from morphogen.models.model import Array, Model, Params
from morphogen.solvers.auto import choose_scheme
from morphogen.solvers.stability import IMPLICIT_DIFFUSION, divergence_flags, observed_scale
from morphogen.solvers.step import Noise, check_stability, make_step, max_stable_dt
from morphogen.util.progress import ProgressBar

OVERFLOW = 1e15
"""Magnitude beyond which a value counts as blown up."""

Step = Callable[[Array, Params, Array, Array, Array], Array]


def integrate(
    step: Step, u0: Array, params: Params, *, steps: int, dt: Any, t0: Any = 0.0, key: Array
) -> tuple[Array, Array, Array]:
    """Apply ``step`` ``steps`` times with ``lax.scan``; returns ``(u, t, key)``.

    A step with ``invariants(params, t0, dt)`` (ETDRK4's exponentials and φ-coefficients) has
    them computed once, before the loop, and passed to every step as ``aux``.
    Pure and differentiable: ``jax.grad`` of a function of the final state with respect to
    ``params`` (or ``u0``) works through it.
    """
    dt = jnp.asarray(dt, u0.dtype)
    invariants = getattr(step, "invariants", None)
    aux = None if invariants is None else invariants(params, jnp.asarray(t0, u0.dtype), dt)

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
def _cached_step(model: Model, domain: Any, scheme: str, noise: Noise | None, clamp) -> Step:
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


def simulate(
    model: Model,
    domain: Any,
    u0: Array,
    params: Params,
    *,
    steps: int,
    dt: float,
    scheme: str = "euler",
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
) -> Solution:
    """Simulate one state ``u0`` (shape ``(S, *spatial)``) for ``steps`` steps of ``dt``.

    Args:
        params: parameter values (scalars or fields broadcastable to the spatial shape).
        clamp: bounds applied after every step: ``"model"`` (default) uses ``model.clamp``
            (``None`` for most models), ``None`` none, or ``(lo, hi)``.
        every: take a snapshot every ``every`` steps (and of the initial state); memory stays
            bounded by ``max_snapshots`` (older snapshots are thinned to every other one).
        unsafe: skip the stability check and the early divergence detection (NaN, Inf and
            overflow are still reported).
        scheme: a fixed-step scheme (:data:`morphogen.solvers.step.SCHEMES`), ``auto``
            (:func:`morphogen.solvers.auto.choose_scheme`) or ``adaptive``
            (:mod:`morphogen.solvers.adaptive`: error control by ``rtol``/``atol``, ``dt`` is the
            first step and ``steps * dt`` the end time).
        on_chunk: called with ``n`` after each compiled chunk of ``n`` steps (fixed-step
            schemes); an exception it raises stops the run there (a server's cancel button).

    Raises:
        UnstableTimeStepError: ``dt`` above the stability limit (unless ``unsafe``).
        BlowUpError: NaN/Inf/overflow, naming the first bad step and species.
        DivergenceError: a growing checkerboard mode or values ``RANGE_FACTOR`` beyond the
            starting scale, naming the step, species and a ``dt`` to retry with.
    """
    return _drive(
        model, domain, u0, params, batched=False, steps=steps, dt=dt, scheme=scheme,
        noise=noise, clamp=clamp, seed=seed, every=every, max_snapshots=max_snapshots,
        progress=progress, unsafe=unsafe, rtol=rtol, atol=atol, on_chunk=on_chunk,
    )


def simulate_batch(
    model: Model,
    domain: Any,
    u0: Array,
    params: Params,
    *,
    steps: int,
    dt: float,
    scheme: str = "euler",
    noise: Noise | None = None,
    clamp: tuple[float, float] | None | str = "model",
    seed: int = 0,
    every: int | None = None,
    max_snapshots: int = 240,
    progress: bool = False,
    unsafe: bool = False,
    on_chunk: Callable[[int], None] | None = None,
) -> Solution:
    """Simulate a batch as one jitted program (vmapped on accelerators; on CPU in blocks of
    members sized by :func:`batch_block`, which measures faster there).

    ``u0`` has shape ``(B, S, *spatial)`` and every parameter a leading axis ``B`` (see
    :func:`morphogen.solvers.step.batch_params`). Members that blow up do not stop the run: they
    are marked in ``Solution.valid`` (search strategies score them worst). ``on_chunk(n)`` is
    called after each compiled chunk of ``n`` steps; an exception it raises stops the run there
    (a server's cancel button).
    """
    return _drive(
        model, domain, u0, params, batched=True, steps=steps, dt=dt, scheme=scheme,
        noise=noise, clamp=clamp, seed=seed, every=every, max_snapshots=max_snapshots,
        progress=progress, unsafe=unsafe, on_chunk=on_chunk,
    )


def _drive(model, domain, u0, params, *, batched: bool, steps: int, dt: float, scheme: str,
           noise, clamp, seed: int, every, max_snapshots: int, progress: bool,
           unsafe: bool, rtol: float | None = None, atol: float | None = None,
           on_chunk: Callable[[int], None] | None = None) -> Solution:
    start = time.perf_counter()
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
        scheme = choose_scheme(model, domain, p, batched=batched)
    if isinstance(clamp, str):
        clamp = model.clamp
    if scheme == "adaptive" or rtol is not None or atol is not None:
        return _adaptive(model, domain, u, p, batched=batched, steps=steps, dt=dt,
                         scheme=scheme, noise=noise, clamp=clamp, every=every,
                         max_snapshots=max_snapshots, progress=progress, unsafe=unsafe,
                         rtol=rtol, atol=atol, start=start)
    if not unsafe:
        check_stability(model, domain, p, dt, scheme, batched=batched)
    step = _cached_step(model, domain, scheme, noise, tuple(clamp) if clamp else None)
    block = batch_block(u.shape[0]) if batched else 0
    run = _compiled(step, block)
    key = jax.random.PRNGKey(seed)
    if batched:
        key = jax.random.split(key, u.shape[0])
    chunk = every or max(1, min(steps, 250))
    shots = _Snapshots(max_snapshots) if every else None
    if shots:
        shots.add(0, u)
    n_batch = u.shape[0] if batched else 1
    first_bad = np.zeros(n_batch, np.int64)
    watch = None if unsafe else _Watch(model, domain, u, p, dt, scheme, batched)
    solves = SolveWatch.for_run(model, domain, p, scheme, batched)
    t = jnp.asarray(0.0, dtype)
    done = 0
    bar = ProgressBar(steps, enabled=progress, unit="step")
    while done < steps:
        n = min(chunk, steps - done)
        u_prev, t_prev, key_prev = u, t, key
        u, t_b, key = run(u, p, t, dt, key, n)
        t = t_b[0] if batched else t_b
        done += n
        bad = np.asarray(_bad_species(u, batched))  # (B, S)
        newly = bad.any(axis=1) & (first_bad == 0)
        first_bad[newly] = done
        if newly.any() and not batched:
            bar.close()
            raise _locate_blowup(model, step, u_prev, p, t_prev, dt, key_prev, done - n, n)
        if watch is not None:
            diverging = watch.check(u)
            newly = diverging.any(axis=1) & (first_bad == 0)
            first_bad[newly] = done
            if newly.any() and not batched:
                bar.close()
                raise watch.error(diverging[0], done, float(t))
        if solves is not None:
            solves.check(u, p, t, dt, done)
        if shots and (done % every == 0 or done == steps):
            shots.add(done, u)
        bar.update(n)
        if on_chunk is not None:
            on_chunk(n)
    bar.close()
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
        scheme=scheme,
        snapshot_times=[k * dt for k in snap_steps],
        warnings=[warning] if warning else [],
    )


def _adaptive(model, domain, u, p, *, batched: bool, steps: int, dt: float, scheme: str,
              rtol, atol, start: float, clamp, **options) -> Solution:
    """``scheme="adaptive"``: error-controlled steps (:mod:`morphogen.solvers.adaptive`)."""
    if scheme != "adaptive":
        raise MorphogenError(f"--rtol/--atol control --scheme adaptive, not {scheme}; drop "
                             "them or use --scheme adaptive")
    if batched:
        raise MorphogenError("scheme adaptive runs one state at a time (simulate); use euler, "
                             "rk4, imex or etdrk4 for a batch")
    from morphogen.solvers.adaptive import DEFAULT_ATOL, DEFAULT_RTOL, simulate_adaptive

    run = simulate_adaptive(
        model, domain, u, p, steps=steps, dt=dt, clamp=tuple(clamp) if clamp else None,
        rtol=DEFAULT_RTOL if rtol is None else rtol, atol=DEFAULT_ATOL if atol is None else atol,
        **options)
    return Solution(state=run.state, t=run.t, steps=run.accepted, snapshots=run.snapshots,
                    snapshot_steps=run.snapshot_steps, wall_time=time.perf_counter() - start,
                    scheme="adaptive", rejected_steps=run.rejected,
                    snapshot_times=run.snapshot_times)


def _bad_species(u: Array, batched: bool) -> Array:
    bad = ~jnp.isfinite(u) | (jnp.abs(u) > OVERFLOW)
    axes = tuple(range(2 if batched else 1, u.ndim))
    flags = bad.any(axis=axes)
    return flags if batched else flags[None]


def _locate_blowup(model, step, u, p, t, dt, key, offset: int, n: int) -> BlowUpError:
    """Replay a chunk one step at a time to name the first bad step and species."""
    one = jax.jit(lambda u, t, k: integrate(step, u, p, steps=1, dt=dt, t0=t, key=k))
    for i in range(n):
        u, t, key = one(u, t, key)
        bad = np.asarray(_bad_species(u, False))[0]
        if bad.any():
            names = tuple(s for s, b in zip(model.species, bad, strict=True) if b)
            return BlowUpError(offset + i + 1, names, float(t))
    return BlowUpError(offset + n, model.species, float(t))


class _Watch:
    """Early divergence detection between chunks (see :mod:`morphogen.solvers.stability`)."""

    def __init__(self, model, domain, u0, p, dt: float, scheme: str, batched: bool):
        self.model, self.domain, self.p = model, domain, p
        self.dt, self.scheme, self.batched = dt, scheme, batched
        self.scale = observed_scale(u0, model, p, batched)
        self.on_grid = hasattr(domain, "laplacian")
        self.prev = None
        self.why = ""

    def check(self, u: Array) -> np.ndarray:
        """Species diverging now, shape ``(B, S)``."""
        out, growing, grid = divergence_flags(u, self.scale, self.prev, self.batched,
                                              self.on_grid)
        if growing.any():
            ratio = float(np.max(grid[growing] / self.prev[growing]))
            self.why = f"a grid-scale (checkerboard) mode is growing (x{ratio:.3g} per check)"
        elif out.any():
            self.why = "values are orders of magnitude beyond the range the run started from"
        self.prev = grid
        return out | growing

    def error(self, flags: np.ndarray, step: int, t: float) -> DivergenceError:
        names = tuple(s for s, b in zip(self.model.species, flags, strict=True) if b)
        try:
            limit = max_stable_dt(self.model, self.domain, self.p, self.scheme)
        except MorphogenError:
            limit = float("inf")
        suggested = limit if limit < self.dt else 0.5 * self.dt
        alternative = ""
        if self.scheme in IMPLICIT_DIFFUSION:
            # the limit of these schemes comes from the reaction at the ground state; a reaction
            # that grows stiff along the run (a^2/h as h decays) can need an explicit step
            try:
                explicit = max_stable_dt(self.model, self.domain, self.p, "euler")
            except MorphogenError:
                explicit = float("inf")
            if explicit < suggested:
                alternative = f", or --scheme euler with --dt {explicit:.6g} (its limit)"
        return DivergenceError(step, names, t, self.why, suggested, alternative)


class _Snapshots:
    """Host-side snapshots with bounded memory: when full, keep every other one."""

    def __init__(self, limit: int):
        self.limit = max(2, limit)
        self.stride = 1
        self.seen = 0
        self.items: list[tuple[int, np.ndarray]] = []

    def add(self, step: int, u: Array) -> None:
        if self.seen % self.stride == 0:
            self.items.append((step, np.asarray(u)))
            if len(self.items) > self.limit:
                self.items = self.items[::2]
                self.stride *= 2
        self.seen += 1

    def result(self) -> tuple[np.ndarray, list[int]]:
        return np.stack([u for _, u in self.items]), [s for s, _ in self.items]
