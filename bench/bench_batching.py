"""A population as one batch against its members one at a time, per grid size (16² to 256²).

The engine's population path, :func:`morphogen.engine.simulate.simulate_batch` (what every
search evaluates a generation with), against :func:`~morphogen.engine.simulate.simulate` called
for each member in turn (the same compiled program for every member), for :data:`MEMBERS`
Gray-Scott members (Skaggs table 3.1 parameters, each member its own F and k), explicit Euler,
float32, periodic 5-point Laplacian. The number of steps at each size keeps the work near
:data:`CELL_STEPS` cell-steps. Speed is cell-steps per CPU-second of this process
(``time.process_time``), the best of :data:`ROUNDS` interleaved rounds, with the load average;
``batch_over_one`` is the ratio in the same run (≥ 1: batching is not slower per cell).
"""

from __future__ import annotations

import os
import time

import jax
import numpy as np

from morphogen.domains.grid import Grid
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate, simulate_batch
from morphogen.models.library import get_model
from morphogen.solvers.step import batch_params

MEMBERS, SIZES, CELL_STEPS, ROUNDS, DT = 16, (16, 32, 64, 128, 256), 6e7, 3, 1.0


def _cpu(fn) -> float:
    t0 = time.process_time()
    jax.block_until_ready(fn())
    return time.process_time() - t0


def _runs(size: int) -> tuple[dict, int]:
    model, grid = get_model("gray-scott"), Grid((size, size))
    p = model.parameters()
    u0 = np.asarray(make_initial("blobs", model, grid, p, seed=0))
    steps = max(10, int(CELL_STEPS / (MEMBERS * size * size)))
    rng = np.random.default_rng(0)
    pb = batch_params(p, MEMBERS)
    pb = {**pb, "F": np.asarray(rng.uniform(0.03, 0.05, MEMBERS), np.float32),
          "k": np.asarray(rng.uniform(0.055, 0.065, MEMBERS), np.float32)}
    ub = np.broadcast_to(u0, (MEMBERS, *u0.shape))

    def one_at_a_time():
        return [simulate(model, grid, u0, {k: v[i] for k, v in pb.items()}, steps=steps,
                         dt=DT).state for i in range(MEMBERS)]

    def batch():
        return simulate_batch(model, grid, ub, pb, steps=steps, dt=DT).state

    return {"batch": batch, "one_at_a_time": one_at_a_time}, steps


def run() -> dict:
    rows = {}
    for size in SIZES:
        runs, steps = _runs(size)
        for fn in runs.values():
            fn()  # compile
        cpu = {name: [] for name in runs}
        load = os.getloadavg()[0]
        for _ in range(ROUNDS):
            for name, fn in runs.items():
                cpu[name].append(round(_cpu(fn), 4))
        cells = MEMBERS * size * size * steps
        rate = {name: cells / min(t) for name, t in cpu.items()}
        rows[f"{size}x{size}"] = {
            "steps": steps, "cpu_s": cpu, "cell_steps_per_cpu_s": rate,
            "batch_over_one": rate["batch"] / rate["one_at_a_time"],
            "load_before_after": [round(load, 2), round(os.getloadavg()[0], 2)]}
    return {"members": MEMBERS, "model": "gray-scott", "sizes": rows,
            "worst_batch_over_one": min(r["batch_over_one"] for r in rows.values())}


if __name__ == "__main__":
    print(run())
