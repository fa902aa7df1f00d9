"""The stages of a mesh pipeline (:mod:`morphogen.flowers.pipeline`), one function per kind.

Each stage reads the mesh's per-vertex fields and returns fields of its own (Ringham et al.
fig. 4, §3.4.5): ``positional`` (eq. 21, positional information), ``fields`` (expressions of
fields and ``x, y, z``), ``points`` (§3.4.4 rejection sampling), ``veins`` (§3.4.1 space
colonisation, open or closed) and ``simulate`` (a model on the mesh, parameters and initial
values from fields). Field expressions are parsed by :mod:`morphogen.models.expr`, never
evaluated as Python.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError
from morphogen.util.io import write_npz


def evaluate(text: Any, mesh: Mesh) -> np.ndarray:
    """A number, or an expression of the mesh's fields and ``x, y, z`` -> ``(V,)`` float64."""
    from morphogen.models.expr import compile_expression

    if isinstance(text, int | float) and not isinstance(text, bool):
        return np.full(mesh.n_vertices, float(text))
    if not isinstance(text, str):
        raise MorphogenError(f"expected a number or an expression, got {text!r}")
    env = {**mesh.fields, **{k: mesh.vertices[:, i] for i, k in enumerate("xyz")}}
    expr = compile_expression(text, env, what="fields and x, y, z")
    out = np.broadcast_to(np.asarray(expr(env), np.float64), (mesh.n_vertices,)).copy()
    if not np.all(np.isfinite(out)):
        raise MorphogenError(f"expression {text!r} gives non-finite values")
    return out


def run_stage(stage, mesh: Mesh, spec, stage_dir: Path, progress: bool, pictures: bool,
              share: Callable[[float], None] | None = None, made: set[str] | None = None):
    """Returns ``(new fields, record entries, vertex colours or None)``; ``share(f)`` after
    each chunk of a simulation (the share of its steps done)."""
    from morphogen.flowers import positional_information, seed_field

    kind = stage["kind"]
    view = stage.get("view", spec.get("view", "oblique"))
    if kind == "positional":
        name = stage.get("field", "g")
        g = positional_information(
            mesh, stage.get("sources", "margin"), stage.get("sinks", "base"),
            source_value=float(stage.get("source_value", 1.0)),
            sink_value=float(stage.get("sink_value", 0.0)), decay=float(stage.get("decay", 0.0)))
        colours = _preview(stage_dir, mesh, g, stage.get("cmap", spec.get("cmap", "viridis")),
                           view, pictures)
        return {name: g}, {}, colours
    if kind == "fields":
        table = stage.get("fields", {})
        if not isinstance(table, dict) or not table:
            raise MorphogenError("a fields stage needs fields = { name = \"expression\", ... }")
        new: dict[str, np.ndarray] = {}
        for key, text in table.items():
            new[key] = evaluate(text, mesh.with_fields(**new))
        if "show" not in stage:
            return new, {}, None
        shown = evaluate(stage["show"], mesh.with_fields(**new))
        return new, {}, _preview(stage_dir, mesh, shown,
                                 stage.get("cmap", spec.get("cmap", "viridis")), view, pictures)
    if kind == "points":
        density = stage.get("density")
        f = None if density is None else evaluate(density, mesh)
        field = seed_field(mesh.n_vertices, int(stage.get("count", 100)), density=f,
                           low=float(stage.get("low", 1.0)), high=float(stage.get("high", 1.0)),
                           seed=int(stage.get("seed", spec.get("seed", 0))))
        return {stage.get("field", "points"): field}, {}, None
    if kind == "veins":
        return _veins_stage(stage, mesh, spec, stage_dir, view, pictures)
    return _simulate_stage(stage, mesh, spec, stage_dir, progress, pictures, share, made)


def grow_veins(stage: Mapping[str, Any], mesh: Mesh, seed: int = 0):
    """The vein graph and fields of a ``veins`` stage table (also used by ``mesh veins``)."""
    from morphogen.flowers.veins import vein_fields
    from morphogen.flowers.veins_closed import colonisation

    spec = stage.get("seeds")
    if not isinstance(spec, str) or not spec.strip():
        raise MorphogenError("a veins stage needs seeds = \"VERTEX SET\" or an expression, "
                             "e.g. seeds = \"base\"")
    if spec in mesh.vertex_set_names():
        seeds = mesh.vertex_set(spec)
    else:
        seeds = np.flatnonzero(evaluate(spec, mesh) > 0.5)
    if seeds.size == 0:
        raise MorphogenError(f"veins: seeds {spec!r} select no vertex")
    lengths = {k: float(stage[k]) for k in ("influence", "kill", "step", "tip_radius", "birth",
                                            "min_branch") if k in stage}
    density = stage.get("density")
    graph = colonisation(stage.get("venation", "open"))(
        mesh, seeds, points=_integer(stage, "points", 2000),
        iterations=_integer(stage, "iterations", 400), gamma=float(stage.get("gamma", 3.0)),
        density=None if density is None else evaluate(density, mesh),
        seed=_integer(stage, "seed", seed), refill=_integer(stage, "refill", 0),
        same_piece=bool(stage.get("same_piece", False)), **lengths)
    return graph, vein_fields(mesh, graph)


def _integer(stage: Mapping[str, Any], key: str, default: int) -> int:
    value = stage.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise MorphogenError(f"veins: {key} must be an integer, got {value!r}")
    return int(value)


