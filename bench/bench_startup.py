"""Start-up: wall time of ``morphogen --help``, ``models``, ``simulate --help`` and a first small
simulate (Gray-Scott 64x64, 100 steps), each in a fresh process.

Measured in the same run, interleaved with the commands: a bare ``python -c pass``, ``import
numpy`` and ``import jax`` (the floor a command that simulates cannot go below). Medians of
``ROUNDS`` rounds after one warm-up round (a warm disk: the files are in the page cache), with
the load average before and after. Targets (issue 11 §4): ``--help`` and ``models`` under 0.5 s,
a first small simulate under 3 s.

The commands share a compilation cache (:mod:`morphogen.util.compile_cache`) in a fresh folder,
which
the warm-up round fills: ``simulate_64`` is a repeated simulate that loads its compiled programs,
``simulate_64_no_cache`` the same command with the cache off, which compiles them again.
"""

from __future__ import annotations

import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from morphogen.util import compile_cache

ROUNDS = 5
TARGETS_S = {"help": 0.5, "models": 0.5, "simulate_64": 3.0}


def _morphogen() -> list[str]:
    """The installed ``morphogen`` script next to this interpreter, else ``python -m``."""
    script = Path(sys.executable).with_name("morphogen")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "morphogen.cli.main"]


def _cases(out: str) -> dict[str, list[str]]:
    cli = _morphogen()
    simulate = ["simulate", "gray-scott", "--size", "64x64", "--steps", "100", "--out", out,
                "--quiet"]
    return {
        "python_pass": [sys.executable, "-c", "pass"],
        "import_numpy": [sys.executable, "-c", "import numpy"],
        "import_jax": [sys.executable, "-c", "import jax"],
        "help": [*cli, "--help"],
        "models": [*cli, "models"],
        "simulate_help": [*cli, "simulate", "--help"],
        "simulate_64": [*cli, *simulate],
        "simulate_64_no_cache": ["env", f"{compile_cache.ENV}=off", *cli, *simulate],
    }


def _time(command: list[str], env: dict[str, str]) -> float:
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env=env)
    return time.perf_counter() - start


def run() -> dict:
    tmp = tempfile.mkdtemp(prefix="morphogen-startup-")
    try:
        cases = _cases(str(Path(tmp) / "run"))
        env = {**os.environ, compile_cache.ENV: str(Path(tmp) / "compile-cache")}
        load_before = os.getloadavg()
        for command in cases.values():
            _time(command, env)  # warm-up round: files into the page cache
        times: dict[str, list[float]] = {name: [] for name in cases}
        for _ in range(ROUNDS):
            for name, command in cases.items():
                times[name].append(_time(command, env))
        load_after = os.getloadavg()
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    median = {name: statistics.median(t) for name, t in times.items()}
    return {
        "benchmark": "start-up of the morphogen command, fresh processes, warm disk",
        "command": " ".join(_morphogen()),
        "rounds": ROUNDS,
        "median_s": median,
        "min_s": {name: min(t) for name, t in times.items()},
        "simulate_64_minus_import_jax_s": median["simulate_64"] - median["import_jax"],
        "targets_s": TARGETS_S,
        "meets_target": {name: median[name] < limit for name, limit in TARGETS_S.items()},
        "load_average_1min": {"before": load_before[0], "after": load_after[0]},
    }
