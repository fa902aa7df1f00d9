"""One big grid: morphogen's own Gray-Scott step against the best fused single-thread Numba
loop, per core, in one run.

``fused``: what ``morphogen simulate gray-scott --size 256 --scheme euler --steps 2000`` does,
less writing its files, on the fused CPU step of :mod:`morphogen.solvers.fused`
(``MORPHOGEN_FUSED=on``; by default it takes runs from 2³² cell-steps):
:func:`morphogen.runs.prepare.prepare` of that configuration (the library model's parameters,
its ``blobs`` start with seed 0, periodic 256², 5-point stencil, float32, ``dt`` = 90 % of the
Euler limit, 0.9448) and :func:`morphogen.runs.execute.run_prepared`
(``simulate``: compiled chunks of 250 steps with the blow-up and divergence checks between
them), compiled and warmed up before timing. Beside it:

- ``fused_kernel``: the fused step's kernel alone, all ``STEPS`` in one call (no checks between
  chunks, no run set-up): what the generated loop itself reaches;
- ``jax``: the same run on the JAX step (``MORPHOGEN_FUSED=off``), one XLA program a chunk;
- ``wrap_padded``: the JAX run with the previous periodic operator, which read a wrap-padded
  array (``jnp.pad(mode="wrap")``) through overlapping slices; XLA on CPU materialised the
  padding in three copies per step (:mod:`morphogen.domains.stencils`);
- ``numba``: :mod:`bench.gs_numba`, the same arithmetic in one fused loop (two buffers, no
  modulo in the interior), from the same initial state with the same ``dt``.

Per core: each run is timed in CPU seconds of its process (``time.process_time``, every thread:
a run that keeps two threads busy is charged for both, one that waits for a core is not) and in
wall seconds; rates are cell-steps (65 536 × 2000 a round) per second, medians of ``ROUNDS``
interleaved rounds. XLA as shipped may split a loop over its thread pool (one thread per
allowed core); ``*_pinned`` rows run the same five in a second process pinned to one core (it
is started from a thread pinned with ``os.sched_setaffinity`` and inherits the mask, so XLA
sizes its pool to that core), taking turns with the others round by round. The load average is
recorded before and after: on a shared machine the ratios measured in the same run are what to
read.

Same arithmetic: XLA on CPU flushes denormals to zero and treats denormal inputs as zero, and
contracts ``a * b + c`` into fused multiply-adds; the Numba loop sets the same MXCSR bits around
its call and is compiled with ``fastmath={"contract"}`` (contraction only), as is the fused
step. The check, asserted: after ``STEPS`` steps the Numba state and the fused step's are within
twice float32's own rounding of the JAX step's (the largest difference between the JAX step in
float32 and in float64), the pinned process's states equal this process's bit for bit and the
``wrap_padded`` state equals the JAX step's.

``LEVERS`` records what XLA's own options gave on the same run (measured apart, pinned to one
core with the other core busy; docs/schemes.md).

Needs Numba (the ``fast`` extra, which ``make bench`` installs); without it, it prints one line
and keeps the stored ``bench/results/gs_single.json``.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import os
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from bench.timing import cpu_and_wall
from morphogen.domains.grid import Grid
from morphogen.domains.stencils import Neighbours, padded
from morphogen.engine.simulate import simulate
from morphogen.runs.config import RunConfig
from morphogen.runs.execute import run_prepared
from morphogen.runs.prepare import Prepared, prepare
from morphogen.solvers.fused import ENV, MIN_WORK, fused_step

SIZE, STEPS, ROUNDS = 256, 2000, 3
ROOT = Path(__file__).resolve().parent.parent
RESULT = Path(__file__).parent / "results" / "gs_single.json"
KINDS = ("fused", "fused_kernel", "jax", "wrap_padded", "numba")
LEVERS = {
    "method": "simulate of this run (chunks of 250 with the checks), CPU seconds, medians of 3, "
              "one process per setting pinned to core 0 with the other core busy (load 2.3)",
    "default": "0.996e9 cell-steps/CPU-s (the bare chunks without the checks: 1.09e9)",
    "donate_argnums (state, clock, key) on the chunk's jit": "1.08-1.12e9 bare chunks against "
                                                            "1.09-1.10e9 undonated: no gain",
    "--xla_cpu_multi_thread_eigen=false": "0.975e9 (no gain; bare chunks 1.10e9)",
    "--xla_cpu_parallel_codegen_split_count=1 (with the above)": "0.984e9 (no gain)",
    "--xla_cpu_prefer_vector_width=512": "1.04e9 against 1.01e9 (no gain)",
    "--xla_cpu_use_fusion_emitters=false": "3.8e8 (much slower)",
    "lax.scan unroll=2 or 4": "0.3-1.1x (slower)",
}
"""XLA's levers on this run, measured before the fused step (docs/schemes.md)."""


