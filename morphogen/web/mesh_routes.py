"""The Mesh page: a pattern grown on a procedural flower mesh, viewed in 3D.

``POST /api/mesh`` queues a job that builds a corolla or a single petal
(:mod:`morphogen.flowers.shapes`), scales it so that one mesh unit is about one grid cell (the
library's parameters assume ``dx = 1``), simulates a library model on it
(:func:`morphogen.engine.simulate.simulate` with the mesh as the domain, Ringham et al. §3.4) and
returns the vertices, faces and per-vertex colours for the page's rotatable canvas, plus a
still image from :func:`morphogen.render.mesh.render_mesh`.

It is Ringham et al.'s modelling loop (§3.3, §5) in the browser: a *prepattern* painted on the
flower is a named vertex field (a species' starting value at its vertices: sources and sinks; or
a parameter's value there: production) applied by :func:`morphogen.domains.ply.apply_fields`, as a
PLY field is for the CLI; the simulation runs in segments and each segment's colours are served
as ``live.bin`` (the flower as ``geometry.json``) while the job runs, so the page watches the
pattern grow; a request naming an earlier job (``from``) continues its final state with new
parameters instead of restarting; and the result is downloadable as the ``out.ply`` /
``out.png`` pair that
:func:`morphogen.render.mesh_outputs.write_mesh_outputs` writes for ``morphogen pipeline``.
"""

from __future__ import annotations

import io
import json
import tempfile
from pathlib import Path
from typing import Any

import imageio.v3 as iio
import numpy as np
from fastapi import APIRouter, Request

from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate
from morphogen.errors import MorphogenError
from morphogen.render.colour import colourise
from morphogen.runs.policy import resolve_run
from morphogen.web.catalog import check_params, resolve_model
from morphogen.web.jobs import Job, Progress
from morphogen.web.limits import JSONBody, Limits, check_budget, choice, integer, number
from morphogen.web.settings import INITIAL_KINDS, read_settings

router = APIRouter(prefix="/api/mesh")

SHAPES = ("corolla", "petal")
MAX_VERTICES = 20_000
MAX_ACROSS = 160.0
"""Bound on ``size * detail`` (vertices across the flower), checked before meshing: a corolla
has about ``0.7 (size * detail)^2`` vertices."""


def build_mesh(shape: str, petals: int, size: float, detail: float):
    """A flower mesh ``size`` units across with about ``detail`` vertices per unit length."""
    from morphogen.flowers.shapes import corolla, petal

    if shape == "corolla":
        mesh = corolla(petals, radius=1.0, edge=2.0 / (size * detail))
        scale = size / 2.0
    else:
        mesh = petal(length=1.0, width=0.7, edge=1.0 / (size * detail))
        scale = size
    if mesh.n_vertices > MAX_VERTICES:
        raise MorphogenError(
            f"the mesh has {mesh.n_vertices} vertices, more than {MAX_VERTICES}; "
            "lower the size or the detail"
        )
    return mesh.replace(vertices=np.asarray(mesh.vertices) * scale)


SIZE_RANGE = (20.0, 240.0)
DETAIL_RANGE = (0.2, 1.5)
SEGMENTS = 8
"""Pieces the simulation is cut into, each one's colours shown live (one compile serves all)."""
MESH_SETTINGS = ("params", "dt", "seed", "init", "species", "cmap")
"""The run settings a Mesh request takes from its body (``steps`` follows ``dt``; the mesh's
own ``size`` and ``detail`` are not the grid's)."""


