"""Model files: reaction-diffusion equations written by hand, in TOML.

A file names the species, the parameters and one equation per species, e.g.::

    name = "schnakenberg"
    species = ["u", "v"]
    [parameters]
    a = 0.1
    b = 0.9
    Du = 1.0
    Dv = 40.0
    [equations]
    u = "a - u + u**2*v + Du*lap(u)"
    v = "b - u**2*v + Dv*lap(v)"

Each equation is the right-hand side of :math:`\\partial_t u_i = R_i + D_i \\nabla^2 u_i`
(Skaggs eq. 2.2). It is split into the reaction ``R_i`` (every additive term without ``lap``) and
the diffusion coefficient ``D_i`` (the sum of the ``coef`` of the terms ``coef*lap(u_i)``; the
coefficient may read parameters, numbers and ``x, y, z``; see
:mod:`morphogen.models.text.terms`). Optional entries: ``description``, ``reference``,
``display``, the run hints ``dt``, ``t_end``, ``init`` and ``clamp``, ``[initial]`` and
``[excited]`` (per-species values or expressions of the parameters), ``[presets.NAME]`` and
``[anisotropy]`` (a principal direction and two rates, Ringham et al. eq. 18). The text is
untrusted: expressions go through the whitelist compiler of :mod:`morphogen.models.expr`, and
every error names the file line and column. See ``docs/equations.md``.
"""

from __future__ import annotations

import keyword
import math
import os
import re
import tomllib
import unicodedata
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from morphogen.errors import MorphogenError
from morphogen.models.expr import (
    RESERVED,
    Evaluator,
    ExpressionError,
    compile_node,
    parse,
)
from morphogen.models.model import INITIAL_NAMES, Array, Model, Params
from morphogen.models.text.terms import check_coefficient, principal_tensor, split_equation
from morphogen.models.text.toml_text import MAX_DEPTH, KeyIndex, too_deep
from morphogen.util import guard
from morphogen.util.io import read_text

COORDINATES = ("x", "y", "z")

KEYS = (
    "name", "species", "description", "reference", "display", "dt", "t_end", "init", "clamp",
    "parameters", "equations", "initial", "excited", "presets", "anisotropy",
)  # fmt: skip
"""Top-level keys and tables of a model file."""

_TOO_DEEP = (f"arrays or tables nested more than {MAX_DEPTH} deep; a model file needs at most "
             "two levels (e.g. species = [\"u\", \"v\"])")


def load_model_file(path: str | os.PathLike) -> Model:
    """Read and parse a model file (see :func:`parse_model`)."""
    path = Path(path)
    return parse_model(read_text(path, "model file"), name=path.stem, path=path)


def parse_model(
    text: str, name: str | None = None, path: str | os.PathLike | None = None
) -> Model:
    """Build a :class:`Model` from model-file text.

    Args:
        text: the TOML text (kept as ``Model.source``).
        name: the model name when the file has no ``name`` key.
        path: where the text came from, used in error messages.

    Raises:
        MorphogenError: one line naming the problem, with the file line and column for errors
            inside expressions and TOML syntax.
    """
    text = text.removeprefix("\ufeff")
    src = _Source(text, path)
    deep = too_deep(text)
    if deep is not None:
        raise src.error(_TOO_DEEP, deep)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise src.toml_error(exc) from None
    except RecursionError:  # too_deep missed it (an unusual string form): same answer
        raise src.error(_TOO_DEEP) from None
    unknown = sorted(set(data) - set(KEYS))
    if unknown:
        raise src.error(f"unknown key {unknown[0]!r}; a model file may have {', '.join(KEYS)}")
    species = _species(data, src)
    params = _parameters(data, src, species)
    eqs = _table(data, "equations", src, required=True)
    for key in eqs:
        if key not in species:
            raise src.error(
                f"[equations] has an equation for {key!r}, which is not a species "
                f"(species: {', '.join(species)})",
                src.locate("equations", key),
            )
    missing = [s for s in species if s not in eqs]
    if missing:
        raise src.error(
            f"species {missing[0]!r} has no equation in [equations]", src.locate(None, "species")
        )
    reaction_names = set(params) | set(species) | set(COORDINATES) | {"t"}
    coef_names = set(params) | set(COORDINATES)
    reactions, coefficients = [], []
    for s in species:
        rx, coef = _equation(eqs[s], s, species, reaction_names, coef_names, src)
        reactions.append(rx)
        coefficients.append(coef)
    tensors = _anisotropy(data, src, species, coef_names, coefficients)
    display = data.get("display")
    if display is not None and display not in species:
        raise src.error(
            f"display = {display!r} is not a species (species: {', '.join(species)})",
            src.locate(None, "display"),
        )
    title = data.get("name", name or (Path(path).stem if path else "model"))
    for key in ("name", "description", "reference", "init"):
        if key in data and not isinstance(data[key], str):
            raise src.error(f"{key} must be a string", src.locate(None, key))
    return Model(
        name=title,
        species=species,
        params=params,
        reaction=_reaction(species, reactions),
        diffusion=_diffusion(coefficients, tensors),
        ground=_state_values(data, "initial", src, species, params),
        excited=_state_values(data, "excited", src, species, params),
        display=display,
        presets=_presets(data, src, params),
        description=data.get("description", ""),
        reference=data.get("reference", f"model file {path}" if path else "model file"),
        source=text,
        **_run_hints(data, src),
    )


