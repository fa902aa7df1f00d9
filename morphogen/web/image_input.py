"""An uploaded image on the grid: a PNG's grey levels as one species' starting state or as a
parameter's spatial field; and an uploaded picture to match (:func:`picture_bytes`, PNG or
JPEG, checked by its header and handed on undecoded).

The image is stretched over the whole grid, row 0 at the top as in the picture, and each cell
takes a grey level ``g`` in ``[0, 1]`` (the mean of R, G, B for a colour image), which becomes
``lo + (hi - lo) g`` there: black is ``lo``, white ``hi``, like a prepattern loaded from a file
in Ready. Cell ``(i, j)`` of an ``(h, w)`` grid has its centre at image coordinates
``(r, c) = ((i + 1/2) H / h - 1/2, (j + 1/2) W / w - 1/2)`` (pixel centres at whole numbers):

- ``nearest``: the pixel that centre falls on;
- ``bilinear``: ``g`` interpolated linearly between the four pixel centres around ``(r, c)``
  (:func:`scipy.ndimage.map_coordinates`, order 1), the edge pixels held beyond the image, so a
  small image gives a smooth field instead of blocks.
"""

from __future__ import annotations

import base64
import binascii

import numpy as np

from morphogen.errors import MorphogenError

MAX_IMAGE_BYTES = 4 * 1024 * 1024
"""Largest accepted PNG (decoded from base64)."""

MAX_IMAGE_PIXELS = 4096 * 4096
"""Most pixels a PNG may announce in its header (a grid has at most 512 cells a side): a small
file that decompresses to a huge picture is refused before it is decoded."""


def png_size(data: bytes) -> tuple[int, int]:
    """``(width, height)`` from a PNG's header (its first chunk, ``IHDR``), without decoding."""
    if len(data) < 24 or data[12:16] != b"IHDR":
        raise MorphogenError("the PNG could not be read; is the file complete?")
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def _file_bytes(text: object, kind: str) -> bytes:
    """Base64 text (optionally a ``data:`` URL) -> the file's bytes, at most
    :data:`MAX_IMAGE_BYTES`."""
    if not isinstance(text, str) or not text:
        raise MorphogenError(f"image must be a base64-encoded {kind}")
    try:
        data = base64.b64decode(text.split(",", 1)[-1], validate=True)
    except (binascii.Error, ValueError):
        raise MorphogenError(f"image is not valid base64; send the {kind} file's bytes") from None
    if len(data) > MAX_IMAGE_BYTES:
        raise MorphogenError(f"the image is over {MAX_IMAGE_BYTES // 2**20} MiB; use a smaller one")
    return data


def _check_pixels(width: int, height: int, kind: str) -> None:
    if width * height > MAX_IMAGE_PIXELS:
        raise MorphogenError(f"the {kind} is {width} x {height} pixels, more than the "
                             f"{MAX_IMAGE_PIXELS / 1e6:.3g} million accepted; reduce it first")


def picture_bytes(text: object) -> tuple[bytes, tuple[int, int]]:
    """Base64 PNG or JPEG text -> the file's bytes and its ``(width, height)``, read from its
    header without decoding it: the file's size and the pixels its header announces are
    checked, anything that is not a readable picture is one line. For a consumer that decodes
    and reduces the picture itself (``match``), so the server never holds the full-size float
    picture."""
    import io

    from PIL import Image

    data = _file_bytes(text, "PNG or JPEG")
    if not (data.startswith(b"\x89PNG") or data.startswith(b"\xff\xd8\xff")):
        raise MorphogenError("the file is not a picture: send a PNG or JPEG image")
    if data.startswith(b"\x89PNG"):
        _check_pixels(*png_size(data), "picture")
    try:
        with Image.open(io.BytesIO(data)) as img:
            size = img.size
    except Image.DecompressionBombError:
        raise MorphogenError("the picture is too large to decode safely; reduce it first") from None
    except Exception:  # a malformed header must come back as one line
        raise MorphogenError("the picture could not be read; is the file complete?") from None
    _check_pixels(*size, "picture")
    return data, size


def decode_png(text: object) -> np.ndarray:
    """Base64 PNG text -> grey levels ``(H, W)`` float32 in ``[0, 1]``."""
    import imageio.v3 as iio

    data = _file_bytes(text, "PNG")
    if not data.startswith(b"\x89PNG"):
        raise MorphogenError("only PNG images are accepted; save the picture as PNG")
    _check_pixels(*png_size(data), "PNG")
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


RESAMPLING = ("nearest", "bilinear")
"""How an image is resampled onto the grid (see the module docstring)."""


def image_field(grey: np.ndarray, shape: tuple[int, int], lo: float, hi: float,
                resample: str = "nearest") -> np.ndarray:
    """``grey`` ``(H, W)`` resampled onto an ``(h, w)`` grid (:data:`RESAMPLING`) and mapped to
    ``lo + (hi - lo) g``; returns ``(h, w)`` float32."""
    if resample not in RESAMPLING:
        raise MorphogenError(f"resampling must be one of {', '.join(RESAMPLING)}, "
                             f"got {resample!r}")
    h, w = shape
    if resample == "bilinear":
        from scipy.ndimage import map_coordinates

        r = (np.arange(h) + 0.5) * grey.shape[0] / h - 0.5
        c = (np.arange(w) + 0.5) * grey.shape[1] / w - 0.5
        rr, cc = np.meshgrid(r, c, indexing="ij")
        g = map_coordinates(np.asarray(grey, np.float64), [rr, cc], order=1, mode="nearest")
    else:
        rows = np.minimum((np.arange(h) + 0.5) * grey.shape[0] / h, grey.shape[0] - 1)
        cols = np.minimum((np.arange(w) + 0.5) * grey.shape[1] / w, grey.shape[1] - 1)
        g = grey[rows.astype(int)][:, cols.astype(int)]
    return (lo + (hi - lo) * g).astype(np.float32)
