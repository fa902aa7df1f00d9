"""A run as data: :class:`RunConfig`, and ``run.json`` to reproduce it exactly.

``run.json`` holds the whole configuration (model name or the model file's text, parameter
overrides, domain, dt, steps, scheme, seed, initial condition, noise, clamp, rendering) plus
provenance (package versions, device, wall time). ``morphogen simulate --config run.json``
rebuilds the same :class:`RunConfig` (:func:`load_run_file`) and so the same state, bit for bit
on the same machine. :mod:`morphogen.runs.prepare` resolves it into objects and
:mod:`morphogen.runs.execute` runs it and writes its files.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, fields
from functools import partial
from pathlib import Path
from typing import Any

from morphogen.errors import MorphogenError
from morphogen.runs.schema import validate_config
from morphogen.runs.settings import default
from morphogen.util.io import read_bytes

FORMAT = "morphogen-run/1"
SNAPSHOTS = 241
"""Snapshots a run with ``every`` keeps at most (``simulate``'s ``max_snapshots`` + 1)."""


def _from_dict(cls: type, data: dict[str, Any]) -> Any:
    """Rebuild a config from ``run.json``'s ``config`` object (unknown keys are an error)."""
    if not isinstance(data, dict):
        raise MorphogenError("run file: 'config' must be an object")
    known = {f.name for f in fields(cls)}
    unknown = sorted(set(data) - known)
    if unknown:
        raise MorphogenError(f"run file has unknown settings {unknown}")
    if "model" not in data:
        raise MorphogenError("run file lacks the 'model' setting")
    validate_config(data, "run file")
    return cls(**data)


@dataclass
class RunConfig:
    """Everything that determines a simulation and its pictures: one field per row of
    :data:`morphogen.runs.settings.SETTINGS`, in its order, with its type and default
    (``tests/runs/test_settings_table.py`` checks that they agree, and prints the lines to paste
    when a row is added).

    ``steps`` or ``time`` may be ``None``: the model's suggested ``t_end`` and ``dt`` fill in
    (the suggested ``dt`` is reduced to 90 % of the stability limit when the domain needs it).
    ``clamp`` is ``"model"`` (the model's own bounds), ``None`` or ``[lo, hi]``.
    :meth:`from_dict` rebuilds a config from ``run.json``'s ``config`` object (unknown keys are
    an error).
    """

    model: str
    model_source: str | None = None
    preset: str | None = None
    params: dict[str, Any] = field(default_factory=partial(default, "params"))
    size: list[int] = field(default_factory=partial(default, "size"))
    mesh: str | None = None
    mesh_fields: list[str] = field(default_factory=partial(default, "mesh_fields"))
    dx: float = 1.0
    boundary: Any = "periodic"
    stencil: int | str | None = None
    dt: float | None = None
    steps: int | None = None
    time: float | None = None
    scheme: str = "euler"
    rtol: float | None = None
    atol: float | None = None
    seed: int = 0
    init: str | None = None
    init_options: dict[str, Any] = field(default_factory=partial(default, "init_options"))
    noise: dict[str, Any] | None = None
    clamp: Any = "model"
    every: int | None = None
    species: str | None = None
    cmap: str | None = None
    vmin: float | None = None
    vmax: float | None = None
    threshold: float | None = None
    fps: float = 12.0
    animation: str = "gif"
    unsafe: bool = False
    precision: str = "float32"

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RunConfig:
        """The config of ``run.json``'s ``config`` object (unknown keys are an error)."""
        return _from_dict(cls, data)


def load_run_file(path: str | Path) -> RunConfig:
    """Read ``run.json`` (as written by :func:`execute`) into a :class:`RunConfig`."""
    try:
        if not Path(path).exists():
            raise MorphogenError(f"cannot read run file {path}: No such file or directory")
        data = json.loads(read_bytes(path, "run file").decode("utf-8-sig"))
    except UnicodeDecodeError:
        raise MorphogenError(f"run file {path} is not UTF-8 text (is it a run.json?)") from None
    except RecursionError:
        raise MorphogenError(f"run file {path} is nested too deeply") from None
    except json.JSONDecodeError as exc:
        raise MorphogenError(
            f"run file {path} is not valid JSON: {exc.msg} (line {exc.lineno})"
        ) from None
    if not isinstance(data, dict) or not isinstance(data.get("config"), dict):
        raise MorphogenError(f"{path} is not a morphogen run file (no 'config' object)")
    if "format" in data:
        check_format(data["format"], f"run file {path}")
    return RunConfig.from_dict(data["config"])


def check_format(value: Any, where: str) -> None:
    """Refuse a ``format`` other than ``morphogen-run/N`` with ``N`` at most this version's
    (:data:`FORMAT`): a newer file may hold settings this version would misread. A run file
    without ``format`` (written by hand) is read as the current version."""
    name, _, version = FORMAT.partition("/")
    kind, _, number = value.partition("/") if isinstance(value, str) else ("", "", "")
    if kind != name or not number.isdigit() or not number.isascii():
        raise MorphogenError(f"{where} is not a morphogen run file (format {str(value)[:40]!r}, "
                             f"expected {FORMAT!r})")
    number = number.lstrip("0") or "0"
    if len(number) > 9 or int(number) > int(version):
        raise MorphogenError(f"{where} has format {value[:40]}, written by a newer morphogen; this "
                             f"one reads {FORMAT} and older: upgrade morphogen to replay it")
