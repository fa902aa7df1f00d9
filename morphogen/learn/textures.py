"""Target textures: loading an image, rotated copies of it, and synthetic example textures.

Images here are float RGB arrays in ``[0, 1]`` of shape ``(H, W, 3)``. The neural RD state is
shown as an image through its first three channels, ``rgb = x[0:3] + 0.5`` (the convention of
the texture neural CA that seed 002 builds on).
"""

from __future__ import annotations

from pathlib import Path

import imageio.v3 as iio
import jax
import jax.numpy as jnp
import numpy as np
from scipy import ndimage

from morphogen.errors import MorphogenError
from morphogen.models.model import Array
from morphogen.render.images import to_uint8 as to_uint8
from morphogen.util.io import check_image

SYNTHETIC = ("stripes", "dots", "checker", "lined", "blotchy", "lizards", "labyrinth")
"""Names of the synthetic textures :func:`synthetic_texture` makes (the targets of the shipped
rules, :mod:`morphogen.models.neural_library`, in the spirit of seed 002's fig. 2; ``labyrinth``
is the disordered counterpart of ``stripes`` that a drifting stripe rule turns into)."""


def state_to_rgb(u: Array) -> Array:
    """RGB image of neural RD states: ``(..., n, H, W)`` -> ``(..., H, W, 3)``, ``x[:3] + 0.5``.

    Not clipped, so the loss sees (and penalises) values outside ``[0, 1]``.
    """
    return jnp.moveaxis(u[..., :3, :, :], -3, -1) + 0.5


def load_texture(path: str | Path, size: int | None = None) -> np.ndarray:
    """Read an image file as float RGB ``(S, S, 3)``: grey or RGBA become RGB, a non-square
    image is centre-cropped to a square, and ``size`` (if given) resizes it (area averaging
    when shrinking).

    Raises:
        MorphogenError: the file is missing or not an image.
    """
    path = check_image(path, "target image")  # missing, FIFO, device named; header and size
    try:
        img = np.asarray(iio.imread(path))
    except Exception:  # imageio raises many types (and multi-line messages) for bad files
        raise MorphogenError(
            f"cannot read target image {path}: not a PNG, JPEG, ... that can be decoded"
        ) from None
    return prepare_texture(img, size)


def prepare_texture(img: np.ndarray, size: int | None = None) -> np.ndarray:
    """Normalise an image array (``uint8`` or float, grey/RGB/RGBA) to float RGB ``(S, S, 3)``."""
    img = np.asarray(img)
    scale = 255.0 if img.dtype == np.uint8 else (65535.0 if img.dtype == np.uint16 else 1.0)
    img = img.astype(np.float32) / scale
    if not np.all(np.isfinite(img)):
        raise MorphogenError("target image holds NaN or infinite values (a float image with "
                             "missing data?); give a picture of finite values")
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=-1)
    if img.ndim != 3 or img.shape[-1] not in (1, 3, 4):
        raise MorphogenError(f"target image must be grey, RGB or RGBA, got shape {img.shape}")
    if img.shape[-1] == 1:
        img = np.repeat(img, 3, axis=-1)
    img = img[..., :3]
    h, w = img.shape[:2]
    s = min(h, w)
    if s < 16:
        raise MorphogenError(f"target image is too small ({h}x{w}); use at least 16x16 pixels")
    top, left = (h - s) // 2, (w - s) // 2
    img = img[top : top + s, left : left + s]
    if size is not None and size != s:
        if size < 16:
            raise MorphogenError(f"target size must be at least 16 pixels, got {size}")
        img = np.asarray(jax.image.resize(jnp.asarray(img), (size, size, 3), "linear"))
    return np.clip(img, 0.0, 1.0).astype(np.float32)


def crop_size(side: int) -> int:
    """Side of the largest square that fits inside a ``side``-square image at any rotation."""
    return int((side - 1) / np.sqrt(2.0)) + 1


def rotated_crops(img: np.ndarray, n_rot: int) -> np.ndarray:
    """``n_rot`` copies of a square image rotated by ``360 k / n_rot`` degrees, each cropped to
    the central square that stays inside the image, shape ``(n_rot, c, c, 3)``.

    Bilinear sampling about the image centre; rotations by multiples of 90 degrees are exact
    pixel permutations, so rotating the target by 90 degrees permutes the crops when ``n_rot``
    is a multiple of 4 (seed 002, "Rotation-invariant texture loss").
    """
    if n_rot < 1:
        raise MorphogenError(f"the number of target rotations must be >= 1, got {n_rot}")
    side = img.shape[0]
    c = crop_size(side)
    centre = (side - 1) / 2.0
    offs = np.arange(c, dtype=np.float64) - (c - 1) / 2.0
    oy, ox = np.meshgrid(offs, offs, indexing="ij")
    out = []
    for k in range(n_rot):
        angle = 2.0 * np.pi * k / n_rot
        cos, sin = _exact(np.cos(angle)), _exact(np.sin(angle))
        ys = centre + cos * oy - sin * ox
        xs = centre + sin * oy + cos * ox
        chans = [
            ndimage.map_coordinates(img[..., ch], [ys, xs], order=1, mode="nearest")
            for ch in range(3)
        ]
        out.append(np.stack(chans, axis=-1))
    return np.stack(out).astype(np.float32)


def _exact(v: float) -> float:
    """Round cosines and sines of multiples of 90 degrees to exact 0 or +-1."""
    r = round(v)
    return float(r) if abs(v - r) < 1e-12 else float(v)


def synthetic_texture(kind: str, size: int = 64, seed: int = 0) -> np.ndarray:
    """A periodic example texture, float RGB ``(size, size, 3)``; lengths scale with ``size``
    (quoted here for ``size = 64``).

    - ``stripes``: dark blue stripes on cream, period ``size / 5`` along the lattice vector
      ``(3, 4)``, so they are oblique and tile the torus seamlessly.
    - ``dots``: red dots of radius ``size / 16`` on a pale background at jittered positions of a
      ``4 x 4`` lattice (periodic distances).
    - ``checker``: dark brown and cream squares of side 8 with soft edges.
    - ``lined``: thin grey-blue lines 8 apart on white, gently undulating.
    - ``blotchy``: irregular ochre blotches on sand: periodic noise band-limited around
      wavelength 16 and thresholded.
    - ``lizards``: a ``4 x 4`` tiling of little green lizards (body, head, tail, four legs,
      an eye), alternately turned by 90 degrees, on pale yellow.
    - ``labyrinth``: the stripes' colours and period in a disordered maze (band-pass noise in a
      thin ring at the stripes' wavenumber, thresholded).
    """
    if kind not in SYNTHETIC:
        raise MorphogenError(f"unknown synthetic texture {kind!r}; use one of {SYNTHETIC}")
    from morphogen.learn import targets

    ink, background, colour = targets.INK[kind](size, seed)
    img = background * (1.0 - ink[..., None]) + colour * ink[..., None]
    return np.clip(img, 0.0, 1.0).astype(np.float32)
