"""Transfer functions from morphogen concentrations to colours.

A *transfer function* maps a scalar field to RGB. Three kinds are provided:

- :func:`colourise` — a continuous colour map: any matplotlib colormap name, or a user colour
  ramp written as text (``"#000000,#ff8800,#ffffff"`` or ``"0:#000,0.3:#f80,1:#fff"``).
  Values are normalised linearly, ``t = clip((f - vmin) / (vmax - vmin), 0, 1)``.
- :func:`threshold_map` — two colours split at one level, the altered colouring of
  Skaggs fig. 4.7 (seed 000, §4.2: "each cell is either purple or white depending on its value
  crossing some threshold").
- :func:`step_map` — piecewise-constant colours between given levels, the "step transfer
  function mapping morphogen values to pigment colors" of Ringham et al. §4.3 (*Primula*) and
  the user-defined colour maps of their §3.5.

Colour-map strings starting with ``step:`` or ``ramp:`` are transfer functions at absolute
values (:mod:`morphogen.render.transfer`), accepted by :func:`colourise` and so by every
``cmap`` of pipelines and the command line.

All functions take NumPy arrays of any shape ``(...)`` (a 2D grid ``(H, W)``, a 3D grid
``(D, H, W)``, a stack of snapshots ``(F, H, W)`` or per-vertex values ``(V,)``) and return
``uint8`` RGB of shape ``(..., 3)``. Non-finite values (NaN, ±Inf — a blown-up simulation) are
drawn in a flag colour, magenta by default, and never enter the automatic colour scale.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import matplotlib
import numpy as np
from matplotlib.colors import Colormap, LinearSegmentedColormap, to_rgb

from morphogen.errors import MorphogenError
from morphogen.render.transfer import is_transfer, parse_transfer

NAN_COLOUR = "#ff00ff"
"""Default colour for NaN and ±Inf cells: magenta, absent from the usual colour maps."""

_LIST_HINT = (
    "list valid names with morphogen.render.colormap_names() "
    "(or python -c \"import matplotlib; print(sorted(matplotlib.colormaps))\"), "
    "or give a colour ramp such as '#000000,#ff8800,#ffffff'"
)


@dataclass(frozen=True)
class Ramp:
    """A piecewise-linear colour ramp through exact colour stops.

    Attributes:
        positions: ``(K,)`` strictly increasing stop positions, first 0 and last 1.
        colours: ``(K, 3)`` RGB in [0, 1] at each stop.
    """

    positions: np.ndarray
    colours: np.ndarray

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Colours at normalised values ``t`` ``(...)`` in [0, 1] -> ``(..., 3)`` floats."""
        return np.stack(
            [np.interp(t, self.positions, self.colours[:, c]) for c in range(3)], axis=-1
        )

    def to_colormap(self, name: str = "ramp", n: int = 256) -> Colormap:
        """The same ramp as a matplotlib colormap with an ``n``-entry lookup table."""
        return LinearSegmentedColormap.from_list(
            name, list(zip(self.positions.tolist(), self.colours.tolist(), strict=True)), N=n
        )


def colormap_names() -> list[str]:
    """Names accepted as ``cmap``: every colormap registered with matplotlib, sorted."""
    return sorted(matplotlib.colormaps)


def parse_colour(colour: str | Sequence[float]) -> np.ndarray:
    """One colour (``"#f80"``, ``"#ff8800"``, ``"white"``, or RGB floats) -> ``(3,)`` in [0, 1]."""
    try:
        return np.asarray(to_rgb(colour), dtype=np.float64)
    except (ValueError, TypeError):
        raise MorphogenError(
            f"invalid colour {colour!r}: use a hex code like '#ff8800' or '#f80', "
            "or a named colour like 'white'"
        ) from None