def _run_hints(data, src) -> dict[str, Any]:
    """``dt``, ``t_end``, ``init`` and ``clamp``: the model's suggestions for a run."""
    out: dict[str, Any] = {}
    for key in ("dt", "t_end"):
        if key in data:
            value = _number(data[key], key, src, src.locate(None, key))
            if not (value > 0 and math.isfinite(value)):
                raise src.error(f"{key} must be a positive finite number, got {value:g}",
                                src.locate(None, key))
            out[key] = value
    if "init" in data:
        if data["init"] not in INITIAL_NAMES:
            raise src.error(
                f"init = {data['init']!r} is not an initial condition; use one of "
                + ", ".join(INITIAL_NAMES), src.locate(None, "init"),
            )  # fmt: skip
        out["init"] = data["init"]
    if "clamp" in data:
        bounds = data["clamp"]
        where = src.locate(None, "clamp")
        if not isinstance(bounds, list) or len(bounds) != 2:
            raise src.error("clamp must be [low, high], e.g. clamp = [0, 100]", where)
        lo, hi = (_number(b, "clamp bound", src, where) for b in bounds)
        if not lo < hi:
            raise src.error(f"clamp needs low < high, got [{lo:g}, {hi:g}]", where)
        out["clamp"] = (lo, hi)
    return out


def _reaction(species: tuple[str, ...], terms: Sequence[Evaluator]):
    """``R(u, p, c)``: every reaction expression, stacked to shape ``(S, *spatial)``."""

    def reaction(u: Array, p: Params, c: Mapping[str, Array]) -> Array:
        import jax.numpy as jnp

        env = {**p, **c}
        env.update((s, u[i]) for i, s in enumerate(species))
        shape = u.shape[1:]
        return jnp.stack([jnp.broadcast_to(jnp.asarray(f(env), u.dtype), shape) for f in terms])

    return reaction


def _diffusion(coefficients: Sequence[Evaluator | None], tensors: Mapping[int, tuple]):
    """``D(p, c)``: a scalar or field per species, or a :class:`Tensor` for anisotropic ones."""

    def diffusion(p: Params, c: Mapping[str, Array]) -> tuple:
        env = {**p, **c}
        out: list[Any] = []
        for i, coef in enumerate(coefficients):
            if i in tensors:
                out.append(principal_tensor(*(f(env) for f in tensors[i])))
            else:
                out.append(0.0 if coef is None else coef(env))
        return tuple(out)

    return diffusion


def _equation(value, s, species, reaction_names, coef_names, src):
    """Compile one equation into (reaction evaluator, diffusion evaluator or None)."""
    if not isinstance(value, str):
        shown = value if isinstance(value, int | float) and not isinstance(value, bool) else "..."
        raise src.error(
            f"the equation for {s} must be an expression in quotes, e.g. {s} = \"{shown}\"",
            src.locate("equations", s),
        )
    text = value
    try:
        tree = parse(text, extra_functions={"lap": 1})
        reaction, total = split_equation(tree, text, s, species)
        if reaction is None:
            rx = _zero
        else:
            names = "known names:"
            rx = compile_node(reaction, text, reaction_names, what=names)
        coef = None
        if total is not None:
            names = "a diffusion coefficient may use numbers and"
            coef = compile_node(total, text, coef_names, what=names)
    except ExpressionError as exc:
        raise src.expression_error(exc, "equations", s, f"equation for {s}") from None
    return rx, coef


def _zero(env: Mapping[str, Array]) -> float:
    return 0.0


