"""Network evolution: cell-steps per CPU-second of the population evaluation (Yamamoto §3.4,
Table 1), the kernels side by side in one run.

Populations of 150 individuals on a 32 × 32 periodic grid, explicit Euler, ``dt = 0.1``,
float32, 400 steps, from one random state uniform in ``[0.5, 1.5)``:

- ``table2``: the hand-made Table-2 network (``m_max = 9``: 3 evolvable slots);
- ``slots12``: 12-slot networks (§4.2, ``m_max = 12``) with all 6 evolvable slots used (the
  Table-2 reactions and three more at rate ``1e-6``), the most work a Table-1 genome asks.

Kernels: ``lanes`` (:mod:`morphogen.search.networks.lanes`, the evaluation's kernel: member axis
innermost), ``vmap_padded`` (the earlier evaluation: the padded runtime-structure step of
``solvers.step.make_step`` under ``vmap``), ``fixed`` (``table2`` only: the fixed-structure
``models/network.py`` model under ``vmap``), and, when run by the benchmark environment's
Python (``.venv-bench/bin/python bench/bench_networks.py``, ``make bench-peers``, which has
Numba), two fused single-thread Numba loops as the reference: ``numba_generic`` does the same
12-slot arithmetic (zero-rate slots skipped), ``numba_written`` has the Table-2 network written
out. The Numba kernels live here, never in the package.

Speed is cell-steps per CPU-second of this process (``time.process_time``: all its threads,
so a kernel that keeps two threads busy is charged for both), the best of ``REPEATS``
interleaved repeats, each with the 1-minute load average; ratios are to ``lanes`` in the same
run. ``full_run``: a full Table-1 run (150 × 1024 × 38 000 steps × 100 generations ≈ 5.8e11
cell-steps, every individual valid: an upper bound, culling drops invalid ones) projected from
the ``slots12`` and ``table2`` lanes figures for one process per core on 2 cores.

``fitness``: the Table-2 hand-made rates against the seed's Fig. 4 rates (Table 2), full Table-1
evaluation, with the default initial condition (``init = "steady"``) and the earlier uniform one,
``DRAWS`` initial draws each.
"""

from __future__ import annotations

import os
import time

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.grid import Grid
from morphogen.engine.simulate import integrate
from morphogen.models.network import yamamoto_activator_inhibitor
from morphogen.search.networks import evolve
from morphogen.search.networks.genome import (
    NetworkSpec,
    make_genome,
    rates,
    stack,
    table2_genome,
    table2_spec,
)
from morphogen.search.networks.lanes import advance_population
from morphogen.search.networks.reaction import genome_params, padded_model
from morphogen.solvers.step import make_step

SIZE, POP, STEPS, DT, REPEATS, DRAWS = 32, 150, 400, 0.1, 3, 5
FULL_RUN = 150 * 32 * 32 * (20000 + 9 * 2000) * 100
ME = np.array([[2, 0, 2], [0, 1, 0], [1, 1, 0]])
MP = np.array([[3, 0, 2], [0, 1, 1], [1, 0, 0]])
FIG4 = [0.0, 0.0, 0.031, 0.015, 0.02, 0.0, 0.094, 0.3, 0.0019]


def populations() -> dict:
    spec9 = table2_spec()
    spec12 = NetworkSpec(("A", "B", "C"), 12, (0.005, 0.2, 0.0), fixed=(0, 1),
                         fixed_rates=(0.0, 0.0))
    k12 = [0, 0, 0.1, 0.01, 0.02, 0.0, 0.01, 0.1, 0.02, 1e-6, 1e-6, 1e-6]
    g12 = make_genome(spec12, k12, np.concatenate([ME, np.eye(3, dtype=int)], 1),
                      np.concatenate([MP, np.eye(3, dtype=int)], 1))
    return {"table2": (spec9, stack([table2_genome(spec9)] * POP)),
            "slots12": (spec12, stack([g12] * POP))}


def _cpu(fn) -> tuple[float, float]:
    load = os.getloadavg()[0]
    t0 = time.process_time()
    fn()
    return time.process_time() - t0, (load + os.getloadavg()[0]) / 2


