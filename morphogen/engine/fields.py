"""Parameter values and parameter fields.

Any model parameter may be a number, an array broadcastable to the domain's spatial shape (a
prepattern; on the command line a ``.npy`` file), or an expression of ``x``, ``y``, ``z``
(coordinates in [0, 1] on grids) and of the model's other scalar parameters, e.g. a
Pearson-style map ``F = "0.01 + 0.06*x"``, ``k = "0.045 + 0.025*y"``. Expressions go through the
safe compiler (:mod:`morphogen.models.expr`), never ``eval``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.expr import compile_expression
from morphogen.models.model import Model
from morphogen.util.io import load_npy

COORDINATES = ("x", "y", "z")


def parse_value(text: str) -> float | str:
    """A ``-p NAME=VALUE`` value: a number if it parses as one, else an expression string."""
    try:
        return float(text)
    except ValueError:
        return text.strip()


def resolve_params(model: Model, domain: Any, values: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """Turn numbers, arrays and expressions into float32 arrays (scalars stay 0-d).

    Expressions may read ``x``, ``y``, ``z`` and the model's scalar parameters.

    Raises:
        MorphogenError: an unknown name, a bad expression (with its column), a non-finite value
            or an array that does not fit the domain.
    """
    scalars = {k: float(v) for k, v in values.items() if _is_number(v)}
    out: dict[str, np.ndarray] = {}
    for name, value in values.items():
        if isinstance(value, str) and value.lower().endswith(".npy"):
            arr = _field_from_file(name, value, domain)
        elif isinstance(value, str):
            arr = _field_from_expression(name, value, domain, scalars)
        else:
            arr = np.asarray(value, dtype=np.float32)
            if arr.ndim and not _fits(arr.shape, domain.spatial_shape):
                raise MorphogenError(
                    f"parameter {name!r} has shape {arr.shape}, which does not fit the domain "
                    f"{tuple(domain.spatial_shape)}"
                )
        if not np.all(np.isfinite(arr)):
            raise MorphogenError(f"parameter {name!r} is not finite: {value!r}")
        out[name] = arr
    return out


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float | np.floating | np.integer) and not isinstance(value, bool)


def _fits(shape: tuple[int, ...], spatial: tuple[int, ...]) -> bool:
    try:
        return np.broadcast_shapes(shape, tuple(spatial)) == tuple(spatial)
    except ValueError:
        return False


def _field_from_file(name: str, path: str, domain: Any) -> np.ndarray:
    """A prepattern saved with ``numpy.save``: an array broadcastable to the domain."""
    cells = int(np.prod(domain.spatial_shape))
    arr = np.asarray(load_npy(path, f"parameter {name}: field file", cells), dtype=np.float32)
    if not _fits(arr.shape, domain.spatial_shape):
        raise MorphogenError(
            f"parameter {name}: {path} has shape {arr.shape}, the domain needs "
            f"{tuple(domain.spatial_shape)}"
        )
    return arr


def _field_from_expression(
    name: str, text: str, domain: Any, scalars: Mapping[str, float]
) -> np.ndarray:
    allowed = set(COORDINATES) | {k for k in scalars if k != name}
    try:
        expr = compile_expression(text, allowed, what="coordinates x, y, z and scalar parameters")
    except MorphogenError as exc:
        raise MorphogenError(f"parameter {name}: {exc}") from None
    env: dict[str, Any] = {c: np.asarray(domain.coords[c]) for c in COORDINATES}
    env.update(scalars)
    value = np.asarray(expr(env), dtype=np.float32)
    return np.broadcast_to(value, np.broadcast_shapes(value.shape, ())).copy()