def parse_ramp(spec: str) -> Ramp:
    """Parse a user colour ramp.

    Two forms: ``"c0,c1,...,cK"`` (stops evenly spaced over [0, 1]) and
    ``"p0:c0,p1:c1,...,pK:cK"`` (explicit positions, strictly increasing from 0 to 1).
    Each ``c`` is anything :func:`parse_colour` accepts.
    """
    parts = [p.strip() for p in spec.split(",")]
    if len(parts) < 2 or any(not p for p in parts):
        raise MorphogenError(
            f"invalid colour ramp {spec!r}: give two or more comma-separated colours, "
            "e.g. '#000000,#ff8800,#ffffff' or '0:#000,0.3:#f80,1:#fff'"
        )
    explicit = [":" in p for p in parts]
    if any(explicit) and not all(explicit):
        raise MorphogenError(
            f"invalid colour ramp {spec!r}: give a position for every stop or for none"
        )
    if all(explicit):
        positions = []
        colours = []
        for part in parts:
            pos, _, col = part.partition(":")
            try:
                positions.append(float(pos))
            except ValueError:
                raise MorphogenError(
                    f"invalid colour ramp {spec!r}: stop position {pos!r} is not a number"
                ) from None
            colours.append(parse_colour(col.strip()))
        pos_arr = np.asarray(positions)
        if pos_arr[0] != 0.0 or pos_arr[-1] != 1.0 or np.any(np.diff(pos_arr) <= 0):
            raise MorphogenError(
                f"invalid colour ramp {spec!r}: stop positions must increase strictly "
                "from 0 to 1"
            )
    else:
        colours = [parse_colour(p) for p in parts]
        pos_arr = np.linspace(0.0, 1.0, len(parts))
    return Ramp(positions=pos_arr, colours=np.stack(colours))


def parse_cmap(spec: str | Colormap) -> Colormap:
    """A colour-map specification -> a matplotlib :class:`~matplotlib.colors.Colormap`.

    ``spec`` is a Colormap (returned as is), a matplotlib colormap name (``"viridis"``,
    ``"magma_r"``, ...), or a colour ramp string (see :func:`parse_ramp`; anything containing a
    comma). Unknown names raise :class:`MorphogenError` saying how to list the valid ones.
    """
    if isinstance(spec, Colormap):
        return spec
    if not isinstance(spec, str):
        raise MorphogenError(f"invalid colour map {spec!r}: give a name or a colour ramp string")
    if "," in spec:
        return parse_ramp(spec).to_colormap(name=spec)
    try:
        return matplotlib.colormaps[spec]
    except KeyError:
        raise MorphogenError(f"unknown colour map {spec!r}: {_LIST_HINT}") from None


def check_cmap(spec: str | Colormap) -> None:
    """Raise :class:`MorphogenError` unless ``spec`` is a colour map, a ramp or a transfer
    function (``step: ...``, ``ramp: ...``) that :func:`colourise` accepts."""
    if is_transfer(spec):
        parse_transfer(spec)
    else:
        parse_cmap(spec)


def _transfer(spec: str | Colormap) -> Callable[[np.ndarray], np.ndarray]:
    """Normalised values ``(...)`` -> float RGB ``(..., 3)``; ramps are interpolated exactly."""
    if isinstance(spec, str) and "," in spec:
        return parse_ramp(spec)
    cmap = parse_cmap(spec)
    return lambda t: cmap(t)[..., :3]


def colour_limits(
    field: np.ndarray, vmin: float | None = None, vmax: float | None = None
) -> tuple[float, float]:
    """The colour scale ``(vmin, vmax)``: given values, else the min / max of finite cells.

    An all-non-finite field gets ``(0, 1)``. A given limit beyond the data collapses the other,
    automatic one onto it; two given limits with ``vmin > vmax`` raise :class:`MorphogenError`.
    """
    field = np.asarray(field, dtype=np.float64)
    finite = field[np.isfinite(field)]
    lo = float(finite.min()) if vmin is None and finite.size else vmin
    hi = float(finite.max()) if vmax is None and finite.size else vmax
    lo = 0.0 if lo is None else float(lo)
    hi = 1.0 if hi is None else float(hi)
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise MorphogenError(f"colour limits must be finite numbers, got vmin={lo}, vmax={hi}")
    if lo > hi:
        if vmin is not None and vmax is not None:
            raise MorphogenError(f"colour limits are reversed: vmin={lo:g} > vmax={hi:g}")
        lo, hi = (lo, lo) if vmin is not None else (hi, hi)
    return lo, hi


