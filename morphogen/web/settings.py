"""Run settings in web request bodies, read from the table of :mod:`morphogen.runs.settings`.

Every route that starts a simulation (the live view, Atlas, Evolve, Mesh) reads its run
settings here instead of by hand: each row's ``web`` check (a number, a whole number, one of
the row's web choices, a colour map, a stencil) with the row's bounds, narrowed where a route
has its own limits (the grid size of a live view, of an atlas tile). A value that is absent or
``null`` (or an empty text) takes the route's default; the default is checked as a given value
would be, unless it is ``None`` ("the model's choice", left to the route). A bad value is
refused with one line naming the setting (:class:`MorphogenError`, HTTP 400).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from morphogen.errors import MorphogenError
from morphogen.render.colour import parse_cmap
from morphogen.runs.settings import BY_NAME, default
from morphogen.web.limits import choice, integer, number

INITIAL_KINDS: tuple[str, ...] = BY_NAME["init"].choices_for("web")
"""Initial conditions the web app offers (those of :mod:`morphogen.engine.initial` that need no
file)."""


def read_settings(body: Mapping[str, Any], names: Iterable[str], *,
                  defaults: Mapping[str, Any] | None = None,
                  bounds: Mapping[str, tuple[float, float]] | None = None,
                  keys: Mapping[str, str] | None = None,
                  labels: Mapping[str, str] | None = None) -> dict[str, Any]:
    """The run settings ``names`` of a request body, validated.

    Args:
        defaults: the route's defaults (else the table's).
        bounds: the route's ``(lo, hi)`` of a setting (else the row's).
        keys: the body's key of a setting where it is not the setting's name (an atlas tile's
            ``size`` is ``tile``).
        labels: the setting's name in errors where it is not the row's.
    """
    defaults, bounds, keys, labels = defaults or {}, bounds or {}, keys or {}, labels or {}
    out = {}
    for name in names:
        value = body.get(keys.get(name, name))
        if value is None or value == "":
            value = defaults[name] if name in defaults else default(name)
            if value is None:
                out[name] = None
                continue
        out[name] = check(name, value, label=labels.get(name), bounds=bounds.get(name))
    return out


def check(name: str, value: Any, *, label: str | None = None,
          bounds: tuple[float, float] | None = None) -> Any:
    """``value`` of setting ``name`` as its row's ``web`` check reads it (within ``bounds``,
    else the row's; named ``label`` in errors, else the row's name), or a one-line error."""
    row = BY_NAME[name]
    label = label or row.message_name
    lo, hi = bounds or (row.lo, row.hi)
    if row.web == "number":
        return number(value, label, lo, hi)
    if row.web == "integer":
        return integer(value, label, int(lo), int(hi))
    if row.web == "choice":
        return choice(value, label, row.choices_for("web"))
    if row.web == "cmap":
        return colour_map(value)
    if row.web == "stencil":
        return stencil(value)
    return value  # text and params: checked against the model by the route


def colour_map(name: Any) -> str:
    """A validated colour-map name or ramp."""
    if not isinstance(name, str) or len(name) > 200:
        raise MorphogenError("colour map must be a name such as 'viridis'")
    parse_cmap(name)
    return name


def stencil(value: Any) -> int | str:
    """A Laplacian stencil: a number of points (``5``, ``7``, ``9``, as a number or text) or
    ``"spectral"``."""
    options = BY_NAME["stencil"].choices
    if isinstance(value, bool) or str(value) not in options or isinstance(value, float):
        raise MorphogenError(f"stencil must be one of {', '.join(options)}; got {value!r}")
    return value if value == "spectral" else int(value)
