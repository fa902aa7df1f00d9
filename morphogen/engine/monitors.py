"""What a time loop does between two compiled chunks: monitors.

A run advances in compiled chunks: ``lax.scan`` over up to 250 steps, or up to a snapshot
(:func:`morphogen.engine.simulate.simulate`), or error-controlled segments between output times
(:func:`morphogen.engine.adaptive_loop.simulate_adaptive`). Nothing inside a chunk can report,
so after each one the loop hands a :class:`Chunk` to its monitors, in order (py-pde's trackers,
run between compiled chunks by its solver controller):

- :class:`BlowUp`: NaN, Inf or ``|u| >`` :data:`OVERFLOW`, naming the first bad step (a chunk is
  replayed one step at a time when the loop can) and species; never silently clamped.
- :class:`Divergence`: a run that diverges before it overflows (values
  :data:`~morphogen.solvers.stability.RANGE_FACTOR` beyond the starting scale, a growing
  checkerboard mode: :func:`morphogen.solvers.stability.divergence_flags`).
- :class:`morphogen.engine.solve_watch.SolveWatch`: implicit solves that stop at their cap.
- :class:`Snapshots`: states every ``every`` steps with bounded memory (one thinning policy).
- :class:`Progress`: the progress bar; :class:`Cancel`: a caller's hook, whose exception stops
  the run (a server's cancel button).

A single run stops at the first blow-up or divergence; a batch records, per member, the end of
the chunk in which it first failed (:func:`first_failure`) and goes on.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.errors import BlowUpError
from morphogen.models.model import Array
from morphogen.solvers.stability import divergence_flags
from morphogen.util.progress import ProgressBar

OVERFLOW = 1e15
"""Magnitude beyond which a value counts as blown up."""

Replay = Callable[[], Iterator[tuple[Array, Array]]]
"""Replays a chunk one step at a time from the state before it, yielding ``(u, t)`` per step."""


@dataclass(frozen=True)
class Chunk:
    """A run just after one compiled chunk, as its loop hands it to the monitors.

    Attributes:
        u: the state, shape ``(S, *spatial)`` (``(B, S, *spatial)`` for a batch).
        t: the time.
        step: the step number (the adaptive loop: the nominal ``t / dt``).
        n: the steps in this chunk (nominal for the adaptive loop).
        dt: the step (the adaptive loop: its nominal ``dt``).
        taken: the steps taken so far (the adaptive loop: the accepted ones; else ``step``).
        replay: the chunk again one step at a time, or ``None`` where the loop cannot.
    """

    u: Array
    t: Any
    step: int
    n: int
    dt: float
    taken: int
    replay: Replay | None = None


class Monitor:
    """A job between chunks: :meth:`check` after each one, :meth:`close` once the run ends,
    normally or not. :meth:`check` may raise to stop the run."""

    def check(self, chunk: Chunk) -> None:
        raise NotImplementedError

    def close(self) -> None:
        """Release what the monitor holds (a progress bar)."""


def bad_species(u: Array, batched: bool) -> np.ndarray:
    """Species with a NaN, Inf or a value beyond :data:`OVERFLOW`, shape ``(B, S)`` (``B = 1``
    for one state); a NumPy state (the fused CPU step's) is checked by NumPy, without a copy into
    XLA or its threads."""
    if isinstance(u, np.ndarray):
        return _bad(u, batched, np)
    return np.asarray(_bad_compiled(u, batched))


def _bad(u: Any, batched: bool, xp: Any) -> Any:
    bad = ~xp.isfinite(u) | (xp.abs(u) > OVERFLOW)
    flags = bad.any(axis=tuple(range(2 if batched else 1, u.ndim)))
    return flags if batched else flags[None]


@partial(jax.jit, static_argnames="batched")
def _bad_compiled(u: Array, batched: bool) -> Array:
    """:func:`bad_species` as one compiled pass (op by op, a 256² state took about 1 ms a
    check, a sixth of a fused chunk's time)."""
    return _bad(u, batched, jnp)


class _Check(Monitor):
    """A per-species test after each chunk: one state stops at the first failure
    (:meth:`error`); a batch records the step at which each member first failed."""

    def __init__(self, species: Sequence[str], members: int | None):
        self.species = tuple(species)
        self.batched = members is not None
        self.first = np.zeros(members or 1, np.int64)

    def flags(self, chunk: Chunk) -> np.ndarray:
        """Failing species, shape ``(B, S)``."""
        raise NotImplementedError

    def error(self, chunk: Chunk, flags: np.ndarray) -> Exception:
        """The error that stops one state whose species ``flags`` (shape ``(S,)``) failed."""
        raise NotImplementedError

    def check(self, chunk: Chunk) -> None:
        flags = self.flags(chunk)
        newly = flags.any(axis=1) & (self.first == 0)
        self.first[newly] = chunk.step
        if newly.any() and not self.batched:
            raise self.error(chunk, flags[0])

    def names(self, flags: np.ndarray) -> tuple[str, ...]:
        return tuple(s for s, b in zip(self.species, flags, strict=True) if b)


def first_failure(*checks: _Check) -> np.ndarray:
    """Per batch member, the end of the chunk in which any check first failed (0: never)."""
    first = np.zeros_like(checks[0].first)
    for check in checks:
        take = (first == 0) | ((check.first > 0) & (check.first < first))
        first = np.where(take, check.first, first)
    return first


class BlowUp(_Check):
    """NaN, Inf or overflow (:func:`bad_species`), reported as a :class:`BlowUpError` with the
    first bad step and species: a chunk with a :attr:`Chunk.replay` is replayed one step at a
    time to find them; otherwise the chunk's end (its :attr:`Chunk.taken` steps) is named."""

    def flags(self, chunk: Chunk) -> np.ndarray:
        return bad_species(chunk.u, self.batched)

    def error(self, chunk: Chunk, flags: np.ndarray) -> BlowUpError:
        if chunk.replay is None:
            return BlowUpError(chunk.taken, self.names(flags), float(chunk.t))
        offset = chunk.step - chunk.n
        t = chunk.t
        for i, (u, t) in enumerate(chunk.replay()):
            bad = bad_species(u, False)[0]
            if bad.any():
                return BlowUpError(offset + i + 1, self.names(bad), float(t))
        return BlowUpError(chunk.step, self.species, float(t))


DivergenceReport = Callable[[Chunk, tuple[str, ...], str], Exception]
"""``report(chunk, species, why)``: the error that stops a diverging run."""


class Divergence(_Check):
    """Values far beyond the starting scale and (with ``checkerboard``, on grids) a growing
    grid-scale mode (:func:`morphogen.solvers.stability.divergence_flags`), caught before they
    overflow. ``scale`` is the starting scale (:func:`~morphogen.solvers.stability.observed_scale`),
    shape ``(B, S)``; ``report`` words the error."""

    def __init__(self, species: Sequence[str], members: int | None, scale: np.ndarray, *,
                 checkerboard: bool, report: DivergenceReport):
        super().__init__(species, members)
        self.scale, self.checkerboard, self.report = scale, checkerboard, report
        self.prev: np.ndarray | None = None
        self.why = ""

    def flags(self, chunk: Chunk) -> np.ndarray:
        out, growing, grid = divergence_flags(chunk.u, self.scale, self.prev, self.batched,
                                              self.checkerboard)
        if growing.any():
            ratio = float(np.max(grid[growing] / self.prev[growing]))
            self.why = f"a grid-scale (checkerboard) mode is growing (x{ratio:.3g} per check)"
        elif out.any():
            self.why = "values are orders of magnitude beyond the range the run started from"
        self.prev = grid
        return out | growing

    def error(self, chunk: Chunk, flags: np.ndarray) -> Exception:
        return self.report(chunk, self.names(flags), self.why)


class Snapshots(Monitor):
    """The state at the end of every chunk (a loop with snapshots ends its chunks every
    ``every`` steps and at the last step), on the host, with bounded memory.

    The thinning policy: keep every ``2^j``-th state, ``j`` the smallest for which at most
    ``limit`` (at least 2) are kept; when one more would exceed it, every other one is dropped
    and ``j`` grows by one. With ``final``, the last state is kept too when the stride passes
    over it (the adaptive loop, whose output times are the point of a run).
    """

    def __init__(self, limit: int, u0: Array, *, final: bool = False):
        self.limit = max(2, limit)
        self.final = final
        self.stride = 1
        self.seen = 0
        self.items: list[tuple[int, np.ndarray]] = []
        self.last: tuple[int, Array] | None = None
        self.add(0, u0)

    def add(self, step: int, u: Array) -> None:
        """Offer the state after ``step`` steps."""
        self.last = (step, u)
        if self.seen % self.stride == 0:
            self.items.append((step, np.asarray(u)))
            if len(self.items) > self.limit:
                self.items = self.items[::2]
                self.stride *= 2
        self.seen += 1

    def check(self, chunk: Chunk) -> None:
        self.add(chunk.step, chunk.u)

    def result(self) -> tuple[np.ndarray, list[int]]:
        """The kept states, shape ``(F, ...)``, and their step numbers."""
        items = self.items
        if self.final and self.last is not None and self.last[0] != items[-1][0]:
            items = [*items, (self.last[0], np.asarray(self.last[1]))]
        return np.stack([u for _, u in items]), [s for s, _ in items]


class Progress(Monitor):
    """A progress bar on standard error (:class:`morphogen.util.progress.ProgressBar`) of
    ``total`` steps (``unit="step"``), or of ``total`` chunks for any other unit."""

    def __init__(self, total: int, *, enabled: bool, unit: str = "step"):
        self.unit = unit
        self.bar = ProgressBar(total, enabled=enabled, unit=unit)

    def check(self, chunk: Chunk) -> None:
        self.bar.update(chunk.n if self.unit == "step" else 1)

    def close(self) -> None:
        self.bar.close()


class Cancel(Monitor):
    """Calls ``hook(n)`` after each chunk of ``n`` steps; an exception it raises stops the run
    there (a server's cancel button, a caller's own progress)."""

    def __init__(self, hook: Callable[[int], None]):
        self.hook = hook

    def check(self, chunk: Chunk) -> None:
        self.hook(chunk.n)


class Monitors:
    """The monitors of one run, in order; ``None`` entries are switched off. Used as a context
    manager, it closes them all when the run ends, normally or not."""

    def __init__(self, *monitors: Monitor | None):
        self.items = [m for m in monitors if m is not None]

    def check(self, chunk: Chunk) -> None:
        """Hand ``chunk`` to each monitor in order."""
        for monitor in self.items:
            monitor.check(chunk)

    def __enter__(self) -> Monitors:
        return self

    def __exit__(self, *exc: object) -> None:
        for monitor in self.items:
            monitor.close()
