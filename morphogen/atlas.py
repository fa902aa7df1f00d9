"""Parameter atlases: a grid of parameter pairs simulated as one batched program.

The classic example is the Gray-Scott (F, k) map (Richard et al. fig. 9; Pearson's
classification): every tile is one run with its own ``(x, y)`` parameter pair, all tiles share
the initial state, and the whole grid is a single ``simulate_batch`` call (``vmap`` over the
``NX * NY`` members), not a loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.fields import resolve_params
from morphogen.initial import make_initial
from morphogen.models.model import Model
from morphogen.simulate import simulate_batch
from morphogen.steppers import batch_params, check_stability


@dataclass(frozen=True)
class Axis:
    """One atlas axis: a parameter ``name`` and its ``values`` (evenly spaced)."""

    name: str
    values: np.ndarray

    @classmethod
    def parse(cls, text: str) -> Axis:
        """``"F=0.01:0.07:16"`` -> 16 values of ``F`` from 0.01 to 0.07 inclusive."""
        name, sep, spec = text.partition("=")
        parts = spec.split(":")
        if not sep or len(parts) != 3 or not name.strip():
            raise MorphogenError(f"axis {text!r}: use NAME=START:STOP:COUNT, e.g. F=0.01:0.07:16")
        try:
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise MorphogenError(
                f"axis {text!r}: START, STOP must be numbers, COUNT whole"
            ) from None
        if not 1 <= count <= 64:
            raise MorphogenError(f"axis {text!r}: COUNT must be between 1 and 64")
        return cls(name.strip(), np.linspace(start, stop, count))


@dataclass
class Atlas:
    """The result of :func:`compute_atlas`.

    Attributes:
        states: final states, shape ``(NY, NX, S, *spatial)``.
        valid: whether each run stayed finite and bounded, shape ``(NY, NX)``.
        x, y: the axes.
        wall_time: seconds for the batched simulation.
    """

    states: np.ndarray
    valid: np.ndarray
    x: Axis
    y: Axis
    wall_time: float


def compute_atlas(
    model: Model,
    domain: Any,
    x: Axis,
    y: Axis,
    *,
    params: dict[str, Any] | None = None,
    steps: int,
    dt: float,
    init: str | None = None,
    seed: int = 0,
    progress: bool = False,
    scheme: str = "euler",
    unsafe: bool = False,
    **options: Any,
) -> Atlas:
    """Simulate every ``(x, y)`` pair at once (one vmapped program).

    Args:
        params: the other parameters (defaults from the model); ``x.name`` and ``y.name`` must
            be model parameters.
        unsafe: skip the explicit stability check (done over every member, since a diffusion
            coefficient may be an axis).
        options: passed to :func:`morphogen.simulate.simulate_batch` (``noise``, ``clamp``).
    """
    if x.name == y.name:
        raise MorphogenError(f"the two atlas axes must be different parameters, both are {x.name}")
    values = model.parameters({**(params or {}), x.name: 0.0, y.name: 0.0})
    base = resolve_params(model, domain, values)
    ny, nx = len(y.values), len(x.values)
    batch = batch_params(base, ny * nx, batched=())
    xx, yy = np.meshgrid(x.values, y.values)
    batch[x.name] = np.asarray(xx.reshape(-1), np.float32)
    batch[y.name] = np.asarray(yy.reshape(-1), np.float32)
    sample = dict(values)
    sample.update({x.name: float(x.values.mean()), y.name: float(y.values.mean())})
    u0 = make_initial(init or model.init, model, domain, sample, seed=seed)
    u0 = np.broadcast_to(u0, (ny * nx, *u0.shape))
    if not unsafe:
        check_stability(model, domain, batch, dt, scheme, batched=True)
    sol = simulate_batch(model, domain, u0, batch, steps=steps, dt=dt, seed=seed, scheme=scheme,
                         progress=progress, unsafe=True, **options)
    shape = (ny, nx)
    return Atlas(
        states=sol.state.reshape(*shape, *sol.state.shape[1:]),
        valid=sol.valid.reshape(shape),
        x=x,
        y=y,
        wall_time=sol.wall_time,
    )

