"""Transfer functions written as text: step maps, thresholds and non-linear ramps at absolute
concentrations (Ringham et al. §3.5, "user-defined color maps"; the step map of §4.3
*Primula*, the non-linear map of §4.4 *Dianthus*).

A colour-map string that starts with ``step:`` or ``ramp:`` is a transfer function in the
field's own units, so it is accepted wherever a colour map is (``cmap`` in pipeline stages,
``--cmap`` on the command line, :func:`morphogen.render.colour.colourise`):

``step: C0 < L1 < C1 < ... < LK < CK``
    piecewise-constant: value ``f`` gets ``C_i`` with ``i = #{j : L_j <= f}`` (``C0`` below
    ``L1``, ``CK`` at or above ``LK``). One level is a threshold:
    ``step: #f4c430 < 0.08 < #3b0612``.

``ramp: V0 C0, V1 C1, ..., VK CK [; gamma G]``
    piecewise-linear between colour stops at the values ``V0 < ... < VK``, constant outside.
    With ``gamma``, the value is first bent: ``f' = V0 + (VK - V0) t^G`` with
    ``t = clip((f - V0)/(VK - V0), 0, 1)``, so ``G > 1`` holds the low colours longer and
    ``G < 1`` reaches the high ones sooner. Unevenly spaced stops give any monotone
    non-linear map, e.g. ``ramp: 0 #ffffff, 0.25 #f4d6dc, 0.35 #c0143c, 1 #6e0019``.

Colours are anything matplotlib reads (``#f80``, ``#ff8800``, ``white``). The colour limits
(``vmin``/``vmax``) do not apply: the levels and stops are concentrations.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from matplotlib.colors import to_rgb

from morphogen.errors import MorphogenError

PREFIXES = ("step:", "ramp:")
"""Colour-map strings starting with one of these are transfer functions."""

_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


@dataclass(frozen=True)
class Transfer:
    """A parsed transfer function.

    Attributes:
        kind: ``"step"`` or ``"ramp"``.
        values: ``(K,)`` step levels, or ``(K + 1,)`` ramp stop values; strictly increasing.
        colours: ``(K + 1, 3)`` RGB in [0, 1].
        gamma: the ramp's exponent (1 for steps).
    """

    kind: str
    values: np.ndarray
    colours: np.ndarray
    gamma: float = 1.0

    def __call__(self, field: np.ndarray) -> np.ndarray:
        """Float RGB ``(..., 3)`` of finite values ``(...)``."""
        f = np.asarray(field, np.float64)
        if self.kind == "step":
            return self.colours[np.searchsorted(self.values, f, side="right")]
        lo, hi = self.values[0], self.values[-1]
        if self.gamma != 1.0:
            t = np.clip((f - lo) / (hi - lo), 0.0, 1.0)
            f = lo + (hi - lo) * t**self.gamma
        return np.stack([np.interp(f, self.values, self.colours[:, c]) for c in range(3)], -1)


def is_transfer(spec: object) -> bool:
    """Whether ``spec`` is a transfer-function string (``step: ...`` or ``ramp: ...``)."""
    return isinstance(spec, str) and spec.lstrip().lower().startswith(PREFIXES)


def _colour(text: str, spec: str) -> np.ndarray:
    try:
        return np.asarray(to_rgb(text.strip()), np.float64)
    except (ValueError, TypeError):
        raise MorphogenError(f"transfer {spec!r}: {text.strip()!r} is not a colour; use "
                             "'#ff8800', '#f80' or a name like 'white'") from None


def _number(text: str, spec: str, what: str) -> float:
    text = text.strip()
    if not _NUMBER.match(text):
        raise MorphogenError(f"transfer {spec!r}: {what} {text!r} is not a number")
    return float(text)


def _increasing(values: list[float], spec: str, what: str) -> np.ndarray:
    arr = np.asarray(values, np.float64)
    if np.any(np.diff(arr) <= 0):
        raise MorphogenError(f"transfer {spec!r}: {what} must increase strictly, got "
                             f"{', '.join(f'{v:g}' for v in arr)}")
    return arr


def parse_transfer(spec: str) -> Transfer:
    """Parse ``step: ...`` or ``ramp: ...`` (module docstring); one-line errors otherwise."""
    kind, _, body = spec.strip().partition(":")
    kind = kind.strip().lower()
    if kind == "step":
        parts = body.split("<")
        if len(parts) < 3 or len(parts) % 2 == 0:
            raise MorphogenError(f"transfer {spec!r}: write colours and levels alternately, "
                                 "e.g. 'step: #f4c430 < 0.08 < #3b0612'")
        colours = np.stack([_colour(p, spec) for p in parts[0::2]])
        levels = [_number(p, spec, "level") for p in parts[1::2]]
        return Transfer("step", _increasing(levels, spec, "levels"), colours)
    if kind == "ramp":
        stops, _, option = body.partition(";")
        gamma = 1.0
        if option.strip():
            name, _, value = option.strip().partition(" ")
            if name.strip().lower() != "gamma":
                raise MorphogenError(f"transfer {spec!r}: after ';' only 'gamma G' is known")
            gamma = _number(value, spec, "gamma")
            if gamma <= 0:
                raise MorphogenError(f"transfer {spec!r}: gamma must be positive")
        items = [s.split() for s in stops.split(",")]
        if len(items) < 2 or any(len(item) != 2 for item in items):
            raise MorphogenError(f"transfer {spec!r}: give two or more 'VALUE COLOUR' stops "
                                 "separated by commas, e.g. 'ramp: 0 #ffffff, 1 #c0143c'")
        values = [_number(v, spec, "stop value") for v, _ in items]
        colours = np.stack([_colour(c, spec) for _, c in items])
        return Transfer("ramp", _increasing(values, spec, "stop values"), colours, gamma)
    raise MorphogenError(f"transfer {spec!r}: start with 'step:' or 'ramp:'")
