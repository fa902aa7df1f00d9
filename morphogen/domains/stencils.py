"""Finite-difference Laplacian stencils and the neighbour views they read.

A stencil reads a field through ``at(*offset)``: the field moved so that ``at(dy, dx)[..., i, j]``
is the value at ``(i + dy, j + dx)`` on the last 2 (3) axes; leading axes (species) are carried
along, so one pass serves every species. Two views provide it:

- :func:`padded`: slices of the field padded by one ghost cell on every side (any boundary);
- :func:`periodic`: the wrapped field, each shift built so that XLA fuses it into the stencil's
  arithmetic. A wrap-padded array (``jnp.pad(mode="wrap")``: concatenates) read through several
  overlapping slices is materialised by XLA on CPU, in three copies per step (``jnp.roll``, also
  concatenates, measured slower still); each shift here is a zero-pad of a slice with the wrapped
  row (column) put in by a select, read once, so that an explicit step is one loop. The values are
  the same, and so are the results, bit for bit (Gray-Scott 256², explicit Euler: 1.3-1.4x as
  fast as the wrap-padded array, ``bench/results/gs_single.json``).

Weights are normalised so that every stencil is a consistent second-order approximation of the
Laplacian (a Fourier mode ``exp(i k x)`` of small ``k`` decays at ``-|k|^2``).

- 5-point (2D): ``(N + S + E + W - 4 c) / h^2``; Richard et al. part II eq. for ``u(t + h_t)``.
- 9-point (2D): the relative weights of Richard et al. §III.2.2 (edge 0.2, corner 0.05,
  centre -1), scaled by 1/0.3 so that the stencil approximates the Laplacian itself:
  ``(2/3 edges + 1/6 corners - 10/3 c) / h^2``. Its leading error term is isotropic.
  (Richard et al.'s literal stencil equals ``0.3 h^2 * Laplacian``; their ``D`` values therefore
  correspond to ``0.3 D / dx^2`` here.)
- 7-point (3D): ``(sum of 6 neighbours - 6 c) / h^2``.

The Fourier symbol of each stencil (eigenvalue on the mode with wavenumbers ``k``) is given by
:meth:`Stencil.symbol`; its most negative value gives the explicit stability limit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np
from jax import lax

from morphogen.models.model import Array

Neighbours = Callable[..., Array]
"""``at(*offset) -> Array``: the field moved by a cell offset (one entry per spatial axis)."""


@dataclass(frozen=True)
class Stencil:
    """A Laplacian stencil: ``apply(at, dx)`` and its spectral radius for ``dx = 1``;
    ``shifts``: on a torus it reads :func:`periodic` rather than a wrap-padded array (the
    axis-aligned stencils; the 9-point's corners take two shifts each, and it measured 0.8x as
    fast that way, Gray-Scott 256²)."""

    name: str
    apply: Callable[[Neighbours, float], Array]
    symbol: Callable[..., np.ndarray]
    spectral_radius: float
    shifts: bool = False


def padded(g: Array, ndim: int) -> Neighbours:
    """Neighbours from ``g``, a field padded by one ghost cell on each side of its last ``ndim``
    axes; ``at(*offset)`` has the unpadded shape."""
    def at(*offset: int) -> Array:
        axes = range(g.ndim - ndim, g.ndim)
        return g[(..., *(slice(1 + o, g.shape[a] - 1 + o) for a, o in zip(axes, offset,
                                                                            strict=True)))]

    return at


def periodic(u: Array, ndim: int) -> Neighbours:
    """Neighbours of ``u`` on a torus over its last ``ndim`` axes (diagonal offsets move along
    one axis, then the next)."""
    def at(*offset: int) -> Array:
        out = u
        for axis, o in zip(range(u.ndim - ndim, u.ndim), offset, strict=True):
            if o:
                out = _wrapped_shift(out, axis, o)
        return out

    return at


def _wrapped_shift(u: Array, axis: int, step: int) -> Array:
    """``out[i] = u[(i + step) mod n]`` along ``axis`` for ``step = ±1``: ``u`` without its
    first (last) slice, zero-padded at the other end, and the wrapped slice selected there."""
    if step not in (1, -1):
        raise ValueError(f"periodic shifts are by one cell, got {step}")
    n = u.shape[axis]
    forward = step == 1
    inner = lax.slice_in_dim(u, 1, n, axis=axis) if forward else lax.slice_in_dim(
        u, 0, n - 1, axis=axis)
    wrapped = lax.slice_in_dim(u, 0, 1, axis=axis) if forward else lax.slice_in_dim(
        u, n - 1, n, axis=axis)
    widths = [(0, 0)] * u.ndim
    widths[axis] = (0, 1) if forward else (1, 0)
    index = np.arange(n).reshape((n,) + (1,) * (u.ndim - 1 - axis))
    return jnp.where(index == (n - 1 if forward else 0), wrapped, jnp.pad(inner, widths))


def _five(at: Neighbours, h: float) -> Array:
    return (at(-1, 0) + at(1, 0) + at(0, -1) + at(0, 1) - 4.0 * at(0, 0)) / (h * h)


def _nine(at: Neighbours, h: float) -> Array:
    edges = at(-1, 0) + at(1, 0) + at(0, -1) + at(0, 1)
    corners = at(-1, -1) + at(-1, 1) + at(1, -1) + at(1, 1)
    return (edges * (2.0 / 3.0) + corners * (1.0 / 6.0) - at(0, 0) * (10.0 / 3.0)) / (h * h)


def _seven(at: Neighbours, h: float) -> Array:
    s = (
        at(-1, 0, 0) + at(1, 0, 0)
        + at(0, -1, 0) + at(0, 1, 0)
        + at(0, 0, -1) + at(0, 0, 1)
    )
    return (s - 6.0 * at(0, 0, 0)) / (h * h)


def _symbol_axes(*k: np.ndarray) -> np.ndarray:
    return sum(2.0 * np.cos(ki) - 2.0 for ki in k)


def _symbol_nine(ky: np.ndarray, kx: np.ndarray) -> np.ndarray:
    edges = 2.0 * np.cos(kx) + 2.0 * np.cos(ky)
    corners = 4.0 * np.cos(kx) * np.cos(ky)
    return edges * (2.0 / 3.0) + corners * (1.0 / 6.0) - 10.0 / 3.0


STENCILS: dict[tuple[int, int], Stencil] = {
    (2, 5): Stencil("5-point", _five, _symbol_axes, 8.0, shifts=True),
    (2, 9): Stencil("9-point", _nine, _symbol_nine, 16.0 / 3.0),
    (3, 7): Stencil("7-point", _seven, _symbol_axes, 12.0, shifts=True),
}
"""Stencils by ``(dimensions, points)``."""
