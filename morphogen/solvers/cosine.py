"""The discrete cosine transform (DCT-II) and its inverse on the grid's own size, by FFT.

A no-flux species' Laplacian is diagonal in the cosines ``cos(pi m (i + 1/2) / n)``,
``m = 0 .. n - 1`` (:mod:`morphogen.solvers.fourier`). Their coefficients are the DCT-II

.. math:: X_m = 2 \\sum_{i=0}^{n-1} x_i \\cos\\frac{\\pi m (2i + 1)}{2n}

per axis (:func:`scipy.fft.dctn` ``type=2``, unnormalised), which Makhoul's reordering
(IEEE Trans. ASSP 28, 1980) computes with one real FFT of the same size: the even-indexed
values followed by the odd-indexed ones reversed, transformed, turned by ``e^{-i pi m / 2n}``;
mode ``m`` is twice the real part, mode ``n - m`` minus twice the imaginary part. On a 2D grid
(or the last two axes of a 3D one) both axes go through one ``rfft2`` (Makhoul's 2D form). The
same coefficients from an FFT of the field mirrored along every axis cost a transform of
``2^d`` times the data with the products on ``2^d`` times the modes: the live view's no-flux
IMEX and ETDRK4 frames took 1.6-4.8 times as long (Gray-Scott on 256² and 512², docs/web.md).
``jax.scipy.fft.dctn`` gives the same coefficients (to float32 rounding) by Makhoul's 1D form
along each axis, each a complex FFT of the full length: a transform, multiplier and inverse of
two species took 2.7-3.5 times the CPU time of this module's on 64²-512² grids
(``bench/bench_cosine.py``, ``bench/results/cosine.json``), so the 2D form is kept.

:func:`idct` is the exact inverse of :func:`dct` (a mode multiplier between them acts on the
cosine coefficients, whatever their scale).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.models.model import Array


def dct(x: Array, ndim: int) -> Array:
    """DCT-II over the last ``ndim`` axes of real ``x`` (same shape, real)."""
    for axis in range(x.ndim - ndim, x.ndim - 2):
        x = _dct1(x, axis)
    return _dct2(x) if ndim >= 2 else _dct1(x, x.ndim - 1)


def idct(X: Array, ndim: int) -> Array:
    """Inverse of :func:`dct` over the last ``ndim`` axes."""
    x = _idct2(X) if ndim >= 2 else _idct1(X, X.ndim - 1)
    for axis in range(X.ndim - ndim, X.ndim - 2):
        x = _idct1(x, axis)
    return x


def _twiddle(n: int, count: int, sign: float, dtype) -> np.ndarray:
    """``e^{sign i pi m / 2n}``, ``m = 0 .. count - 1``, complex of ``dtype``'s precision."""
    w = np.exp(sign * 0.5j * np.pi * np.arange(count) / n)
    return w.astype(np.result_type(dtype, np.complex64))


def _interleave(x: Array, axis: int) -> Array:
    """Even-indexed values, then the odd-indexed ones reversed."""
    odd = jax.lax.slice_in_dim(x, 1, None, 2, axis)
    return jnp.concatenate([jax.lax.slice_in_dim(x, 0, None, 2, axis), jnp.flip(odd, axis)],
                           axis)


def _deinterleave(v: Array, axis: int) -> Array:
    """Inverse of :func:`_interleave`."""
    n = v.shape[axis]
    m = (n + 1) // 2
    even = jax.lax.slice_in_dim(v, 0, m, 1, axis)
    odd = jnp.flip(jax.lax.slice_in_dim(v, m, n, 1, axis), axis)
    if n % 2:
        pad = [(0, 0, 0)] * v.ndim
        pad[axis] = (0, 1, 0)
        odd = jax.lax.pad(odd, jnp.zeros((), v.dtype), pad)
    shape = list(v.shape)
    shape[axis] = 2 * m
    both = jnp.stack([even, odd], axis + 1).reshape(shape)
    return jax.lax.slice_in_dim(both, 0, n, 1, axis)


