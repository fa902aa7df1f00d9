"""Time a few more full-settings generations of a finished experiment run, in this process and
split over one Ray worker per core, to project a full Table-1 run (docs/networks.md).

    python docs/images/networks/time_generations.py RUN_DIR [GENERATIONS]

``RUN_DIR`` is a run folder written by ``make_figures.py`` (its settings are Table 1's). The
folder is copied to a temporary one, and ``GENERATIONS`` (default 3) more generations are bred
and evaluated there twice from the same saved state: once in this process (single-threaded)
and once with :class:`~morphogen.search.networks.ray_workers.RayNetworkEvaluator` (the
``--executor auto`` choice on a multi-core machine). Prints wall seconds per generation, the
valid count, and the projection of 100 generations at the measured mean.
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

from morphogen.util.cluster import SINGLE_THREAD

os.environ.setdefault("XLA_FLAGS", SINGLE_THREAD)

from make_figures import BUDGET, EVAL, experiment  # noqa: E402

from morphogen.search.networks.evolve import completed, run  # noqa: E402
from morphogen.search.networks.ray_workers import RayNetworkEvaluator  # noqa: E402


def timed(src: Path, generations: int, evaluator) -> list[tuple[float, str]]:
    """Wall seconds and log line of each of ``generations`` generations after ``src``'s last."""
    number = int(src.name.split("-")[0].removeprefix("exp"))
    seed = int(src.name.rsplit("seed", 1)[1])
    spec, template, ops = experiment(number)
    rows: list[tuple[float, str]] = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / src.name
        shutil.copytree(src, out)
        clock = [time.perf_counter()]

        def log(line: str) -> None:
            now = time.perf_counter()
            rows.append((now - clock[0], line))
            clock[0] = now

        run(spec, template, out, ops=ops, ev=EVAL, seed=seed, resume=True, log=log,
            evaluator=evaluator, population=BUDGET["population"],
            generations=completed(out) + generations)
    return rows


def main(src: Path, generations: int) -> None:
    for name, evaluator in (("one process", None), ("Ray, one worker per core",
                                                    RayNetworkEvaluator())):
        rows = timed(src, generations, evaluator)
        for wall, line in rows:
            print(f"{name}: {line}, {wall:.1f} s", flush=True)
        later = [wall for wall, _ in rows[1:]] or [rows[0][0]]
        mean = sum(later) / len(later)
        print(f"{name}: {mean:.1f} s per generation after the first -> 100 generations "
              f"{100 * mean / 60:.1f} min (load {os.getloadavg()[0]:.2f})", flush=True)


if __name__ == "__main__":
    main(Path(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 3)
