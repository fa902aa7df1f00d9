"""``make bench``: run every benchmark module and write ``bench/results/<name>.json``.

Each ``bench/bench_<name>.py`` exposes ``run() -> dict``; results are printed and written with
the machine they ran on (processor count, platform, JAX device), so figures are always read next
to the reference measured in the same run.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import platform
import sys
from pathlib import Path

import jax

from morphogen.util.io import write_json

HERE = Path(__file__).parent


def machine() -> dict:
    return {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "jax": jax.__version__,
        "device": str(jax.devices()[0]),
    }


def main(argv: list[str] | None = None) -> int:
    names = sorted(p.stem.removeprefix("bench_") for p in HERE.glob("bench_*.py"))
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", choices=names + [[]], help="benchmarks to run")
    args = parser.parse_args(argv)
    (HERE / "results").mkdir(exist_ok=True)
    for name in args.names or names:
        print(f"== {name}", flush=True)
        result = importlib.import_module(f"bench.bench_{name}").run()
        result["machine"] = machine()
        write_json(HERE / "results" / f"{name}.json", result)
        print(json.dumps(result, indent=2, default=str), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
