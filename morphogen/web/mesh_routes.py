"""The Mesh page: a pattern grown on a procedural flower mesh, viewed in 3D.

``POST /api/mesh`` queues a job that builds a corolla or a single petal
(:mod:`morphogen.flowers.shapes`), scales it so that one mesh unit is about one grid cell (the
library's parameters assume ``dx = 1``), simulates a library model on it
(:func:`morphogen.simulate.simulate` with the mesh as the domain, Ringham et al. §3.4) and
returns the vertices, faces and per-vertex colours for the page's rotatable canvas, plus a
still image from :func:`morphogen.render.mesh.render_mesh`.
"""

from __future__ import annotations

from typing import Any

import imageio.v3 as iio
import numpy as np
from fastapi import APIRouter, Request

from morphogen.errors import MorphogenError
from morphogen.initial import make_initial
from morphogen.render.colour import colourise
from morphogen.simulate import simulate
from morphogen.steppers import max_stable_dt
from morphogen.web.batch import colour_map
from morphogen.web.catalog import check_params, resolve_model
from morphogen.web.jobs import Job, Progress
from morphogen.web.limits import JSONBody, Limits, check_budget, choice, integer, number
from morphogen.web.live import INITIAL_KINDS

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
    values = model.parameters(check_params(body.get("params"), model))
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
    given_dt = body.get("dt")
    dt = model.dt if given_dt is None else number(given_dt, "dt", 1e-6, 1e3)
    steps = integer(body.get("steps", round(model.t_end / dt)), "steps", 1, 200_000)
    init = choice(body.get("init") or (model.init if model.init in INITIAL_KINDS else "noise"),
                  "initial condition", INITIAL_KINDS)
    seed = integer(body.get("seed", 0), "seed", 0, 2**31 - 1)
    cmap = colour_map(body.get("cmap", "magma"))
    species = body.get("species") or model.display_species
    index = model.species_index(species)

    def work(job: Job, progress: Progress) -> dict[str, Any]:
        progress(0.0, "building the mesh")
        mesh = build_mesh(shape, petals, size, detail)
        check_budget(mesh.n_vertices, steps, 1, lim)
        # the model's dt, lowered below the mesh's explicit stability limit unless given
        step_dt = dt if given_dt is not None else min(
            dt, 0.95 * max_stable_dt(model, mesh, values))
        progress(0.05, f"simulating {steps} steps on {mesh.n_vertices} vertices")
        u0 = make_initial(init, model, mesh, values, seed=seed)
        sol = simulate(model, mesh, u0, values, steps=steps, dt=step_dt, seed=seed,
                       clamp=model.clamp)
        field = np.asarray(sol.state[index], np.float64)
        rgb = colourise(field, cmap)
        progress(0.9, "rendering")
        from morphogen.render.mesh import render_mesh

        vertices = np.asarray(mesh.vertices, np.float32)
        faces = np.asarray(mesh.faces, np.int32)
        image = render_mesh(vertices, faces, rgb, view="oblique", size=(640, 640),
                            background="#15171c")
        job.files["mesh.png"] = (iio.imwrite("<bytes>", image, extension=".png"), "image/png")
        return {
            "image": f"/api/jobs/{job.id}/files/mesh.png",
            "vertices": np.round(vertices, 3).ravel().tolist(),
            "faces": faces.ravel().tolist(),
            "colours": rgb.ravel().tolist(),
            "n_vertices": int(mesh.n_vertices), "n_faces": int(mesh.n_faces),
            "model": model.name, "species": species, "steps": steps, "dt": step_dt,
            "range": [float(np.nanmin(field)), float(np.nanmax(field))],
            "wall_time_s": round(sol.wall_time, 3),
        }

    job = request.app.state.jobs.submit("mesh", work)
    return {"job": job.id}
