"""Recording the Explore view: the frames shown while recording, as an animated GIF or an MP4.

A :class:`Recorder` keeps the ``uint8`` pictures the live simulation sends to the page (the
shown species quantised on the colour scale of its frame, :mod:`morphogen.web.live`), at most
:data:`MAX_FRAMES` of them (the oldest go first), and encodes them through a colour map's
256-entry lookup table with :mod:`imageio` (GIF through Pillow, MP4 through ffmpeg/libx264).
Each picture is ``h * w`` bytes, so a full recording of 512² frames holds 75 MiB.
"""

from __future__ import annotations

import threading
from collections import deque
from typing import Any

import imageio.v3 as iio
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.render.colour import parse_cmap
from morphogen.util.extras import require

MAX_FRAMES = 300
"""Frames kept by one recording (about 15 s at 20 frames/s)."""
FORMATS = {"gif": "image/gif", "mp4": "video/mp4"}
"""Download formats and their media types."""


class Recorder:
    """The frames of one tab's recording (thread-safe: frames arrive from the frame loop)."""

    def __init__(self, max_frames: int = MAX_FRAMES):
        self.on = False
        self.frames: deque[np.ndarray] = deque(maxlen=max_frames)
        self.lock = threading.Lock()

    def start(self) -> None:
        """Forget earlier frames and record from the next one."""
        with self.lock:
            self.frames.clear()
            self.on = True

    def stop(self) -> None:
        with self.lock:
            self.on = False

    def add(self, pixels: np.ndarray) -> None:
        """Keep one picture ``(h, w)`` uint8 while recording (a copy: the caller's may change)."""
        if self.on:
            with self.lock:
                self.frames.append(np.array(pixels, np.uint8))

    def describe(self) -> dict[str, Any]:
        return {"on": self.on, "frames": len(self.frames), "max_frames": self.frames.maxlen}

    def encode(self, fmt: str, cmap: str, fps: int = 20, every: int = 1) -> bytes:
        """The recorded frames as ``fmt`` (``gif`` or ``mp4``) bytes through colour map ``cmap``,
        at ``fps`` frames a second, each side reduced ``every`` times (every ``every``-th cell:
        2 makes a GIF about a quarter of the size).

        MP4 (H.264, yuv420p) needs even sides: odd ones are padded by one row or column
        repeating the edge.
        """
        if fmt not in FORMATS:
            raise MorphogenError(f"recording format must be one of {', '.join(FORMATS)}")
        with self.lock:
            frames = list(self.frames)
        if not frames:
            raise MorphogenError("nothing recorded yet: press Record, let it run, then download")
        shapes = {f.shape for f in frames}
        if len(shapes) > 1:
            raise MorphogenError("the grid changed while recording; record again")
        lut = colour_table(cmap)
        video = lut[np.stack(frames)[:, ::every, ::every]]  # (T, h, w, 3) uint8
        if fmt == "gif":
            return iio.imwrite("<bytes>", video, extension=".gif", duration=1000 / fps, loop=0)
        h, w = video.shape[1:3]
        video = np.pad(video, ((0, 0), (0, h % 2), (0, w % 2), (0, 0)), mode="edge")
        return _ffmpeg_mp4(video, fps)


def colour_table(cmap: str) -> np.ndarray:
    """A colour map as a ``(256, 3)`` uint8 lookup table (the page's table, too)."""
    cm = parse_cmap(cmap)
    return np.rint(np.asarray(cm(np.linspace(0.0, 1.0, 256)))[:, :3] * 255).astype(np.uint8)


def _ffmpeg_mp4(video: np.ndarray, fps: int) -> bytes:
    """MP4 bytes through the ffmpeg binary of ``imageio-ffmpeg`` (written to a temporary file:
    the MP4 container needs to seek).

    ffmpeg is started by :func:`subprocess.run` without a Python ``preexec_fn`` (imageio-ffmpeg's
    own writer passes ``os.setpgrp``, which makes the child run Python between fork and exec: in
    this multithreaded JAX process that can deadlock, and JAX warns about ``os.fork()``);
    ``start_new_session`` gives the same protection from Ctrl-C without it."""
    import subprocess
    import tempfile
    from pathlib import Path

    imageio_ffmpeg = require("imageio_ffmpeg", "video", "recording a video")

    h, w = video.shape[1:3]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "recording.mp4"
        cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error",
               "-f", "rawvideo", "-vcodec", "rawvideo", "-s", f"{w}x{h}", "-pix_fmt", "rgb24",
               "-r", str(fps), "-i", "-", "-an", "-vcodec", "libx264", "-pix_fmt", "yuv420p",
               "-r", str(fps), str(path)]
        done = subprocess.run(cmd, input=np.ascontiguousarray(video, np.uint8).tobytes(),
                              capture_output=True, start_new_session=True, timeout=300,
                              check=False)
        if done.returncode != 0:
            raise MorphogenError("ffmpeg could not write the MP4: "
                                 + done.stderr.decode(errors="replace").strip()[-200:])
        return path.read_bytes()
