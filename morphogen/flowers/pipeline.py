"""Multi-stage mesh pipelines (Ringham et al. fig. 4, §3.4.5), described in TOML.

A pipeline names a mesh and a list of stages. Every stage reads the mesh's per-vertex fields
and adds fields of its own, so an earlier stage's output becomes a later stage's prepattern:
parameters, initial values, boundary values or the anisotropy direction. ::

    [mesh]
    shape = "tube"                # petal | corolla | tube (morphogen.flowers), or file = "x.ply"
    lobes = 5
    edge = 0.08                   # mean edge of the final mesh, after scale
    scale = 4.0                   # optional uniform scale of the generated shape

    [[stage]]                     # positional information: g = 1 on the margin, 0 at the throat
    kind = "positional"
    field = "g"
    sources = "margin"
    sinks = "throat"

    [[stage]]                     # any field from expressions of fields and x, y, z
    kind = "fields"
    fields = { alpha = "lerp(13.5, 16.25, g**10)" }
    show = "alpha"                # optional: render this field to out.png with cmap

    [[stage]]                     # random points (density by rejection, §3.4.4)
    kind = "points"
    field = "seeds"
    count = 80
    density = "g"

    [[stage]]                     # veins by space colonisation (§3.4.1): fields vein,
    kind = "veins"                # vein_thickness, vein_distance; graph in veins.npz
    seeds = "base"                # a vertex set or an expression (> 0.5 is a seed)
    points = 4000                 # attraction points; optional influence, kill, step (mesh
    iterations = 400              # units), density, gamma, tip_radius, seed, refill, birth,
                                  # min_branch, same_piece, venation ("open" or "closed")

    [[stage]]                     # a simulation: any library model or model file
    kind = "simulate"
    model = "kohleria.toml"
    steps = 6000
    dt = 0.2
    directions = "g"              # anisotropy frame: the gradient of field g (eq. 18)
    omega = 1e6                   # optional stochastic diffusion (eq. 17)
    params = { alpha = "alpha" }  # numbers or expressions of fields
    initial = { a = "where(seeds > 0, seeds, a)" }  # per species; may read the species' values
                                  # from init and same-named fields
    boundary = { u = "dirichlet=0@margin" }

In a simulation stage, fields an earlier stage made and named like a species are its initial
values, those named like a parameter its values per vertex; the mesh's own fields (a PLY file's,
a generated shape's) only where ``params`` names them or a ``fields`` stage copies them (``fields
= { v = "v" }``), never by their name alone. The final state's species become fields
(renamed with ``outputs = { v = "v1" }``). Each stage writes ``DIR/NN-NAME/`` (``out.ply``,
``out.png``, ``fields.npz``, ``stage.json``); ``DIR/final.ply`` holds every field and
``DIR/pipeline.json`` a record. With ``resume``, stages whose ``stage.json`` matches and whose
``fields.npz`` exists, and which ``pipeline.json`` lists as finished, are not recomputed;
``pipeline.json`` is written after every stage with ``"status": "partial"`` (and the stage
that failed, if one did) and ends as ``"done"``. A front end follows a run with
``report(k, n, share)`` (stage ``k`` of ``n``, the share of it done) and stops it by raising
from that call.
"""

from __future__ import annotations

import json
import time
import tomllib
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError
from morphogen.flowers.stages import run_stage
from morphogen.models.text import toml_text
from morphogen.util.io import (
    check_out_name,
    ensure_writable_dir,
    read_text,
    write_json,
    write_npz,
)

KINDS = ("positional", "fields", "points", "veins", "simulate")
_KEYS = {
    "positional": {"field", "sources", "sinks", "source_value", "sink_value", "decay", "cmap"},
    "fields": {"fields", "show", "cmap"},
    "points": {"field", "count", "density", "low", "high", "seed"},
    "veins": {"seeds", "points", "influence", "kill", "step", "iterations", "density", "gamma",
              "tip_radius", "seed", "refill", "birth", "min_branch", "same_piece", "show",
              "cmap", "venation"},
    "simulate": {"model", "preset", "steps", "time", "dt", "seed", "init", "init_options",
                 "params", "initial", "boundary", "directions", "omega", "outputs", "show",
                 "cmap", "unsafe", "scheme", "rtol", "atol"},
}
_COMMON = {"kind", "name", "view"}
_INTEGERS = {"count", "seed", "points", "iterations", "refill", "steps"}
"""Stage keys whose value is a whole number."""
_NUMBERS = {"source_value", "sink_value", "decay", "low", "high", "influence", "kill", "step",
            "tip_radius", "birth", "min_branch", "gamma", "time", "dt", "omega", "rtol", "atol"}
"""Stage keys whose value is a finite number."""
_TABLES = {"params", "initial", "boundary", "outputs", "init_options", "fields"}
"""Stage keys whose value is a table."""


