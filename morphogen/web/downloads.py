"""Downloads: PNG pictures and run files that ``morphogen simulate --config`` accepts."""

from __future__ import annotations

import json
from typing import Any

import imageio.v3 as iio
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.render.colour import colourise
from morphogen.render.images import upscale
from morphogen.runs.settings import default


def png_bytes(field: np.ndarray, cmap: str, scale: int = 1) -> bytes:
    """A field ``(H, W)`` through colour map ``cmap`` as PNG bytes, enlarged ``scale`` times."""
    rgb = upscale(colourise(field, cmap), scale)
    return iio.imwrite("<bytes>", rgb, extension=".png")


def run_config(sim: Any, steps: int | None = None) -> bytes:
    """The ``run.json`` of a live simulation's settings (:mod:`morphogen.runs.config` format).

    ``steps`` defaults to the steps taken so far (at least 1000); running the file with
    ``morphogen simulate --config`` starts from the same initial condition and seed, so it
    reproduces what the page showed, strokes painted by hand aside. Pasted equations travel
    inside the file as ``model_source``; ``dx`` and ``stencil`` appear when they are not the
    defaults. A parameter map (an uploaded image) has no place in a
    run file: the file is refused while one is set.
    """
    from morphogen.runs.config import FORMAT

    d = sim.describe()
    if d.get("maps"):
        raise MorphogenError(f"parameter {', '.join(d['maps'])} is a map from an image, which a "
                             "run file cannot hold; clear the map to save a run file")
    n = int(steps) if steps is not None else max(1000, int(d["steps"]))
    config: dict[str, Any] = {
        "model": d["model"],
        "params": d["params"],
        "size": [d["height"], d["size"]],
        **({"dx": d["dx"]} if d["dx"] != default("dx") else {}),
        "boundary": d["boundary"],
        **({"stencil": d["stencil"]} if d["stencil"] != default("stencil") else {}),
        "scheme": d["scheme"],
        "dt": d["dt"],
        "steps": n,
        "seed": d["seed"],
        "init": d["init"],
        "species": d["show"],
        "cmap": d["cmap"],
    }
    source = sim.engine.model.source
    if source:
        config["model_source"] = source
    return (json.dumps({"format": FORMAT, "config": config}, indent=2) + "\n").encode()