def _anisotropy(data, src, species, coef_names, coefficients) -> dict[int, tuple]:
    """``[anisotropy]``: ``s = { angle = ..., along = ..., across = ... }`` per species."""
    table = _table(data, "anisotropy", src)
    out: dict[int, tuple] = {}
    for s, spec in table.items():
        where = src.locate("anisotropy", s)
        if s not in species:
            raise src.error(f"[anisotropy] names {s!r}, which is not a species", where)
        if not isinstance(spec, dict):
            raise src.error(
                f"[anisotropy] {s} must be a table, e.g. {s} = {{ angle = \"0.3\", "
                'along = "D1", across = "D2" }', where,
            )  # fmt: skip
        extra = sorted(set(spec) - {"angle", "along", "across"})
        if extra or "along" not in spec or "across" not in spec:
            raise src.error(
                f"[anisotropy] {s} takes angle (radians, default 0), along and across", where
            )
        i = species.index(s)
        if coefficients[i] is not None:
            raise src.error(
                f"species {s} has both a lap() term and an [anisotropy] entry; remove the "
                "lap() term from its equation (the [anisotropy] entry gives its diffusion)", where,
            )  # fmt: skip
        parts = []
        for key in ("angle", "along", "across"):
            text = _expression_text(spec.get(key, 0.0), src, "anisotropy", s, f"{s}.{key}", key)
            names = "anisotropy may use numbers and"
            try:
                tree = parse(text)
                check_coefficient(tree, text, species, "anisotropy depends on")
                parts.append(compile_node(tree, text, coef_names, what=names))
            except ExpressionError as exc:
                raise src.expression_error(
                    exc, "anisotropy", s, f"anisotropy {s}.{key}", key
                ) from None
        out[i] = tuple(parts)
    return out


def _species(data, src) -> tuple[str, ...]:
    if "species" not in data:
        raise src.error('the model file has no species list; add e.g. species = ["u", "v"]')
    species = data["species"]
    where = src.locate(None, "species")
    if not (isinstance(species, list) and species and all(isinstance(s, str) for s in species)):
        raise src.error('species must be a non-empty list of names, e.g. ["u", "v"]', where)
    if len(species) > guard.LIMITS.species:
        raise src.error(f"{len(species)} species is more than the limit of "
                        f"{guard.LIMITS.species}", where)
    for s in species:
        _check_name(s, "species", src, where)
    seen = set()
    for s in species:
        if s in seen:
            raise src.error(f"species {s!r} is listed twice", where)
        seen.add(s)
    return tuple(species)


def _parameters(data, src, species) -> dict[str, float]:
    params = {}
    for key, value in _table(data, "parameters", src).items():
        where = src.locate("parameters", key)
        _check_name(key, "parameter", src, where)
        if key in species:
            raise src.error(f"{key!r} is both a species and a parameter; rename one", where)
        params[key] = _number(value, f"parameter {key}", src, where)
    return params


def _presets(data, src, params) -> dict[str, dict[str, float]]:
    out: dict[str, dict[str, float]] = {}
    for preset, values in _table(data, "presets", src).items():
        if not isinstance(values, dict):
            raise src.error(f"presets.{preset} must be a table of parameter values")
        out[preset] = {}
        for key, value in values.items():
            where = src.locate(f"presets.{preset}", key)
            if key not in params:
                raise src.error(
                    f"preset {preset!r} sets unknown parameter {key!r}; parameters are "
                    + (", ".join(params) or "none"), where,
                )  # fmt: skip
            out[preset][key] = _number(value, f"preset {preset} {key}", src, where)
    return out


def _state_values(data, section, src, species, params):
    """``[initial]`` / ``[excited]``: ``p -> S floats`` from numbers or parameter expressions."""
    if section not in data:
        return None
    table = _table(data, section, src)
    for key in table:
        if key not in species:
            raise src.error(f"[{section}] names {key!r}, which is not a species",
                            src.locate(section, key))
    missing = [s for s in species if s not in table]
    if missing:
        raise src.error(f"[{section}] needs a value for every species; {missing[0]!r} is missing")
    terms = []
    for s in species:
        text = _expression_text(table[s], src, section, s, f"[{section}] {s}")
        try:
            tree = parse(text)
            names = "values may use numbers and the parameters:"
            terms.append(compile_node(tree, text, params, what=names))
        except ExpressionError as exc:
            raise src.expression_error(exc, section, s, f"[{section}] {s}") from None

    def values(p: Params) -> tuple[float, ...]:
        return tuple(float(f(p)) for f in terms)

    return values


def _table(data, key, src, required=False) -> dict[str, Any]:
    if key not in data:
        if required:
            raise src.error(f'the model file has no [{key}] table; add one, e.g. u = "..."')
        return {}
    if not isinstance(data[key], dict):
        raise src.error(f"{key} must be a table ([{key}])", src.locate(None, key))
    return data[key]


def _check_name(name, kind, src, where) -> None:
    if unicodedata.normalize("NFKC", name) != name:
        raise src.error(
            f"{kind} name {name!r} changes under Unicode normalisation (Python reads it as "
            f"{unicodedata.normalize('NFKC', name)!r}); use plain letters", where,
        )  # fmt: skip
    if not name.isidentifier() or name.startswith("_") or keyword.iskeyword(name):
        raise src.error(
            f"{kind} name {name!r} is not usable in expressions; use letters, digits and "
            "underscores, starting with a letter", where,
        )  # fmt: skip
    if name in RESERVED:
        raise src.error(
            f"{kind} name {name!r} is reserved (functions, lap, x, y, z, t); rename it", where
        )


