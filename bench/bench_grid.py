"""The explicit grid step and its batching, against references measured in the same run.

(a) Gray-Scott (Skaggs eqs. 2.3-2.4) on 256², 5-point, periodic, explicit Euler, float32, through
:func:`morphogen.engine.simulate.simulate` (batch 1) and
:func:`~morphogen.engine.simulate.simulate_batch`
(batch 16), next to a textbook NumPy loop and to the same engine with the previous grid
operator, which padded and differenced each species separately (``per_species``).

(b) The reaction-network workload of issue 11 (Yamamoto §3.4: 150 members × 32², 3 species,
``dt = 0.1``): ``simulate_batch`` against ``jax.vmap`` over
:func:`~morphogen.engine.simulate.integrate`
with the previous operator (the figure the issue measured) and with the current one, and every
CPU batching rule (one member at a time, blocks of 15, one ``vmap``) at 32² and 16².

Cell-steps per second = members × grid cells × steps / wall seconds, compile excluded; medians
of interleaved rounds; the load average is recorded before and after, since the machine's 2 cores
are shared. Also tried and not kept: several steps per ``lax.scan`` iteration (``unroll`` 2 and
4), 0.3-1.1× the speed of ``unroll=1`` at 256² and 0.1-0.6× at 32² in one run at load 15.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.grid import Grid
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import batch_block, integrate, simulate, simulate_batch
from morphogen.models.library import get_model
from morphogen.models.network import yamamoto_activator_inhibitor
from morphogen.solvers.step import batch_params, make_step

SIZE, STEPS, BATCH, ROUNDS = 256, 2000, 16, 3
NET_MEMBERS, NET_STEPS = 150, 400


@dataclass(frozen=True, eq=False)
class PerSpeciesGrid(Grid):
    """The previous operator: one pad and one stencil pass per species."""

    def diffuse(self, u, coeffs, bcs):
        return jnp.stack([d * self.laplacian(u[i], bc)
                          for i, (d, bc) in enumerate(zip(coeffs, bcs, strict=True))])


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


def _seconds(fn: Callable[[], object]) -> float:
    start = time.perf_counter()
    jax.block_until_ready(fn())
    return time.perf_counter() - start


def _network_runs(size: int) -> dict[str, tuple[Callable, float]]:
    """The network workload at ``size``²: each way of running it, with its cell-steps."""
    model = yamamoto_activator_inhibitor()
    grid = Grid((size, size))
    u = jnp.asarray(np.random.default_rng(0).uniform(0.5, 1.5, (NET_MEMBERS, 3, size, size)),
                    jnp.float32)
    p = {k: jnp.full(NET_MEMBERS, v, jnp.float32) for k, v in model.parameters().items()}
    keys = jax.random.split(jax.random.key(0), NET_MEMBERS)
    cells = NET_MEMBERS * size * size * NET_STEPS

    def vmapped(step):
        fn = jax.jit(jax.vmap(lambda u, p, k: integrate(step, u, p, steps=NET_STEPS, dt=0.1,
                                                        key=k)[0]))
        return lambda: fn(u, p, keys)

    def blocks(step, block):
        def one(m):
            return integrate(step, m[0], m[1], steps=NET_STEPS, dt=0.1, key=m[2])[0]

        fn = jax.jit(lambda u, p, k: jax.lax.map(one, (u, p, k), batch_size=block))
        return lambda: fn(u, p, keys)

    step = make_step(model, grid)
    runs = {
        "vmap_integrate_per_species": vmapped(make_step(model, PerSpeciesGrid((size, size)))),
        "vmap_integrate": vmapped(step),
        "blocks_of_1": blocks(step, 1),
        "blocks_of_15": blocks(step, 15),
        "simulate_batch": lambda: simulate_batch(model, grid, u, p, steps=NET_STEPS, dt=0.1,
                                                 unsafe=True).state,
    }
    return {name: (fn, cells) for name, fn in runs.items()}


def run() -> dict:
    load_before = os.getloadavg()
    model, grid = get_model("gray-scott"), Grid((SIZE, SIZE))
    p = model.parameters()
    u0 = make_initial("blobs", model, grid, p, seed=0)
    ub, pb = np.broadcast_to(u0, (BATCH, *u0.shape)), batch_params(p, BATCH)
    old = PerSpeciesGrid((SIZE, SIZE))
    cells = SIZE * SIZE * STEPS
    runs: dict[str, tuple[Callable, float]] = {
        "gray_scott_batch1": (lambda: simulate(model, grid, u0, p, steps=STEPS, dt=1.0).state,
                              cells),
        "gray_scott_batch1_per_species": (
            lambda: simulate(model, old, u0, p, steps=STEPS, dt=1.0).state, cells),
        "gray_scott_batch16": (
            lambda: simulate_batch(model, grid, ub, pb, steps=STEPS, dt=1.0).state,
            cells * BATCH),
    }
    for size in (32, 16):
        runs.update({f"network_{size}_{k}": v for k, v in _network_runs(size).items()})
    for fn, _ in runs.values():
        fn()  # compile
    ref_steps = 200
    u, v = u0[0].copy(), u0[1].copy()
    times: dict[str, list[float]] = {name: [] for name in [*runs, "numpy"]}
    for _ in range(ROUNDS):
        for name, (fn, _) in runs.items():
            times[name].append(_seconds(fn))
        times["numpy"].append(_seconds(lambda: numpy_gray_scott(u, v, p, ref_steps, 1.0)))
    rate = {name: runs[name][1] / float(np.median(t)) for name, t in times.items()
            if name != "numpy"}
    rate["numpy_gray_scott"] = SIZE * SIZE * ref_steps / float(np.median(times["numpy"]))
    net = "network_32_"
    return {
        "benchmark": "explicit Euler, float32, 5-point, periodic; medians of interleaved rounds",
        "rounds": ROUNDS,
        "load_average_before": load_before,
        "load_average_after": os.getloadavg(),
        "cell_steps_per_s": rate,
        "gray_scott_batch1_over_per_species": rate["gray_scott_batch1"]
        / rate["gray_scott_batch1_per_species"],
        "gray_scott_batch1_over_numpy": rate["gray_scott_batch1"] / rate["numpy_gray_scott"],
        "network_simulate_batch_over_vmap_integrate_per_species":
            rate[net + "simulate_batch"] / rate[net + "vmap_integrate_per_species"],
        "network_simulate_batch_over_vmap_integrate":
            rate[net + "simulate_batch"] / rate[net + "vmap_integrate"],
        "batch_block_chosen": batch_block(NET_MEMBERS),
        "issue_figures": {"gray_scott_batch1": "1.3-2.3e8", "numpy_fused_loop": "3.8e8",
                          "network_simulate_batch": "2.1-3.0e7",
                          "network_vmap_integrate": "4.6e7"},
        "targets": {"gray_scott_batch1": ">= 2x per_species and >= the fused loop",
                    "network_simulate_batch": ">= 2x vmap over integrate (per_species)"},
    }
