"""Finite-difference Laplacian stencils on a padded array.

Each stencil takes a field padded by one ghost cell on every side of its last 2 (3) axes and
returns the Laplacian of the interior; leading axes (species) are carried along, so one pass
serves every species. Weights are normalised so that every stencil is a consistent second-order
approximation of the Laplacian (a Fourier mode ``exp(i k x)`` of small ``k`` decays at ``-|k|^2``).

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

import numpy as np

from morphogen.models.model import Array


@dataclass(frozen=True)
class Stencil:
    """A Laplacian stencil: ``apply(padded, dx)`` and its spectral radius for ``dx = 1``."""

    name: str
    apply: Callable[[Array, float], Array]
    symbol: Callable[..., np.ndarray]
    spectral_radius: float


def _five(g: Array, h: float) -> Array:
    c = g[..., 1:-1, 1:-1]
    return (g[..., :-2, 1:-1] + g[..., 2:, 1:-1] + g[..., 1:-1, :-2] + g[..., 1:-1, 2:]
            - 4.0 * c) / (h * h)


def _nine(g: Array, h: float) -> Array:
    c = g[..., 1:-1, 1:-1]
    edges = g[..., :-2, 1:-1] + g[..., 2:, 1:-1] + g[..., 1:-1, :-2] + g[..., 1:-1, 2:]
    corners = g[..., :-2, :-2] + g[..., :-2, 2:] + g[..., 2:, :-2] + g[..., 2:, 2:]
    return (edges * (2.0 / 3.0) + corners * (1.0 / 6.0) - c * (10.0 / 3.0)) / (h * h)


def _seven(g: Array, h: float) -> Array:
    c = g[..., 1:-1, 1:-1, 1:-1]
    s = (
        g[..., :-2, 1:-1, 1:-1] + g[..., 2:, 1:-1, 1:-1]
        + g[..., 1:-1, :-2, 1:-1] + g[..., 1:-1, 2:, 1:-1]
        + g[..., 1:-1, 1:-1, :-2] + g[..., 1:-1, 1:-1, 2:]
    )
    return (s - 6.0 * c) / (h * h)


def _symbol_axes(*k: np.ndarray) -> np.ndarray:
    return sum(2.0 * np.cos(ki) - 2.0 for ki in k)


def _symbol_nine(ky: np.ndarray, kx: np.ndarray) -> np.ndarray:
    edges = 2.0 * np.cos(kx) + 2.0 * np.cos(ky)
    corners = 4.0 * np.cos(kx) * np.cos(ky)
    return edges * (2.0 / 3.0) + corners * (1.0 / 6.0) - 10.0 / 3.0


STENCILS: dict[tuple[int, int], Stencil] = {
    (2, 5): Stencil("5-point", _five, _symbol_axes, 8.0),
    (2, 9): Stencil("9-point", _nine, _symbol_nine, 16.0 / 3.0),
    (3, 7): Stencil("7-point", _seven, _symbol_axes, 12.0),
}
"""Stencils by ``(dimensions, points)``."""