def load_pipeline(path: str | Path) -> dict[str, Any]:
    """Read and check a pipeline file; returns ``{"mesh": {...}, "stage": [...], "base": dir}``."""
    p = Path(path)
    try:
        data = toml_text.loads(read_text(p, "pipeline file"))
    except tomllib.TOMLDecodeError as exc:
        raise MorphogenError(f"pipeline file {p}: {exc}") from None
    extra = set(data) - {"mesh", "stage", "seed", "cmap", "view"}
    if extra:
        raise MorphogenError(f"pipeline file {p}: unknown keys {sorted(extra)}; use [mesh] and "
                             "[[stage]] tables")
    if not isinstance(data.get("mesh"), dict):
        raise MorphogenError(f"pipeline file {p} needs a [mesh] table (shape = ... or file = ...)")
    stages = data.get("stage", [])
    if not isinstance(stages, list) or not stages:
        raise MorphogenError(f"pipeline file {p} has no [[stage]] tables")
    for i, stage in enumerate(stages, 1):
        if not isinstance(stage, dict):
            raise MorphogenError(f"stage {i}: write each stage as a [[stage]] table")
        kind = stage.get("kind")
        if kind not in KINDS:
            raise MorphogenError(f"stage {i}: kind must be one of {', '.join(KINDS)}, got {kind!r}")
        unknown = set(stage) - _KEYS[kind] - _COMMON
        if unknown:
            raise MorphogenError(f"stage {i} ({kind}): unknown keys {sorted(unknown)}; allowed: "
                                 f"{', '.join(sorted(_KEYS[kind] | _COMMON))}")
        check_stage_values(stage, f"stage {i} ({kind})")
    return {**data, "base": p.parent}


def check_stage_values(stage: Mapping[str, Any], where: str) -> None:
    """Refuse a stage value of the wrong type before anything runs: whole numbers
    (``steps``, ``count``, ...), finite numbers (``dt``, ``decay``, ...), tables (``params``,
    ``initial``, ...), and a ``model`` for a simulation."""
    for key, value in stage.items():
        number = isinstance(value, int | float) and not isinstance(value, bool)
        if key in _INTEGERS and not (number and isinstance(value, int)):
            raise MorphogenError(f"{where}: {key} must be an integer, got {value!r}")
        if key in _NUMBERS and not (number and np.isfinite(value)):
            raise MorphogenError(f"{where}: {key} must be a finite number, got {value!r}")
        if key in _TABLES and not isinstance(value, dict):
            raise MorphogenError(f"{where}: {key} must be a table {{ name = value, ... }}, "
                                 f"got {value!r}")
    if stage.get("kind") == "simulate" and not isinstance(stage.get("model"), str):
        raise MorphogenError(f"{where}: a simulate stage needs model = NAME or a model file")


def build_mesh(spec: Mapping[str, Any], base: Path = Path(".")) -> Mesh:
    """The mesh of a ``[mesh]`` table: ``file = "x.ply"`` or ``shape = ...`` with the
    generator's keyword arguments, and an optional uniform ``scale``. ``edge`` is the mean edge
    of the final mesh, after ``scale`` (as ``morphogen mesh make --edge``); a shape whose
    estimated vertex count is absurd is refused before meshing
    (:func:`morphogen.flowers.sizing.make_shape`)."""
    from morphogen import flowers
    from morphogen.domains.ply import load_mesh
    from morphogen.flowers.sizing import make_shape

    args = dict(spec)
    scale = args.pop("scale", 1.0)
    if "file" in args:
        mesh = load_mesh(base / args.pop("file"))
        if args:
            raise MorphogenError(f"[mesh] with file takes only scale; got {sorted(args)}")
        if scale != 1.0:
            if isinstance(scale, bool) or not isinstance(scale, int | float) or not (
                    np.isfinite(scale) and scale > 0):
                raise MorphogenError(f"[mesh] scale must be positive, got {scale!r}")
            mesh = mesh.replace(vertices=mesh.vertices * float(scale))
        return mesh
    shape = args.pop("shape", None)
    if shape not in flowers.SHAPES:
        raise MorphogenError(f"[mesh] needs file = ... or shape = one of "
                             f"{', '.join(flowers.SHAPES)}")
    try:
        return make_shape(shape, edge=args.pop("edge", 0.02), scale=scale, **args)
    except MorphogenError as exc:
        raise MorphogenError(f"[mesh] {exc}") from None


