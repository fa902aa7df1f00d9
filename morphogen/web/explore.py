"""HTTP and WebSocket routes of the Explore page (the live simulation).

Frames travel as binary messages: a 28-byte little-endian header
``(width u16, height u16, frame u32, t f32, steps u32, lo f32, hi f32, compute_ms f32)``
followed by ``width * height`` bytes of the shown species quantised to 0-255 (row 0 at the top).
The page pulls one frame at a time over a WebSocket (send ``"next"``, receive a frame), which
keeps at most one frame in flight per tab; ``GET .../frame`` serves the same bytes for polling.
"""

from __future__ import annotations

import math
import struct
from typing import Any

from fastapi import APIRouter, Request, WebSocket, WebSocketDisconnect
from fastapi.responses import JSONResponse, Response

from morphogen.errors import MorphogenError
from morphogen.util import guard
from morphogen.web import downloads
from morphogen.web.image_input import RESAMPLING, decode_png, image_field
from morphogen.web.limits import JSONBody, OptionalBody, choice, integer, number, run_limited
from morphogen.web.live import Frame, LiveSim
from morphogen.web.recording import FORMATS
from morphogen.web.settings import read_settings

router = APIRouter(prefix="/api/live")

HEADER = struct.Struct("<HHIfIfff")
"""Frame header: width, height, frame number, t, steps, lo, hi, compute time (ms)."""
MAX_STROKE = 64
"""Points in one paint request (a drag is sent in pieces)."""
MAX_PNG_SIDE = 4096
"""Largest side of a downloaded PNG in pixels."""


def encode_frame(f: Frame) -> bytes:
    """Header + pixels of a :class:`Frame` (see the module docstring)."""
    h, w = f.pixels.shape
    head = HEADER.pack(w, h, f.frame, f.t, f.steps, f.lo, f.hi, 1000.0 * f.compute_s)
    return head + f.pixels.tobytes()


def _sim(request_or_ws: Request | WebSocket, sid: str) -> LiveSim:
    return request_or_ws.app.state.sessions.get(sid)


LIVE_SETTINGS = ("params", "preset", "size", "dx", "boundary", "stencil", "scheme", "seed",
                 "init")
"""The run settings a live view takes from its request body (``height`` is its own)."""


async def _configure(request: Request, sim: LiveSim, body: dict[str, Any]) -> dict[str, Any]:
    lim = request.app.state.limits

    def configure() -> dict[str, Any]:
        run = read_settings(body, LIVE_SETTINGS, defaults={"size": 256},
                            bounds={"size": (lim.min_size, lim.max_size)})
        return sim.configure(body.get("model", {"library": "gray-scott"}),
                             height=body.get("height"), **run)

    return await run_limited(configure, lim.request_timeout_s, "setting up the model")


@router.post("")
async def create(request: Request, body: OptionalBody = None):
    """Start a live simulation for one tab; returns its id and settings."""
    body = body or {}
    store = request.app.state.sessions
    sid, sim = store.create()
    try:
        state = await _configure(request, sim, body)
    except MorphogenError:
        store.drop(sid)
        raise
    return {"id": sid, **state}


@router.get("/{sid}")
async def describe(request: Request, sid: str):
    return _sim(request, sid).describe()


@router.delete("/{sid}")
async def close(request: Request, sid: str):
    request.app.state.sessions.drop(sid)
    return {"ok": True}


@router.post("/{sid}/configure")
async def configure(request: Request, sid: str, body: JSONBody):
    """Change model, grid size or boundary (and reset)."""
    return await _configure(request, _sim(request, sid), body)


@router.post("/{sid}/params")
async def params(request: Request, sid: str, body: JSONBody):
    """Change parameter values (slider moves); never recompiles."""
    sim = _sim(request, sid)
    notices = sim.set_params(body.get("params", {}))
    if "dt" in body:
        notices += sim.set_dt(body["dt"])
    return {"notices": notices, **sim.describe()}


@router.post("/{sid}/view")
async def view(request: Request, sid: str, body: JSONBody):
    """Species shown, steps per frame, colour map, colour range (``"auto"`` or ``[lo, hi]``)."""
    sim = _sim(request, sid)
    sim.set_view(species=body.get("species"), steps_per_frame=body.get("steps_per_frame"),
                 cmap=body.get("cmap"), value_range=body.get("range"))
    return sim.describe()


