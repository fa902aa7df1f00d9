"""Run a prepared configuration and write its files: ``state.npz``, pictures and ``run.json``
(:data:`~morphogen.runs.config.FORMAT`), staged so that a failed run leaves nothing behind."""

from __future__ import annotations

import platform
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.engine.simulate import Solution, simulate
from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.runs.config import FORMAT, RunConfig
from morphogen.runs.outputs import write_outputs
from morphogen.runs.prepare import Prepared, precision, prepare
from morphogen.solvers.step import Noise
from morphogen.util.io import check_run_dir, staged_dir, write_json


def run_prepared(prep: Prepared, *, progress: bool = False) -> Solution:
    """Simulate a prepared run."""
    c = prep.config
    noise = Noise(**c.noise) if c.noise else None
    clamp = tuple(c.clamp) if isinstance(c.clamp, list | tuple) else c.clamp
    solution = simulate(
        prep.model, prep.domain, prep.u0, prep.params, steps=prep.steps, dt=prep.dt,
        scheme=prep.scheme, noise=noise, clamp=clamp, seed=c.seed, every=c.every,
        progress=progress, unsafe=c.unsafe, rtol=c.rtol, atol=c.atol,
    )
    if c.clamp == "model" and prep.model.clamp is not None:
        check_ceiling(prep.model, np.asarray(solution.state), prep.model.clamp[1])
    return solution


def check_ceiling(model: Model, state: np.ndarray, ceiling: float) -> None:
    """A model's declared upper bound is a guard against overflow, not physics: a species
    that reaches it has blown up, and the run says so instead of keeping the pinned values."""
    for i, s in enumerate(model.species):
        pinned = float(np.mean(state[i] >= ceiling))
        if pinned > 0:
            raise MorphogenError(
                f"numerical blow-up: {pinned:.0%} of species {s} reached the model's ceiling "
                f"{ceiling:g}; reduce --dt or check the parameters, or use --clamp LO:HI to "
                "bound values explicitly"
            )


def execute(config: RunConfig, out: str | Path, *, progress: bool = False) -> Solution:
    """Prepare, simulate and write ``state.npz``, ``final.png``, ``run.json`` (and an
    animation when snapshots were taken) into ``out``, replacing an earlier run there whole;
    nothing is created unless the run succeeds. A float64 run computes in JAX's x64 mode for
    its own duration only."""
    with precision(config.precision):
        prep = prepare(config)
        check_run_dir(out)
        started = time.perf_counter()
        solution = run_prepared(prep, progress=progress)
        wall = time.perf_counter() - started
        with staged_dir(out) as stage:
            write_outputs(stage, prep, solution)
            write_json(stage / "run.json", run_record(prep, solution, wall))
    return solution


def run_record(prep: Prepared, solution: Solution, wall: float) -> dict[str, Any]:
    """The JSON written to ``run.json``."""
    import jax

    config = asdict(prep.config)
    if prep.model.source is not None:
        config["model_source"] = prep.model.source
    return {
        "format": FORMAT,
        "config": config,
        "resolved": {
            "model": prep.model.name,
            "species": list(prep.model.species),
            "params": {k: _describe(v) for k, v in prep.params.items()},
            "dt": prep.dt,
            "steps": prep.steps,
            "t_end": solution.t,
            "clamp": prep.model.clamp if prep.config.clamp == "model" else prep.config.clamp,
            "scheme": solution.scheme,
            **_adaptive_record(solution),
            **({"warnings": solution.warnings} if solution.warnings else {}),
        },
        "provenance": {
            "morphogen": _version("morphogen"),
            "jax": jax.__version__,
            "numpy": np.__version__,
            "python": platform.python_version(),
            "device": str(jax.devices()[0]),
            "wall_time_s": round(wall, 3),
        },
    }


def _adaptive_record(solution: Solution) -> dict[str, Any]:
    """Accepted and rejected steps of an ``adaptive`` run (nothing for fixed steps)."""
    if solution.rejected_steps is None:
        return {}
    return {"accepted_steps": solution.steps, "rejected_steps": solution.rejected_steps}


def _describe(value: np.ndarray) -> Any:
    arr = np.asarray(value)
    if arr.ndim == 0:
        return float(arr)
    return {"field": list(arr.shape), "min": float(arr.min()), "max": float(arr.max())}


def _version(package: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(package)
    except PackageNotFoundError:
        return "unknown"
