"""Interleaved timing rounds shared by the benchmarks."""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping
from typing import Any


def interleaved(runs: Mapping[str, Callable[[], Any]], rounds: int
                ) -> tuple[dict[str, list[float]], tuple[float, ...], tuple[float, ...]]:
    """Wall times of each run over ``rounds`` rounds, the runs taking turns within a round so
    that a change of the machine's load falls on all of them alike; and the load averages
    (1, 5 and 15 minutes) before and after."""
    load_before = os.getloadavg()
    times: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(rounds):
        for name, run in runs.items():
            t0 = time.perf_counter()
            run()
            times[name].append(time.perf_counter() - t0)
    return times, load_before, os.getloadavg()


def interleaved_cpu(runs: Mapping[str, Callable[[], Any]], rounds: int
                    ) -> tuple[dict[str, list[float]], dict[str, list[float]]]:
    """As :func:`interleaved`, recording both the CPU seconds of this process
    (``time.process_time``: every thread, not the time other jobs took from it) and the wall
    seconds of each run: ``(cpu, wall)``, each ``{name: [one per round]}``."""
    cpu: dict[str, list[float]] = {name: [] for name in runs}
    wall: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(rounds):
        for name, run in runs.items():
            c, w = cpu_and_wall(run)
            cpu[name].append(c)
            wall[name].append(w)
    return cpu, wall


def cpu_and_wall(run: Callable[[], Any]) -> tuple[float, float]:
    """The CPU seconds of this process (every thread) and the wall seconds of one call."""
    c0, t0 = time.process_time(), time.perf_counter()
    run()
    return time.process_time() - c0, time.perf_counter() - t0