def run_pipeline(
    pipeline: Mapping[str, Any] | str | Path,
    out: str | Path,
    *,
    resume: bool = False,
    progress: bool = False,
    pictures: bool = True,
    report: Callable[[int, int, float], None] | None = None,
) -> Mesh:
    """Run every stage in order; returns the mesh with all fields. Outputs are described in the
    module docstring; with ``pictures=False`` no stage renders its ``out.png`` or writes its
    ``out.ply`` (for timing and tests), ``final.ply`` is still written.

    ``report(k, n, share)`` is called as stage ``k`` of ``n`` starts (``share`` 0) and ends
    (1), and in a simulation stage after every compiled chunk of steps (the share of its steps
    done); an exception it raises stops the pipeline there (a server's cancel button)."""
    from morphogen.domains.ply import save_ply

    spec = load_pipeline(pipeline) if isinstance(pipeline, str | Path) else pipeline
    for i, stage in enumerate(spec["stage"], 1):
        check_stage_values(stage, f"stage {i} ({stage.get('kind')})")
    out_path = check_out_name(out)
    if out_path.exists() and not out_path.is_dir():
        raise MorphogenError(f"output {out_path} exists and is not a directory; choose another "
                             "--out")
    mesh = build_mesh(spec["mesh"], Path(spec.get("base", ".")))  # before creating anything
    done = _finished_stages(out_path) if resume else set()
    existed = out_path.exists()
    out_dir = ensure_writable_dir(out_path)
    record: dict[str, Any] = {"status": "partial",
                              "mesh": {"vertices": mesh.n_vertices, "faces": mesh.n_faces,
                                       **{k: v for k, v in spec["mesh"].items()}}, "stages": []}
    colours = None
    made: set[str] = set()
    count = len(spec["stage"])
    for i, stage in enumerate(spec["stage"], 1):
        share = None if report is None else (lambda f, k=i: report(k, count, f))
        if share is not None:
            share(0.0)
        name = stage.get("name", stage["kind"])
        stage_dir = out_dir / f"{i:02d}-{_slug(name)}"
        started = time.perf_counter()
        cached = _cached(stage_dir, stage) if stage_dir.name in done else None
        info: dict[str, Any] = {"name": name, "kind": stage["kind"], "dir": stage_dir.name}
        if cached is not None:
            fields, info["resumed"] = cached, True
        else:
            fresh = not stage_dir.exists()
            ensure_writable_dir(stage_dir)
            try:
                fields, extra, colours = run_stage(stage, mesh, spec, stage_dir, progress,
                                                   pictures, share, made)
            except BaseException as exc:
                _mark_partial(out_dir, stage_dir, fresh, not existed, record, i, exc)
                raise
            info.update(extra)
            write_npz(stage_dir / "fields.npz", fields)
            write_json(stage_dir / "stage.json", stage)
        mesh = mesh.with_fields(**fields)
        made.update(fields)
        info.update(fields=sorted(fields), seconds=round(time.perf_counter() - started, 3))
        record["stages"].append(info)
        write_json(out_dir / "pipeline.json", record)  # the stages finished so far
        if share is not None:
            share(1.0)
    save_ply(out_dir / "final.ply", mesh, colours=colours)
    write_json(out_dir / "pipeline.json", {**record, "status": "done"})
    return mesh


def _finished_stages(out: Path) -> set[str]:
    """The stage folders an earlier run in ``out`` finished, by its ``pipeline.json`` (a run
    that stopped part-way records ``"status": "partial"`` and the stages it finished); a
    folder without that record has none to reuse."""
    try:
        record = json.loads(read_text(out / "pipeline.json", "pipeline record", 2**20))
        return {str(s["dir"]) for s in record["stages"] if not s.get("failed")}
    except (MorphogenError, ValueError, KeyError, TypeError, AttributeError):
        return set()


def _mark_partial(out_dir: Path, stage_dir: Path, fresh: bool, made_out: bool,
                  record: dict[str, Any], index: int, exc: BaseException) -> None:
    """After stage ``index`` failed: remove its folder if this run made it, and record the run
    as partial (the stages finished, the one that failed) in ``pipeline.json``, so the
    outputs left are marked and ``--resume`` knows what it can reuse. A run in a new folder
    that failed in its first stage leaves nothing."""
    import shutil

    if fresh:
        shutil.rmtree(stage_dir, ignore_errors=True)
    if not record["stages"] and made_out:
        try:
            out_dir.rmdir()
        except OSError:
            pass
        return
    reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    write_json(out_dir / "pipeline.json",
               {**record, "failed": {"stage": index, "dir": stage_dir.name, "error": reason}})


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "-" for c in name)


def _cached(stage_dir: Path, stage: Mapping[str, Any]) -> dict[str, np.ndarray] | None:
    try:
        same = json.loads((stage_dir / "stage.json").read_text()) == json.loads(
            json.dumps(stage))
        if not same:
            return None
        from morphogen.util.npz import read_npz

        return read_npz(stage_dir / "fields.npz", "stage fields")  # the one checked reader
    except (OSError, ValueError, MorphogenError):
        return None  # a damaged stage is run again