def _veins_stage(stage, mesh: Mesh, spec, stage_dir: Path, view: Any, pictures: bool):
    """Veins: fields ``vein``, ``vein_thickness``, ``vein_distance``; ``veins.npz`` graph; a
    preview of ``show`` (default ``vein_distance``) with the veins drawn over it."""
    from morphogen.render.colour import colourise
    from morphogen.render.images import write_png
    from morphogen.render.mesh import overlay_veins, render_mesh

    graph, fields = grow_veins(stage, mesh, int(spec.get("seed", 0)))
    write_npz(stage_dir / "veins.npz", graph.arrays())
    shown = evaluate(stage.get("show", "vein_distance"), mesh.with_fields(**fields))
    colours = overlay_veins(colourise(shown, stage.get("cmap", spec.get("cmap", "viridis"))),
                            fields["vein"], fields["vein_thickness"])
    if pictures:
        write_png(stage_dir / "out.png", render_mesh(mesh.vertices, mesh.faces, colours,
                                                     view=view))
    from morphogen.flowers.veins import vein_statistics

    stats = vein_statistics(graph, float(mesh.areas.sum()))
    return fields, {"nodes": len(graph.nodes), "remaining_points": len(graph.remaining),
                    "max_order": int(graph.order.max()), "tips": stats["tips"],
                    "loops": stats["loops"], "stub_share": round(stats["stub_share"], 4),
                    "vein_length": round(stats["length"], 4),
                    "vein_spacing": round(stats["spacing"], 5)}, colours


def _simulate_stage(stage, mesh: Mesh, spec, stage_dir: Path, progress: bool, pictures: bool,
                    share: Callable[[float], None] | None = None,
                    made: set[str] | None = None):
    """One simulation: model, parameters and initial values from fields, then outputs. Fields
    named like a species or parameter are applied implicitly only when an earlier stage made
    them (``made``; ``None``: every field); a field of the ``[mesh]`` file is used only where
    ``params`` or ``initial`` name it."""
    from morphogen.domains.ply import apply_fields
    from morphogen.engine.initial import make_initial
    from morphogen.engine.simulate import simulate
    from morphogen.models.registry import load_model
    from morphogen.render.mesh_outputs import write_mesh_outputs
    from morphogen.solvers.policy import plan_run

    if "model" not in stage:
        raise MorphogenError("a simulate stage needs model = NAME or a model file")
    ref = str(stage["model"])
    base = Path(spec.get("base", "."))
    files = (".toml", ".ant", ".antimony", ".xml", ".sbml")
    model = load_model(str(base / ref) if ref.lower().endswith(files) else ref)
    domain = mesh.replace(boundary=stage.get("boundary", "neumann"), omega=stage.get("omega"))
    if "directions" in stage:
        domain = domain.replace(directions=domain.face_gradient(evaluate(stage["directions"],
                                                                         mesh)))
    values = model.parameters(preset=stage.get("preset"))
    seed = int(stage.get("seed", spec.get("seed", 0)))
    init = stage.get("init", model.init)
    u0 = make_initial(init, model, domain, values, seed=seed, **stage.get("init_options", {}))
    u0, values = apply_fields(model, domain, u0, values, names=made)
    for key, text in stage.get("params", {}).items():
        if key not in model.params:
            raise MorphogenError(f"unknown parameter {key!r} for model {model.name}")
        values[key] = text if isinstance(text, int | float) else evaluate(text, mesh)
    params = {k: np.asarray(v, np.float32) for k, v in values.items()}
    current = mesh.with_fields(**{s: u0[i] for i, s in enumerate(model.species)})
    for key, text in stage.get("initial", {}).items():
        u0[model.species_index(key)] = evaluate(text, current)
    given = stage.get("dt")
    plan = plan_run(model, domain, params, scheme=str(stage.get("scheme", "euler")),
                    dt=None if given is None else float(given),
                    steps=int(stage["steps"]) if "steps" in stage else None,
                    t_end=float(stage["time"]) if "time" in stage else None,
                    unsafe=bool(stage.get("unsafe", False)), rtol=stage.get("rtol"),
                    atol=stage.get("atol"))
    dt, steps = plan.dt, plan.steps
    done = 0

    def chunk(n: int) -> None:
        nonlocal done
        done += n
        share(done / max(steps, 1))

    sol = simulate(model, domain, u0, params, steps=steps, dt=dt, seed=seed, progress=progress,
                   unsafe=bool(stage.get("unsafe", False)),
                   scheme=plan.scheme, rtol=stage.get("rtol"),
                   atol=stage.get("atol"), on_chunk=None if share is None else chunk)
    write_npz(stage_dir / "state.npz", {s: sol.state[i] for i, s in enumerate(model.species)})
    show = stage.get("show", model.display_species)
    if pictures:
        write_mesh_outputs(stage_dir, domain, model, sol.state,
                           stage.get("cmap", spec.get("cmap", "viridis")), species=show,
                           view=stage.get("view", spec.get("view", "oblique")))
    from morphogen.render.colour import colourise

    colours = colourise(sol.state[model.species_index(show)],
                        stage.get("cmap", spec.get("cmap", "viridis")))
    rename = stage.get("outputs", {})
    fields = {rename.get(s, s): sol.state[i] for i, s in enumerate(model.species)}
    return fields, {"model": model.name, "steps": steps, "dt": dt, "t": sol.t,
                    "wall_time": round(sol.wall_time, 3)}, colours


def _preview(stage_dir: Path, mesh: Mesh, values: np.ndarray, cmap: Any, view: Any,
             pictures: bool = True):
    from morphogen.render.colour import colourise
    from morphogen.render.images import write_png
    from morphogen.render.mesh import render_mesh

    colours = colourise(values, cmap)
    if pictures:
        write_png(stage_dir / "out.png", render_mesh(mesh.vertices, mesh.faces, colours,
                                                     view=view))
    return colours
