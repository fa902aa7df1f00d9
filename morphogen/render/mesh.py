"""Coloured triangle meshes to images, headless (no display, no GPU).

Per-vertex colours are averaged onto faces and shaded with a two-sided Lambert term from a
light at the camera, then projected orthographically and drawn with a depth buffer
(:func:`morphogen.render.raster.rasterise`). This is a
preview renderer for checking patterns, in the spirit of Ringham et al. §3.5, not a replacement
for a physically based renderer.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.colors import to_rgb

from morphogen.errors import MorphogenError
from morphogen.render.raster import rasterise

VIEWS: dict[str, tuple[float, float]] = {
    "top": (90.0, -90.0),
    "front": (0.0, -90.0),
    "side": (0.0, 0.0),
    "oblique": (55.0, -60.0),
    "below": (-90.0, -90.0),
}
"""Named viewpoints: (elevation, azimuth) in degrees, matplotlib's convention."""

MARGIN = 8
"""Pixels of background kept around the drawing: the mesh is fitted inside it, and the
picture cropped to it."""


def parse_view(view: str | Sequence[float]) -> tuple[float, float]:
    """A view name from :data:`VIEWS`, ``"ELEV,AZIM"`` or an ``(elev, azim)`` pair."""
    if isinstance(view, str):
        if view in VIEWS:
            return VIEWS[view]
        try:
            elev, azim = (float(v) for v in view.split(","))
        except ValueError:
            raise MorphogenError(
                f"unknown view {view!r}; use {', '.join(VIEWS)} or ELEV,AZIM in degrees"
            ) from None
        return elev, azim
    elev, azim = view
    return float(elev), float(azim)


def _camera(elev: float, azim: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The picture's right and up directions and the direction towards the viewer, for a
    camera at elevation ``elev`` and azimuth ``azim`` (matplotlib's convention: ``top`` looks
    down the z axis with x to the right and y up)."""
    e, a = np.radians(elev), np.radians(azim)
    towards = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    right = np.array([-np.sin(a), np.cos(a), 0.0])
    return right, np.cross(towards, right), towards


def render_mesh(
    vertices: np.ndarray,
    faces: np.ndarray,
    colours: np.ndarray,
    *,
    view: str | Sequence[float] = "oblique",
    size: tuple[int, int] = (800, 800),
    background: str = "white",
    shade: float = 0.6,
) -> np.ndarray:
    """Render a mesh with per-vertex colours.

    Args:
        vertices: ``(V, 3)`` positions.
        faces: ``(F, 3)`` vertex indices.
        colours: ``(V, 3)`` uint8 or float RGB in [0, 1].
        view: a name from :data:`VIEWS` or ``(elevation, azimuth)`` in degrees.
        size: image ``(width, height)`` in pixels.
        shade: strength of the Lambert shading, 0 (flat colours) to 1.

    Returns:
        ``(height, width, 3)`` uint8 RGB.
    """
    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces)
    colours = np.asarray(colours)
    if colours.shape != (len(vertices), 3):
        raise MorphogenError(f"need one RGB colour per vertex, got shape {colours.shape}")
    rgb = colours.astype(np.float64) / (255.0 if colours.dtype == np.uint8 else 1.0)
    right, up, towards = _camera(*parse_view(view))
    tris = vertices[faces]
    normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-30)
    light = np.abs(normals @ towards)
    face_rgb = rgb[faces].mean(axis=1) * ((1.0 - shade) + shade * light)[:, None]
    # orthographic: the mesh's projection fills the picture less a margin, centred
    width, height = size
    screen = np.stack([vertices @ right, -(vertices @ up)], axis=-1)
    lo, hi = screen.min(axis=0), screen.max(axis=0)
    scale = min((width - 2 * MARGIN) / max(hi[0] - lo[0], 1e-12),
                (height - 2 * MARGIN) / max(hi[1] - lo[1], 1e-12))
    pixels = (screen - (lo + hi) / 2) * scale + np.array([width, height]) / 2
    image = rasterise(pixels[faces], (vertices @ towards)[faces], np.clip(face_rgb, 0.0, 1.0),
                      (width, height), np.array(to_rgb(background)))
    return _crop(image, background)


def _crop(image: np.ndarray, background: str, margin: int = MARGIN) -> np.ndarray:
    """Trim uniform background around the drawing, keeping a small margin."""
    bg = np.rint(np.array(to_rgb(background)) * 255).astype(np.uint8)
    mask = np.any(image != bg, axis=2)
    if not mask.any():
        return image
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    r0, r1 = max(rows[0] - margin, 0), min(rows[-1] + margin + 1, image.shape[0])
    c0, c1 = max(cols[0] - margin, 0), min(cols[-1] + margin + 1, image.shape[1])
    return image[r0:r1, c0:c1]


def overlay_veins(
    colours: np.ndarray,
    vein: np.ndarray,
    thickness: np.ndarray | None = None,
    *,
    colour: str = "#1b1340",
) -> np.ndarray:
    """Per-vertex colours with veins drawn over them (Ringham et al. fig. 6): vein vertices
    are mixed towards ``colour`` by ``0.6 + 0.4 t / t_max`` for thickness ``t`` (fully
    where the veins are thickest).

    Args:
        colours: ``(V, 3)`` uint8 or float RGB in [0, 1].
        vein: ``(V,)`` vein mask (1 on veins).
        thickness: optional ``(V,)`` vein radius.

    Returns:
        ``(V, 3)`` uint8 RGB.
    """
    colours = np.asarray(colours)
    rgb = colours.astype(np.float64) / (255.0 if colours.dtype == np.uint8 else 1.0)
    mask = np.clip(np.asarray(vein, np.float64), 0.0, 1.0)
    if mask.shape != (len(rgb),):
        raise MorphogenError(f"vein mask has shape {mask.shape}, expected ({len(rgb)},)")
    weight = mask * 0.6
    if thickness is not None and np.max(thickness) > 0:
        weight = mask * (0.6 + 0.4 * np.asarray(thickness) / np.max(thickness))
    out = rgb * (1 - weight[:, None]) + np.array(to_rgb(colour))[None] * weight[:, None]
    return np.rint(np.clip(out, 0.0, 1.0) * 255).astype(np.uint8)
