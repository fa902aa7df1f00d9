"""Ink maps of the synthetic example textures (:func:`morphogen.learn.textures.synthetic_texture`).

Each function returns ``(ink, background, colour)``: an ink coverage ``(size, size)`` in
``[0, 1]`` and the two RGB colours it blends. Every map is periodic on the ``size`` torus
(lattices that divide ``size``, periodic distances, noise filtered in Fourier space), so a
target tiles seamlessly like the RD state it trains. All lengths scale with ``size``; they are
chosen near the scale seed states (one blob per ``16^2`` cells, :mod:`morphogen.learn.seeds`)
can break symmetry at, the texture scale of seed 002's fig. 2.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def _coords(size: int) -> tuple[np.ndarray, np.ndarray]:
    return np.meshgrid(np.arange(size, dtype=np.float64), np.arange(size, dtype=np.float64),
                       indexing="ij")


def _wrap(d: np.ndarray, size: float) -> np.ndarray:
    """Periodic displacement in ``[-size/2, size/2)``."""
    return (d + size / 2) % size - size / 2


def _soft(signed: np.ndarray, sharpness: float = 2.0) -> np.ndarray:
    """``1`` inside (``signed < 0``), ``0`` outside, a ``tanh`` edge about a cell wide."""
    return 0.5 - 0.5 * np.tanh(sharpness * signed)


def stripes(size: int, seed: int) -> tuple:
    y, x = _coords(size)
    phase = 2.0 * np.pi * (3 * x + 4 * y) / size
    ink = 0.5 + 0.5 * np.tanh(3.0 * np.cos(phase))
    return ink, np.array([0.97, 0.93, 0.8]), np.array([0.1, 0.15, 0.45])


def dots(size: int, seed: int) -> tuple:
    y, x = _coords(size)
    rng = np.random.default_rng(seed)
    spacing, radius = size / 4.0, size / 16.0
    ink = np.zeros((size, size))
    for i in range(4):
        for j in range(4):
            cy, cx = (np.array([i, j]) + 0.5 + rng.uniform(-0.2, 0.2, 2)) * spacing
            r = np.hypot(_wrap(y - cy, size), _wrap(x - cx, size))
            ink = np.maximum(ink, _soft(r - radius))
    return ink, np.array([0.95, 0.95, 0.9]), np.array([0.8, 0.15, 0.1])


def checker(size: int, seed: int) -> tuple:
    y, x = _coords(size)
    k = 2.0 * np.pi * 4 / size
    ink = 0.5 + 0.5 * np.tanh(4.0 * np.sin(k * y) * np.sin(k * x))
    return ink, np.array([0.95, 0.9, 0.78]), np.array([0.3, 0.18, 0.1])


def lined(size: int, seed: int) -> tuple:
    y, x = _coords(size)
    wave = 0.06 * size * np.sin(2.0 * np.pi * 2 * x / size)
    phase = 2.0 * np.pi * 8 * (y + wave) / size
    ink = 0.5 + 0.5 * np.tanh(5.0 * (np.cos(phase) - 0.55))
    return ink, np.array([0.97, 0.97, 0.95]), np.array([0.25, 0.3, 0.45])


def _band_noise(size: int, seed: int, wavenumber: float, width: float) -> np.ndarray:
    """White noise filtered to a Gaussian ring ``|k| ~ wavenumber`` (cycles per ``size``),
    normalised to zero mean and unit variance; periodic."""
    rng = np.random.default_rng(seed)
    k = np.fft.fftfreq(size) * size
    kk = np.hypot(k[:, None], k[None, :])
    ring = np.exp(-((kk - wavenumber) ** 2) / (2.0 * width**2))
    field = np.real(np.fft.ifft2(np.fft.fft2(rng.normal(size=(size, size))) * ring))
    return (field - field.mean()) / field.std()


def blotchy(size: int, seed: int) -> tuple:
    field = _band_noise(size, seed + 1, wavenumber=4.0, width=1.5)
    ink = 0.5 + 0.5 * np.tanh(3.0 * (field - 0.3))
    return ink, np.array([0.93, 0.85, 0.65]), np.array([0.55, 0.3, 0.08])


def labyrinth(size: int, seed: int) -> tuple:
    field = _band_noise(size, seed + 2, wavenumber=5.0, width=0.35)
    ink = 0.5 + 0.5 * np.tanh(3.0 * field)
    return ink, np.array([0.97, 0.93, 0.8]), np.array([0.1, 0.15, 0.45])


def lizards(size: int, seed: int) -> tuple:
    """Each ``size/4`` cell holds one lizard; ``u`` runs along its body (head at ``u > 0``)."""
    y, x = _coords(size)
    cell = size / 4.0
    s = cell / 16.0
    ink = np.zeros((size, size))
    for i in range(4):
        for j in range(4):
            cy, cx = (i + 0.5) * cell, (j + 0.5) * cell
            dy, dx = _wrap(y - cy, size), _wrap(x - cx, size)
            angle = np.pi / 4 + (np.pi / 2) * ((i + j) % 2)
            u = dx * np.cos(angle) + dy * np.sin(angle)
            v = -dx * np.sin(angle) + dy * np.cos(angle)
            body = np.hypot(u / (4.0 * s), v / (2.0 * s)) - 1.0
            head = np.hypot(u - 5.0 * s, v) / (2.0 * s) - 1.0
            tail = np.where((u < -3.0 * s) & (u > -8.0 * s), np.abs(v) / (0.9 * s) - 1.0, 1.0)
            legs = [np.hypot(u - a * s, v - b * s) / (1.1 * s) - 1.0
                    for a in (2.0, -2.0) for b in (2.8, -2.8)]
            shape = np.minimum.reduce([body, head, tail, *legs])
            eye = np.hypot(u - 5.5 * s, v - 0.9 * s) / (0.6 * s) - 1.0
            ink = np.maximum(ink, _soft(shape * 2.0 * s) - 0.8 * _soft(eye * 0.6 * s))
    return np.clip(ink, 0.0, 1.0), np.array([0.98, 0.95, 0.7]), np.array([0.2, 0.6, 0.15])


INK: dict[str, Callable[[int, int], tuple]] = {
    "stripes": stripes, "dots": dots, "checker": checker, "lined": lined,
    "blotchy": blotchy, "lizards": lizards, "labyrinth": labyrinth,
}
"""Ink map makers by texture name."""
