"""Stacking parameter sets and initial states into the batch :func:`simulate_batch` runs.

:func:`~morphogen.engine.simulate.simulate_batch` takes ``u0`` of shape ``(B, S, *spatial)``
and every parameter with a leading axis ``B``; these build both from ``B`` ordinary sets, so a
batch is written as a list of what one run takes::

    params = mg.stack_params([model.parameters({"F": f}) for f in (0.03, 0.04, 0.05)])
    u0 = mg.stack_states([u0_a, u0_b, u0_c])
    sol = mg.simulate_batch(model, grid, u0, params, steps=2000, dt=1.0)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.model import Array


def stack_params(sets: Sequence[Mapping[str, Array]]) -> dict[str, Array]:
    """One batched parameter dict ``{name: (B, ...)}`` from ``B`` parameter dicts.

    Every set must name the same parameters; a scalar in one set and a field in another are
    broadcast to the field's shape (all fields of a name must share one shape).
    """
    sets = list(sets)
    if not sets:
        raise MorphogenError("stack_params needs at least one parameter set")
    names = set(sets[0])
    for i, s in enumerate(sets[1:], start=1):
        if set(s) != names:
            odd = sorted(names ^ set(s))
            raise MorphogenError(f"parameter set {i} differs from set 0 in {', '.join(odd)}; "
                                 "every set must name the same parameters")
    out = {}
    for name in sets[0]:
        values = [np.asarray(s[name], np.float64) for s in sets]
        try:
            shape = np.broadcast_shapes(*(v.shape for v in values))
        except ValueError:
            raise MorphogenError(f"parameter {name!r} has shapes that do not broadcast: "
                                 f"{sorted({v.shape for v in values})}") from None
        out[name] = jnp.asarray(np.stack([np.broadcast_to(v, shape) for v in values]),
                                jnp.result_type(float))
    return out


def stack_states(states: Sequence[Array]) -> Array:
    """One batch ``(B, S, *spatial)`` from ``B`` initial states of the same shape."""
    states = [np.asarray(u) for u in states]
    if not states:
        raise MorphogenError("stack_states needs at least one state")
    shapes = sorted({u.shape for u in states})
    if len(shapes) > 1:
        raise MorphogenError(f"states of different shapes cannot be stacked: {shapes}")
    return jnp.asarray(np.stack(states))
