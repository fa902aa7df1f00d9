"""A picture as one grey field: read, checked, cropped, reduced to a channel or colour axis.

Skaggs (seed 000, §6.4) asks for a fitness "initialized to target patterns which look similar to
a photograph or drawing"; a photograph is not a simulation, so before it is described
(:mod:`morphogen.match.signature`) it is reduced to what a simulated species is: one scalar
field. Which scalar is the user's choice (``channel``):

- ``auto`` (default): the first principal component of the RGB pixels, signed so that it grows
  with luminance. A recoloured pattern (any colour map whose colours lie near a line in RGB)
  comes back to its grey levels up to an affine change, which the descriptors ignore.
- ``luma``: ``0.299 R + 0.587 G + 0.114 B``; ``red``, ``green``, ``blue``: one channel;
  ``saturation``: ``max − min`` of R, G, B (a coloured motif on a grey ground);
- ``R,G,B``: the projection on a colour axis, e.g. ``1,-1,0`` (red against green).

Bad input is one :class:`~morphogen.errors.MorphogenError` line: a file that is not an image, an
image whose header claims more than :data:`MAX_PIXELS` pixels (a decompression bomb is refused
before it is decoded), a crop outside the image, a picture too small or blank in the chosen
channel. A picture larger than :data:`WORK_SIDE` is reduced by area averaging (its scale is kept
in :attr:`Picture.scale`, so wavelengths are still quoted in the original pixels).

A picture may carry a mask (:attr:`Picture.mask`): a mesh flattened onto its plane
(:mod:`morphogen.match.mesh_picture`) covers only part of its square pixels, and the signature
then describes the pixels inside alone; :attr:`Picture.inner` is the largest rectangle of them
(for what needs a full rectangle, the texture loss of the search).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morphogen.errors import MorphogenError

CHANNELS = ("auto", "luma", "red", "green", "blue", "saturation")
"""Named channels; a colour axis ``R,G,B`` is accepted too."""

MAX_PIXELS = 40_000_000
"""Largest picture accepted (width x height from the header, checked before decoding)."""

MIN_SIDE = 24
"""Smallest picture side (after the crop), in pixels."""

WORK_SIDE = 384
"""Pictures with a longer side are reduced to it (area averaging) before they are described."""

BLANK = 1e-3
"""A field whose standard deviation is below this (values in [0, 1]) is blank."""


@dataclass(frozen=True)
class Picture:
    """A picture reduced to one field.

    Attributes:
        field: grey levels, shape ``(H, W)`` float32 in ``[0, 1]`` (reduced to at most
            :data:`WORK_SIDE` per side).
        rgb: the cropped picture as shown on the answer sheet, ``(H, W, 3)`` float32.
        scale: original pixels per pixel of ``field`` (1 unless the picture was reduced).
        source: the file name (or ``"array"``).
        mask: ``(H, W)`` bool, ``True`` where the picture is (a flattened mesh); ``None``: every
            pixel. Outside it ``field`` holds the median inside and ``rgb`` white.
        pixel_size: the length of a pixel of ``field`` in mesh units (a mesh target), or
            ``None``.
        note: how the picture was made, for the log and the report (``""`` for a picture file).
    """

    field: np.ndarray
    rgb: np.ndarray
    scale: float
    source: str
    mask: np.ndarray | None = None
    pixel_size: float | None = None
    note: str = ""

    @property
    def inner(self) -> np.ndarray:
        """``field`` where every pixel is inside: all of it, or the largest rectangle inside
        :attr:`mask`, ``(h, w)``."""
        if self.mask is None:
            return self.field
        x, y, w, h = largest_rectangle(self.mask)
        return self.field[y:y + h, x:x + w]

    @property
    def centre(self) -> tuple[int, int] | None:
        """The pixel (row, column) deepest inside :attr:`mask` (farthest from every pixel
        outside), or ``None`` without a mask: where the answer sheet shows the picture."""
        if self.mask is None:
            return None
        from scipy.ndimage import distance_transform_edt

        depth = distance_transform_edt(np.pad(self.mask, 1))[1:-1, 1:-1]
        row, col = np.unravel_index(int(np.argmax(depth)), depth.shape)
        return int(row), int(col)


def largest_rectangle(mask: np.ndarray) -> tuple[int, int, int, int]:
    """The largest axis-aligned rectangle of ``True`` pixels of ``mask`` ``(H, W)``, as
    ``(x, y, w, h)`` (the crop convention). Row by row, the runs of ``True`` ending there form a
    histogram, whose largest rectangle one pass with a stack finds (``(0, 0, 1, 1)`` if none)."""
    runs = np.zeros(mask.shape[1], np.int64)
    best, box = 0, (0, 0, 1, 1)
    for row in range(mask.shape[0]):
        runs = np.where(mask[row], runs + 1, 0)
        heights = [*runs.tolist(), 0]  # the zero closes every bar
        stack: list[int] = []
        for col, height in enumerate(heights):
            while stack and heights[stack[-1]] >= height:
                top = heights[stack.pop()]
                left = stack[-1] + 1 if stack else 0
                if top * (col - left) > best:
                    best, box = top * (col - left), (left, row - top + 1, col - left, top)
            stack.append(col)
    return box


def parse_crop(text: str | None) -> tuple[int, int, int, int] | None:
    """``"X,Y,W,H"`` (pixels, from the top left corner) -> a tuple, or ``None``."""
    if text is None:
        return None
    parts = text.replace("x", ",").split(",")
    try:
        values = tuple(int(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 4 or values[0] < 0 or values[1] < 0 or values[2] < 1 or values[3] < 1:
        raise MorphogenError(f"bad crop {text!r}: write X,Y,W,H in pixels, e.g. 10,20,200,200")
    return values  # type: ignore[return-value]


def crop_box(crop: tuple[int, int, int, int] | None, width: int,
             height: int) -> tuple[int, int, int, int]:
    """The ``(left, top, right, bottom)`` box of ``crop`` (or the whole picture) in a
    ``width x height`` picture; a crop outside it, or a box under :data:`MIN_SIDE`, is refused."""
    x, y, w, h = crop if crop is not None else (0, 0, width, height)
    if x + w > width or y + h > height:
        raise MorphogenError(f"crop {x},{y},{w},{h} lies outside the {width}x{height} picture")
    if min(w, h) < MIN_SIDE:
        raise MorphogenError(f"the picture is {w}x{h} pixels; use at least {MIN_SIDE}x{MIN_SIDE}")
    return x, y, x + w, y + h


def read_rgb(source: str | Path | bytes, crop: tuple[int, int, int, int] | None = None,
             *, what: str = "picture") -> tuple[np.ndarray, int]:
    """A picture file (a path, or an uploaded file's bytes) as float RGB ``(h, w, 3)`` in
    ``[0, 1]`` (alpha composited on white), cropped, and reduced while still 8-bit to about
    :data:`WORK_SIDE` pixels a side: the pixels the header announces are checked before
    anything is decoded, a JPEG is decoded at the reduced size directly, and no full-size
    array of floats is ever made (a 6300² PNG peaked at 3.4 GB when it was). Returns the array
    and the longer side of the cropped picture in original pixels (for the scale)."""
    import io

    from PIL import Image

    if isinstance(source, bytes):
        name, stream = "the uploaded picture", io.BytesIO(source)
    else:
        from morphogen.util.io import check_input_file

        path = check_input_file(source, what, limit=float("inf"))  # FIFOs, devices named
        name, stream = f"{what} {path}", path
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(stream) as img:
                w, h = img.size
                if w * h > MAX_PIXELS:
                    raise MorphogenError(
                        f"{name} claims {w}x{h} pixels, over the limit of "
                        f"{MAX_PIXELS // 1_000_000} million; crop or reduce it first")
                box = crop_box(crop, w, h)
                side = max(box[2] - box[0], box[3] - box[1])
                if crop is None and img.format == "JPEG" and side >= 2 * WORK_SIDE:
                    img.draft("RGB", (w * WORK_SIDE // side, h * WORK_SIDE // side))
                    box = (0, 0, *img.size)
                img.load()
                if img.mode not in ("L", "LA", "RGB", "RGBA"):
                    img = img.convert("RGBA")
                img = img.crop(box) if box != (0, 0, *img.size) else img
                factor = max(img.size) // WORK_SIDE
                if factor > 1:
                    img = img.reduce(factor)  # box averages of 8-bit pixels
                rgba = np.asarray(img.convert("RGBA"), np.float32) / 255.0
    except MorphogenError:
        raise
    except (Image.DecompressionBombError, Image.DecompressionBombWarning):
        raise MorphogenError(f"{name} is too large to decode safely") from None
    except Exception:  # any decoder failure is the same user error: not a readable picture
        raise MorphogenError(f"{name} is not a picture that can be read (PNG, JPEG, ...)"
                             ) from None
    alpha = rgba[..., 3:]
    return rgba[..., :3] * alpha + (1.0 - alpha), side


def to_field(rgb: np.ndarray, channel: str = "auto") -> np.ndarray:
    """Reduce RGB ``(H, W, 3)`` to one field ``(H, W)`` (see the module docstring)."""
    flat = rgb.reshape(-1, 3).astype(np.float64)
    luma = flat @ np.array([0.299, 0.587, 0.114])
    if channel == "auto":
        centred = flat - flat.mean(axis=0)
        cov = centred.T @ centred / max(len(flat), 1)
        axis = np.linalg.eigh(cov)[1][:, -1]
        value = centred @ axis
        if np.dot(value, luma - luma.mean()) < 0:
            value = -value
    elif channel == "luma":
        value = luma
    elif channel in ("red", "green", "blue"):
        value = flat[:, ("red", "green", "blue").index(channel)]
    elif channel == "saturation":
        value = flat.max(axis=1) - flat.min(axis=1)
    else:
        try:
            axis = np.array([float(v) for v in channel.split(",")])
        except ValueError:
            axis = np.zeros(0)
        if axis.shape != (3,) or not np.any(axis) or not np.all(np.isfinite(axis)):
            raise MorphogenError(
                f"unknown channel {channel!r}; use one of {', '.join(CHANNELS)} or a colour "
                "axis of three finite numbers R,G,B such as 1,-1,0")
        value = flat @ axis
    value = value.reshape(rgb.shape[:2])
    lo, hi = float(value.min()), float(value.max())
    return ((value - lo) / max(hi - lo, 1e-12)).astype(np.float32)


def _reduce(a: np.ndarray, factor: float) -> np.ndarray:
    """Area-average ``a`` (``(H, W)`` or ``(H, W, 3)``) by ``factor`` >= 1."""
    from PIL import Image

    h, w = a.shape[:2]
    size = (max(1, round(w / factor)), max(1, round(h / factor)))
    chans = a[..., None] if a.ndim == 2 else a
    out = [np.asarray(Image.fromarray(chans[..., c].astype(np.float32), mode="F")
                      .resize(size, Image.BOX)) for c in range(chans.shape[-1])]
    res = np.stack(out, axis=-1)
    return res[..., 0] if a.ndim == 2 else res


def load_picture(image: str | Path | bytes | np.ndarray, *, channel: str = "auto",
                 crop: tuple[int, int, int, int] | None = None) -> Picture:
    """Read and reduce a picture: a file, an uploaded file's bytes, or an array ``(H, W)`` /
    ``(H, W, 3)`` in [0, 1]. The picture is cropped and reduced to :data:`WORK_SIDE` before
    its field is computed, so memory follows the work size, not the picture's."""
    if isinstance(image, np.ndarray):
        rgb = np.asarray(image, np.float32)
        if rgb.ndim == 2:
            rgb = np.repeat(rgb[..., None], 3, axis=-1)
        if rgb.ndim != 3 or rgb.shape[-1] not in (3, 4) or not np.all(np.isfinite(rgb)):
            raise MorphogenError(f"a picture array must be (H, W) or (H, W, 3), got {rgb.shape}")
        left, top, right, bottom = crop_box(crop, rgb.shape[1], rgb.shape[0])
        rgb, source = rgb[top:bottom, left:right, :3], "array"
        side = max(rgb.shape[:2])
    else:
        rgb, side = read_rgb(image, crop)
        source = "upload" if isinstance(image, bytes) else str(image)
    if max(rgb.shape[:2]) > WORK_SIDE:
        rgb = _reduce(rgb, max(rgb.shape[:2]) / WORK_SIDE)
    field = to_field(rgb, channel)
    if float(np.std(field)) < BLANK or float(np.ptp(rgb)) < 2.0 / 255.0:
        raise MorphogenError(f"the picture is blank in channel {channel!r}: no pattern to match")
    return Picture(field=np.clip(field, 0.0, 1.0).astype(np.float32),
                   rgb=np.clip(rgb, 0.0, 1.0).astype(np.float32),
                   scale=float(side / max(rgb.shape[:2])), source=source)