def normalise(
    field: np.ndarray, vmin: float | None = None, vmax: float | None = None
) -> np.ndarray:
    """``t = clip((f - vmin) / (vmax - vmin), 0, 1)`` as float64 of the field's shape.

    A constant scale (``vmin == vmax``, e.g. a uniform state) maps every finite cell to 0, the
    low end of the map, as matplotlib's ``Normalize`` does; no division by zero occurs.
    Non-finite cells stay NaN.
    """
    field = np.asarray(field, dtype=np.float64)
    lo, hi = colour_limits(field, vmin, vmax)
    span = hi - lo
    with np.errstate(invalid="ignore"):
        t = np.clip((field - lo) / span, 0.0, 1.0) if span > 0 else np.zeros_like(field)
    return np.where(np.isfinite(field), t, np.nan)


def _to_bytes(rgb: np.ndarray, field: np.ndarray, nan_colour: str) -> np.ndarray:
    bad = ~np.isfinite(field)
    if bad.any():
        rgb = np.where(bad[..., None], parse_colour(nan_colour), rgb)
    return np.rint(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8)


def colourise(
    field: np.ndarray,
    cmap: str | Colormap = "viridis",
    vmin: float | None = None,
    vmax: float | None = None,
    *,
    nan_colour: str = NAN_COLOUR,
) -> np.ndarray:
    """Map a scalar field through a colour map.

    Args:
        field: ``(...)`` real values, e.g. ``(H, W)``; NaN/±Inf allowed.
        cmap: a matplotlib colormap name or Colormap, or a colour ramp string
            (``"#000,#f80,#fff"``, ``"0:#000,0.3:#f80,1:#fff"``; exact colours at the stops),
            or a transfer function at absolute values (``"step: #fff < 0.5 < #a00"``,
            ``"ramp: 0 #fff, 0.3 #f4d6dc, 0.35 #c0143c, 1 #6e0019"``;
            :mod:`morphogen.render.transfer`).
        vmin, vmax: colour scale; each defaults to the min / max of the finite values
            (ignored by transfer functions, whose levels are values of the field).
        nan_colour: colour of non-finite cells.

    Returns:
        ``(..., 3)`` uint8 RGB.
    """
    field = np.asarray(field, dtype=np.float64)
    if is_transfer(cmap):
        return _to_bytes(parse_transfer(cmap)(np.nan_to_num(field)), field, nan_colour)
    transfer = _transfer(cmap)
    t = normalise(field, vmin, vmax)
    rgb = transfer(np.nan_to_num(t, nan=0.0))
    return _to_bytes(rgb, field, nan_colour)


def step_map(
    field: np.ndarray,
    levels: Sequence[float],
    colours: Sequence[str],
    *,
    nan_colour: str = NAN_COLOUR,
) -> np.ndarray:
    """Piecewise-constant colours (Ringham et al. §4.3, step transfer function).

    With levels ``l_1 < ... < l_K`` and colours ``c_0, ..., c_K``, a cell with value ``f`` gets
    ``c_i`` where ``i = #{j : l_j <= f}``, i.e. ``c_0`` below ``l_1``, ``c_K`` at or above
    ``l_K``.

    Args:
        field: ``(...)`` real values.
        levels: ``K >= 1`` strictly increasing finite levels.
        colours: ``K + 1`` colours.

    Returns:
        ``(..., 3)`` uint8 RGB.
    """
    lv = np.asarray(levels, dtype=np.float64).reshape(-1)
    if lv.size == 0 or not np.all(np.isfinite(lv)) or np.any(np.diff(lv) <= 0):
        raise MorphogenError(f"step levels must be finite and strictly increasing, got {levels}")
    if len(colours) != lv.size + 1:
        raise MorphogenError(
            f"step map needs one more colour than levels: {lv.size} levels, "
            f"{len(colours)} colours"
        )
    palette = np.stack([parse_colour(c) for c in colours])
    field = np.asarray(field, dtype=np.float64)
    index = np.searchsorted(lv, np.nan_to_num(field, nan=-np.inf), side="right")
    return _to_bytes(palette[index], field, nan_colour)


def threshold_map(
    field: np.ndarray,
    level: float,
    low: str = "#ffffff",
    high: str = "#a00000",
    *,
    nan_colour: str = NAN_COLOUR,
) -> np.ndarray:
    """Two colours split at ``level`` (Skaggs fig. 4.7, seed 000 §4.2).

    Cells with ``f >= level`` get ``high``, the others ``low``. Returns ``(..., 3)`` uint8 RGB.
    """
    return step_map(field, [level], [low, high], nan_colour=nan_colour)
