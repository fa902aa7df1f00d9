"""The Explore page's Match panel: from a picture to the models, parameters and scale that grow a
pattern like it (:func:`morphogen.match.match`, docs/match.md), as a background job.

``GET /api/match`` lists the models that have a search box (:data:`morphogen.match.BOXES`), the
ones tried by default, and the bounds of the options. ``POST /api/match`` takes ``{"image":
base64 PNG or JPEG, "models": [...], "budget", "minutes", "top", "polarity", "channel",
"seed"}``; the picture is checked in the request, before anything is queued: the upload's size
(:data:`~morphogen.web.image_input.MAX_IMAGE_BYTES`, and the server's body limit), the pixels its
header announces (refused before decoding), then the match's own checks (at least 24² pixels,
not blank), so a bad upload is refused at once in one line. The search then runs as a job (one
job at a time, under ``Limits.job_timeout_s``), its progress the simulations done out of about
``budget + top + 1`` and the target's description; a cancel stops it after the simulation in
progress. The defaults keep it short: the smallest budget (:data:`DEFAULT_BUDGET` simulations)
and a minute of searching.

The result names the target (family, wavelength in the picture's pixels) and each candidate,
best first: model, searched parameters, grid spacing ``dx``, grid, ``dt``, the replay's family
and descriptor distance to the picture, its picture (job file ``candidate_K.png``, grey as
``morphogen match`` draws it) and its ``run.json`` object, which the page opens in Explore (model,
parameters, ``dx``, grid, ``dt``, initial condition and seed). ``sheet.png`` is the answer sheet
(target | best | next best) as ``morphogen match`` writes it.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from fastapi import APIRouter, Request

from morphogen.errors import MorphogenError
from morphogen.web.jobs import Job, Progress
from morphogen.web.limits import JSONBody, choice, integer, number, run_limited

router = APIRouter(prefix="/api/match")

DEFAULT_BUDGET = 8
"""The smallest budget :func:`morphogen.match.match` takes: a few populations, about a minute."""
MAX_BUDGET = 96
"""The command's default budget; more is for the command line."""
DEFAULT_MINUTES = 1.0
MAX_MINUTES = 3.0
"""Searching time at most, leaving the job's limit (5 minutes) for the verification runs."""
PICTURE_SIDE = 192
"""Side of a candidate's picture (the centre square of its replay)."""


def options() -> dict[str, Any]:
    """The models that can be matched and the bounds of the options (the panel's controls)."""
    from morphogen.match import BOXES, CHANNELS, DEFAULT_MODELS, POLARITIES

    return {"models": list(BOXES), "default_models": list(DEFAULT_MODELS),
            "budget": {"default": DEFAULT_BUDGET, "min": DEFAULT_BUDGET, "max": MAX_BUDGET},
            "minutes": {"default": DEFAULT_MINUTES, "min": 0.1, "max": MAX_MINUTES},
            "top": {"default": 3, "min": 1, "max": 6},
            "polarities": list(POLARITIES), "channels": list(CHANNELS)}


def parse_options(body: dict[str, Any]) -> dict[str, Any]:
    """The match's keyword arguments from a request; one-line errors for bad values."""
    from morphogen.match import BOXES, CHANNELS, DEFAULT_MODELS, POLARITIES

    models = body.get("models", list(DEFAULT_MODELS))
    if (not isinstance(models, list) or not models or len(models) > len(BOXES)
            or len(set(map(str, models))) != len(models)):
        raise MorphogenError(f"models must be a list of 1 to {len(BOXES)} different names from "
                             + ", ".join(BOXES))
    for name in models:
        choice(name, "model", list(BOXES))
    return {
        "models": list(models),
        "budget": integer(body.get("budget", DEFAULT_BUDGET), "budget", DEFAULT_BUDGET,
                          MAX_BUDGET),
        "minutes": number(body.get("minutes", DEFAULT_MINUTES), "minutes", 0.1, MAX_MINUTES),
        "top": integer(body.get("top", 3), "candidates", 1, 6),
        "polarity": choice(body.get("polarity", "auto"), "polarity", POLARITIES),
        "channel": choice(body.get("channel", "auto"), "channel", CHANNELS),
        "seed": integer(body.get("seed", 0), "seed", 0, 2**31 - 1),
    }


