"""Animations of snapshots: GIF (Pillow through imageio) and MP4 (ffmpeg through imageio).

Frames are ``uint8`` RGB arrays of shape ``(F, H, W, 3)``. To turn ``F`` scalar snapshots
``(F, H, W)`` into frames on one common colour scale, call :func:`morphogen.render.colourise`
on the whole stack. (Richard et al. §3.2, seed 001, assemble a GIF of a growing pattern from
saved PNGs with ImageMagick; here it is one call.) Both writers are atomic: the animation goes
to a temporary file in the target directory and is renamed into place only when complete.
"""

from __future__ import annotations

from pathlib import Path

import imageio.v2 as iio2
import imageio.v3 as iio
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.util.extras import require
from morphogen.util.io import atomic_path, ensure_writable_dir, write_atomic

ANIMATION_FORMATS = (".gif", ".mp4")
"""File extensions :func:`write_animation` understands."""


def _check_frames(frames: np.ndarray) -> np.ndarray:
    frames = np.asarray(frames)
    if frames.dtype != np.uint8 or frames.ndim != 4 or frames.shape[-1] != 3:
        raise MorphogenError(
            f"frames must be uint8 of shape (F, H, W, 3), got {frames.dtype} {frames.shape}"
        )
    if 0 in frames.shape:
        raise MorphogenError(f"no frames to write: shape {frames.shape}")
    return frames


def _check_fps(fps: float) -> float:
    if not (isinstance(fps, int | float) and np.isfinite(fps) and fps > 0):
        raise MorphogenError(f"frames per second must be a positive number, got {fps!r}")
    return float(fps)


def write_gif(path: str | Path, frames: np.ndarray, fps: float = 10, *, loop: int = 0) -> Path:
    """Write frames ``(F, H, W, 3)`` uint8 as an animated GIF, atomically.

    Each frame is shown for ``1000 / fps`` milliseconds; ``loop=0`` repeats forever. GIF holds
    at most 256 colours per frame (Pillow quantises each frame), and Pillow merges consecutive
    identical frames into one longer frame.
    """
    frames = _check_frames(frames)
    fps = _check_fps(fps)
    path = Path(path)
    ensure_writable_dir(path.parent)
    data = iio.imwrite(
        "<bytes>", frames, extension=".gif", duration=1000.0 / fps, loop=loop
    )
    return write_atomic(path, lambda fh: fh.write(data))


def pad_even(frames: np.ndarray) -> np.ndarray:
    """Pad ``(F, H, W, 3)`` by one edge row / column where ``H`` / ``W`` is odd.

    H.264 with 4:2:0 chroma needs even dimensions.
    """
    h, w = frames.shape[1:3]
    return np.pad(frames, ((0, 0), (0, h % 2), (0, w % 2), (0, 0)), mode="edge")


def _ffmpeg() -> str:
    imageio_ffmpeg = require("imageio_ffmpeg", "video", "MP4 output (or write a .gif)")
    try:
        return imageio_ffmpeg.get_ffmpeg_exe()
    except RuntimeError:
        raise MorphogenError("MP4 output needs ffmpeg, which imageio-ffmpeg could not find; "
                             "write a .gif instead") from None


def write_mp4(
    path: str | Path, frames: np.ndarray, fps: float = 10, *, quality: float = 8.0
) -> Path:
    """Write frames ``(F, H, W, 3)`` uint8 as an H.264 MP4 (yuv420p), atomically.

    Odd heights or widths are padded by one replicated edge row / column (:func:`pad_even`).
    ``quality`` is imageio-ffmpeg's 0–10 scale (10 best).
    """
    frames = pad_even(_check_frames(frames))
    fps = _check_fps(fps)
    _ffmpeg()
    path = Path(path)
    ensure_writable_dir(path.parent)
    with atomic_path(path, suffix=".mp4") as tmp, iio2.get_writer(
        tmp,
        format="FFMPEG",
        mode="I",
        fps=fps,
        codec="libx264",
        pixelformat="yuv420p",
        quality=quality,
        macro_block_size=1,
        ffmpeg_log_level="error",
    ) as writer:
        for frame in frames:
            writer.append_data(frame)
    return path


def write_animation(path: str | Path, frames: np.ndarray, fps: float = 10) -> Path:
    """Write frames ``(F, H, W, 3)`` uint8 as ``.gif`` or ``.mp4``, chosen by the extension."""
    suffix = Path(path).suffix.lower()
    if suffix == ".gif":
        return write_gif(path, frames, fps)
    if suffix == ".mp4":
        return write_mp4(path, frames, fps)
    raise MorphogenError(
        f"cannot write an animation to {str(path)!r}: use a .gif or .mp4 file name"
    )
