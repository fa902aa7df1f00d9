"""The web application: a FastAPI server and a static front end.

:func:`create_app` builds the app; ``morphogen serve`` runs it with uvicorn on 127.0.0.1. Routes
are grouped by page (:mod:`~morphogen.web.explore`, :mod:`~morphogen.web.atlas_routes`, ...);
all of them validate their input (:mod:`~morphogen.web.limits`) and turn a
:class:`~morphogen.errors.MorphogenError` into HTTP 400 with ``{"error": message}``, a time-out
into 504 and an expired session into 404, which the page shows as a message.

The front end (``static/``) is plain HTML, CSS and JavaScript served by this app; a
Content-Security-Policy of ``'self'`` keeps the browser from fetching anything from elsewhere.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from contextlib import asynccontextmanager
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.responses import FileResponse, JSONResponse
from fastapi.staticfiles import StaticFiles
from starlette.middleware.trustedhost import TrustedHostMiddleware

from morphogen.errors import MorphogenError
from morphogen.flowers.case_studies import EXAMPLES
from morphogen.web import (
    atlas_routes,
    case_study_routes,
    evolve_routes,
    explore,
    export_routes,
    guards,
    info,
    jobs,
    match_routes,
    mesh_routes,
    runs_routes,
)
from morphogen.web.evolution import EvolveRuns
from morphogen.web.jobs import JobGone, JobStore
from morphogen.web.limits import Limits, WorkTimeout
from morphogen.web.sessions import SessionGone, SessionStore
from morphogen.web.warmup import start_warm_up

STATIC = Path(__file__).parent / "static"
LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1", "[::1]")

CSP = (
    "default-src 'self'; img-src 'self' data: blob:; script-src 'self'; style-src 'self'; "
    "connect-src 'self'; font-src 'self'; object-src 'none'; base-uri 'none'; "
    "frame-ancestors 'none'"
)


def create_app(
    *,
    limits: Limits | None = None,
    archive: str | Path | None = None,
    allowed_hosts: Sequence[str] = LOCAL_HOSTS,
    warm_up: bool = False,
    examples: str | Path | None = None,
    token: str | None = None,
) -> FastAPI:
    """Build the app.

    Args:
        limits: request bounds (defaults of :class:`Limits`).
        archive: the run archive's index file (SQLite) shared with ``morphogen evolve``
            (``$MORPHOGEN_ARCHIVE`` or ``runs/index.sqlite`` when ``None``).
        allowed_hosts: accepted ``Host`` headers (guards a local server against DNS
            rebinding); add the public name when serving beyond 127.0.0.1.
        warm_up: compile the library models' live frame programs in a background thread at
            start (:mod:`morphogen.web.warmup`), so a model switch need not wait for them.
        examples: the folder whose ``flowers/*.toml`` the Mesh page offers as case studies
            (:mod:`morphogen.web.case_study_routes`; the repository's ``examples/`` when ``None``).
        token: an access token every request must carry (:class:`morphogen.web.guards.
            AccessToken`; ``morphogen serve --allow-remote``); ``None``: none asked.
    """
    @asynccontextmanager
    async def lifespan(app: FastAPI):
        stop = threading.Event()
        if warm_up:
            start_warm_up(lim, stop)
        yield
        stop.set()
        app.state.jobs.shutdown()
        app.state.evolve.stop_all()

    app = FastAPI(title="morphogen", docs_url=None, redoc_url=None, openapi_url=None,
                  lifespan=lifespan)
    lim = limits or Limits()
    app.state.limits = lim
    app.state.sessions = SessionStore(lim)
    app.state.jobs = JobStore(lim)
    app.state.archive = Path(archive) if archive is not None else None
    app.state.evolve = EvolveRuns(lim.session_idle_s)
    app.state.examples = Path(examples) if examples is not None else EXAMPLES
    app.add_middleware(TrustedHostMiddleware, allowed_hosts=list(allowed_hosts))

    @app.middleware("http")
    async def security_headers(request: Request, call_next):
        response = await call_next(request)
        response.headers["Content-Security-Policy"] = CSP
        response.headers["X-Content-Type-Options"] = "nosniff"
        response.headers["Cache-Control"] = "no-store"
        return response

    @app.exception_handler(SessionGone)
    async def gone(request: Request, exc: SessionGone):
        return JSONResponse({"error": str(exc), "gone": True}, status_code=404)

    @app.exception_handler(JobGone)
    async def no_job(request: Request, exc: JobGone):
        return JSONResponse({"error": str(exc)}, status_code=404)

    @app.exception_handler(WorkTimeout)
    async def timeout(request: Request, exc: WorkTimeout):
        return JSONResponse({"error": str(exc)}, status_code=504)

    @app.exception_handler(MorphogenError)
    async def bad_input(request: Request, exc: MorphogenError):
        return JSONResponse({"error": str(exc)}, status_code=400)

    for module in (info, explore, atlas_routes, jobs, evolve_routes, runs_routes, case_study_routes,
                   mesh_routes, export_routes, match_routes):
        app.include_router(module.router)

    @app.get("/", include_in_schema=False)
    async def index():
        return FileResponse(STATIC / "index.html")

    app.mount("/static", StaticFiles(directory=STATIC), name="static")
    guards.install(app, lim, token)
    return app
