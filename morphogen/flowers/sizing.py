"""A named flower shape at a given edge length in final mesh units, refused before meshing when
it would be absurdly large.

``mesh make`` and a pipeline's ``[mesh]`` table both describe a shape by its generator
arguments, an ``edge`` and a uniform ``scale``; both mean by ``edge`` the mean edge length of
the final, scaled mesh (Ringham et al. §3.2 give mesh sizes as triangle counts of the final
flower). The generator therefore runs at ``edge / scale`` and its vertices are multiplied by
``scale``.

Before meshing, the vertex count is estimated from the area ``A`` of the same shape meshed
coarsely (at scale 1): a near-equilateral mesh of edge ``e`` has faces of area
``sqrt(3)/4 e^2`` and about half as many vertices as faces, so

.. math:: V \\approx \\frac{2 A}{\\sqrt 3\\, e^2}

(interior vertices have six neighbours; the boundary adds a few per cent). Requests over
:data:`~morphogen.flowers.meshing.MAX_VERTICES` are refused with the estimate.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError
from morphogen.flowers import organs, shapes
from morphogen.flowers.meshing import MAX_VERTICES

_COARSE = (0.03, 0.01)
"""Edges (scale 1) tried for the area estimate, coarsest first: a shape may refuse an edge that
is too coarse for its smallest part."""


def _generator(shape: str):
    if shape not in shapes.SHAPES:
        raise MorphogenError(f"unknown shape {shape!r}; use one of {', '.join(shapes.SHAPES)}")
    return getattr(organs if hasattr(organs, shape) else shapes, shape)


def _call(shape: str, edge: float, options: dict[str, Any]) -> Mesh:
    try:
        return _generator(shape)(edge=edge, **options)
    except TypeError as exc:
        raise MorphogenError(f"{shape}: {exc}") from None


def estimate_vertices(shape: str, edge: float, **options: Any) -> int:
    """About how many vertices ``shape`` has at mean edge ``edge`` (scale 1), from the area of a
    coarse mesh of the same shape; exact (the coarse mesh itself) when ``edge`` is coarse."""
    if edge >= _COARSE[0]:
        return _call(shape, edge, options).n_vertices
    for coarse in _COARSE:
        try:
            area = float(_call(shape, coarse, options).areas.sum())
            break
        except MorphogenError:
            if coarse == _COARSE[-1]:
                raise
    with np.errstate(over="ignore", divide="ignore"):
        estimate = 2.0 * area / (np.sqrt(3.0) * float(edge) ** 2)
    return int(round(min(estimate, 1e18)))  # an edge whose square underflows: far over any limit


def make_shape(shape: str, *, edge: float, scale: float = 1.0, **options: Any) -> Mesh:
    """The generator ``shape`` of :mod:`morphogen.flowers` with mean edge ``edge`` after a
    uniform ``scale``; the estimated vertex count must not exceed ``MAX_VERTICES``.

    Raises:
        MorphogenError: unknown shape or option, a non-positive ``edge`` or ``scale``, or a
            request whose estimate is over the limit (the message gives the estimate and the
            smallest edge that fits).
    """
    for label, value in (("edge", edge), ("scale", scale)):
        if isinstance(value, bool) or not isinstance(value, int | float) or not (
                np.isfinite(value) and value > 0):
            raise MorphogenError(f"{label} must be a positive number, got {value!r}")
    for label, value in options.items():
        _check_finite(label, value)
    # rounded to 12 digits, so that e.g. edge 0.6 at scale 24 meshes exactly as 0.025 at scale 1
    local = float(f"{float(edge) / float(scale):.12g}")
    if local < 1e-9:
        raise MorphogenError(
            f"edge {edge:g} at scale {scale:g} is an edge of {local:.3g} on the {shape} at its own "
            "size, far too fine to mesh; raise edge or lower scale")
    count = estimate_vertices(shape, local, **options)
    if count > MAX_VERTICES:
        smallest = float(edge) * np.sqrt(count / MAX_VERTICES)
        raise MorphogenError(
            f"{shape} with edge {edge:g} (mesh units after scale {scale:g}) would have about "
            f"{count:,} vertices, over the limit of {MAX_VERTICES:,}; use edge >= {smallest:.3g}")
    mesh = _call(shape, local, options)
    if scale != 1.0:
        with np.errstate(over="ignore"):
            vertices = mesh.vertices * float(scale)
        if not np.all(np.abs(vertices) <= MAX_COORDINATE):
            raise MorphogenError(
                f"scale {scale:g} puts the {shape}'s vertices beyond {MAX_COORDINATE:g} mesh "
                "units, more than a PLY file's 32-bit numbers hold safely; use a smaller scale")
        mesh = mesh.replace(vertices=vertices)
    return mesh


MAX_COORDINATE = 1e30
"""Largest vertex coordinate a scaled shape may have (a PLY file stores 32-bit floats, which end
at 3.4e38; areas, squared lengths and the diffusion operators need room below that)."""


def _check_finite(label: str, value: Any) -> None:
    """Refuse a generator option that is, or holds, a NaN or infinite number (it gave a
    traceback deep inside the meshing)."""
    if isinstance(value, list | tuple):
        for item in value:
            _check_finite(label, item)
    elif isinstance(value, float) and not np.isfinite(value):
        raise MorphogenError(f"{label} must be a finite number, got {value!r}")
