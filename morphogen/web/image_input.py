"""An uploaded image as a starting state: a PNG's grey levels mapped onto one species.

Each grid cell takes the grey level ``g`` in ``[0, 1]`` of the image pixel it falls on (nearest
neighbour, the image stretched over the whole grid, row 0 at the top as in the picture) and the
species gets ``lo + (hi - lo) g`` there, like a prepattern loaded from a file in Ready.
"""

from __future__ import annotations

import base64
import binascii

import numpy as np

from morphogen.errors import MorphogenError

MAX_IMAGE_BYTES = 4 * 1024 * 1024
"""Largest accepted PNG (decoded from base64)."""


def decode_png(text: object) -> np.ndarray:
    """Base64 PNG text -> grey levels ``(H, W)`` float32 in ``[0, 1]``."""
    import imageio.v3 as iio

    if not isinstance(text, str) or not text:
        raise MorphogenError("image must be a base64-encoded PNG")
    try:
        data = base64.b64decode(text.split(",", 1)[-1], validate=True)
    except (binascii.Error, ValueError):
        raise MorphogenError("image is not valid base64; send the PNG file's bytes") from None
    if len(data) > MAX_IMAGE_BYTES:
        raise MorphogenError(f"the image is over {MAX_IMAGE_BYTES // 2**20} MiB; use a smaller one")
    if not data.startswith(b"\x89PNG"):
        raise MorphogenError("only PNG images are accepted; save the picture as PNG")
    try:
        img = np.asarray(iio.imread(data, extension=".png"))
    except Exception:  # a malformed file must come back as one line, whatever the decoder says
        raise MorphogenError("the PNG could not be read; is the file complete?") from None
    img = img.astype(np.float32) / (65535.0 if img.dtype == np.uint16 else 255.0)
    if img.ndim == 3:
        img = img[..., :3].mean(axis=-1) if img.shape[-1] >= 3 else img[..., 0]
    if img.ndim != 2 or min(img.shape) < 1:
        raise MorphogenError("the PNG has no pixels")
    return img


def image_field(grey: np.ndarray, shape: tuple[int, int], lo: float, hi: float) -> np.ndarray:
    """Nearest-neighbour resampling of ``grey`` ``(H, W)`` onto an ``(h, w)`` grid, mapped to
    ``lo + (hi - lo) g``; returns ``(h, w)`` float32."""
    h, w = shape
    rows = np.minimum((np.arange(h) + 0.5) * grey.shape[0] / h, grey.shape[0] - 1).astype(int)
    cols = np.minimum((np.arange(w) + 0.5) * grey.shape[1] / w, grey.shape[1] - 1).astype(int)
    return (lo + (hi - lo) * grey[rows][:, cols]).astype(np.float32)
