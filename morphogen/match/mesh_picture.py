"""A mesh as a picture: one vertex field of a PLY file, flattened onto its best-fit plane.

``morphogen match final.ply`` matches the pattern a mesh run or a flower pipeline left on a
surface (Ringham et al. 2021, §3.1: PLY in, coloured PLY out). The signature
(:mod:`morphogen.match.signature`) reads square pixels, so the mesh is first seen from above:

1. **the plane**: with ``c`` the mean of the vertex positions ``x_i`` and
   ``X - c = U Σ Vᵀ`` (principal component analysis), the first two right singular vectors
   ``e₁, e₂`` span the best-fit plane and ``n = e₁ × e₂`` is its normal, signed so that most of
   the surface's projected area is counter-clockwise seen from ``+n`` (the side its faces face).
   Each vertex gets plane coordinates ``(u, v) = ((x - c)·e₁, (x - c)·e₂)`` and a depth
   ``w = (x - c)·n``. A flat mesh keeps its lengths exactly, whatever its position and tilt in
   space; a curved petal is foreshortened by the cosine of its tilt from the plane.
2. **the pixels**: square, of side ``h = max(Δu, Δv) / (WORK_SIDE - 2 MARGIN)`` mesh units
   (:data:`~morphogen.match.picture.WORK_SIDE` on the longer side), kept as
   :attr:`~morphogen.match.picture.Picture.pixel_size` so wavelengths are quoted in mesh units.
3. **the values**: at each pixel centre ``p`` inside a projected triangle ``(a, b, c)`` the
   field is interpolated linearly, ``f(p) = λ_a f_a + λ_b f_b + λ_c f_c`` with the barycentric
   coordinates ``λ`` of ``p`` (the same linear elements the mesh operators use). Where several
   triangles cover a pixel (a curled petal, one organ in front of another) the one nearest the
   viewer at ``+n`` (largest interpolated ``w``) is kept, a depth buffer; matplotlib's
   ``LinearTriInterpolator`` would do the interpolation but its triangle finder refuses
   overlapping triangles, which multi-organ flowers have.
4. **the mask**: pixels no triangle covers are outside the picture's mask, and so are those
   whose visible triangle is seen at a grazing angle, its projected area below
   :data:`MIN_COSINE` of its area (a tube's wall seen from its mouth: its pattern would come out
   squeezed); the signature never sees them.

Which field (``field``): a vertex property by name; ``"colours"`` for the vertex colours, reduced
like a picture's through ``channel`` (:func:`morphogen.match.picture.to_field`); by default the
first species (the fields of the last ``simulate`` stage in a ``pipeline.json`` beside the file,
or the arrays of a ``state.npz`` beside it, in the file's order), else the colours, else the
first field; a ``channel`` other than ``auto`` without a ``field`` reads the colours.

Bad input is one :class:`~morphogen.errors.MorphogenError` line: a file that is not PLY, a PLY
without faces or without the field, a mesh that flattens to a line or to too few pixels, a
constant or blank field.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.match.picture import BLANK, MIN_SIDE, WORK_SIDE, Picture, to_field

MESH_SUFFIXES = (".ply",)
"""File endings read as a mesh target rather than a picture."""

COLOURS = "colours"
"""The ``field`` that names the vertex colours (read through ``channel``)."""

MARGIN = 2
"""Empty pixels around the flattened mesh."""

MIN_COSINE = 0.5
"""Pixels whose triangle is tilted by more than 60 degrees from the plane are left out."""

CHUNK = 1 << 20
"""Pixel-triangle pairs tested at once (bounds the rasteriser's memory to some 100 MB)."""


def is_mesh_target(image: object) -> bool:
    """Whether ``image`` names a mesh file (by its ending) rather than a picture."""
    return isinstance(image, str | Path) and Path(image).suffix.lower() in MESH_SUFFIXES


def load_mesh_picture(path: str | Path, *, field: str | None = None,
                      channel: str = "auto") -> Picture:
    """Read a PLY mesh and flatten one vertex field into a masked :class:`Picture` (module
    docstring), ``pixel_size`` in mesh units."""
    from morphogen.domains.mesh_geometry import face_normals
    from morphogen.domains.ply import load_mesh

    path = Path(path)
    mesh = load_mesh(path)
    name, grey, rgb = vertex_values(mesh.fields, path, field, channel)
    uv, depth = flatten(mesh.vertices, mesh.faces)
    pixel = float(np.ptp(uv, axis=0).max()) / (WORK_SIDE - 2 * MARGIN)
    channels = grey[:, None] if rgb is None else np.column_stack([grey, rgb])
    image, face = rasterise(uv, depth, mesh.faces, channels, pixel)
    # twice each triangle's area, as _signed_areas projected
    area = np.linalg.norm(face_normals(mesh.vertices, mesh.faces), axis=1)
    steep = np.abs(_signed_areas(uv, mesh.faces)) < MIN_COSINE * area
    mask = (face >= 0) & ~steep[np.maximum(face, 0)]
    h, w = mask.shape
    if min(h, w) < MIN_SIDE or mask.sum() < MIN_SIDE**2:
        raise MorphogenError(f"{path} flattens to {w}x{h} pixels, {int(mask.sum())} of them on "
                             f"the mesh seen at under 60 degrees: too few to describe (at least "
                             f"{MIN_SIDE} a side and {MIN_SIDE**2} on the mesh)")
    inside = image[..., 0][mask]
    if float(np.std(inside)) < BLANK:
        raise MorphogenError(f"field {name!r} of {path} is blank where the mesh is seen: no "
                             "pattern to match")
    shown = np.repeat(image[..., :1], 3, axis=-1) if rgb is None else image[..., 1:]
    note = (f"field {name} flattened onto its best-fit plane: {w}x{h} pixels of {pixel:.4g} "
            "mesh units")
    if steep.any():
        note += (f"; {np.sum(area[steep]) / np.sum(area):.0%} of the surface, tilted over 60 "
                 "degrees from the plane, left out")
    return Picture(field=np.where(mask, image[..., 0], np.median(inside)).astype(np.float32),
                   rgb=np.clip(np.where(mask[..., None], shown, 1.0), 0.0, 1.0).astype(np.float32),
                   scale=1.0, source=str(path), mask=mask, pixel_size=pixel, note=note)


def vertex_values(fields: dict[str, np.ndarray], path: Path, field: str | None,
                  channel: str) -> tuple[str, np.ndarray, np.ndarray | None]:
    """The field matched (module docstring): its name, its values rescaled to ``[0, 1]``
    ``(V,)``, and the vertex colours ``(V, 3)`` in ``[0, 1]`` when it is read from them (to
    show on the answer sheet), else ``None``."""
    from morphogen.domains.ply import COLOUR_CHANNELS

    colours = all(c in fields for c in COLOUR_CHANNELS[:3])
    if field is None and channel != "auto" and colours:
        field = COLOURS  # a channel is asked for: it reads the colours
    name = field or default_field(path, list(fields), colours)
    rgb = None
    if name == COLOURS and colours:
        rgb = np.stack([fields[c] for c in COLOUR_CHANNELS[:3]], axis=1)
        values = to_field(rgb[:, None, :].astype(np.float32), channel)[:, 0].astype(np.float64)
    elif name in fields:
        if channel != "auto":
            raise MorphogenError(f"--channel reads colours (a picture, or --field {COLOURS}), "
                                 f"not the field {name!r}")
        values = np.asarray(fields[name], np.float64)
    else:
        have = [n for n in fields if not (colours and n in COLOUR_CHANNELS)]
        have += [COLOURS] if colours else []
        raise MorphogenError(f"{path} has no vertex field {name!r}; it has "
                             f"{', '.join(have) if have else 'no fields'}")
    span = float(np.ptp(values))
    if span <= 1e-12 * max(1.0, float(np.max(np.abs(values)))):
        raise MorphogenError(f"field {name!r} of {path} is constant: no pattern to match")
    return name, (values - values.min()) / span, rgb


def default_field(path: Path, names: list[str], colours: bool) -> str:
    """The field matched when none is named: the first species, else the colours, else the
    first field (module docstring)."""
    from morphogen.domains.ply import COLOUR_CHANNELS

    species = set(species_beside(path))
    for name in names:
        if name in species:
            return name
    if colours:
        return COLOURS
    scalars = [n for n in names if n not in COLOUR_CHANNELS]
    if not scalars:
        raise MorphogenError(f"{path} has no vertex field to match (only x, y, z)")
    return scalars[0]


def species_beside(path: Path) -> list[str]:
    """Species names the files beside a PLY give: the fields of the last ``simulate`` stage of
    ``pipeline.json`` (a pipeline's ``final.ply``), else the arrays of ``state.npz`` (a mesh
    run's PLY); empty when neither can be read."""
    try:
        record = json.loads((path.parent / "pipeline.json").read_text())
    except (OSError, ValueError):
        record = None
    stages = record.get("stages") if isinstance(record, dict) else None
    runs = [s for s in stages if isinstance(s, dict) and s.get("kind") == "simulate"] \
        if isinstance(stages, list) else []
    if runs and isinstance(runs[-1].get("fields"), list):
        return [str(n) for n in runs[-1]["fields"]]
    from morphogen.util.npz import npz_members

    try:  # the headers only, through the one checked reader
        return list(npz_members(path.parent / "state.npz", "mesh run state"))
    except MorphogenError:
        return []


def flatten(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plane coordinates ``(V, 2)`` and depths ``(V,)`` of ``vertices`` ``(V, 3)`` on their
    best-fit plane (module docstring, item 1)."""
    x = np.asarray(vertices, np.float64)
    centred = x - x.mean(axis=0)
    _, sigma, axes = np.linalg.svd(centred, full_matrices=False)
    if sigma[1] <= 1e-9 * max(sigma[0], 1e-300):
        raise MorphogenError("the mesh lies on a line: it has no plane to be seen on")
    e1, e2 = axes[0], axes[1]
    uv = centred @ np.stack([e1, e2], axis=1)
    if np.sum(_signed_areas(uv, faces)) < 0.0:
        e2 = -e2
        uv[:, 1] = -uv[:, 1]
    return uv, centred @ np.cross(e1, e2)


def _signed_areas(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Twice the signed area of each projected triangle, ``(F,)``."""
    a, b, c = uv[faces[:, 0]], uv[faces[:, 1]], uv[faces[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def rasterise(uv: np.ndarray, depth: np.ndarray, faces: np.ndarray, values: np.ndarray,
              pixel: float) -> tuple[np.ndarray, np.ndarray]:
    """Linear interpolation of per-vertex ``values`` ``(V, C)`` over the triangles ``faces``
    ``(F, 3)`` at plane coordinates ``uv`` ``(V, 2)``, on square pixels of side ``pixel``,
    nearest (largest ``depth``) triangle first (module docstring, items 2-3).

    Returns ``(image (H, W, C) float64, face (H, W) int)``: ``face`` the triangle seen at each
    pixel, -1 where none is (``image`` is 0 there). The ``v`` axis points up the picture (row 0
    is the largest ``v``).
    """
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    w, h = (np.ceil((hi - lo) / pixel - 1e-9).astype(int) + 2 * MARGIN).tolist()
    # vertex positions in pixel units: the centre of pixel (row i, column j) is (j, i)
    px = np.column_stack([(uv[:, 0] - lo[0]) / pixel + MARGIN - 0.5,
                          (hi[1] - uv[:, 1]) / pixel + MARGIN - 0.5])
    tri = px[faces]
    det = _signed_areas(px, faces)
    live = np.abs(det) > 1e-12 * max(float(np.abs(det).max()), 1e-300)  # edge-on: no pixels
    first = np.clip(np.ceil(tri.min(axis=1)), 0, [w - 1, h - 1]).astype(np.int64)
    last = np.clip(np.floor(tri.max(axis=1)), -1, [w - 1, h - 1]).astype(np.int64)
    size = np.maximum(last - first + 1, 0)
    count = np.where(live, size[:, 0] * size[:, 1], 0)
    image = np.zeros((h * w, values.shape[1]))
    nearest = np.full(h * w, -np.inf)
    face = np.full(h * w, -1)
    ends = np.cumsum(count)
    start = 0
    while start < len(faces):
        stop = max(int(np.searchsorted(ends, ends[start] - count[start] + CHUNK, "right")),
                   start + 1)
        _scan(slice(start, stop), count, first, size, tri, det, faces, depth, values, w,
              image, nearest, face)
        start = stop
    return image.reshape(h, w, -1), face.reshape(h, w)


def _scan(part: slice, count: np.ndarray, first: np.ndarray, size: np.ndarray, tri: np.ndarray,
          det: np.ndarray, faces: np.ndarray, depth: np.ndarray, values: np.ndarray, w: int,
          image: np.ndarray, nearest: np.ndarray, face: np.ndarray) -> None:
    """Test the pixels of the bounding boxes of the triangles ``part`` and keep, per pixel, the
    nearest covering triangle and its interpolated values (updates ``image``, ``nearest`` and
    ``face``)."""
    n = count[part]
    if not n.sum():
        return
    t = np.repeat(np.arange(part.start, part.stop), n)
    k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    col = first[t, 0] + k % size[t, 0]
    row = first[t, 1] + k // size[t, 0]
    a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
    dx, dy = col - a[:, 0], row - a[:, 1]
    lb = (dx * (c[:, 1] - a[:, 1]) - dy * (c[:, 0] - a[:, 0])) / det[t]
    lc = ((b[:, 0] - a[:, 0]) * dy - (b[:, 1] - a[:, 1]) * dx) / det[t]
    weights = np.stack([1.0 - lb - lc, lb, lc], axis=1)
    inside = np.all(weights >= -1e-9, axis=1)
    t, weights = t[inside], weights[inside]
    pix = (row * w + col)[inside]
    z = np.einsum("pk,pk->p", weights, depth[faces[t]])
    order = np.lexsort((z, pix))  # by pixel, nearest last
    pix, z, t, weights = pix[order], z[order], t[order], weights[order]
    top = np.append(pix[1:] != pix[:-1], True)
    pix, z, t, weights = pix[top], z[top], t[top], weights[top]
    closer = z > nearest[pix]
    pix, t, weights = pix[closer], t[closer], weights[closer]
    nearest[pix] = z[closer]
    face[pix] = t
    image[pix] = np.einsum("pk,pkc->pc", weights, values[faces[t]])
