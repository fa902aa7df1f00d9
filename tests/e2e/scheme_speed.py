"""Frames per second of the live view per scheme at its own step (docs/web.md's table).

    JAX_PLATFORMS=cpu .venv/bin/python tests/e2e/scheme_speed.py [SCHEME ...] > speed.jsonl

Gray-Scott on 256² and 512², periodic and no flux, each scheme (all of the live view's, or those
named) as Explore starts it (its own ``dt`` and the server's steps per frame): the set-up with
its first frame (compiles included), then up to 20 frames or 8 s, timed on the server
(``LiveSim.frame``, no browser). One JSON line per case with the mean, median and fastest frame
(on a shared machine the median is the steadier figure) and the 1-minute load average.
"""

from __future__ import annotations

import json
import os
import statistics
import sys
import time

from morphogen.solvers.registry import LIVE
from morphogen.web.limits import Limits
from morphogen.web.live import LiveSim


def main(schemes: list[str]) -> None:
    sim = LiveSim(Limits())
    for size in (256, 512):
        for scheme in schemes or LIVE:
            for boundary in ("periodic", "neumann"):
                t0 = time.perf_counter()
                d = sim.configure({"library": "gray-scott"}, size=size, scheme=scheme,
                                  boundary=boundary)
                sim.frame()
                setup = time.perf_counter() - t0
                took: list[float] = []
                start = time.perf_counter()
                while len(took) < 20 and time.perf_counter() - start < 8:
                    t0 = time.perf_counter()
                    sim.frame()
                    took.append(time.perf_counter() - t0)
                ms = statistics.fmean(took) * 1000
                print(json.dumps({"size": size, "scheme": scheme, "boundary": boundary,
                                  "dt": d["dt"], "dt_max": d["dt_max"],
                                  "steps_per_frame": d["steps_per_frame"], "frames": len(took),
                                  "ms": ms, "ms_median": statistics.median(took) * 1000,
                                  "ms_min": min(took) * 1000, "fps": 1000 / ms,
                                  "setup_s": setup, "load": os.getloadavg()[0]}), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