def _mirror_index(x: Array, axis: int) -> Array:
    """``x[n - m]`` along ``axis``, with ``x[n] = 0``."""
    zero = jnp.zeros_like(jax.lax.slice_in_dim(x, 0, 1, 1, axis))
    return jnp.concatenate([zero, jnp.flip(jax.lax.slice_in_dim(x, 1, None, 1, axis), axis)],
                           axis)


def _halves(y: Array, n: int) -> Array:
    """The DCT-II along the last axis from ``y = e^{-i pi m / 2n} V_m``, ``m <= n/2``:
    ``2 Re y_m`` for modes ``0 .. n/2`` and ``-2 Im y_m`` for modes ``n - m``."""
    h = n // 2 + 1
    return jnp.concatenate([2 * y.real, -2 * jnp.flip(y.imag[..., 1:n - h + 1], -1)], -1)


def _dct1(x: Array, axis: int) -> Array:
    x = jnp.moveaxis(x, axis, -1)
    n = x.shape[-1]
    v = jnp.fft.rfft(_interleave(x, x.ndim - 1), axis=-1)
    out = _halves(_twiddle(n, n // 2 + 1, -1.0, x.dtype) * v, n)
    return jnp.moveaxis(out, -1, axis)


def _idct1(X: Array, axis: int) -> Array:
    X = jnp.moveaxis(X, axis, -1)
    n = X.shape[-1]
    h = n // 2 + 1
    y = jax.lax.complex(X[..., :h], -_mirror_index(X, X.ndim - 1)[..., :h])
    v = jnp.fft.irfft(_twiddle(n, h, 1.0, X.dtype) * y / 2, n=n, axis=-1)
    return jnp.moveaxis(_deinterleave(v, v.ndim - 1), -1, axis)


def _dct2(x: Array) -> Array:
    """DCT-II over the last two axes with one ``rfft2``: with ``V`` the transform of the
    field reordered along both axes and ``w_a`` the turns,
    ``X[m1, m2] = 2 Re(w1 (w2 V[m1, m2] + conj(w2) conj(V[-m1, m2])))`` and
    ``X[m1, n2 - m2] = -2 Im(w1 (w2 V[m1, m2] - conj(w2) conj(V[-m1, m2])))``."""
    n1, n2 = x.shape[-2:]
    h2 = n2 // 2 + 1
    v = jnp.fft.rfft2(_interleave(_interleave(x, x.ndim - 2), x.ndim - 1))
    w1 = _twiddle(n1, n1, -1.0, x.dtype)[:, None]
    w2 = _twiddle(n2, h2, -1.0, x.dtype)[None, :]
    back = jnp.conj(jnp.roll(jnp.flip(v, -2), 1, -2))  # conj(V[-m1, m2])
    p, q = (w1 * w2) * v, (w1 * np.conj(w2)) * back
    lo = 2 * (p + q).real
    hi = -2 * jnp.flip((p - q).imag[..., 1:n2 - h2 + 1], -1)
    return jnp.concatenate([lo, hi], -1)


def _idct2(X: Array) -> Array:
    """Inverse of :func:`_dct2` (Makhoul's eq. for the 2D inverse):
    ``V[m1, m2] = conj(w1 w2) ((X[m1, m2] - X[-m1, -m2]) - i (X[-m1, m2] + X[m1, -m2])) / 4``,
    ``X[-m] = X[n - m]`` and ``X[n] = 0``."""
    n1, n2 = X.shape[-2:]
    h2 = n2 // 2 + 1
    r1 = _mirror_index(X, X.ndim - 2)
    r2 = _mirror_index(X, X.ndim - 1)[..., :h2]
    r12 = _mirror_index(r1, X.ndim - 1)[..., :h2]
    y = jax.lax.complex(X[..., :h2] - r12, -(r1[..., :h2] + r2))
    w = (np.conj(_twiddle(n1, n1, -1.0, X.dtype)[:, None] * _twiddle(n2, h2, -1.0, X.dtype))
         / 4).astype(y.dtype)
    v = jnp.fft.irfft2(w * y, s=(n1, n2))
    return _deinterleave(_deinterleave(v, v.ndim - 1), v.ndim - 2)
