"""Read-only routes shared by every page: models, model descriptions, colour maps."""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import Response

from morphogen.errors import MorphogenError
from morphogen.solvers.registry import LIVE, SCHEMES
from morphogen.web.catalog import describe, library_names, resolve_model
from morphogen.web.limits import JSONBody
from morphogen.web.live import STEP_CHOICES
from morphogen.web.recording import colour_table
from morphogen.web.settings import INITIAL_KINDS

router = APIRouter(prefix="/api")

COLORMAPS = (
    "viridis", "magma", "inferno", "plasma", "cividis", "twilight", "turbo", "gray", "bone",
    "copper", "pink", "ocean", "coolwarm", "RdBu_r", "Spectral", "PuOr", "YlGnBu", "cubehelix",
)
"""Colour maps listed in the pages' menus (any matplotlib name or colour ramp is accepted)."""
MAX_CMAP_CHARS = 200


@router.get("/models")
async def models():
    """Library models (name and one-line description) and the menus' choices."""
    from morphogen.models.library import get_model

    out = []
    for name in library_names():
        m = get_model(name)
        out.append({"name": name, "description": m.description, "species": list(m.species)})
    return {
        "models": out,
        "colormaps": list(COLORMAPS),
        "init_kinds": list(INITIAL_KINDS),
        "step_choices": list(STEP_CHOICES),
        "schemes": list(LIVE),
        "scheme_costs": {n: dict(zip(("periodic", "neumann"), SCHEMES[n].live_cost,
                                     strict=True)) for n in LIVE},
    }


@router.get("/models/{name}")
async def model(request: Request, name: str):
    """Parameters (with slider ranges), species and presets of a library model."""
    m, _ = resolve_model({"library": name}, request.app.state.limits)
    return describe(m)


@router.post("/models/parse")
async def parse(request: Request, body: JSONBody):
    """Check pasted equation text with the safe parser; returns the model description."""
    m, _ = resolve_model({"equations": body.get("equations")}, request.app.state.limits)
    return describe(m)


@router.get("/colormap")
async def colormap(name: str = "viridis"):
    """A colour map as a 256 x 3 RGB lookup table (768 bytes)."""
    if len(name) > MAX_CMAP_CHARS:
        raise MorphogenError(f"colour map text is longer than {MAX_CMAP_CHARS} characters")
    return Response(colour_table(name).tobytes(), media_type="application/octet-stream")