@dataclass(frozen=True, eq=False)
class WrapPaddedGrid(Grid):
    """The previous periodic operator: slices of a wrap-padded array (periodic grids only)."""

    def _neighbours(self, u, bc) -> Neighbours:
        pad = ((0, 0),) * (u.ndim - self.ndim) + ((1, 1),) * self.ndim
        return padded(jnp.pad(u, pad, mode="wrap"), self.ndim)


def prepared() -> Prepared:
    """``morphogen simulate gray-scott --size 256 --scheme euler --steps STEPS``, prepared."""
    return prepare(RunConfig(model="gray-scott", size=[SIZE, SIZE], scheme="euler",
                             steps=STEPS))


def runs(prep: Prepared) -> dict[str, Callable[[], np.ndarray]]:
    """Each kind of run, returning its final state ``(2, SIZE, SIZE)``."""
    from bench import gs_numba

    old = dataclasses.replace(prep, domain=WrapPaddedGrid(prep.domain.shape))
    params = {k: float(v) for k, v in prep.params.items()}
    kernel = _with_fused("on", lambda: fused_step(
        prep.model, prep.domain, {k: np.float32(v) for k, v in params.items()}, scheme="euler",
        noise=None, clamp=None, dtype=np.float32, steps=STEPS))
    assert kernel is not None, "the fused step does not cover this run"
    return {
        "fused": lambda: _with_fused("on", lambda: run_prepared(prep).state),
        "fused_kernel": lambda: kernel(prep.u0, 0.0, prep.dt, STEPS)[0],
        "jax": lambda: _with_fused("off", lambda: run_prepared(prep).state),
        "wrap_padded": lambda: run_prepared(old).state,
        "numba": lambda: gs_numba.advance(prep.u0, params, STEPS, prep.dt),
    }


def _with_fused(mode: str, run: Callable[[], Any]) -> Any:
    """``run()`` with ``MORPHOGEN_FUSED`` set to ``mode`` (empty: unset, the default)."""
    old = os.environ.pop(ENV, None)
    if mode:
        os.environ[ENV] = mode
    try:
        return run()
    finally:
        os.environ.pop(ENV, None)
        if old is not None:
            os.environ[ENV] = old


def worker(state_path: str) -> None:
    """The pinned process: compile, save the final states, then time the run named on each
    line of stdin, answering ``{"cpu": s, "wall": s}``."""
    prep = prepared()
    kinds = runs(prep)
    finals = {name: fn() for name, fn in kinds.items()}  # compile
    np.savez(state_path, fused=finals["fused"], jax=finals["jax"])
    print(json.dumps({"cpus_allowed": len(os.sched_getaffinity(0))}), flush=True)
    for line in sys.stdin:
        cpu, wall = cpu_and_wall(kinds[line.strip()])
        print(json.dumps({"cpu": cpu, "wall": wall}), flush=True)


class Pinned:
    """The pinned process (:func:`worker`) on the first allowed core."""

    def __init__(self, state_path: str) -> None:
        allowed = os.sched_getaffinity(0)
        self.core = min(allowed)
        os.sched_setaffinity(0, {self.core})  # this thread only; the child inherits its mask
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "bench.bench_gs_single", "--worker", state_path],
                cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        finally:
            os.sched_setaffinity(0, allowed)
        self.cpus_allowed = json.loads(self.proc.stdout.readline())["cpus_allowed"]

    def time(self, name: str) -> tuple[float, float]:
        self.proc.stdin.write(name + "\n")
        self.proc.stdin.flush()
        answer = json.loads(self.proc.stdout.readline())
        return answer["cpu"], answer["wall"]

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait(timeout=60)


def _float64_state(prep: Prepared) -> np.ndarray:
    """morphogen's run in float64, for the size of float32's rounding after ``STEPS`` steps."""
    with jax.enable_x64(True):
        p = {k: np.float64(v) for k, v in prep.params.items()}
        return simulate(prep.model, prep.domain, np.asarray(prep.u0, np.float64), p,
                        steps=STEPS, dt=prep.dt).state


def _check(finals: dict[str, np.ndarray], pinned: dict[str, np.ndarray], f64: np.ndarray
           ) -> dict:
    ours, loop, fused = finals["jax"], finals["numba"], finals["fused"]
    rounding = float(np.abs(ours - f64).max())
    diff = float(np.abs(loop - ours).max())
    fused_diff = float(np.abs(fused - ours).max())
    for name in ("fused", "jax"):
        assert np.array_equal(pinned[name], finals[name]), f"the pinned {name} state differs"
    assert np.array_equal(finals["wrap_padded"], ours), "the previous operator's state differs"
    assert np.array_equal(finals["fused_kernel"], fused), "the bare kernel's state differs"
    assert diff <= 2 * rounding, f"numba differs by {diff:.3g}, float32 rounds by {rounding:.3g}"
    assert fused_diff <= 2 * rounding, (f"the fused step differs by {fused_diff:.3g}, float32 "
                                        f"rounds by {rounding:.3g}")
    return {"numba_max_abs_diff": diff, "numba_identical_fraction": float(np.mean(loop == ours)),
            "fused_max_abs_diff": fused_diff,
            "fused_identical_fraction": float(np.mean(fused == ours)),
            "fused_equals_numba": bool(np.array_equal(fused, loop)),
            "float32_rounding_max_abs": rounding, "pinned_identical": True,
            "wrap_padded_identical": True, "state_range": [float(ours.min()), float(ours.max())]}