@router.post("/{sid}/reset")
async def reset(request: Request, sid: str, body: OptionalBody = None):
    body = body or {}
    sim = _sim(request, sid)
    await run_limited(lambda: sim.reset(body.get("init", sim.init), body.get("seed", sim.seed)),
                      request.app.state.limits.request_timeout_s, "reset")
    return sim.describe()


@router.post("/{sid}/paint")
async def paint(request: Request, sid: str, body: JSONBody):
    """Paint discs at ``points`` (``[[x, y], ...]``, fractions of width and height); ``mode``
    excite / erase / value, optionally on one ``species`` only (see ``LiveSim.paint``)."""
    sim = _sim(request, sid)
    points = body.get("points")
    if not isinstance(points, list) or not points:
        raise MorphogenError("paint needs points: a list of [x, y] pairs in [0, 1]")
    if len(points) > MAX_STROKE:
        raise MorphogenError(f"at most {MAX_STROKE} points per paint request")
    for pt in points:
        if not isinstance(pt, list | tuple) or len(pt) != 2:
            raise MorphogenError("each paint point must be [x, y]")

    stroke = bool(body.get("stroke", False))

    def work():
        for i, (x, y) in enumerate(points):
            sim.paint(x, y, body.get("radius", 0.03), body.get("mode", "excite"),
                      stroke=stroke and i == 0, species=body.get("species"),
                      value=body.get("value"))

    await run_limited(work, request.app.state.limits.request_timeout_s, "painting")
    return {"ok": True, "undo": len(sim.undo_stack)}


@router.post("/{sid}/image")
async def image(request: Request, sid: str, body: JSONBody):
    """Start one species from an image: ``{png: base64, species, lo, hi}`` (grey levels mapped
    to ``lo..hi``, see :mod:`morphogen.web.image_input`); undone like a stroke."""
    sim = _sim(request, sid)
    grey = decode_png(body.get("png"))
    lo = number(body.get("lo", 0.0), "lo", -1e6, 1e6)
    hi = number(body.get("hi", 1.0), "hi", -1e6, 1e6)
    field = image_field(grey, tuple(sim.engine.grid.shape), lo, hi)
    left = sim.load_species(body.get("species"), field)
    return {"ok": True, "undo": left}


@router.post("/{sid}/map")
async def parameter_map(request: Request, sid: str, body: JSONBody):
    """A parameter as a spatial field from an image: ``{param, png: base64, lo, hi, resample}``
    (grey level ``g`` -> ``lo + (hi - lo) g``: ``lo`` at black, ``hi`` at white; ``resample``
    ``bilinear`` (default) or ``nearest``, see :mod:`morphogen.web.image_input`). Returns the
    notices (``dt`` lowered) and the settings, whose ``maps`` name the mapped parameters."""
    sim = _sim(request, sid)
    name = body.get("param")
    if not isinstance(name, str) or not name:
        raise MorphogenError("param must name the parameter the image maps")
    grey = decode_png(body.get("png"))
    lo = number(body.get("lo"), "the map's low value", -1e6, 1e6)
    hi = number(body.get("hi"), "the map's high value", -1e6, 1e6)
    if not hi > lo:
        raise MorphogenError(f"the map's high value (white) must be above its low value "
                             f"(black); got low {lo:g}, high {hi:g}")
    resample = choice(body.get("resample", "bilinear"), "resampling", RESAMPLING)
    notices = await run_limited(lambda: sim.set_map(name, grey, lo, hi, resample),
                                request.app.state.limits.request_timeout_s, "the parameter map")
    return {"notices": notices, **sim.describe()}


@router.delete("/{sid}/map/{name}")
async def clear_map(request: Request, sid: str, name: str):
    """The parameter is a number again (its slider value)."""
    sim = _sim(request, sid)
    return {"notices": sim.set_map(name, None), **sim.describe()}


@router.post("/{sid}/undo")
async def undo(request: Request, sid: str):
    """Undo the last brush stroke (a paint request with ``stroke: true`` starts one)."""
    left = _sim(request, sid).undo()
    return {"ok": True, "undo": left}


@router.get("/{sid}/probe")
async def probe(request: Request, sid: str, x: float, y: float):
    """Every species' value in the cell under ``(x, y)`` (fractions from the top left)."""
    return _sim(request, sid).probe(x, y)


