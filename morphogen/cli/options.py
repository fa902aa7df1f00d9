"""Parsers for command-line values shared by several sub-commands, and the run settings'
flags (:func:`add_run_arguments`, :func:`run_settings`) declared from the table of
:mod:`morphogen.runs.settings`.

Each parser raises :class:`MorphogenError` with a one-line message on bad input.
"""

from __future__ import annotations

import argparse
import math
import os
from typing import Any

from morphogen.errors import MorphogenError
from morphogen.runs.settings import SEED_MAX, Setting, default, for_command


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


def stencil(text: str | None) -> int | str | None:
    """``--stencil 9`` -> ``9``; ``spectral`` stays a word; absent -> ``None`` (the default)."""
    if text is None or text == "spectral":
        return text
    return int(text)


def init_options(items: list[str] | None) -> dict[str, Any]:
    """``--init-opt count=20 --init-opt sigma=2`` -> ``{"count": 20.0, "sigma": 2.0}``."""
    return assignments(items, "--init-opt")


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


ARG_TYPES = {"float": float, "positive_int": positive_int, "positive_float": positive_float,
             "seed": seed}
"""argparse types a row of :data:`morphogen.runs.settings.SETTINGS` may name (``argtype``)."""

PARSERS = {"size": size, "boundary": boundary, "stencil": stencil, "clamp": clamp,
           "noise": noise, "assignments": assignments, "init_options": init_options}
"""Parsers of a flag's text a row may name (``parse``)."""


def add_run_arguments(parser: argparse.ArgumentParser, command: str) -> None:
    """Declare the flags of every run setting that ``command`` takes, with the table's help,
    metavar and choices; ``--steps`` and ``--time`` exclude each other. Every default is
    ``None`` (or off): :func:`run_settings` fills in the command's defaults, so a flag given
    on the command line can be told from one left out."""
    rows = for_command(command)
    names = {s.name for s in rows}
    length = parser.add_mutually_exclusive_group() if {"steps", "time"} <= names else parser
    for row in rows:
        target = length if row.name in ("steps", "time") else parser
        flags = [row.short, row.flag] if row.short else [row.flag]
        if row.arg == "switch":
            target.add_argument(*flags, action="store_true", help=row.help)
            continue
        kwargs: dict[str, Any] = {"help": row.help, "default": None}
        if row.arg == "append":
            kwargs["action"] = "append"
        if row.metavar:
            kwargs["metavar"] = row.metavar
        if row.argtype:
            kwargs["type"] = ARG_TYPES[row.argtype]
        if row.choices_for(command):
            kwargs["choices"] = row.choices_for(command)
        target.add_argument(*flags, **kwargs)


def given_settings(args: argparse.Namespace, command: str) -> dict[str, Any]:
    """The run settings given on the command line, as run-setting values (``--size 64x64`` ->
    ``{"size": [64, 64]}``, ``--x64`` -> ``{"precision": "float64"}``)."""
    out: dict[str, Any] = {}
    for row in for_command(command):
        raw = getattr(args, _dest(row))
        if raw is None or raw is False:
            continue
        if row.arg == "switch":
            out[row.name] = row.switch_value
        else:
            out[row.name] = PARSERS[row.parse](raw) if row.parse else raw
    return out


def run_settings(args: argparse.Namespace, command: str,
                 defaults: dict[str, Any] | None = None) -> dict[str, Any]:
    """Every run setting ``command`` takes: given on the command line, else the command's own
    default from ``defaults``, else the table's."""
    values = {row.name: default(row.name) for row in for_command(command)}
    return {**values, **(defaults or {}), **given_settings(args, command)}


def _dest(row: Setting) -> str:
    """The argparse attribute of a row's flag (``--init-opt`` -> ``init_opt``)."""
    return row.flag.lstrip("-").replace("-", "_")
