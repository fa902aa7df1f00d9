"""Trained neural RD rules shipped with morphogen: ``neural:NAME`` (seed 002, fig. 2).

Each rule is ``NAME.npz`` (a :func:`morphogen.models.neural.save_neural_model` file, n = 12
channels, h = 64 hidden units, ~7 kB) with its training record ``NAME.json`` beside it
(iterations, wall time, final loss, settings); :mod:`morphogen.learn.train_library` trains them from
synthetic targets, reproducibly. ``neural:NAME`` names one wherever a model name is accepted
(``morphogen simulate``, run files, pipelines, :func:`morphogen.models.registry.load_model`).
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

from morphogen.errors import MorphogenError
from morphogen.models.model import Model

FOLDER = Path(__file__).parent
"""Where the shipped ``.npz`` rules and their ``.json`` records live."""

PREFIX = "neural:"
"""Model names ``neural:NAME`` resolve to the shipped rule ``NAME``."""


def rule_names() -> list[str]:
    """Names of the shipped rules, sorted (without the ``neural:`` prefix)."""
    return sorted(p.stem for p in FOLDER.glob("*.npz"))


def model_names() -> list[str]:
    """The model names of the shipped rules: ``neural:NAME``, sorted."""
    return [PREFIX + n for n in rule_names()]


def _rule(name: str) -> str:
    """``NAME`` of ``neural:NAME`` (or of ``NAME``), checked against the shipped rules."""
    rule = name[len(PREFIX):] if name.startswith(PREFIX) else name
    if rule not in rule_names():
        known = ", ".join(model_names()) or "none installed"
        raise MorphogenError(f"unknown neural rule {name!r}; shipped rules: {known}")
    return rule


def record(name: str) -> dict:
    """The training record of a shipped rule (``{}`` when its ``.json`` is missing, unreadable
    or not a JSON object: the record only describes the rule, the ``.npz`` is the rule)."""
    path = FOLDER / f"{_rule(name)}.json"
    try:
        info = json.loads(path.read_text(encoding="utf-8")) if path.is_file() else {}
    except (OSError, ValueError, RecursionError):
        return {}
    return info if isinstance(info, dict) else {}


def load_rule(name: str) -> Model:
    """The :class:`Model` of the shipped rule ``neural:NAME`` (or ``NAME``).

    Raises:
        MorphogenError: no such rule, listing the shipped ones.
    """
    from morphogen.models.neural import load_neural_model

    rule = _rule(name)
    model = load_neural_model(FOLDER / f"{rule}.npz")
    info = record(rule)
    text = info.get("description", rule)
    text = text if isinstance(text, str) else rule
    iters = info.get("iterations")
    iters = iters if isinstance(iters, int) and not isinstance(iters, bool) else None
    trained = f", {iters} training iterations" if iters else ""
    return replace(
        model,
        name=PREFIX + rule,
        description=f"neural RD rule trained on {text} (Mordvintsev et al.{trained})",
    )


def describe_rule(name: str) -> str:
    """A few lines about a shipped rule for ``morphogen models``, from its record alone (no
    weights are loaded, so listing stays fast)."""
    rule = _rule(name)
    info = record(rule)
    settings = info.get("settings", {})
    settings = settings if isinstance(settings, dict) else {}
    n, h = settings.get("channels", "?"), settings.get("hidden", "?")
    lines = [
        f"{PREFIX}{rule}: neural RD rule trained on {info.get('description', rule)}",
        f"  species: x0..x{n - 1 if isinstance(n, int) else '?'} ({n} channels, {h} hidden "
        "units; shown as RGB x0..x2)",
        "  parameters: r=1, d=1",
        "  suggested: dt=1, time=2000, init=blobs",
        f"  trained: {info.get('iterations', '?')} iterations of the {info.get('preset', '?')} "
        f"preset in {info.get('seconds', '?')} s, final loss {_number(info.get('final_loss'))}",
        "  reference: Mordvintsev, Randazzo & Niklasson, eq. 1",
    ]
    return "\n".join(lines)


def _number(value: object) -> str:
    return f"{value:.3g}" if isinstance(value, int | float) else "?"
