"""Gray-Scott on a 256x256 grid: morphogen (JAX) vs a plain NumPy step, in the same run.

Both integrate Skaggs eqs. 2.3-2.4 with the 5-point stencil, periodic boundaries, explicit Euler,
float32. Reported: cell-steps per second (cells x steps / wall seconds, compile excluded) for
batch 1 and batch 16, and the ratio to NumPy.
"""

from __future__ import annotations

import time

import numpy as np

from morphogen.domains.grid import Grid
from morphogen.initial import make_initial
from morphogen.models.library import get_model
from morphogen.simulate import simulate, simulate_batch
from morphogen.steppers import batch_params

SIZE, STEPS, BATCH = 256, 2000, 16


def numpy_gray_scott(u: np.ndarray, v: np.ndarray, p: dict, steps: int, dt: float) -> None:
    """The reference: the textbook NumPy update (np.roll Laplacian), in place."""
    f, k, du, dv = (np.float32(p[n]) for n in ("F", "k", "Du", "Dv"))
    dt = np.float32(dt)
    for _ in range(steps):
        lu = np.roll(u, 1, 0) + np.roll(u, -1, 0) + np.roll(u, 1, 1) + np.roll(u, -1, 1) - 4 * u
        lv = np.roll(v, 1, 0) + np.roll(v, -1, 0) + np.roll(v, 1, 1) + np.roll(v, -1, 1) - 4 * v
        uvv = u * v * v
        u += dt * (du * lu - uvv + f * (1 - u))
        v += dt * (dv * lv + uvv - (f + k) * v)


def _best_of(fn, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def run() -> dict:
    model, grid = get_model("gray-scott"), Grid((SIZE, SIZE))
    p = model.parameters()
    u0 = make_initial("blobs", model, grid, p, seed=0)
    cells = SIZE * SIZE

    simulate(model, grid, u0, p, steps=STEPS, dt=1.0)  # compile
    t1 = _best_of(lambda: simulate(model, grid, u0, p, steps=STEPS, dt=1.0))

    ub = np.broadcast_to(u0, (BATCH, *u0.shape))
    pb = batch_params(p, BATCH)
    simulate_batch(model, grid, ub, pb, steps=STEPS, dt=1.0)
    tb = _best_of(lambda: simulate_batch(model, grid, ub, pb, steps=STEPS, dt=1.0), 2)

    ref_steps = 200
    u, v = u0[0].copy(), u0[1].copy()
    tn = _best_of(lambda: numpy_gray_scott(u, v, p, ref_steps, 1.0))
    numpy_rate = cells * ref_steps / tn
    single = cells * STEPS / t1
    batched = cells * STEPS * BATCH / tb
    return {
        "benchmark": "gray-scott 256x256, 2000 steps, float32, Euler, 5-point",
        "morphogen_batch1_cell_steps_per_s": single,
        "morphogen_batch16_cell_steps_per_s": batched,
        "numpy_cell_steps_per_s": numpy_rate,
        "ratio_batch1_vs_numpy": single / numpy_rate,
        "ratio_batch16_vs_numpy": batched / numpy_rate,
        "targets": {"batched_cell_steps_per_s": 1.0e8, "ratio_vs_numpy": 5.0},
    }
