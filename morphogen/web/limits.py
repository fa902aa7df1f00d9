"""Server-side bounds on every request, and running work under a time limit.

The web app takes input from anyone who can reach the port, so each request is validated here
before any simulation starts: sizes, step counts and batch sizes are bounded so that no single
request can hold the machine for long, and every piece of work runs under a wall-clock limit.
A request outside the bounds gets a one-line :class:`MorphogenError` (HTTP 400), never a hang.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, Any, TypeVar

import anyio
import anyio.to_thread
from fastapi import Body

from morphogen.errors import MorphogenError

T = TypeVar("T")

JSONBody = Annotated[dict[str, Any], Body()]
"""A request's JSON object (validated field by field by the route)."""
OptionalBody = Annotated[dict[str, Any] | None, Body()]
"""A JSON object that may be left out (routes treat ``None`` as ``{}``)."""


@dataclass(frozen=True)
class Limits:
    """Bounds applied to every request.

    Attributes:
        min_size, max_size: cells per side of a live grid.
        max_steps_per_frame: steps advanced for one frame of the live view.
        max_sessions: live simulations kept at once (least recently used are dropped).
        session_idle_s: a live simulation unused this long is dropped.
        max_equation_chars: length of pasted model text.
        max_tiles_per_axis: tiles along each axis of an atlas.
        max_tile_size: cells per side of one atlas tile or evolved individual.
        max_population: individuals in one Evolve generation.
        max_cell_steps: cells x steps x batch of one batched job (atlas or generation).
        request_timeout_s: wall-clock limit of one synchronous request (a frame, a reset).
        job_timeout_s: wall-clock limit of one background job (an atlas, a generation).
        case_study_timeout_s: wall-clock limit of a flower case study (a shipped pipeline;
            the largest take about 15 minutes on 2 cores).
        max_jobs: background jobs kept (finished ones are dropped oldest first).
        max_body_bytes: a request's body (a PNG of 4 MiB is 5.4 MiB as base64 JSON); larger
            is refused with 413 before it is read (:mod:`morphogen.web.guards`).
        max_upload_bytes: the body of a checkpoint upload (64 MiB of ``.npz`` as base64).
        body_timeout_s: time for a request's body to arrive after its headers (408 after).
        header_timeout_s: time for a request's headers to arrive; the connection is closed
            after it.
        keep_alive_s: an idle kept-alive connection is closed after this long.
        max_ws_message_bytes: one WebSocket message (the live view sends ``next``/``show``).
    """

    min_size: int = 16
    max_size: int = 512
    max_steps_per_frame: int = 256
    max_sessions: int = 16
    session_idle_s: float = 900.0
    max_equation_chars: int = 4000
    max_tiles_per_axis: int = 16
    max_tile_size: int = 128
    max_population: int = 36
    max_cell_steps: float = 3.0e9
    request_timeout_s: float = 30.0
    job_timeout_s: float = 300.0
    case_study_timeout_s: float = 3600.0
    max_jobs: int = 32
    max_body_bytes: int = 8 * 2**20
    max_upload_bytes: int = 96 * 2**20
    body_timeout_s: float = 60.0
    header_timeout_s: float = 10.0
    keep_alive_s: int = 5
    max_ws_message_bytes: int = 64 * 1024


def number(value: Any, name: str, lo: float | None = None, hi: float | None = None) -> float:
    """``value`` as a finite float within ``[lo, hi]``, or a one-line error naming ``name``."""
    if isinstance(value, bool):
        raise MorphogenError(f"{name} must be a number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise MorphogenError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(x):
        raise MorphogenError(f"{name} must be a finite number, got {value!r}")
    if lo is not None and x < lo:
        raise MorphogenError(f"{name} must be >= {lo:g}, got {x:g}")
    if hi is not None and x > hi:
        raise MorphogenError(f"{name} must be <= {hi:g}, got {x:g}")
    return x


def integer(value: Any, name: str, lo: int, hi: int) -> int:
    """``value`` as an int within ``[lo, hi]`` (a float with a fractional part is refused)."""
    x = number(value, name, lo, hi)
    if x != int(x):
        raise MorphogenError(f"{name} must be a whole number, got {value!r}")
    return int(x)


def choice(value: Any, name: str, options: tuple[str, ...] | list[str]) -> str:
    """``value`` if it is one of ``options``, else an error listing them."""
    if not isinstance(value, str) or value not in options:
        raise MorphogenError(f"{name} must be one of {', '.join(options)}; got {value!r}")
    return value


def check_budget(cells: int, steps: int, batch: int, limits: Limits) -> None:
    """Refuse a batched job whose ``cells * steps * batch`` exceeds ``limits.max_cell_steps``."""
    work = float(cells) * float(steps) * float(batch)
    if work > limits.max_cell_steps:
        raise MorphogenError(
            f"this request needs {work:.3g} cell-steps, more than the server allows "
            f"({limits.max_cell_steps:.3g}); use fewer steps, smaller tiles or fewer tiles"
        )


class WorkTimeout(MorphogenError):
    """A piece of work ran past its wall-clock limit."""


async def run_limited(fn: Callable[[], T], timeout_s: float, what: str,
                      advice: str | None = None) -> T:
    """Run the blocking ``fn`` in a worker thread; give up after ``timeout_s`` seconds.

    On time-out the caller gets :class:`WorkTimeout` at once, with ``advice`` (by default
    about grids and steps, or about pictures when ``what`` reads one). The worker thread cannot
    be killed, but every request is bounded (see :class:`Limits`), so it finishes soon after.
    """
    finished = False
    with anyio.move_on_after(timeout_s):
        result = await anyio.to_thread.run_sync(fn, abandon_on_cancel=True)
        finished = True
    if not finished:
        if advice is None:
            advice = ("try a smaller picture (fewer pixels)" if "picture" in what
                      else "try a smaller grid, fewer steps per frame or fewer steps")
        raise WorkTimeout(f"{what} took longer than {timeout_s:g} s and was stopped; {advice}")
    return result
