"""The pseudo-spectral Laplacian on a periodic grid (``--stencil spectral``).

A periodic field on ``n_a`` cells per axis is a trigonometric polynomial; the Laplacian of that
polynomial is, mode by mode,

.. math:: \\widehat{\\nabla^2 u}(k) = -|k|^2\\,\\hat u(k),\\qquad
          k_a = \\frac{2\\pi m_a}{n_a\\,dx},\\; -\\tfrac{n_a}{2} \\le m_a < \\tfrac{n_a}{2},

computed with one real FFT forward and one back (``rfftn`` / ``irfftn``). Where the 5-point
stencil multiplies mode ``k`` by ``sum_a (2 cos(k_a dx) - 2) / dx^2 = -|k|^2 (1 - O(k^2 dx^2))``,
this is exact for every resolved mode, so a pattern on a coarse grid has the wavelength of the
continuous PDE (Murray, Mathematical Biology II, ch. 2, analyses the continuum operator; the
seeds' finite differences, Richard et al. part II and Ringham eq. 8, are its second-order
approximations). The ``m = -n/2`` (Nyquist) mode of an even axis keeps ``k = pi / dx``.

Its spectral radius ``max |k|^2 = sum_a (2 pi floor(n_a/2) / (n_a dx))^2`` (``d pi^2 / dx^2`` on
even grids, against ``4 d / dx^2`` for the 5- and 7-point stencils) sets the explicit
stability limit, ``pi^2 / 4 ≈ 2.47`` times smaller than the stencils'. Only periodic
boundaries have this Fourier basis; others are refused.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from morphogen.models.model import Array

SPECTRAL = "spectral"
"""The ``stencil`` value that selects this operator."""


def symbol(*k: np.ndarray) -> np.ndarray:
    """``-|k|^2`` for angular wavenumbers per cell ``k_a`` in ``[-pi, pi]`` (``dx = 1``)."""
    return -sum(np.asarray(ki, np.float64) ** 2 for ki in k)


def wavenumbers(shape: tuple[int, ...]) -> list[np.ndarray]:
    """Angular wavenumbers per cell on the ``rfftn`` grid of ``shape`` (last axis halved),
    each broadcastable to ``(n_0, ..., n_{-1} // 2 + 1)``."""
    freqs = [2 * np.pi * np.fft.fftfreq(n) for n in shape[:-1]]
    freqs.append(2 * np.pi * np.fft.rfftfreq(shape[-1]))
    return np.meshgrid(*freqs, indexing="ij", sparse=True)


def spectral_radius(shape: tuple[int, ...], dx: float) -> float:
    """``max |k|^2`` over the grid's modes: the largest eigenvalue of ``-Laplacian``."""
    return float(sum((2 * np.pi * (n // 2) / (n * dx)) ** 2 for n in shape))


def laplacian(f: Array, dx: float, ndim: int | None = None) -> Array:
    """Pseudo-spectral Laplacian over the last ``ndim`` axes of ``f`` (all axes by default),
    every one periodic; leading axes (species) are transformed together."""
    ndim = f.ndim if ndim is None else ndim
    axes = tuple(range(f.ndim - ndim, f.ndim))
    shape = f.shape[f.ndim - ndim:]
    lam = jnp.asarray(symbol(*wavenumbers(shape)) / dx**2, f.dtype)
    return jnp.fft.irfftn(lam * jnp.fft.rfftn(f, axes=axes), s=shape, axes=axes).astype(f.dtype)
