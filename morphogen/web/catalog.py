"""Models offered by the web app: library models by name, or pasted equation text.

A *model spec* is the JSON a page sends: ``{"library": "gray-scott"}`` or
``{"equations": "<model file text>"}``. Equation text is untrusted (it comes from whoever can
reach the server), so it goes through :func:`morphogen.models.text.equations.parse_model` only — an
AST
whitelist, never ``eval`` — and a payload such as ``__import__('os').system(...)`` is refused with
the parser's one-line message before anything runs.

Resolved models are cached by a key (library name, or a hash of the text), so two browser tabs
showing the same model share one compiled program.
"""

from __future__ import annotations

import hashlib
import importlib
import math
from collections import OrderedDict
from collections.abc import Mapping
from threading import Lock
from typing import Any

from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.web.limits import Limits, number

SLIDER_HINTS: dict[str, dict[str, tuple[float, float]]] = {
    "gray-scott": {"F": (0.0, 0.1), "k": (0.03, 0.075)},
}
"""Slider ranges where the default rule (0 to twice the default) is a poor fit."""

_CACHE: OrderedDict[str, Model] = OrderedDict()
_CACHE_LOCK = Lock()
_CACHE_SIZE = 32


def library_names() -> list[str]:
    """Names of the library models, sorted, then the shipped trained neural RD rules
    (``neural:NAME``, :mod:`morphogen.models.neural_library`)."""
    from morphogen.models.library import LIBRARY
    from morphogen.models.neural_library import model_names

    return sorted(LIBRARY) + model_names()


def model_key(spec: Mapping[str, Any]) -> str:
    """A stable key for a model spec: ``lib:<name>`` or ``eq:<sha256 of the text>``."""
    if not isinstance(spec, Mapping):
        raise MorphogenError('model must be {"library": NAME} or {"equations": TEXT}')
    if "library" in spec:
        name = spec["library"]
        if not isinstance(name, str):
            raise MorphogenError("library model name must be a string")
        return f"lib:{name}"
    if "equations" in spec:
        text = spec["equations"]
        if not isinstance(text, str):
            raise MorphogenError("equations must be text")
        return "eq:" + hashlib.sha256(text.encode()).hexdigest()
    raise MorphogenError('model must be {"library": NAME} or {"equations": TEXT}')


def resolve_model(spec: Mapping[str, Any], limits: Limits) -> tuple[Model, str]:
    """The :class:`Model` for a spec and its cache key.

    Raises:
        MorphogenError: unknown library name, text too long, or text the safe parser refuses
            (syntax error, unknown name, forbidden construct), with the parser's message.
    """
    key = model_key(spec)
    with _CACHE_LOCK:
        if key in _CACHE:
            _CACHE.move_to_end(key)
            return _CACHE[key], key
    if key.startswith("lib:"):
        from morphogen.models.library import get_model

        model = get_model(spec["library"])
    else:
        model = parse_equations(spec["equations"], limits)
    with _CACHE_LOCK:
        _CACHE[key] = model
        while len(_CACHE) > _CACHE_SIZE:
            _CACHE.popitem(last=False)
    return model, key


def parse_equations(text: str, limits: Limits) -> Model:
    """Pasted model text -> :class:`Model` through the safe parser only."""
    if len(text) > limits.max_equation_chars:
        raise MorphogenError(
            f"equation text is {len(text)} characters; the limit is {limits.max_equation_chars}"
        )
    if not text.strip():
        raise MorphogenError("equation text is empty: paste a model file (TOML)")
    try:
        equations = importlib.import_module("morphogen.models.text.equations")
    except ImportError:
        raise MorphogenError(
            "pasted equations need morphogen.models.text.equations, which this installation lacks"
        ) from None
    return equations.parse_model(text)


def slider_range(model_name: str, name: str, value: float) -> tuple[float, float]:
    """A slider range for parameter ``name`` whose default is ``value``.

    The model's hint if there is one; otherwise ``[0, 2 v]`` for a positive default,
    ``[2 v, 0]`` for a negative one and ``[-1, 1]`` for zero. The range always contains ``v``.
    """
    hint = SLIDER_HINTS.get(model_name, {}).get(name)
    if hint is not None:
        lo, hi = hint
    elif value > 0:
        lo, hi = 0.0, 2.0 * value
    elif value < 0:
        lo, hi = 2.0 * value, 0.0
    else:
        lo, hi = -1.0, 1.0
    return min(lo, value), max(hi, value)


def describe(model: Model) -> dict[str, Any]:
    """The JSON a page needs to build its controls for ``model``."""
    params = []
    for name, value in model.params.items():
        v = float(value)
        lo, hi = slider_range(model.name, name, v)
        params.append({"name": name, "value": v, "min": lo, "max": hi, "step": _step(lo, hi)})
    return {
        "name": model.name,
        "species": list(model.species),
        "display": model.display_species,
        "params": params,
        "presets": {k: dict(v) for k, v in model.presets.items()},
        "description": model.description,
        "reference": model.reference,
        "source": model.source,
    }


def _step(lo: float, hi: float) -> float:
    """A slider increment giving about 1000 positions, rounded to a power of ten."""
    span = hi - lo
    if span <= 0:
        return 1e-3
    return 10.0 ** math.floor(math.log10(span / 1000.0))


def check_params(values: Any, model: Model) -> dict[str, float]:
    """Validate parameter overrides: known names, finite numbers within +-1e6."""
    if values is None:
        return {}
    if not isinstance(values, Mapping):
        raise MorphogenError("params must be an object of NAME: number")
    out = {}
    for name, value in values.items():
        if name not in model.params:
            raise MorphogenError(
                f"unknown parameter {name!r} for model {model.name}; parameters are "
                + ", ".join(model.params)
            )
        out[name] = number(value, f"parameter {name}", -1e6, 1e6)
    return out