def check_paint(paint: Any, model) -> tuple[str, float, list[int]] | None:
    """``paint`` is ``{"name": species or parameter, "value": number, "vertices": [indices]}``
    (checked before the job is queued); ``None`` without paint."""
    if not paint:
        return None
    if not isinstance(paint, dict):
        raise MorphogenError("paint must be an object {name, value, vertices}")
    name = paint.get("name")
    if name not in model.species and name not in model.params:
        raise MorphogenError(f"paint names {name!r}; paint a species ({', '.join(model.species)}) "
                             f"or a parameter ({', '.join(model.params)})")
    value = number(paint.get("value"), "paint value", -1e6, 1e6)
    idx = paint.get("vertices") or []
    if not isinstance(idx, list) or not all(isinstance(i, int) and i >= 0 for i in idx):
        raise MorphogenError("paint vertices must be a list of vertex indices")
    return name, value, idx


def prepattern(paint: tuple[str, float, list[int]] | None, model, values: dict,
               n_vertices: int) -> dict[str, np.ndarray]:
    """The painted vertex field ``{name: (V,) float32}`` (``{}`` without paint): the painted
    vertices take the value; elsewhere a parameter keeps its value, and a species is NaN (its
    starting state is kept there, see :func:`seed_state`)."""
    if paint is None:
        return {}
    name, value, idx = paint
    if idx and max(idx) >= n_vertices:
        raise MorphogenError(f"paint vertices must be below {n_vertices}; paint again after "
                             "growing the flower")
    base = float(np.mean(values[name])) if name in model.params else np.nan
    field = np.full(n_vertices, base, np.float32)
    field[idx] = value
    return {name: field}


def seed_state(u0: np.ndarray, model, fields: dict[str, np.ndarray]) -> np.ndarray:
    """A species' painted field replaces its starting state where painted (NaN elsewhere)."""
    u = np.array(u0, np.float32, copy=True)
    for i, s in enumerate(model.species):
        if s in fields:
            u[i] = np.where(np.isnan(fields[s]), u[i], fields[s])
    return u


def pipeline_files(mesh, model, state: np.ndarray, cmap: str, species: str) -> dict:
    """``out.ply`` and ``out.png`` exactly as ``morphogen pipeline`` writes a stage's mesh."""
    from morphogen.render.mesh_outputs import write_mesh_outputs

    with tempfile.TemporaryDirectory() as tmp:
        ply, png = write_mesh_outputs(tmp, mesh, model, state, cmap, species=species)
        return {"out.ply": (Path(ply).read_bytes(), "application/octet-stream"),
                "out.png": (Path(png).read_bytes(), "image/png")}


@router.get("/limits")
async def limits() -> dict:
    """The bounds the Mesh page checks before asking: size, detail and size x detail."""
    return {"size": SIZE_RANGE, "detail": DETAIL_RANGE, "max_across": MAX_ACROSS}


