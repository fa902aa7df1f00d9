"""Helpers shared by the web app's tests (API tests and browser tests)."""

from __future__ import annotations

import time
from collections.abc import Callable

# A flower pipeline small enough for tests: a tiny petal, a fields stage and a simulation of
# STEPS steps (replace the word); the Mesh page lists it as a case study.
TINY_PETAL = """# A tiny petal (Ringham et al. 2021, §4.2, used only by the tests)
seed = 1
view = "top"

[mesh]
shape = "petal"
edge = 0.2

[[stage]]
name = "colour"
kind = "fields"
fields = { m = "s" }

[[stage]]
name = "grow"
kind = "simulate"
model = "gray-scott"
steps = STEPS
initial = { v = "where(s > 0.5, 0.25, 0)", u = "where(s > 0.5, 0.5, 1)" }
show = "v"
cmap = "magma"
"""


def poll_job(client, job: str, until: Callable[[dict], bool], timeout: float = 120.0) -> dict:
    """The status of background job ``job`` once ``until(status)`` holds (polled every 50 ms);
    fails the test after ``timeout`` seconds."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        status = client.get(f"/api/jobs/{job}").json()
        if until(status):
            return status
        time.sleep(0.05)
    raise AssertionError(f"job {job} never reached the state: {status}")


def finished(status: dict) -> bool:
    """A job that has stopped working, well or not."""
    return status["status"] in ("done", "error")