def _finite(x: float, digits: int = 4) -> float | None:
    """A number for JSON (which has no NaN): rounded, or ``None`` when not finite."""
    return round(float(x), digits) if math.isfinite(float(x)) else None


def _plain(obj: Any) -> Any:
    """``obj`` with NumPy scalars and arrays as Python numbers and lists, and every non-finite
    number as ``None`` (a run file's summary may hold NaN, which JSON cannot)."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple | np.ndarray):
        return [_plain(v) for v in obj]
    if isinstance(obj, bool | np.bool_):
        return bool(obj)
    if isinstance(obj, int | np.integer):
        return int(obj)
    if isinstance(obj, float | np.floating):
        return float(obj) if math.isfinite(float(obj)) else None
    return obj


def _png(rgb: np.ndarray) -> bytes:
    import imageio.v3 as iio

    return iio.imwrite("<bytes>", np.asarray(rgb, np.uint8), extension=".png")


@router.get("")
async def describe():
    """The Match panel's choices: models, defaults and bounds."""
    return options()


@router.post("")
async def start(request: Request, body: JSONBody) -> dict[str, Any]:
    """Check the picture and options, then queue the match; returns ``{"job", "picture"}``."""
    from morphogen.match import load_picture
    from morphogen.web.image_input import picture_bytes

    lim = request.app.state.limits
    opts = parse_options(body)

    def check() -> tuple[bytes, tuple[int, int]]:
        # the upload's bytes, decoded and reduced by the match itself (memory follows its
        # work size, not the picture's)
        data, size = picture_bytes(body.get("image"))
        load_picture(data, channel=opts["channel"])  # too small or blank: refused now
        return data, size

    rgb, (width, height) = await run_limited(check, lim.request_timeout_s, "reading the picture")

    def work(job: Job, progress: Progress) -> dict[str, Any]:
        from morphogen.match import match
        from morphogen.match.answer import grey_tile, sheet

        said: list[str] = []
        job.expected_s = 60.0 * opts["minutes"]  # the search's limit: the time left counts down
        progress(0.0, "describing the picture")

        def report(done: int, total: int) -> None:
            target = f"{said[0]}; " if said else ""
            progress(min(done / total, 0.99), f"{target}{done} of about {total} simulations")

        started = time.perf_counter()
        result = match(rgb, **opts, log=said.append, report=report)
        base = f"/api/jobs/{job.id}/files"
        candidates = []
        for k, c in enumerate(result.candidates, start=1):
            job.files[f"candidate_{k}.png"] = (_png(grey_tile(c.replay, c.invert, PICTURE_SIDE)),
                                               "image/png")
            candidates.append(_plain({
                "rank": k, "model": c.model, "params": c.params, "dx": c.dx,
                "size": list(c.size), "dt": c.dt, "steps": c.steps, "seed": c.seed,
                "init": c.init, "invert": c.invert, "family": c.family,
                "distance": _finite(c.replay_distance), "search_distance": _finite(c.distance),
                "texture": _finite(c.texture), "wavelength_px": _finite(c.wavelength_px, 2),
                "image": f"{base}/candidate_{k}.png", "run": c.run,
            }))
        picture = load_picture(rgb, channel=opts["channel"])
        job.files["sheet.png"] = (_png(sheet(picture.rgb, result.target, result.scale,
                                             result.candidates, "match")), "image/png")
        target = result.target
        return {
            "target": {"family": target.family,
                       "wavelength_px": _finite(target.wavelength * result.scale, 2)},
            "candidates": candidates, "simulations": len(result.samples),
            "seconds": round(time.perf_counter() - started, 1), "sheet": f"{base}/sheet.png",
            "models": opts["models"], "budget": opts["budget"],
        }

    job = request.app.state.jobs.submit("match", work)
    return {"job": job.id, "picture": {"width": int(width), "height": int(height)}}
