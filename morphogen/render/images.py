"""Still images of states: PNG files, 2D fields, and 3D fields as a mid-plane slice or a montage.

Everything here runs outside ``jit`` on NumPy arrays. Images are ``uint8`` RGB arrays of shape
``(H, W, 3)``; fields are real arrays ``(H, W)`` (2D) or ``(D, H, W)`` (3D, ``z`` first).
"""

from __future__ import annotations

from pathlib import Path

import imageio.v3 as iio
import numpy as np
from matplotlib.colors import Colormap

from morphogen.errors import MorphogenError
from morphogen.render.colour import NAN_COLOUR, colour_limits, colourise
from morphogen.render.mosaic import mosaic
from morphogen.util.io import ensure_writable_dir, write_atomic


def check_image(rgb: np.ndarray) -> np.ndarray:
    """Validate an image: ``(H, W)`` grey, ``(H, W, 3)`` RGB or ``(H, W, 4)`` RGBA, uint8."""
    rgb = np.asarray(rgb)
    if rgb.dtype != np.uint8:
        raise MorphogenError(f"image must be uint8, got {rgb.dtype}; use colourise() first")
    if rgb.ndim not in (2, 3) or (rgb.ndim == 3 and rgb.shape[2] not in (3, 4)):
        raise MorphogenError(
            f"image must have shape (H, W), (H, W, 3) or (H, W, 4), got {rgb.shape}"
        )
    if rgb.shape[0] == 0 or rgb.shape[1] == 0:
        raise MorphogenError(f"image is empty: shape {rgb.shape}")
    return rgb


def to_uint8(rgb: np.ndarray) -> np.ndarray:
    """Float RGB ``(..., 3)`` in ``[0, 1]`` to ``uint8``, clipped (NaN shows black)."""
    rgb = np.nan_to_num(np.asarray(rgb, np.float64), nan=0.0)
    return (np.clip(rgb, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def write_png(path: str | Path, rgb: np.ndarray) -> Path:
    """Write a uint8 image ``(H, W[, 3|4])`` to a PNG file atomically; returns the path.

    The parent directory is created if needed. The file appears only once complete.
    """
    rgb = check_image(rgb)
    path = Path(path)
    ensure_writable_dir(path.parent)
    data = iio.imwrite("<bytes>", rgb, extension=".png")
    return write_atomic(path, lambda fh: fh.write(data))


def upscale(rgb: np.ndarray, factor: int) -> np.ndarray:
    """Nearest-neighbour enlargement: ``(..., H, W, C)`` -> ``(..., H*factor, W*factor, C)``.

    Small grids (64 x 64) stay crisp when shown larger; ``factor=1`` returns the input.
    """
    if int(factor) != factor or factor < 1:
        raise MorphogenError(f"scale factor must be a positive integer, got {factor}")
    factor = int(factor)
    if factor == 1:
        return rgb
    return np.repeat(np.repeat(rgb, factor, axis=-3), factor, axis=-2)


def mid_slice(field: np.ndarray, axis: int = 0) -> np.ndarray:
    """The mid-plane of a 3D field: ``(D, H, W)`` -> the slice at index ``D // 2`` on ``axis``."""
    field = np.asarray(field)
    if field.ndim != 3:
        raise MorphogenError(f"mid_slice needs a 3D field (D, H, W), got shape {field.shape}")
    return np.take(field, field.shape[axis] // 2, axis=axis)


def state_image(
    field: np.ndarray,
    cmap: str | Colormap = "viridis",
    vmin: float | None = None,
    vmax: float | None = None,
    *,
    scale: int = 1,
    nan_colour: str = NAN_COLOUR,
) -> np.ndarray:
    """One species of a state as an image.

    A 2D field ``(H, W)`` is colourised directly; a 3D field ``(D, H, W)`` is shown by its
    mid-plane ``z = D // 2`` with the colour scale of the whole volume (see
    :func:`slice_montage` for all depths).

    Returns:
        ``(H*scale, W*scale, 3)`` uint8 RGB.
    """
    field = np.asarray(field, dtype=np.float64)
    if field.ndim == 3:
        vmin, vmax = colour_limits(field, vmin, vmax)
        field = mid_slice(field)
    elif field.ndim != 2:
        raise MorphogenError(
            f"state_image needs a 2D (H, W) or 3D (D, H, W) field, got shape {field.shape}"
        )
    return upscale(colourise(field, cmap, vmin, vmax, nan_colour=nan_colour), scale)


def slice_indices(depth: int, n: int) -> np.ndarray:
    """``min(n, depth)`` distinct depths evenly spaced over ``[0, depth - 1]``, ends included."""
    if n < 1:
        raise MorphogenError(f"number of slices must be at least 1, got {n}")
    if n == 1:
        return np.array([depth // 2])
    return np.unique(np.rint(np.linspace(0, depth - 1, min(n, depth))).astype(int))


def slice_montage(
    field: np.ndarray,
    n: int = 9,
    cmap: str | Colormap = "viridis",
    vmin: float | None = None,
    vmax: float | None = None,
    *,
    ncols: int | None = None,
    labels: bool = True,
    scale: int = 1,
    pad: int = 2,
    title: str | None = None,
    nan_colour: str = NAN_COLOUR,
) -> np.ndarray:
    """A grid of ``z``-slices of a 3D field, all on the colour scale of the whole volume.

    Args:
        field: ``(D, H, W)``.
        n: number of slices, evenly spaced from ``z = 0`` to ``z = D - 1`` (at most ``D``).
        ncols: tiles per row; default ``ceil(sqrt(n))``.
        labels: label each tile with its depth (``"z=12"``).

    Returns:
        uint8 RGB mosaic, shape as :func:`morphogen.render.mosaic` gives for
        ``(n, H*scale, W*scale, 3)`` tiles.
    """
    field = np.asarray(field, dtype=np.float64)
    if field.ndim != 3:
        raise MorphogenError(f"slice_montage needs a 3D field (D, H, W), got shape {field.shape}")
    lo, hi = colour_limits(field, vmin, vmax)
    zs = slice_indices(field.shape[0], n)
    tiles = upscale(colourise(field[zs], cmap, lo, hi, nan_colour=nan_colour), scale)
    ncols = ncols or int(np.ceil(np.sqrt(len(zs))))
    names = [f"z={z}" for z in zs] if labels else None
    return mosaic(tiles, ncols, labels=names, pad=pad, title=title)
