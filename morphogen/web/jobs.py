"""Background jobs (an atlas, an Evolve generation) with progress and a time limit.

A job is a function ``work(job, progress) -> dict`` run in a worker thread; it calls
``progress(fraction, message)`` between compiled chunks of simulation. The call also enforces the
job's deadline and cancellation: past the deadline it raises :class:`JobStopped`, so a job never
runs long after its limit. Pages poll ``GET /api/jobs/{id}`` for ``status``, ``progress``,
``message``, and then ``result`` or ``error``; images a job made (``job.files``) are served at
``GET /api/jobs/{id}/files/{name}``.

Jobs run one at a time (a single worker): on a small machine two batched simulations side by
side are no faster than one after the other, and the queue keeps the live view responsive.
"""

from __future__ import annotations

import secrets
import threading
import time
import traceback
from collections import OrderedDict
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import Response

from morphogen.errors import MorphogenError
from morphogen.web.limits import Limits

Progress = Callable[[float, str], None]
Work = Callable[["Job", Progress], dict[str, Any]]


ADVICE = {"match": "use a smaller budget, fewer minutes or a smaller picture"}
"""What to change when a job of a kind runs past its limit (others: :data:`DEFAULT_ADVICE`)."""
DEFAULT_ADVICE = "use fewer steps, tiles or individuals"


class JobStopped(MorphogenError):
    """A job ran past its deadline or was cancelled."""


class JobGone(MorphogenError):
    """Unknown job id."""


@dataclass
class Job:
    """One job's status as the pages see it."""

    id: str
    kind: str
    status: str = "queued"  # queued | running | done | error | cancelled
    progress: float = 0.0
    message: str = ""
    result: dict[str, Any] | None = None
    error: str | None = None
    created: float = field(default_factory=time.time)
    started: float | None = None
    finished: float | None = None
    cancel: threading.Event = field(default_factory=threading.Event)
    files: dict[str, tuple[bytes, str]] = field(default_factory=dict)
    """Binary results (images) by name: ``(data, media type)``, served under the job's URL."""
    expected_s: float | None = None
    """The job's own estimate of how long it runs (a search limited by time): the time left
    counts down to it instead of following a progress that may stand still."""

    def to_json(self) -> dict[str, Any]:
        elapsed = ((self.finished or time.time()) - self.started) if self.started else 0.0
        return {
            "id": self.id, "kind": self.kind, "status": self.status,
            "progress": round(self.progress, 4), "message": self.message,
            "result": self.result, "error": self.error, "elapsed_s": round(elapsed, 2),
            "eta_s": self.eta(elapsed),
        }

    def eta(self, elapsed: float) -> float | None:
        """Seconds left: to :attr:`expected_s` when the job gave one (None once it is past),
        else at the rate so far, ``elapsed (1 - p) / p``; None before any progress or once the
        job has ended."""
        if self.status != "running":
            return None
        if self.expected_s is not None:
            left = self.expected_s - elapsed
            return round(left, 1) if left > 0 else None
        if not 0.0 < self.progress < 1.0:
            return None
        return round(elapsed * (1.0 - self.progress) / self.progress, 1)


class JobStore:
    """Queues jobs on one worker thread and keeps the last ``limits.max_jobs`` of them."""

    def __init__(self, limits: Limits):
        self.limits = limits
        self._jobs: OrderedDict[str, Job] = OrderedDict()
        self._lock = threading.Lock()
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="morphogen-job")

    def submit(self, kind: str, work: Work, timeout_s: float | None = None) -> Job:
        """Queue ``work``; returns its :class:`Job` at once. It is stopped after ``timeout_s``
        seconds of running (``limits.job_timeout_s`` when ``None``)."""
        job = Job(id=secrets.token_urlsafe(12), kind=kind)
        with self._lock:
            self._jobs[job.id] = job
            while len(self._jobs) > self.limits.max_jobs:
                self._jobs.popitem(last=False)
        self._pool.submit(self._run, job, work, timeout_s or self.limits.job_timeout_s)
        return job

    def get(self, job_id: str) -> Job:
        with self._lock:
            job = self._jobs.get(job_id)
        if job is None:
            raise JobGone(f"unknown job {job_id!r} (finished jobs are kept for a while only)")
        return job

    def _run(self, job: Job, work: Work, timeout_s: float) -> None:
        if job.cancel.is_set():
            job.status = "cancelled"
            return
        job.status, job.started = "running", time.time()
        deadline = time.monotonic() + timeout_s

        def progress(fraction: float, message: str = "") -> None:
            if job.cancel.is_set():
                raise JobStopped("cancelled")
            if time.monotonic() > deadline:
                raise JobStopped(
                    f"the job took longer than {timeout_s:g} s and was "
                    f"stopped; {ADVICE.get(job.kind, DEFAULT_ADVICE)}"
                )
            job.progress = min(max(float(fraction), 0.0), 1.0)
            job.message = message

        try:
            result = work(job, progress)
        except MorphogenError as exc:
            job.status = "cancelled" if job.cancel.is_set() else "error"
            job.error = str(exc)
        except Exception as exc:  # a bug must reach the page as a message, not a hang
            job.status, job.error = "error", f"internal error: {type(exc).__name__}: {exc}"
            traceback.print_exc()
        else:
            job.status, job.result, job.progress = "done", result, 1.0
        job.finished = time.time()

    def shutdown(self) -> None:
        for job in list(self._jobs.values()):
            job.cancel.set()
        self._pool.shutdown(wait=False, cancel_futures=True)


router = APIRouter(prefix="/api/jobs")


@router.get("/{job_id}")
async def status(request: Request, job_id: str):
    return request.app.state.jobs.get(job_id).to_json()


@router.delete("/{job_id}")
async def cancel(request: Request, job_id: str):
    job = request.app.state.jobs.get(job_id)
    job.cancel.set()
    return job.to_json()


@router.get("/{job_id}/files/{name}")
async def file(request: Request, job_id: str, name: str):
    job = request.app.state.jobs.get(job_id)
    if name not in job.files:
        raise JobGone(f"job {job_id} has no file {name!r}")
    data, media = job.files[name]
    return Response(data, media_type=media)