def measure() -> dict:
    prep = prepared()
    kinds = runs(prep)
    finals = {name: fn() for name, fn in kinds.items()}  # compile
    f64 = _with_fused("off", lambda: _float64_state(prep))
    with tempfile.TemporaryDirectory() as tmp:
        state_path = str(Path(tmp) / "pinned.npz")
        pinned = Pinned(state_path)
        try:
            with np.load(state_path) as saved:
                check = _check(finals, dict(saved), f64)
            rows = [(name, False) for name in KINDS] + [(name, True) for name in KINDS]
            label = {(n, p): n + ("_pinned" if p else "") for n, p in rows}
            cpu: dict[str, list[float]] = {label[r]: [] for r in rows}
            wall: dict[str, list[float]] = {label[r]: [] for r in rows}
            load_before = os.getloadavg()
            for _ in range(ROUNDS):
                for name, pin in rows:
                    c, w = pinned.time(name) if pin else cpu_and_wall(kinds[name])
                    cpu[label[name, pin]].append(round(c, 4))
                    wall[label[name, pin]].append(round(w, 4))
            load_after = os.getloadavg()
        finally:
            pinned.close()
    cells = SIZE * SIZE * STEPS
    table = {k: {"cpu_s": cpu[k], "wall_s": wall[k],
                 "cell_steps_per_cpu_s": float(f"{cells / statistics.median(cpu[k]):.4g}"),
                 "cell_steps_per_wall_s": float(f"{cells / statistics.median(wall[k]):.4g}")}
             for k in cpu}

    def ratio(a: str, b: str) -> dict[str, float]:
        return {per: round(table[a][f"cell_steps_per_{per}"] / table[b][f"cell_steps_per_{per}"],
                           3) for per in ("cpu_s", "wall_s")}

    return {
        "benchmark": f"gray-scott {SIZE}x{SIZE} periodic, 5-point, explicit Euler, float32, "
                     f"dt={prep.dt:.6g}, {STEPS} steps a round; medians of interleaved rounds",
        "rounds": ROUNDS,
        "cpus_allowed": len(os.sched_getaffinity(0)),
        "pinned_core": pinned.core,
        "pinned_cpus_allowed": pinned.cpus_allowed,
        "xla_flags": os.environ.get("XLA_FLAGS", ""),
        "load_average_before": load_before,
        "load_average_after": load_after,
        "cell_steps_per_round": cells,
        "results": table,
        "fused_over_numba": ratio("fused", "numba"),
        "fused_pinned_over_numba_pinned": ratio("fused_pinned", "numba_pinned"),
        "fused_over_jax": ratio("fused", "jax"),
        "fused_pinned_over_jax_pinned": ratio("fused_pinned", "jax_pinned"),
        "fused_kernel_over_numba": ratio("fused_kernel", "numba"),
        "fused_kernel_pinned_over_numba_pinned": ratio("fused_kernel_pinned", "numba_pinned"),
        "jax_pinned_over_numba_pinned": ratio("jax_pinned", "numba_pinned"),
        "jax_over_wrap_padded": ratio("jax", "wrap_padded"),
        "jax_pinned_over_wrap_padded_pinned": ratio("jax_pinned", "wrap_padded_pinned"),
        "same_field": check,
        "numba_settings": {"fastmath": "contract", "mxcsr": "FTZ | DAZ (0x8040) during the loop",
                           "version": _version("numba")},
        "xla_levers": LEVERS,
        "issue_figures": {"jax": "1.0e9 pinned, as shipped before the fused step",
                          "numba": "1.9e9 pinned", "roofline": "about 3e9"},
        "target": "morphogen >= the fused Numba loop, per core",
        "fused_min_work_cell_steps": MIN_WORK,
    }


def _version(name: str) -> str:
    from importlib.metadata import version

    return version(name)


def run() -> dict:
    if importlib.util.find_spec("numba") is None:
        print("gs_single: skipped, numba not installed here (the `fast` extra; keeping the "
              "stored result)", flush=True)
        return json.loads(RESULT.read_text()) if RESULT.exists() else {}
    return measure()


if __name__ == "__main__":
    if sys.argv[1:2] == ["--worker"]:
        worker(sys.argv[2])
        sys.exit(0)
    from bench.run import main

    sys.exit(main(["gs_single"]))
