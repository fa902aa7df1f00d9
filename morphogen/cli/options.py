"""Parsers for command-line values shared by several sub-commands.

Each raises :class:`MorphogenError` with a one-line message on bad input.
"""

from __future__ import annotations

import argparse
import math
import os
from typing import Any

from morphogen.errors import MorphogenError


def size(text: str) -> list[int]:
    """``256x256`` or ``64x64x64`` -> ``[256, 256]``; every axis a whole number >= 3, and the
    grid within :mod:`morphogen.util.guard`'s memory limit for one species."""
    from morphogen.util import guard

    parts = text.lower().split("x")
    if len(parts) not in (2, 3) or any(len(p.strip()) > 12 for p in parts):
        raise MorphogenError(f"--size {text!r}: give 2 or 3 axes, e.g. 256x256 or 64x64x64")
    try:
        values = [int(p) for p in parts]
    except ValueError:
        raise MorphogenError(f"--size {text!r}: use NxM or NxMxK with whole numbers") from None
    if any(v < 3 for v in values):
        raise MorphogenError(f"--size {text!r}: give 2 or 3 axes, each at least 3 cells")
    guard.check_memory(math.prod(values), 1)
    return values


def assignments(items: list[str] | None, flag: str = "-p") -> dict[str, Any]:
    """``["F=0.03", "k=0.05+0.01*x"]`` -> ``{"F": 0.03, "k": "0.05+0.01*x"}``."""
    from morphogen.engine.fields import parse_value

    out: dict[str, Any] = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        if not sep or not name.strip() or not value.strip():
            raise MorphogenError(f"{flag} {item!r}: use NAME=VALUE")
        out[name.strip()] = parse_value(value)
    return out


def boundary(items: list[str] | None) -> Any:
    """``--boundary neumann`` (all species) or ``--boundary v=dirichlet=0.5`` (per species)."""
    if not items:
        return "periodic"
    per_species = {}
    whole = None
    for item in items:
        head, sep, rest = item.partition("=")
        if sep and head.strip().lower() not in ("dirichlet",):
            per_species[head.strip()] = rest.strip()
        else:
            whole = item
    if per_species and whole:
        per_species = {**{"*": whole}, **per_species}
    return per_species or whole


SCHEMES = ("euler", "rk4", "imex1", "imex", "etdrk4", "adaptive", "auto")
"""``--scheme`` choices (:data:`morphogen.solvers.step.SCHEMES` and ``RUN_SCHEMES``), listed here so
that building the parser does not import JAX."""

POPULATION_SCHEMES = tuple(s for s in SCHEMES if s != "adaptive")
"""``--scheme`` choices of commands that advance a population with one ``dt`` (search, atlas):
:func:`morphogen.solvers.auto.population_scheme`."""

STENCILS = ("5", "7", "9", "spectral")
"""``--stencil`` choices: points of a finite-difference stencil, or the spectral Laplacian."""


def stencil(text: str | None) -> int | str | None:
    """``--stencil 9`` -> ``9``; ``spectral`` stays a word; absent -> ``None`` (the default)."""
    if text is None or text == "spectral":
        return text
    return int(text)


def clamp(text: str | None) -> Any:
    """``--clamp 0:5`` -> ``[0.0, 5.0]``; ``none`` -> ``None``; absent -> the model's own."""
    if text is None:
        return "model"
    if text.strip().lower() == "none":
        return None
    lo, sep, hi = text.partition(":")
    try:
        lo_f, hi_f = float(lo), float(hi)
    except ValueError:
        raise MorphogenError(f"--clamp {text!r}: use LO:HI (e.g. 0:5) or none") from None
    if not sep or lo_f >= hi_f:
        raise MorphogenError(f"--clamp {text!r}: need LO < HI")
    return [lo_f, hi_f]


def noise(text: str | None) -> dict[str, Any] | None:
    """``--noise 0.01``, ``--noise 0.01:multiplicative`` or ``--noise 0.01:additive:u,v``."""
    if text is None:
        return None
    parts = text.split(":")
    try:
        amplitude = float(parts[0])
    except ValueError:
        raise MorphogenError(f"--noise {text!r}: start with a number, e.g. 0.01") from None
    out: dict[str, Any] = {"amplitude": amplitude}
    if len(parts) > 1 and parts[1]:
        out["kind"] = parts[1]
    if len(parts) > 2 and parts[2]:
        out["species"] = tuple(s.strip() for s in parts[2].split(","))
    return out


def seed(text: str) -> int:
    """argparse type: a seed, a whole number from 0 to 2**32 - 1 (JAX keys keep 32 bits)."""
    from morphogen.runs.schema import SEED_MAX

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if not 0 <= value <= SEED_MAX:
        raise argparse.ArgumentTypeError(f"{text!r} must be between 0 and {SEED_MAX}")
    return value


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be at least 1")
    return value


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive number")
    return value


def show_progress(args: argparse.Namespace) -> bool:
    """Progress bars on a terminal unless ``--quiet``; off under CI."""
    import sys

    return not getattr(args, "quiet", False) and sys.stderr.isatty() and not os.environ.get("CI")
