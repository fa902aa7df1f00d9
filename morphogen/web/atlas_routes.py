"""The Atlas page: a map over two parameters computed as one batched run.

``POST /api/atlas`` validates the request (its cost is bounded by ``Limits.max_cell_steps``),
queues a job and returns its id. The job is :func:`morphogen.runs.atlas.compute_atlas`, the same
single batched program as ``morphogen atlas``: every ``(x, y)`` pair is one member of a vmapped
batch. The tiles share one colour scale (as in the command's mosaic) and are laid out in one
image without labels: tile ``(i, j)`` (row ``i`` from the top, column ``j``) sits at pixel
``(pad + j (tile + pad), pad + i (tile + pad))``, so the page maps a click to a tile exactly and
draws the axes itself. Row 0 is the largest ``y`` (``y`` grows upwards, as on a plot).

A tile that blew up or ended in a grid-scale checkerboard is numerically unstable at the
atlas's ``dt``, not a pattern: ``valid`` is false there, the mosaic hatches it
(:func:`morphogen.web.batch.hatch`) and ``unstable`` is the one-line report of
:func:`morphogen.runs.atlas.instability_report` (the page counts those tiles and names them on
hover).

With ``"families": true`` the atlas keeps each tile's last states and names its pattern family
(Richard et al. §5.2.2, fig. 9) with the functions of ``morphogen atlas --classify``:
:func:`morphogen.runs.atlas.classify_atlas` on the shown species, each tile framed in its family's
colour (:data:`morphogen.patterns.classify.COLOURS`) and ``families.csv`` written by
:func:`morphogen.runs.atlas.write_families`. The temporal descriptors see ``WATCH + 1`` states
``min(50, steps // WATCH)`` steps apart at the end of the run (the command's default ``4x50``
when the run has 200 steps or more).
"""

from __future__ import annotations

import tempfile
from functools import lru_cache
from pathlib import Path
from typing import Any

import imageio.v3 as iio
import numpy as np
from fastapi import APIRouter, Request

from morphogen.domains.grid import Grid
from morphogen.errors import MorphogenError
from morphogen.patterns.classify import COLOURS, FAMILIES, GRID_ENERGY
from morphogen.runs.atlas import (
    Atlas,
    Axis,
    classify_atlas,
    compute_atlas,
    instability_report,
    plan_atlas,
    write_families,
)
from morphogen.web import batch
from morphogen.web.catalog import check_params, resolve_model
from morphogen.web.jobs import Job, Progress
from morphogen.web.limits import JSONBody, Limits, check_budget, integer, number
from morphogen.web.settings import read_settings

router = APIRouter(prefix="/api/atlas")

PAD = 1
WATCH = 4
"""``COUNT`` of the classifier's ``--watch COUNTxGAP``: ``COUNT + 1`` states kept at the end."""


def parse_axis(spec: Any, model_params: dict[str, float], which: str, limits: Limits) -> dict:
    """``{"name", "lo", "hi", "n"}`` validated against the model's parameters."""
    if not isinstance(spec, dict):
        raise MorphogenError(f"atlas axis {which} must be {{name, lo, hi, n}}")
    name = spec.get("name")
    if name not in model_params:
        raise MorphogenError(
            f"atlas axis {which}: unknown parameter {name!r}; parameters are "
            + ", ".join(model_params)
        )
    lo = number(spec.get("lo"), f"{which} from", -1e6, 1e6)
    hi = number(spec.get("hi"), f"{which} to", -1e6, 1e6)
    if hi <= lo:
        raise MorphogenError(f"atlas axis {which}: 'to' must be larger than 'from'")
    n = integer(spec.get("n", 8), f"{which} tiles", 1, limits.max_tiles_per_axis)
    return {"name": name, "lo": lo, "hi": hi, "n": n,
            "values": np.linspace(lo, hi, n).tolist() if n > 1 else [lo]}


@lru_cache(maxsize=1)
def _grid_energy():
    """The jitted grid-scale energy of a batch of fields, built once (run op by op instead,
    the descriptor took 12 s for six 16² tiles on 2 cores; compiled, 0.4 s, then microseconds)."""
    import jax

    from morphogen.patterns.descriptors import describe

    return jax.jit(jax.vmap(lambda f: describe(f)["grid_energy"]))


def _grid_scale(fields: np.ndarray) -> np.ndarray:
    """Tiles whose power sits at grid scale (a checkerboard: a numerical instability, not a
    pattern), by the classifier's rule (:data:`morphogen.patterns.classify.GRID_ENERGY`)."""
    return np.asarray(_grid_energy()(np.nan_to_num(fields))) > GRID_ENERGY