def _jax_kernels(spec: NetworkSpec, pop, u: jax.Array, name: str) -> dict:
    params = genome_params(pop, spec)
    step = make_step(padded_model(spec), Grid((SIZE, SIZE)))
    vmapped = jax.jit(jax.vmap(lambda x, p: integrate(step, x, p, steps=STEPS, dt=DT,
                                                      key=jax.random.key(0))[0]))
    out = {"lanes": lambda: advance_population(u, params, spec, STEPS, DT).block_until_ready(),
           "vmap_padded": lambda: vmapped(u, params).block_until_ready()}
    if name == "table2":
        model = yamamoto_activator_inhibitor()
        fixed_step = make_step(model, Grid((SIZE, SIZE)))
        fp = {k: jnp.full(POP, v, jnp.float32) for k, v in model.parameters().items()}
        fixed = jax.jit(jax.vmap(lambda x, p: integrate(fixed_step, x, p, steps=STEPS, dt=DT,
                                                        key=jax.random.key(0))[0]))
        out["fixed"] = lambda: fixed(u, fp).block_until_ready()
    lanes = np.asarray(out["lanes"]())
    ref = np.asarray(out["vmap_padded"]())
    err = float(np.max(np.abs(lanes - ref) / np.maximum(np.abs(ref), 1e-6)))
    return out, err


def _numba_kernels(spec: NetworkSpec, pop, u: np.ndarray, name: str) -> dict:
    try:
        from bench import net_numba
    except ImportError:
        return {}
    k = np.asarray(rates(pop), np.float32)
    me, mp = np.asarray(pop.educts), np.asarray(pop.products)
    d = np.asarray(spec.diffusion, np.float32)
    out = {"numba_generic": lambda: net_numba.generic(u, k, me, mp, d, STEPS, DT)}
    if name == "table2":
        out["numba_written"] = lambda: net_numba.table2(u, k, d, STEPS, DT)
    return out


def speed() -> dict:
    rng = np.random.default_rng(0)
    u_np = rng.uniform(0.5, 1.5, (POP, 3, SIZE, SIZE)).astype(np.float32)
    u = jnp.asarray(u_np)
    cells = POP * SIZE * SIZE * STEPS
    result: dict = {}
    for name, (spec, pop) in populations().items():
        kernels, err = _jax_kernels(spec, pop, u, name)
        kernels.update(_numba_kernels(spec, pop, u_np, name))
        for fn in kernels.values():
            fn()  # compile
        rows: dict = {k: {"cpu_s": [], "load_1min": []} for k in kernels}
        for _ in range(REPEATS):  # interleaved
            for label, fn in kernels.items():
                cpu, load = _cpu(fn)
                rows[label]["cpu_s"].append(round(cpu, 4))
                rows[label]["load_1min"].append(round(load, 2))
        for row in rows.values():
            row["cell_steps_per_cpu_s"] = cells / min(row["cpu_s"])
        best = rows["lanes"]["cell_steps_per_cpu_s"]
        for row in rows.values():
            row["over_lanes"] = row["cell_steps_per_cpu_s"] / best
        result[name] = {"kernels": rows, "lanes_vs_vmap_padded_max_rel_diff": err}
    per_core = {n: result[n]["kernels"]["lanes"]["cell_steps_per_cpu_s"] for n in result}
    result["full_run"] = {
        "cell_steps": FULL_RUN,
        "minutes_2_cores_slots12": FULL_RUN / (2 * per_core["slots12"]) / 60,
        "minutes_2_cores_table2": FULL_RUN / (2 * per_core["table2"]) / 60,
        "assumes": "every individual valid to t = 3800; one process per core (e.g. "
                   "--executor ray --batches 2); per-core speed as measured here",
    }
    return result


def fitness() -> dict:
    spec = table2_spec()
    pop = stack([table2_genome(spec), make_genome(spec, FIG4, ME, MP)])
    out: dict = {}
    for init in ("steady", "uniform"):
        ev = evolve.Evaluation(init=init)
        rows = []
        for draw in range(DRAWS):
            u0 = evolve.initial_state(jax.random.key(draw), spec, ev)
            f, _ = evolve.evaluate(pop, u0, spec, ev)
            rows.append([round(float(x), 2) for x in f])
        arr = np.asarray(rows)
        out[init] = {"hand_made": arr[:, 0].tolist(), "fig4": arr[:, 1].tolist(),
                     "fig4_wins": int((arr[:, 1] > arr[:, 0]).sum()), "draws": DRAWS}
    return out


def run() -> dict:
    return {"population": POP, "grid": SIZE, "steps": STEPS, "dt": DT,
            "cpus_allowed": len(os.sched_getaffinity(0)), "speed": speed(),
            "fitness": fitness(), "seed_anchor": "20-50 min on 3x GTX 480; > 30 h on one CPU"}


if __name__ == "__main__":
    print(run())
