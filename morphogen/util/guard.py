"""One guard on the cost of a run, checked before anything is allocated or compiled.

A run of ``B`` members, ``S`` species on ``N`` cells for ``T`` steps keeping ``K`` snapshots
holds about ``B·S·N·(K + W)`` numbers of ``b`` bytes (``W`` working copies: the state, the
RK4 stages, the diffusion fluxes) and does about ``B·S·N·T`` cell updates. Each of these, and
``S`` and ``T`` on their own, has a limit; a run beyond one is refused with its estimate and
the limit, so that a mistyped size or time step fails in a second instead of exhausting memory
or running for years. The command line, the web app and :func:`morphogen.runs.prepare.prepare`
(the Python API) all call :func:`check_run`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from morphogen.errors import MorphogenError

WORKING_COPIES = 8
"""Arrays of the state's size alive during a step (state, RK4 stages, fluxes, noise)."""


@dataclass(frozen=True)
class Limits:
    """The largest run accepted.

    ``updates_per_second`` is a conservative CPU rate used only to state the estimated time.
    """

    memory_bytes: float = 16 * 2**30
    updates: float = 1e14
    steps: int = 10**9
    species: int = 64
    batch: int = 100_000
    updates_per_second: float = 2e8


LIMITS = Limits()
"""The limits every front end applies."""


def _gib(n: float) -> str:
    return f"{n / 2**30:.3g} GiB"


def _duration(seconds: float) -> str:
    for unit, size in (("years", 3.15e7), ("days", 86400.0), ("hours", 3600.0),
                       ("minutes", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


def check_species(count: int, limits: Limits = LIMITS) -> None:
    """Refuse a model with more species than ``limits.species``."""
    if count > limits.species:
        raise MorphogenError(
            f"{count} species is more than the limit of {limits.species}; "
            "split the model or reduce its species"
        )


def check_memory(cells: int, species: int, *, snapshots: int = 1, batch: int = 1,
                 itemsize: int = 4, limits: Limits = LIMITS) -> int:
    """Refuse a state whose memory estimate ``B·S·N·(K + W)·b`` exceeds the limit; returns it."""
    check_species(species, limits)
    if batch > limits.batch:
        raise MorphogenError(f"batch of {batch} is more than the limit of {limits.batch}")
    numbers = batch * species * cells * (snapshots + WORKING_COPIES)
    estimate = numbers * itemsize
    if estimate > limits.memory_bytes:
        raise MorphogenError(
            f"the run needs about {_gib(estimate)} of memory ({batch} x {species} species x "
            f"{cells} cells x {snapshots + WORKING_COPIES} copies), more than the limit of "
            f"{_gib(limits.memory_bytes)}; use a smaller --size, fewer snapshots or a smaller "
            "batch"
        )
    return estimate


def check_steps(steps: float, cells: int, species: int, *, batch: int = 1,
                limits: Limits = LIMITS) -> int:
    """Refuse a step count that is not a finite whole number >= 1, beyond ``limits.steps``, or
    whose work ``B·S·N·T`` exceeds ``limits.updates``; returns it as an ``int``."""
    if not (isinstance(steps, int) or (isinstance(steps, float) and math.isfinite(steps))):
        raise MorphogenError(
            f"the run would take {steps} steps; give a finite --time or --steps"
        )
    if steps > limits.steps:
        raise MorphogenError(
            f"the run would take {steps:.3g} steps, more than the limit of {limits.steps:.3g}; "
            "use a larger --dt, a shorter --time or fewer --steps"
        )
    steps = int(steps)
    if steps < 1:
        raise MorphogenError(f"the run needs at least one step (got {steps})")
    updates = batch * species * cells * steps
    if updates > limits.updates:
        seconds = updates / limits.updates_per_second
        raise MorphogenError(
            f"the run needs about {updates:.3g} cell updates (about {_duration(seconds)}), "
            f"more than the limit of {limits.updates:.3g}; use fewer steps or a smaller --size"
        )
    return steps


def check_run(cells: int, species: int, steps: float, *, snapshots: int = 1, batch: int = 1,
              itemsize: int = 4, limits: Limits = LIMITS) -> int:
    """:func:`check_memory` then :func:`check_steps`; returns the step count."""
    check_memory(cells, species, snapshots=snapshots, batch=batch, itemsize=itemsize,
                 limits=limits)
    return check_steps(steps, cells, species, batch=batch, limits=limits)


def check_numbers(numbers: float, what: str, hint: str, *, itemsize: int = 4,
                  limits: Limits = LIMITS) -> int:
    """Refuse ``what`` (e.g. ``"training"``) if the ``numbers`` it holds at once, of
    ``itemsize`` bytes each, exceed the memory limit; ``hint`` says what to reduce. For the
    commands whose arrays are not one run's state (training pools, network populations)."""
    estimate = int(numbers) * itemsize
    if estimate > limits.memory_bytes:
        raise MorphogenError(
            f"{what} needs about {_gib(estimate)} of memory, more than the limit of "
            f"{_gib(limits.memory_bytes)}; {hint}"
        )
    return estimate


def check_count(value: int, name: str, low: int, high: int) -> int:
    """Refuse a count option outside ``[low, high]`` with a one-line error naming ``name``."""
    if not low <= value <= high:
        raise MorphogenError(f"{name} must be between {low:,} and {high:,}, got {value:,}")
    return value
