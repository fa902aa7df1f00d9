"""The power spectrum of a pattern, its radial average, and the earth mover's distance of two
histograms: one definition of each, for the descriptors, the search's target fitness, picture
matching and the neural texture features.

- :func:`power_spectrum`: ``|f̂(q)|²`` over the last two axes, the mean removed by default
  (a periodic field's FFT magnitude ignores translations exactly).
- :func:`radial_spectrum`: ``P(r) = mean_{round(N |q|) = r} |f̂(q)|²``, ``r = 0 … N/2``, ``q`` in
  cycles per pixel and ``N = min(H, W)``, so ring ``r`` holds wavelength ``N / r`` pixels on any
  aspect ratio (averaging over rings ignores rotations). The descriptors' ``wavelength`` is
  ``N / argmax_{r ≥ 1} P(r)``.
- :func:`spectrum_distribution`: the same rings ``1 … bins`` of the standardised field,
  normalised to sum 1: a distribution over wavenumbers that ignores the field's offset and
  scale (Skaggs-style target matching, :mod:`morphogen.search.fitness`).
- :func:`wasserstein_1d`: ``Σ |CDF_p − CDF_q| / n`` on ``n`` equal bins, in units of the whole
  axis, between 0 and 1; in NumPy for NumPy histograms (float64, as picture matching computes)
  and in JAX otherwise.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

Array = jax.Array


def power_spectrum(f: Array, *, centre: bool = True) -> Array:
    """``|FFT2(f − mean f)|²`` over the last two axes (``centre=False``: of ``f`` as given)."""
    if centre:
        f = f - jnp.mean(f, axis=(-2, -1), keepdims=True)
    return jnp.abs(jnp.fft.fft2(f)) ** 2


def ring_index(h: int, w: int) -> np.ndarray:
    """The ring ``round(N |q|)`` of each wavevector of an ``(h, w)`` FFT, ``N = min(h, w)``."""
    qy = np.fft.fftfreq(h)[:, None]
    qx = np.fft.fftfreq(w)[None, :]
    return np.rint(min(h, w) * np.hypot(qy, qx)).astype(np.int32)


def radial_spectrum(f: Array) -> Array:
    """Radially averaged power spectrum ``P(r)``, ``r = 0 … N/2`` (module docstring)."""
    h, w = f.shape
    rings = min(h, w) // 2 + 1
    ring = np.minimum(ring_index(h, w), rings)  # beyond N/2: one overflow ring, dropped
    power = power_spectrum(f)
    total = jnp.zeros(rings + 1, power.dtype).at[ring].add(power)
    count = np.bincount(ring.ravel(), minlength=rings + 1)
    return (total / np.maximum(count, 1))[:rings]


def spectrum_distribution(field: Array, bins: int | None = None) -> Array:
    """Rings ``1 … bins`` of the standardised field's radial spectrum, summing to 1.

    Args:
        field: shape ``(H, W)``.
        bins: number of rings, at most (and by default) ``min(H, W) // 2``.

    Returns:
        shape ``(bins,)``.
    """
    h, w = field.shape
    top = min(h, w) // 2
    bins = bins or top
    if not 1 <= bins <= top:
        raise ValueError(f"bins must be 1 .. {top} for a {h}x{w} field, got {bins}")
    z = field - jnp.mean(field)
    z = z / jnp.maximum(jnp.std(z), 1e-12)
    mean = radial_spectrum(z)[1:bins + 1]
    return mean / jnp.maximum(jnp.sum(mean), 1e-30)


def wasserstein_1d(p: Any, q: Any) -> Any:
    """Earth mover's distance between two histograms on the same ``n`` equal bins, in units
    of the whole axis: ``sum |CDF_p - CDF_q| / n``, between 0 and 1."""
    xp = np if isinstance(p, np.ndarray) and isinstance(q, np.ndarray) else jnp
    return xp.sum(xp.abs(xp.cumsum(p) - xp.cumsum(q))) / p.shape[0]