@router.post("/{sid}/record")
async def record(request: Request, sid: str, body: JSONBody):
    """``{"on": true}`` starts recording the frames shown (forgetting earlier ones),
    ``{"on": false}`` stops; the recording stays for download."""
    sim = _sim(request, sid)
    if body.get("on"):
        sim.recorder.start()
    else:
        sim.recorder.stop()
    return sim.recorder.describe()


@router.get("/{sid}/recording")
async def recording(request: Request, sid: str, format: str = "gif", fps: int = 20,
                    every: int = 1):
    """The recorded frames as an animated GIF or an MP4 through the current colour map, at
    ``fps`` frames a second, each side reduced ``every`` (1 to 4) times."""
    sim = _sim(request, sid)
    fps = integer(fps, "fps", 1, 60)
    every = integer(every, "every", 1, 4)
    data = await run_limited(lambda: sim.recorder.encode(format, sim.cmap, fps, every),
                             request.app.state.limits.job_timeout_s, "encoding the recording")
    return Response(data, media_type=FORMATS[format],
                    headers=_attachment(f"{sim.describe()['model']}.{format}"))


@router.get("/{sid}/frame")
async def frame(request: Request, sid: str):
    """Advance one frame and return it as bytes (409 with a message after a blow-up)."""
    sim = _sim(request, sid)
    f = await run_limited(sim.frame, request.app.state.limits.request_timeout_s, "a frame")
    if sim.error:
        return JSONResponse({"error": sim.error}, status_code=409)
    return Response(encode_frame(f), media_type="application/octet-stream")


@router.websocket("/{sid}/ws")
async def stream(ws: WebSocket, sid: str):
    """Frames on demand: each text message ``next`` is answered with one binary frame (``show``:
    the current state, time not advanced), or with a JSON text message ``{"error": ...}`` when
    the simulation blew up or a frame failed."""
    await ws.accept()
    limits = ws.app.state.limits
    try:
        while True:
            message = await ws.receive()
            if message["type"] == "websocket.disconnect":
                return
            msg = message.get("text")
            if msg not in ("next", "show"):
                await ws.send_json({"error": "send 'next' (or 'show') to get a frame"})
                continue
            try:
                sim = _sim(ws, sid)
                make = sim.frame if msg == "next" else sim.still
                f = await run_limited(make, limits.request_timeout_s, "a frame")
            except MorphogenError as exc:
                await ws.send_json({"error": str(exc), "gone": not _exists(ws, sid)})
                continue
            if sim.error:
                await ws.send_json({"error": sim.error})
            else:
                await ws.send_bytes(encode_frame(f))
    except WebSocketDisconnect:
        return


def _exists(ws: WebSocket, sid: str) -> bool:
    try:
        ws.app.state.sessions.get(sid)
    except MorphogenError:
        return False
    return True


@router.get("/{sid}/png")
async def png(request: Request, sid: str, cmap: str | None = None, scale: int = 1):
    """The shown species as a PNG through the chosen colour map (a download), each cell
    ``scale`` x ``scale`` pixels (nearest neighbour, so cells stay sharp), at most
    ``MAX_PNG_SIDE`` pixels a side."""
    sim = _sim(request, sid)
    scale = integer(scale, "scale", 1, 16)
    side = max(sim.engine.grid.spatial_shape) * scale
    if side > MAX_PNG_SIDE:
        raise MorphogenError(f"a PNG {side} pixels wide is too large; the server allows "
                             f"{MAX_PNG_SIDE}: choose a scale of at most "
                             f"{max(1, MAX_PNG_SIDE // max(sim.engine.grid.spatial_shape))}")
    data = downloads.png_bytes(sim.field(), cmap or sim.cmap, scale)
    name = f"{sim.describe()['model']}.png"
    return Response(data, media_type="image/png", headers=_attachment(name))


@router.get("/{sid}/config")
async def config(request: Request, sid: str, steps: int | None = None):
    """A run file that ``morphogen simulate --config FILE`` accepts (a download)."""
    sim = _sim(request, sid)
    if steps is not None:
        cells = math.prod(sim.engine.grid.spatial_shape)
        guard.check_steps(integer(steps, "steps", 1, guard.LIMITS.steps), cells,
                          len(sim.engine.model.species))
    data = downloads.run_config(sim, steps)
    return Response(data, media_type="application/json",
                    headers=_attachment(f"{sim.describe()['model']}-run.json"))


def _attachment(name: str) -> dict[str, str]:
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in name)
    return {"Content-Disposition": f'attachment; filename="{safe}"'}
