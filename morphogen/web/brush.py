"""Explore's brush: which values a stroke sets, and the jitted disc painter.

A stroke sets the cells of a disc to a vector of species values ``(S,)``: the model's excited
state, its ground state, or one typed value; a NaN entry leaves that species as it is, so a brush
can paint one species only (the others keep their state, as in Ready's paint tools).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import jax.numpy as jnp
import numpy as np

from morphogen.domains.grid import Grid
from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.web.limits import choice, number

MODES = ("excite", "erase", "value")


def brush_values(model: Model, values: Mapping[str, Any], mode: Any, species: Any,
                 value: Any) -> np.ndarray:
    """The ``(S,)`` float32 values a stroke sets (NaN: species left as it is).

    ``mode`` ``excite`` / ``erase`` / ``value``; ``species`` ``None`` or ``""`` paints every
    species, a name only that one (``value`` needs one)."""
    mode = choice(mode, "paint mode", MODES)
    if species in (None, "") and mode == "value":
        raise MorphogenError("painting a value needs a species; choose one in Brush species")
    index = None if species in (None, "") else model.species_index(species)
    if mode == "value":
        vals = np.zeros(len(model.species), np.float32)
        vals[index] = number(value, "brush value", -1e6, 1e6)
    else:
        vals = np.asarray(model.excited_state(values) if mode == "excite" else
                          model.ground_state(values), np.float32).copy()
    if index is not None:
        chosen = vals[index]
        vals = np.full(len(model.species), np.nan, np.float32)
        vals[index] = chosen
    return vals


def painter(grid: Grid) -> Callable:
    """``paint(u, cx, cy, r, values)``: set a disc of radius ``r`` (grid-width units) around
    ``(cx, cy)`` in ``[0, 1]^2`` to ``values`` ``(S,)``; distances wrap around on the torus.
    A species whose value is NaN is left as it is (a brush on one species).

    On an ``h x w`` grid a height fraction ``dy`` is ``dy h / w`` widths, so the disc stays round.
    """
    x = jnp.asarray(grid.coords["x"])
    y = jnp.asarray(grid.coords["y"])
    aspect = grid.shape[0] / grid.shape[1]

    def paint(u, cx, cy, r, values):
        ddx = jnp.abs(x - cx)
        ddy = jnp.abs(y - cy)
        ddx = jnp.minimum(ddx, 1.0 - ddx)
        ddy = jnp.minimum(ddy, 1.0 - ddy) * aspect
        mask = (ddx**2 + ddy**2) <= r**2
        keep = jnp.isnan(values)[:, None, None]
        return jnp.where(mask[None] & ~keep, values[:, None, None].astype(u.dtype), u)

    return paint
