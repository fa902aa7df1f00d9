"""What leaves the Explore page with its state: a **checkpoint** and a **web page**.

- ``GET state.npz``: the whole live state, painted strokes included, one float32 array per
  species: ``morphogen simulate --config run.json --init state.npz`` continues from it, and
  ``POST state`` (the same file, base64) puts it back into a live view (one undo step).
- ``GET page.html``: the live view as one self-contained HTML page that runs in WebGL2 without
  the server (``morphogen export-web``, :mod:`morphogen.runs.web_page`), starting from the state
  as it is now; its settings are those of the page's run file
  (:func:`morphogen.web.downloads.run_config`).
"""

from __future__ import annotations

import base64
import binascii
import io
import json

import numpy as np
from fastapi import APIRouter, Request
from fastapi.responses import Response

from morphogen.engine.initial import load_state
from morphogen.errors import MorphogenError
from morphogen.runs.config import RunConfig
from morphogen.runs.web_page import export_page
from morphogen.web import downloads
from morphogen.web.limits import JSONBody, number, run_limited

router = APIRouter(prefix="/api/live")


@router.get("/{sid}/page.html")
async def web_page(request: Request, sid: str):
    """The exported page (a download); a setting it cannot run is refused in one line."""
    sim = request.app.state.sessions.get(sid)
    lim = request.app.state.limits

    def build() -> str:
        config = RunConfig.from_dict(json.loads(downloads.run_config(sim))["config"])
        state = np.asarray(sim.state(), np.float32)
        return export_page(config, state)

    page = await run_limited(build, lim.request_timeout_s, "writing the web page")
    name = "".join(c if c.isalnum() or c in "-_." else "_" for c in sim.describe()["model"])
    return Response(page, media_type="text/html",
                    headers={"Content-Disposition": f'attachment; filename="{name}.html"'})


MAX_CHECKPOINT_BYTES = 64 * 2**20
"""Largest checkpoint accepted (4 species of 512 x 512 float64 and more fit)."""


@router.get("/{sid}/state.npz")
async def checkpoint(request: Request, sid: str):
    """The live state as ``state.npz`` (a download): one float32 array per species; its time
    in the ``X-Morphogen-Time`` header (the page keeps it, to put it back after a restart)."""
    sim = request.app.state.sessions.get(sid)
    state, t = sim.snapshot()
    buf = io.BytesIO()
    np.savez(buf, **dict(zip(sim.engine.model.species, state, strict=True)))
    name = "".join(c if c.isalnum() or c in "-_." else "_" for c in sim.describe()["model"])
    return Response(buf.getvalue(), media_type="application/octet-stream",
                    headers={"Content-Disposition": f'attachment; filename="{name}-state.npz"',
                             "X-Morphogen-Time": repr(t)})


@router.post("/{sid}/state")
async def restore(request: Request, sid: str, body: JSONBody):
    """Put a checkpoint back: ``{npz: base64, t: time}`` (``t`` optional: the checkpoint's
    time, a finite number >= 0), read by the engine's safe state loader (no pickles; one finite
    array of the grid's shape per species); undone like a stroke."""
    sim = request.app.state.sessions.get(sid)
    text = body.get("npz")
    if not isinstance(text, str) or len(text) > MAX_CHECKPOINT_BYTES * 4 // 3 + 4:
        raise MorphogenError("send the checkpoint as {\"npz\": base64 text} of at most 64 MiB")
    try:
        raw = base64.b64decode(text, validate=True)
    except (binascii.Error, ValueError):
        raise MorphogenError("the checkpoint is not base64 text") from None
    # every array checked by its header (dtype, the grid's shape) before it is read: 4xx, one line
    state = load_state(raw, sim.engine.model.species, tuple(sim.engine.grid.shape),
                       what="the checkpoint")
    t = body.get("t")
    if t is not None:
        t = number(t, "t", 0.0, 1e30)
    left = sim.load_state(np.asarray(state, np.float32), t)
    return {"ok": True, "undo": left}
