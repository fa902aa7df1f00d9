"""Texture descriptors: what a texture loss compares (seed 002, "Rotation-invariant texture
loss"; Gatys et al. 2015).

An extractor is a frozen (hashable) description plus a weight pytree it builds once:

- ``weights = extractor.init()``
- ``extractor.apply(weights, rgb, periodic) -> list of descriptors``, ``rgb`` of shape
  ``(B, H, W, 3)`` in ``[0, 1]``, each descriptor of shape ``(B, ...)`` and independent of
  ``H, W`` (so a target crop and a differently sized state can be compared).

``periodic`` says how convolutions see the image border: the RD state lives on a torus (wrap
around), a target crop does not (mirror padding).

Extractors:

- :class:`RandomFeatures` (``random``, the default; needs no trained weights): an image pyramid,
  at each level a bank of fixed random 3x3 filters with a ReLU, summarised by their Gram matrix
  ``G = F^T F / (h w)`` (Gatys et al.'s statistics over random rather than trained filters) and
  by their value distributions (sliced optimal transport), plus the colour distribution.
- :class:`SpectrumFeatures` (``spectrum``): the radially averaged power spectrum and a sorted-value
  histogram of each colour channel; rotation invariant by construction.
- :class:`morphogen.learn.vgg.VGGFeatures` (``vgg``): Gram matrices of VGG16 activations, the
  paper's choice, when VGG16 weights are available offline.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.models.model import Array
from morphogen.patterns.spectrum import power_spectrum


def pad2d(x: Array, width: int, periodic: bool) -> Array:
    """Pad the two spatial axes of ``(B, H, W, C)``: wrap around or mirror."""
    pad = ((0, 0), (width, width), (width, width), (0, 0))
    return jnp.pad(x, pad, mode="wrap" if periodic else "reflect")


def conv2d(x: Array, kernel: Array, bias: Array, periodic: bool) -> Array:
    """``same``-size 2D convolution of ``(B, H, W, Cin)`` with an HWIO ``kernel``."""
    k = kernel.shape[0]
    y = jax.lax.conv_general_dilated(
        pad2d(x, k // 2, periodic), kernel, (1, 1), "VALID",
        dimension_numbers=("NHWC", "HWIO", "NHWC"),
    )
    return y + bias


def gram(f: Array) -> Array:
    """Gram matrix of feature maps: ``(B, H, W, C)`` -> ``(B, C, C)``, averaged over pixels."""
    b, h, w, c = f.shape
    flat = f.reshape(b, h * w, c)
    return jnp.einsum("bpc,bpd->bcd", flat, flat) / (h * w)


def avg_pool2(x: Array) -> Array:
    """2x2 average pooling of ``(B, H, W, C)`` (an odd last row or column is dropped)."""
    b, h, w, c = x.shape
    h2, w2 = h // 2, w // 2
    x = x[:, : 2 * h2, : 2 * w2]
    return x.reshape(b, h2, 2, w2, 2, c).mean(axis=(2, 4))


def sortable_bits(x: Array) -> Array:
    """A signed integer key of each float that orders as the values do: the IEEE 754 bits
    (``int32`` for float32, ``int64`` for float64) with the magnitude bits of negative numbers
    flipped, so ``-0.0`` sorts just below ``+0.0``."""
    itype = jnp.dtype(f"int{8 * x.dtype.itemsize}")
    bits = jax.lax.bitcast_convert_type(x, itype)
    return bits ^ ((bits >> (8 * x.dtype.itemsize - 1)) & jnp.iinfo(itype).max)


def quantiles(values: Array, q: int) -> Array:
    """Sorted values at ``q`` evenly spaced quantiles: ``(B, P, C)`` -> ``(B, q, C)``.

    For two equally weighted samples in 1D, the mean squared difference of their quantile
    functions is the squared 2-Wasserstein (optimal transport) distance, so comparing these
    compares whole value distributions, not just their moments.

    The values are sorted as integer keys (:func:`sortable_bits`): XLA's CPU sort has a fast
    path for one integer operand and none for floats, whose total-order comparator made
    ``jnp.sort`` take 80 ms of a 64 x 64 cpu-preset loss; the integer sort takes 15 ms. The
    result is the entry of ``values`` that holds each picked key (its first occurrence), so
    values are bit-identical to ``jnp.sort`` and the gradient reaches the same entry. (Only at
    an exact tie, where a quantile is not differentiable, may it reach another of the tied
    entries than ``jnp.sort``'s, which picks by position among them.)
    """
    n = values.shape[1]
    pick = ((np.arange(q) + 0.5) / q * n).astype(int)
    cols = jnp.moveaxis(values, 1, -1)  # (B, C, P)
    keys = sortable_bits(cols)
    picked = jax.lax.sort(keys, dimension=keys.ndim - 1)[..., pick]  # (B, C, q)
    where = jnp.argmax(keys[..., None, :] == picked[..., :, None], axis=-1)
    out = jnp.take_along_axis(cols, jax.lax.stop_gradient(where), axis=-1)
    return jnp.moveaxis(out, -1, 1)


@dataclass(frozen=True)
class RandomFeatures:
    """Statistics of fixed random filters over an image pyramid.

    Level ``l`` (``l = 0 .. levels-1``) sees the image average-pooled ``2^l`` times; ``width``
    random zero-mean 3x3 filters (unit norm) with random biases and a ReLU give feature maps
    ``F_l`` of shape ``(h w, width)``. A filter at level ``l`` spans ``3 * 2^l`` pixels, so the
    levels cover structure from 3 to ``3 * 2^(levels-1)`` pixels. Descriptors:

    - the colour distribution: each RGB channel's ``quantiles`` quantiles;
    - per level, the Gram matrix ``F_l^T F_l / (h w)`` (Gatys et al.'s co-occurrence
      statistics over random rather than trained filters);
    - per level, each feature's ``quantiles`` quantiles (a sliced optimal-transport
      description of the feature distribution; 0 disables them).

    The filters are drawn from ``seed`` with NumPy, so they never change between runs.
    """

    levels: int = 4
    width: int = 32
    quantiles: int = 32
    seed: int = 0
    name: str = "random"

    def init(self) -> list[tuple[Array, Array]]:
        rng = np.random.default_rng(self.seed)
        out = []
        for _ in range(self.levels):
            k = rng.standard_normal((3, 3, 3, self.width))
            k -= k.mean(axis=(0, 1, 2), keepdims=True)
            k /= np.sqrt((k * k).sum(axis=(0, 1, 2), keepdims=True))
            b = 0.3 * rng.standard_normal(self.width)
            out.append((jnp.asarray(k, jnp.float32), jnp.asarray(b, jnp.float32)))
        return out

    def apply(self, weights: Any, rgb: Array, periodic: bool) -> list[Array]:
        b = rgb.shape[0]
        x = 2.0 * rgb - 1.0
        out = []
        if self.quantiles:
            out.append(quantiles(x.reshape(b, -1, 3), self.quantiles))
        for level, (k, bias) in enumerate(weights):
            if level:
                x = avg_pool2(x)
            f = jax.nn.relu(conv2d(x, k, bias, periodic))
            out.append(gram(f))
            if self.quantiles:
                out.append(quantiles(f.reshape(b, -1, f.shape[-1]), self.quantiles))
        return out


@dataclass(frozen=True)
class SpectrumFeatures:
    """Radial power spectrum and value histogram of each colour channel.

    The power spectrum ``P(k) = |FFT(x - mean)|^2 / (H W)`` (a Hann window on non-periodic
    images, compensated for its energy) is averaged over rings ``|k|`` in ``bins`` equal steps
    of ``[0, 1/2]`` cycles per pixel and compared as ``log(1 + P / 0.01)``. The histogram is the
    channel's sorted values sampled at ``quantiles`` evenly spaced quantiles (a 1D optimal
    transport description of the value distribution).
    """

    bins: int = 16
    quantiles: int = 16
    name: str = "spectrum"

    def init(self) -> dict:
        return {}

    def apply(self, weights: Any, rgb: Array, periodic: bool) -> list[Array]:
        b, h, w, _ = rgb.shape
        x = jnp.moveaxis(rgb, -1, 1)  # (B, 3, H, W)
        centred = x - x.mean(axis=(-2, -1), keepdims=True)
        if not periodic:
            win = np.outer(np.hanning(h), np.hanning(w))
            centred = centred * (win / np.sqrt(np.mean(win**2)))
        power = power_spectrum(centred, centre=False) / (h * w)  # centred before the window
        ky = np.fft.fftfreq(h)[:, None]
        kx = np.fft.fftfreq(w)[None, :]
        ring = np.floor(np.hypot(ky, kx) / 0.5 * self.bins).astype(int)
        onehot = (ring[..., None] == np.arange(self.bins)).astype(np.float32)  # (H, W, K)
        counts = np.maximum(onehot.sum(axis=(0, 1)), 1.0)
        radial = jnp.einsum("bchw,hwk->bck", power, onehot) / counts
        spectrum = jnp.log1p(radial / 0.01).reshape(b, -1)
        hist = quantiles(rgb.reshape(b, h * w, 3), self.quantiles).reshape(b, -1)
        return [spectrum, hist]
