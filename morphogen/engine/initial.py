"""Initial conditions: seeded, reproducible states of shape ``(S, *spatial)``.

Every kind starts from the model's ground state ``g`` (its homogeneous steady state) and, where it
perturbs, moves towards the model's excited values ``e``. Kinds (:data:`INITIAL_KINDS`):

- ``uniform``: exactly ``g`` (no perturbation: a Turing-stable model stays uniform).
- ``noise``: ``g + amplitude * max(|g|, 0.1) * U(-1, 1)`` per cell (uniform with noise).
- ``square``: ``e`` inside a centred square of side ``size`` (fraction of each axis), ``g``
  outside (Richard et al. §IV.4.2 and §5.2.1).
- ``blobs``: ``count`` Gaussian blobs of width ``radius`` (a fraction of the domain, at least
  2.5 cells) or ``sigma`` (cells), or one blob per ``spacing^d`` cells, at random places,
  blending ``g`` to ``e`` (Richard et al. §III.2.1; Mordvintsev et al.'s seed states); on
  meshes a cell is the mean edge length and blobs are spread by area over the surface.
- ``skaggs``: Skaggs eqs. 3.3-3.4 on the unit square centred at the origin (two species):
  ``u0 = 1 - exp(-80((x+0.05)^2 + (y+0.05)^2))``, ``v0 = exp(-80((x-0.05)^2 + (y-0.05)^2))``.
- ``seeds``: ``count`` random cells (or mesh vertices) where ``species`` takes
  ``g + U(0, 1) (e - g)``; elsewhere ``g`` (Ringham et al. §4.9, *Phalaenopsis*: 5 000 seeds
  on about 88 000 vertices, so the default count is 5.7 % of the cells).
- ``random``: every species of every cell drawn independently from ``U(low, high)``, default
  ``[0, 1]`` (Skaggs §3.1: "a random uniform distribution over [0, 1]"; Richard et al.
  §IV.4.1); it ignores ``g`` and ``e``.
- ``image``: a picture's grey level ``I`` in [0, 1] gives ``g + I (e - g)`` (2D grids).
- ``npz``: one array per species, by species name.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.model import INITIAL_NAMES, Model, Params
from morphogen.util.io import check_image

Init = Callable[..., np.ndarray]
MAX_BLOB_WORK = 5e8
"""Largest ``blobs x cells`` a ``blobs`` start may cost (a few seconds of NumPy)."""
INITIAL_KINDS: dict[str, Init] = {}
"""Initial-condition builders by name: ``f(model, domain, g, e, rng, **opts) -> state``."""


def _kind(name: str) -> Callable[[Init], Init]:
    if name not in INITIAL_NAMES:
        raise AssertionError(f"initial condition {name!r} is missing from INITIAL_NAMES")

    def add(fn: Init) -> Init:
        INITIAL_KINDS[name] = fn
        return fn

    return add


def make_initial(
    kind: str, model: Model, domain: Any, params: Params, *, seed: int = 0, **opts: Any
) -> np.ndarray:
    """Build an initial state (float32, shape ``(S, *domain.spatial_shape)``).

    ``kind`` is a name from :data:`INITIAL_KINDS`, or a path to a ``.npz`` file or an image.
    Options are those of the kind (``amplitude``, ``size``, ``count``, ``radius``, ``species``,
    ``path``); unknown options are an error.
    """
    if kind not in INITIAL_KINDS:
        path = Path(kind)
        if path.suffix.lower() == ".npz":
            kind, opts = "npz", {**opts, "path": path}
        elif path.suffix.lower() in (".png", ".jpg", ".jpeg", ".bmp", ".gif", ".tif", ".tiff"):
            kind, opts = "image", {**opts, "path": path}
        else:
            raise MorphogenError(
                f"unknown initial condition {kind!r}; use one of {', '.join(INITIAL_KINDS)} "
                "or a .npz / image file"
            )
    if kind == model.init:
        opts = _with_model_options(model.init_options, opts)
    g = model.ground_state(params)
    e = model.excited_state(params)
    rng = np.random.default_rng(seed)
    try:
        state = INITIAL_KINDS[kind](model, domain, g, e, rng, **opts)
    except MorphogenError:
        raise
    except (TypeError, ValueError, OverflowError) as exc:
        raise MorphogenError(f"bad option for initial condition {kind!r}: {exc}") from None
    return np.ascontiguousarray(state, dtype=np.float32)


_ALTERNATIVES = ({"count", "spacing"}, {"radius", "sigma"})
"""Options that say the same thing two ways: a run's choice of one drops the model's other."""


def _with_model_options(defaults: Any, opts: dict[str, Any]) -> dict[str, Any]:
    """The model's suggested options under the run's own."""
    merged = dict(defaults)
    for group in _ALTERNATIVES:
        if group & opts.keys():
            for key in group:
                merged.pop(key, None)
    return {**merged, **opts}


def _fill(model: Model, domain: Any, values: np.ndarray) -> np.ndarray:
    shape = (len(model.species), *domain.spatial_shape)
    return np.broadcast_to(np.asarray(values, np.float64).reshape(-1, *[1] * len(shape[1:])),
                           shape).copy()


def _blend(g: np.ndarray, e: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """``g + w (e - g)`` for every species; ``weight`` has the spatial shape."""
    view = (-1,) + (1,) * weight.ndim
    return g.reshape(view) + weight[None] * (e - g).reshape(view)


def _positions(domain: Any) -> list[np.ndarray]:
    """Coordinates in [0, 1] of every cell, broadcast to the spatial shape (x first)."""
    names = [n for n in ("x", "y", "z") if n in domain.coords]
    shape = domain.spatial_shape
    return [np.broadcast_to(np.asarray(domain.coords[n], np.float64), shape) for n in names]


@_kind("uniform")
def _uniform(model, domain, g, e, rng):
    return _fill(model, domain, g)


@_kind("noise")
def _noise(model, domain, g, e, rng, amplitude: float = 0.05):
    u = _fill(model, domain, g)
    scale = amplitude * np.maximum(np.abs(g), 0.1).reshape(-1, *[1] * (u.ndim - 1))
    return u + scale * rng.uniform(-1.0, 1.0, u.shape)


@_kind("square")
def _square(model, domain, g, e, rng, size: float = 0.1, amplitude: float = 0.0):
    inside = np.ones(domain.spatial_shape, bool)
    for pos in _positions(domain)[: len(domain.spatial_shape)]:
        inside &= np.abs(pos - 0.5) <= size / 2
    u = _blend(g, e, inside.astype(np.float64))
    return u + amplitude * rng.uniform(-1.0, 1.0, u.shape)


@_kind("blobs")
def _blobs(model, domain, g, e, rng, count: int | None = None, radius: float | None = None,
           spacing: float | None = None, sigma: float | None = None):
    """Gaussian blobs ``max_b exp(-|x - c_b|^2 / (2 s^2))`` blending ``g`` to ``e``.

    On grids lengths are in cells: ``sigma`` (default ``radius · N`` with ``radius = 0.025`` a
    fraction of the smaller side ``N``, at least 2.5 cells), centres uniform, distances periodic.
    On meshes the unit is the mean edge length ``h``: ``sigma`` in edge lengths (default
    ``radius · sqrt(A)``, ``A`` the surface area), centres at vertices drawn by area (uniform over
    the surface), straight-line distances. ``count`` defaults to 12, or with ``spacing`` to one
    blob per ``spacing^d`` cells (per ``(spacing h)^2`` of mesh area): Mordvintsev et al.'s
    sparse seed states (seed 002, fig. 1) are ``spacing = 16``, ``sigma = 2``.
    """
    if count is not None and spacing is not None:
        raise MorphogenError("give the blobs a count or a spacing, not both")
    if radius is not None and sigma is not None:
        raise MorphogenError("give the blobs a radius or a sigma, not both")
    if spacing is not None and not (np.isfinite(spacing) and spacing > 0):
        raise MorphogenError(f"blob spacing must be a positive number of cells, got {spacing}")
    if sigma is not None and not (np.isfinite(sigma) and sigma > 0):
        raise MorphogenError(f"blob sigma must be a positive number of cells, got {sigma}")
    on_mesh = domain.kind == "mesh"
    n_cells = int(np.prod(domain.spatial_shape))
    if spacing is not None:
        count = max(1, round(blob_capacity(domain) / float(spacing) ** (2 if on_mesh else
                                                                       len(domain.spatial_shape))))
    count = 12 if count is None else int(count)
    if not 0 < count <= n_cells:
        raise MorphogenError(f"blob count must be between 1 and the {n_cells} cells, got {count}")
    if count * n_cells > MAX_BLOB_WORK:
        raise MorphogenError(f"{count} blobs on {n_cells} cells is too much work for a start "
                             "state; use fewer blobs (a larger spacing)")
    if on_mesh:
        return _blend(g, e, _mesh_blobs(domain, rng, count, radius, sigma))
    shape = domain.spatial_shape
    pos = _positions(domain)[: max(1, min(3, len(shape)))]
    side = min(shape)
    s = float(sigma) if sigma is not None else max(0.025 if radius is None else float(radius),
                                                   2.5 / side) * side
    lengths = shape[::-1][: len(pos)]  # x runs along the last axis
    weight = np.zeros(shape)
    for _ in range(count):
        centre = rng.uniform(0.0, 1.0, len(pos))
        r2 = sum((_wrap(p - c) * n) ** 2 for p, c, n in zip(pos, centre, lengths, strict=True))
        weight = np.maximum(weight, np.exp(-r2 / (2 * s**2)))
    return _blend(g, e, weight)


def blob_capacity(domain: Any) -> float:
    """The domain's size in cells for blob densities: cells on a grid, ``A / h^2`` on a mesh
    (surface area over the squared mean edge length)."""
    if domain.kind == "mesh":
        return float(np.sum(domain.areas)) / domain.edge_length**2
    return float(np.prod(domain.spatial_shape))


def _mesh_blobs(mesh: Any, rng: np.random.Generator, count: int, radius: float | None,
                sigma: float | None) -> np.ndarray:
    areas = np.asarray(mesh.areas, np.float64)
    if sigma is not None:
        s = float(sigma) * mesh.edge_length
    else:
        s = max(0.025 if radius is None else float(radius), 0.0) * math.sqrt(areas.sum())
        s = max(s, 2.5 * mesh.edge_length)
    centres = rng.choice(len(areas), size=count, p=areas / areas.sum())
    v = np.asarray(mesh.vertices, np.float64)
    weight = np.zeros(len(v))
    for c in centres:
        r2 = np.sum((v - v[c]) ** 2, axis=1)
        weight = np.maximum(weight, np.exp(-r2 / (2 * s**2)))
    return weight


def _wrap(d: np.ndarray) -> np.ndarray:
    """Shortest periodic distance on the unit interval."""
    return d - np.round(d)


@_kind("skaggs")
def _skaggs(model, domain, g, e, rng):
    if len(model.species) != 2:
        raise MorphogenError("the skaggs initial condition (eqs. 3.3-3.4) needs two species")
    x, y = (p - 0.5 for p in _positions(domain)[:2])
    u0 = 1.0 - np.exp(-80.0 * ((x + 0.05) ** 2 + (y + 0.05) ** 2))
    v0 = np.exp(-80.0 * ((x - 0.05) ** 2 + (y - 0.05) ** 2))
    return np.stack([u0, v0])


@_kind("seeds")
def _seeds(model, domain, g, e, rng, count: int | None = None, species: str | None = None):
    u = _fill(model, domain, g)
    n_cells = int(np.prod(domain.spatial_shape))
    count = int(count) if count is not None else max(1, round(0.057 * n_cells))
    if not 0 < count <= n_cells:
        raise MorphogenError(f"seed count must be between 1 and {n_cells}, got {count}")
    i = model.species_index(species or model.display_species)
    flat = u[i].reshape(-1)
    where = rng.choice(n_cells, size=count, replace=False)
    flat[where] = g[i] + rng.uniform(0.0, 1.0, count) * (e[i] - g[i])
    u[i] = flat.reshape(domain.spatial_shape)
    return u


@_kind("random")
def _random(model, domain, g, e, rng, low: float = 0.0, high: float = 1.0):
    low, high = float(low), float(high)
    if not (np.isfinite(low) and np.isfinite(high) and low < high):
        raise MorphogenError(f"random initial condition needs finite low < high, got "
                             f"low={low}, high={high}")
    return rng.uniform(low, high, (len(model.species), *domain.spatial_shape))


@_kind("image")
def _image(model, domain, g, e, rng, path: str | Path = ""):
    import imageio.v3 as iio

    if len(domain.spatial_shape) != 2:
        raise MorphogenError("an image initial condition needs a 2D grid")
    check_image(path, "initial image")  # header and size, before decoding
    try:
        img = np.asarray(iio.imread(path), np.float64)
    except Exception:  # imageio raises many types (and multi-line messages) for bad files
        raise MorphogenError(
            f"cannot read initial image {path}: not a PNG, JPEG, ... that can be decoded"
        ) from None
    if img.ndim == 3:
        img = img[..., :3].mean(axis=-1)
    img = (img - img.min()) / max(float(np.ptp(img)), 1e-12)
    rows = (np.arange(domain.spatial_shape[0]) * img.shape[0]) // domain.spatial_shape[0]
    cols = (np.arange(domain.spatial_shape[1]) * img.shape[1]) // domain.spatial_shape[1]
    return _blend(g, e, img[np.ix_(rows, cols)])


@_kind("npz")
def _npz(model, domain, g, e, rng, path: str | Path = ""):
    return load_state(path, model.species, tuple(domain.spatial_shape))


def load_state(path: str | Path | bytes, species: tuple[str, ...],
               shape: tuple[int, ...], what: str = "state file") -> np.ndarray:
    """A state file (``.npz``, one array per species; a path or its bytes) as float64
    ``(S, *shape)``.

    Read by the one checked reader (:func:`morphogen.util.npz.read_npz`): each species' array
    must announce, in its header, a numeric dtype and exactly ``shape`` before anything is
    allocated for it (a 482-byte file announcing 10¹² elements is refused at once), no pickles,
    and finite values; other members are ignored.
    """
    from morphogen.util.npz import read_npz

    arrays = read_npz(path, what, keys=species, shapes=tuple(shape), finite=True,
                      max_elements=len(species) * math.prod(shape),
                      max_bytes=len(species) * (16 * math.prod(shape) + 4096) + 2**20)
    return np.stack([arrays[s].astype(np.float64) for s in species])