@router.post("")
async def start(request: Request, body: JSONBody):
    """Validate a mesh request and queue it; returns ``{"job": id}``."""
    lim: Limits = request.app.state.limits
    spec = body.get("model", {"library": "gray-scott"})
    model, _ = resolve_model(spec, lim)
    run = read_settings(body, MESH_SETTINGS, defaults={
        "cmap": "magma", "species": model.display_species,
        "init": model.init if model.init in INITIAL_KINDS else "noise"})
    values = model.parameters(check_params(run["params"], model))
    shape = choice(body.get("shape", "corolla"), "shape", SHAPES)
    petals = integer(body.get("petals", 5), "petals", 2, 12)
    size = number(body.get("size", 120), "size", *SIZE_RANGE)
    detail = number(body.get("detail", 0.7), "detail", *DETAIL_RANGE)
    if size * detail > MAX_ACROSS:
        raise MorphogenError(
            f"size x detail is {size * detail:g}; the server allows {MAX_ACROSS:g} "
            f"(about 18 000 vertices): with detail {detail:g} the size can be at most "
            f"{int(MAX_ACROSS / detail)}"
        )
    given_dt = run["dt"]
    given_steps = read_settings(body, ("steps",))["steps"]
    init, seed, cmap, species = run["init"], run["seed"], run["cmap"], run["species"]
    index = model.species_index(species)
    paint = check_paint(body.get("paint"), model)
    previous = None
    if body.get("from"):
        earlier = request.app.state.jobs.get(str(body["from"]))
        if "state.npy" not in earlier.files:
            raise MorphogenError("that flower has no final state to continue; grow it first")
        previous = np.load(io.BytesIO(earlier.files["state.npy"][0]))
        if previous.shape[0] != len(model.species):
            raise MorphogenError("continue needs the same model; grow a new flower instead")

    def work(job: Job, progress: Progress) -> dict[str, Any]:
        progress(0.0, "building the mesh")
        mesh = build_mesh(shape, petals, size, detail)
        if previous is not None and previous.shape[1] != mesh.n_vertices:
            raise MorphogenError("continue needs the same flower (shape, petals, size, "
                                 "detail); grow a new one instead")
        fields = prepattern(paint, model, values, mesh.n_vertices)
        mesh = mesh.replace(fields={k: v for k, v in fields.items() if k in model.params})
        from morphogen.domains.ply import apply_fields

        u0 = previous if previous is not None else make_initial(init, model, mesh, values,
                                                                 seed=seed)
        u0, run_values = apply_fields(model, mesh, seed_state(u0, model, fields), values)
        # the run policy, as the command line's: the model's dt within the mesh's stability
        # limit unless given, steps to the model's t_end unless given
        plan = resolve_run(model, mesh, run_values, dt=given_dt, steps=given_steps)
        step_dt, steps = plan.dt, plan.steps
        check_budget(mesh.n_vertices, steps, 1, lim)
        vertices = np.asarray(mesh.vertices, np.float32)
        faces = np.asarray(mesh.faces, np.int32)
        job.files["geometry.json"] = (json.dumps({
            "vertices": np.round(vertices, 3).ravel().tolist(),
            "faces": faces.ravel().tolist()}).encode(), "application/json")
        u = u0
        wall = 0.0
        for i in range(SEGMENTS):
            n = steps * (i + 1) // SEGMENTS - steps * i // SEGMENTS
            if n == 0:
                continue
            sol = simulate(model, mesh, u, run_values, steps=n, dt=step_dt, seed=seed + i,
                           clamp=model.clamp)
            u, wall = sol.state, wall + sol.wall_time
            job.files["live.bin"] = (colourise(np.asarray(u[index], np.float64), cmap)
                                     .tobytes(), "application/octet-stream")
            progress(0.05 + 0.85 * (i + 1) / SEGMENTS,
                     f"step {steps * (i + 1) // SEGMENTS} of {steps} on {mesh.n_vertices} vertices")
        field = np.asarray(u[index], np.float64)
        rgb = colourise(field, cmap)
        progress(0.9, "rendering")
        from morphogen.render.mesh import render_mesh

        image = render_mesh(vertices, faces, rgb, view="oblique", size=(640, 640),
                            background="#15171c")
        job.files["mesh.png"] = (iio.imwrite("<bytes>", image, extension=".png"), "image/png")
        buf = io.BytesIO()
        np.save(buf, np.asarray(u, np.float32))
        job.files["state.npy"] = (buf.getvalue(), "application/octet-stream")
        job.files.update(pipeline_files(mesh, model, np.asarray(u), cmap, species))
        return {
            "image": f"/api/jobs/{job.id}/files/mesh.png",
            "ply": f"/api/jobs/{job.id}/files/out.ply",
            "png": f"/api/jobs/{job.id}/files/out.png",
            "job": job.id, "painted": sorted(fields),
            "vertices": np.round(vertices, 3).ravel().tolist(),
            "faces": faces.ravel().tolist(),
            "colours": rgb.ravel().tolist(),
            "n_vertices": int(mesh.n_vertices), "n_faces": int(mesh.n_faces),
            "model": model.name, "species": species, "steps": steps, "dt": step_dt,
            "range": [float(np.nanmin(field)), float(np.nanmax(field))],
            "wall_time_s": round(wall, 3),
        }

    job = request.app.state.jobs.submit("mesh", work)
    return {"job": job.id}
