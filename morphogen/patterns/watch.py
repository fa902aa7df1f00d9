"""Simulate a batch and keep its last few states: what the temporal descriptors need.

The run is split in two batched calls of :func:`morphogen.engine.simulate.simulate_batch`: the first
``steps - count * gap`` steps without snapshots, then ``count * gap`` steps with a snapshot every
``gap`` steps, so memory holds ``count + 1`` states per member whatever the run length.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from morphogen.engine.simulate import Solution, simulate_batch
from morphogen.errors import MorphogenError
from morphogen.models.model import Model


def simulate_watched(
    model: Model,
    domain: Any,
    u0: Any,
    params: dict[str, Any],
    *,
    steps: int,
    dt: float,
    count: int = 4,
    gap: int = 50,
    seed: int = 0,
    **options: Any,
) -> tuple[Solution, np.ndarray]:
    """Run ``steps`` steps; return the final solution and snapshots ``(B, count + 1, S, ...)``.

    ``options`` go to :func:`morphogen.engine.simulate.simulate_batch` (``scheme``, ``noise``,
    ``clamp``, ``progress``, ``unsafe``). A member marked invalid in either part is invalid.
    """
    if count < 1 or gap < 1:
        raise MorphogenError(f"watch: count ({count}) and gap ({gap}) must be at least 1")
    tail = count * gap
    if steps < tail:
        raise MorphogenError(f"watch: {steps} steps are fewer than count * gap = {tail}; "
                             "run longer or watch fewer snapshots")
    wall = 0.0
    valid = np.ones(np.shape(u0)[0], bool)
    if steps > tail:
        head = simulate_batch(model, domain, u0, params, steps=steps - tail, dt=dt, seed=seed,
                              **options)
        u0, wall, valid = head.state, head.wall_time, np.asarray(head.valid, bool)
    sol = simulate_batch(model, domain, u0, params, steps=tail, dt=dt, seed=seed + 1,
                         every=gap, max_snapshots=count + 2, **options)
    sol.valid = valid & np.asarray(sol.valid, bool)
    sol.steps = steps
    sol.wall_time += wall
    return sol, np.moveaxis(np.asarray(sol.snapshots), 0, 1)