MAX_MAGNITUDE = 1e30
"""Largest magnitude of a number in a model file: float32 ends near 3.4e38, and a value beyond
this leaves no room for the arithmetic (products, slider ranges) done with it."""


def _number(value, what, src, where) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise src.error(f"{what} must be a number, got {value!r}", where)
    if not abs(value) <= MAX_MAGNITUDE:
        raise src.error(
            f"{what} must be a finite number of magnitude at most {MAX_MAGNITUDE:g}, "
            f"got {value!r}", where,
        )  # fmt: skip
    return float(value)


def _expression_text(value, src, section, key, what, subkey=None) -> str:
    if isinstance(value, bool) or not isinstance(value, str | int | float):
        raise src.error(f"{what} must be an expression in quotes", src.locate(section, key, subkey))
    return value if isinstance(value, str) else repr(float(value))


class _Source:
    """The raw text of a model file, to turn positions into file lines and columns."""

    def __init__(self, text: str, path: str | os.PathLike | None):
        self.lines = text.splitlines()
        self.prefix = f"{path}: " if path else ""
        self._index: KeyIndex | None = None

    def error(self, message: str, at: tuple[int, int] | None = None) -> MorphogenError:
        if at is None:
            return MorphogenError(self.prefix + message)
        return MorphogenError(f"{self.prefix}line {at[0]}, column {at[1]}: {message}")

    def toml_error(self, exc: tomllib.TOMLDecodeError) -> MorphogenError:
        message = str(exc).split("\n")[0]
        match = re.match(r"(.*) \(at line (\d+), column (\d+)\)$", message)
        hint = " (a name is defined twice)" if "overwrite" in message else ""
        if match:
            at = (int(match.group(2)), int(match.group(3)))
            return self.error(f"invalid TOML: {match.group(1)}{hint}", at)
        if message.endswith("(at end of document)"):
            at = (max(len(self.lines), 1), len(self.lines[-1]) + 1 if self.lines else 1)
            return self.error(f"invalid TOML: {message[: -len(' (at end of document)')]}", at)
        return self.error(f"invalid TOML: {message}{hint}")

    def expression_error(self, exc: ExpressionError, section, key, what, subkey=None):
        start = self.locate(section, key, subkey, inside_string=True)
        if start is None:
            return self.error(f"{what}, line {exc.line}, column {exc.column}: {exc.reason}")
        line, column, escapes = start
        if exc.line > 1:
            line, column = line + exc.line - 1, 1
        raw = self.lines[line - 1] if line <= len(self.lines) else ""
        at = (line, _raw_column(raw, column - 1, exc.column, escapes))
        return self.error(f"{what}: {exc.reason}", at)

    def locate(self, section, key, subkey=None, *, inside_string=False):
        """File ``(line, column)`` of ``key`` in ``[section]`` (``None``: top level), or of the
        first character inside its string value when ``inside_string``; ``None`` if not found.
        Constant time: the lines are indexed once (:class:`KeyIndex`), on the first call.
        """
        if self._index is None:
            self._index = KeyIndex(self.lines)
        found = self._index.find(section, key)
        if found is None:
            return None
        number, line, position = found
        if not inside_string and subkey is None:
            return number, len(line) - len(line.lstrip()) + 1
        if subkey is not None:
            sub = re.compile(rf"\b{re.escape(subkey)}\s*=\s*").search(line, position)
            if not sub:
                return number, position + 1
            position = sub.end()
            if not inside_string:
                return number, sub.start() + 1
        return self._string_start(number, line, position)

    def _string_start(self, number: int, line: str, position: int) -> tuple[int, int, bool]:
        """``(line, column, escapes)`` of a value's first character; ``escapes`` is true for
        TOML basic strings (double quotes), whose backslash escapes take several characters."""
        rest = line[position:]
        for quote in ('"""', "'''"):
            if rest.startswith(quote):
                if not rest[3:].strip():
                    return number + 1, 1, quote == '"""'
                return number, position + 4, quote == '"""'
        if rest[:1] in ("'", '"'):
            return number, position + 2, rest[0] == '"'
        return number, position + 1, False


def _raw_column(raw: str, begin: int, column: int, escapes: bool) -> int:
    """File column of the ``column``-th character of a string value that starts at index
    ``begin`` of the file line ``raw`` (an escape such as ``\\"`` counts as one character)."""
    i = begin
    for _ in range(column - 1):
        if escapes and raw[i : i + 1] == "\\":
            i += {"u": 6, "U": 10}.get(raw[i + 1 : i + 2], 2)
        else:
            i += 1
    return i + 1
