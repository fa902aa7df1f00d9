"""The Mesh page's case studies: the flower pipelines of Ringham et al. (2021) §4, run as the
command line runs them.

``GET /api/mesh/cases`` lists the pipelines ``morphogen gallery flowers`` finds
(:func:`morphogen.flowers.case_studies.find_flowers`: ``examples/flowers/*.toml`` and the two older
mesh pipelines) with their names and §4 sections. ``POST /api/mesh/cases`` ``{"name"}`` reads the
file (:func:`morphogen.flowers.pipeline.load_pipeline`: a bad file is refused at once) and queues a
job
that runs it with :func:`morphogen.flowers.pipeline.run_pipeline` into a temporary directory, the
same stages and outputs as ``morphogen pipeline run``. Progress comes from the pipeline's ``report``
calls: stage ``k`` of ``n``, the share of that stage done, and an overall share in which each
simulation stage counts equally and the other stages (meshing, positional information,
fields, points, veins: seconds) count nothing, so the job's ETA follows the simulations. A
cancel stops the run after the compiled chunk in progress (250 steps) or, in a stage that does
not simulate, when it ends; the temporary directory is removed whatever happens.

The result is what the command leaves: ``final.ply`` (every field, and the vertex colours of
the last stage when it colours the mesh) and the ``out.png`` of the last stage that drew a
picture (job files ``out.ply`` and ``out.png``, for download), and the mesh's vertices, faces
and those colours for the page's 3D viewer (from the last picture stage's own ``out.ply`` when
``final.ply`` has none). The server's examples folder is ``create_app(examples=...)``
(``morphogen serve --examples DIR``), so tests can run a tiny pipeline of their own.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from fastapi import APIRouter, Request

from morphogen.errors import MorphogenError
from morphogen.web.jobs import Job, Progress
from morphogen.web.limits import JSONBody

router = APIRouter(prefix="/api/mesh/cases")


def _flowers(request: Request) -> list:
    from morphogen.flowers.case_studies import find_flowers

    return find_flowers(request.app.state.examples)


def overall(kinds: list[str], stage: int, share: float) -> float:
    """The share of a pipeline done when stage ``stage`` (1-based) of the stages ``kinds`` is
    ``share`` done: simulation stages weigh 1 each, the others 0 (all 1 when none simulates)."""
    weights = [1.0 if k == "simulate" else 0.0 for k in kinds]
    if not any(weights):
        weights = [1.0] * len(kinds)
    return (sum(weights[:stage - 1]) + weights[stage - 1] * share) / sum(weights)


RGB = ("red", "green", "blue")


def _last_picture(out: Path) -> Path:
    """The directory of the last stage that drew ``out.png``."""
    record = json.loads((out / "pipeline.json").read_text())
    for stage in reversed(record["stages"]):
        if (out / stage["dir"] / "out.png").is_file():
            return out / stage["dir"]
    raise MorphogenError("the pipeline drew no picture: give a stage show = ... to see it")


def _coloured_ply(out: Path, shown: Path) -> tuple[Path, np.ndarray]:
    """``final.ply`` and its vertex colours ``(V, 3)`` uint8, or the picture stage's own
    ``out.ply`` when the last stage left ``final.ply`` uncoloured."""
    from morphogen.domains.ply import ply_fields

    for path in (out / "final.ply", shown / "out.ply"):
        fields = ply_fields(path) if path.is_file() else {}
        if all(c in fields for c in RGB):
            rgb = np.stack([fields[c] for c in RGB], axis=1)
            return path, np.rint(255 * rgb).astype(np.uint8)
    raise MorphogenError("the pipeline's last stage leaves the mesh uncoloured: give it "
                         "show = ... to see it")


@router.get("")
async def cases(request: Request) -> dict[str, Any]:
    """The case studies: ``[{name, section, caption}]`` in the order of their sections."""
    return {"cases": [{"name": f.name, "section": f.section, "caption": f.caption}
                      for f in _flowers(request)]}


@router.post("")
async def start(request: Request, body: JSONBody) -> dict[str, str]:
    """Queue the case study ``body["name"]``; returns ``{"job": id}``."""
    from morphogen.flowers.pipeline import load_pipeline

    flowers = {f.name: f for f in _flowers(request)}
    name = body.get("name")
    if name not in flowers:
        raise MorphogenError(f"unknown case study {name!r}; choose from {', '.join(flowers)}")
    flower = flowers[name]
    spec = load_pipeline(flower.path)
    kinds = [stage["kind"] for stage in spec["stage"]]

    def work(job: Job, progress: Progress) -> dict[str, Any]:
        from morphogen.flowers.pipeline import run_pipeline

        progress(0.0, f"{flower.caption}: building the mesh")
        started = time.perf_counter()

        def report(k: int, n: int, share: float) -> None:
            label = spec["stage"][k - 1].get("name", kinds[k - 1])
            progress(overall(kinds, k, share),
                     f"{flower.caption}: stage {k} of {n} ({label}), {100 * share:.0f} %")

        with tempfile.TemporaryDirectory(prefix="morphogen-case-") as tmp:
            out = Path(tmp) / name
            mesh = run_pipeline(spec, out, report=report)
            shown = _last_picture(out)
            ply, colours = _coloured_ply(out, shown)
            job.files["out.ply"] = (ply.read_bytes(), "application/octet-stream")
            job.files["out.png"] = ((shown / "out.png").read_bytes(), "image/png")
        base = f"/api/jobs/{job.id}/files"
        return {
            "name": name, "caption": flower.caption, "stage": shown.name,
            "ply": f"{base}/out.ply", "png": f"{base}/out.png", "image": f"{base}/out.png",
            "vertices": np.round(np.asarray(mesh.vertices, np.float32), 4).ravel().tolist(),
            "faces": np.asarray(mesh.faces, np.int32).ravel().tolist(),
            "colours": colours.ravel().tolist(),
            "n_vertices": int(mesh.n_vertices), "n_faces": int(mesh.n_faces),
            "wall_time_s": round(time.perf_counter() - started, 3),
        }

    job = request.app.state.jobs.submit("case study", work,
                                        timeout_s=request.app.state.limits.case_study_timeout_s)
    return {"job": job.id}