@router.post("")
async def start(request: Request, body: JSONBody):
    """Validate an atlas request and queue it; returns ``{"job": id}``."""
    lim: Limits = request.app.state.limits
    spec = body.get("model", {"library": "gray-scott"})
    model, _ = resolve_model(spec, lim)
    base = model.parameters(check_params(read_settings(body, ("params",))["params"], model))
    x = parse_axis(body.get("x"), base, "x", lim)
    y = parse_axis(body.get("y"), base, "y", lim)
    if x["name"] == y["name"]:
        raise MorphogenError("the two atlas axes must be different parameters")
    run = batch.settings(body, model, base, lim, tile_default=64)
    grid = Grid((run["tile"], run["tile"]), dx=run["dx"], boundary=run["boundary"],
                stencil=run["stencil"])
    axes = (Axis(x["name"], np.asarray(x["values"])), Axis(y["name"], np.asarray(y["values"])))
    plan = plan_atlas(model, grid, *axes, params=base, dt=run["dt"], steps=run["steps"])
    run.update(dt=plan.dt, steps=plan.steps)  # the run policy's, as the command line's
    check_budget(run["tile"] ** 2, run["steps"], x["n"] * y["n"], lim)
    cmap = read_settings(body, ("cmap",), defaults={"cmap": "viridis"})["cmap"]
    families = body.get("families", False)
    if not isinstance(families, bool):
        raise MorphogenError("families must be true or false")
    if families and run["steps"] < WATCH:
        raise MorphogenError(f"naming pattern families needs at least {WATCH} steps (the last "
                             "states show whether a pattern still moves); run longer")
    watch = (WATCH, min(50, run["steps"] // WATCH)) if families else None

    def work(job: Job, progress: Progress) -> dict[str, Any]:
        n_runs = x["n"] * y["n"]
        what = f"simulating {n_runs} runs at once, {run['steps']} steps each"
        progress(0.0, f"{what} (compiling)")
        done = 0

        def chunk(n: int) -> None:  # a cancel or the deadline stops the run between chunks
            nonlocal done
            done += n
            progress(done / max(run["steps"], 1), f"{what}: step {done}")

        atlas = compute_atlas(
            model, grid, *axes, params=base, steps=run["steps"], dt=run["dt"],
            init=run["init"], seed=run["seed"], on_chunk=chunk, watch=watch,
        )
        progress(1.0, f"{n_runs} runs in {atlas.wall_time:.1f} s")
        # rows from the top: largest y first
        states = atlas.states[::-1].reshape(n_runs, *atlas.states.shape[2:])
        shown = model.species_index(run["species"])
        named = None
        if families:  # the descriptors include the grid-scale energy of the final states
            progress(1.0, f"{n_runs} runs in {atlas.wall_time:.1f} s; naming their families")
            labels, descriptors = classify_atlas(atlas, shown)
            named = _families(job, atlas, labels, descriptors)
            energy = np.nan_to_num(descriptors["grid_energy"][::-1].reshape(-1))
            grid_scale = energy > GRID_ENERGY
        else:
            grid_scale = _grid_scale(states[:, shown])
        grid_scale = grid_scale.reshape(y["n"], x["n"]) | atlas.unstable[::-1]
        valid = atlas.valid[::-1] & ~grid_scale
        image = batch.mosaic(states, model, run["species"], cmap, (y["n"], x["n"]), PAD,
                             valid=valid.reshape(-1),
                             labels=None if named is None else np.ravel(named["labels"]),
                             colours=COLOURS)
        job.files["atlas.png"] = (iio.imwrite("<bytes>", image, extension=".png"), "image/png")
        return {
            "families": named,
            "image": f"/api/jobs/{job.id}/files/atlas.png",
            "x": x, "y": y, "tile": run["tile"], "pad": PAD,
            "valid": valid.tolist(), "grid_scale": int(grid_scale.sum()),
            "unstable": instability_report(atlas),
            "wall_time_s": round(atlas.wall_time, 3),
            "model": spec, "model_name": model.name, "params": base,
            "dt": run["dt"], "steps": run["steps"], "init": run["init"], "seed": run["seed"],
            "dx": run["dx"], "boundary": run["boundary"], "stencil": run["stencil"],
        }

    job = request.app.state.jobs.submit("atlas", work)
    return {"job": job.id}


def _families(job: Job, atlas: Atlas, labels: np.ndarray,
              descriptors: dict[str, np.ndarray]) -> dict[str, Any]:
    """Each tile's family (rows from the top, as the mosaic), the count and colour of every
    family found (in :data:`~morphogen.patterns.classify.FAMILIES` order), and ``families.csv``
    among the job's files, exactly as ``morphogen atlas --classify`` writes it, from
    :func:`morphogen.runs.atlas.classify_atlas`'s ``(NY, NX)`` labels and descriptors."""
    with tempfile.TemporaryDirectory() as tmp:
        path = write_families(Path(tmp) / "families.csv", atlas, labels, descriptors)
        job.files["families.csv"] = (path.read_bytes(), "text/csv")
    counts = {f: int((labels == f).sum()) for f in FAMILIES if (labels == f).any()}
    return {"labels": labels[::-1].tolist(), "counts": counts,
            "colours": {f: COLOURS[f] for f in counts},
            "csv": f"/api/jobs/{job.id}/files/families.csv"}
