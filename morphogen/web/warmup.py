"""Ahead-of-time warm-up: compile the library models' live frame programs when the server starts.

A model switch in Explore costs the compile of the new model's step program (one per model,
grid, scheme and steps-per-frame value; 3-6 s on 2 busy cores) before its first frame. At start
the server runs, in one background thread, exactly what a page's first frame of each library
model runs: a :class:`~morphogen.web.live.LiveSim` configured with the model's defaults on the
page's default 256² periodic grid, and one frame. The compiled programs land in the shared engine
cache (:func:`morphogen.web.engines.engine_for`), so a later switch to the model finds them, and
so does the ground state solved for the model's default parameters. Other grids, schemes or
boundaries still compile on first use. When it is done the server prints one line
(``warm-up: ...``) with the seconds per model.
"""

from __future__ import annotations

import threading
import time

from morphogen.errors import MorphogenError
from morphogen.web.limits import Limits


def warm_library(limits: Limits, names: list[str], stop: threading.Event,
                 size: int = 256) -> dict[str, float]:
    """Compile one live frame of each named library model (in order) on a ``size``² grid
    until ``stop`` is set; returns the seconds each took (a model the live view refuses is
    skipped)."""
    from morphogen.web.live import LiveSim

    took: dict[str, float] = {}
    for name in names:
        if stop.is_set():
            break
        start = time.perf_counter()
        sim = LiveSim(limits)
        try:
            sim.configure({"library": name}, size=size)
            sim.frame()
        except MorphogenError:
            continue
        took[name] = round(time.perf_counter() - start, 2)
    return took


def warm_and_report(limits: Limits, names: list[str], stop: threading.Event) -> str | None:
    """:func:`warm_library`, then print (and return) one line with the total and each model's
    seconds; nothing when ``stop`` cut it short."""
    start = time.perf_counter()
    took = warm_library(limits, names, stop)
    if stop.is_set():
        return None
    each = ", ".join(f"{name} {s:.1f} s" for name, s in took.items())
    line = (f"warm-up: the live views of {len(took)} library models compiled in "
            f"{time.perf_counter() - start:.1f} s ({each})")
    print(line, flush=True)
    return line


def start_warm_up(limits: Limits, stop: threading.Event) -> threading.Thread:
    """Run :func:`warm_and_report` over the library in a daemon thread."""
    from morphogen.models.library import LIBRARY

    thread = threading.Thread(target=warm_and_report, args=(limits, list(LIBRARY), stop),
                              name="morphogen-warm-up", daemon=True)
    thread.start()
    return thread
