"""Network evolution: cell-steps/s of the population evaluation (Yamamoto §3.4, Table 1).

The population is the Table-2 hand-made network with the rates of each individual perturbed,
evaluated (a) through the padded runtime-structure reaction term
(:mod:`morphogen.search.networks.reaction`, ``m_max = 9`` slots) and (b) through the
fixed-structure :func:`morphogen.models.network.mass_action` model of the same network, both
``vmap``-ed over the population on a 32 × 32 periodic grid, explicit Euler, ``dt = 0.1``, float32.
Reported: cell-steps/s (individuals × cells × steps / wall seconds, compile excluded), the ratio
padded / fixed, and the projected time of a full Table-1 run (150 individuals × 1024 cells ×
38 000 steps × 100 generations ≈ 5.8e11 cell-steps), next to the seed's 20-50 minutes on three
GTX 480 GPUs and > 30 hours on one CPU.

``culling``: one generation's evaluation (:func:`morphogen.search.networks.evolve.evaluate`) of
the random initial populations of Experiments 1 (rates, Table-2 network) and 2 (reactions,
``m ≤ 12``), 150 × 32², Δt = 0.1, at a tenth of Table 1's time (t = 200, every 20, 10 rounds),
with every individual integrated to the end (before) and with invalid individuals dropped at
the bounds checks (after); the 1-minute load average is recorded with each.
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
    stack,
    table2_genome,
    table2_spec,
)
from morphogen.search.networks.operators import Operators, random_population
from morphogen.search.networks.reaction import genome_params, padded_model
from morphogen.solvers.step import make_step

SIZE, POP, STEPS = 32, 150, 400
FULL_RUN = 150 * 32 * 32 * (20000 + 9 * 2000) * 100


def _timed(step, u, p) -> float:
    def one(u, p):
        return integrate(step, u, p, steps=STEPS, dt=0.1, key=jax.random.key(0))[0]

    fn = jax.jit(jax.vmap(one))
    fn(u, p).block_until_ready()
    t0 = time.perf_counter()
    fn(u, p).block_until_ready()
    return time.perf_counter() - t0


def run() -> dict:
    spec = table2_spec()
    grid = Grid((SIZE, SIZE))
    rng = np.random.default_rng(0)
    g = table2_genome(spec)
    pop = stack([g] * POP)
    u = jnp.asarray(rng.uniform(0.5, 1.5, (POP, 3, SIZE, SIZE)), jnp.float32)
    padded = _timed(make_step(padded_model(spec), grid), u, genome_params(pop, spec))
    model = yamamoto_activator_inhibitor()
    p = {k: jnp.full(POP, v, jnp.float32) for k, v in model.parameters().items()}
    fixed = _timed(make_step(model, grid), u, p)
    cells = POP * SIZE * SIZE * STEPS
    rate = cells / padded
    return {
        "population": POP, "grid": SIZE, "steps": STEPS,
        "padded_cell_steps_per_s": rate,
        "fixed_cell_steps_per_s": cells / fixed,
        "padded_over_fixed_time": padded / fixed,
        "full_table1_run_cell_steps": FULL_RUN,
        "projected_full_run_minutes": FULL_RUN / rate / 60,
        "seed_anchor": "20-50 min on 3x GTX 480; > 30 h on one CPU",
        "culling": culling(),
    }


def culling() -> dict:
    """Seconds of one generation's evaluation without and with early dropping of invalid
    individuals (compile excluded: each variant runs twice, the second is timed)."""
    ev = evolve.Evaluation(size=SIZE, dt=0.1, t_start=200.0, interval=20.0, rounds=10)
    net_spec = NetworkSpec(("A", "B", "C"), 12, (0.005, 0.2, 0.0), fixed=(0, 1),
                           fixed_rates=(0.0, 0.0))
    cases = {"exp1_rates": (table2_spec(), table2_genome(table2_spec()), "rates"),
             "exp2_network": (net_spec, make_genome(net_spec, [0.0] * 12), "network")}
    out: dict = {"evaluation": {"population": POP, "grid": SIZE, "dt": 0.1, "t_start": 200.0,
                                "interval": 20.0, "rounds": 10,
                                "steps": ev.start_steps + 9 * ev.round_steps}}
    for name, (spec, template, mode) in cases.items():
        key = jax.random.key(0)
        pop = random_population(key, template, spec, POP, Operators(mode=mode))
        u0 = evolve.initial_state(jax.random.fold_in(key, 2), spec, ev)
        row: dict = {}
        for label, checks, min_batch in (("before", 0, 10**9), ("after", evolve.CHECKS,
                                                                  evolve.MIN_BATCH)):
            saved = evolve.MIN_BATCH
            evolve.MIN_BATCH = min_batch  # 10**9: every individual integrated every chunk
            try:
                evolve.evaluate(pop, u0, spec, ev, checks=checks)
                load = os.getloadavg()[0]
                t0 = time.perf_counter()
                fitness, _ = evolve.evaluate(pop, u0, spec, ev, checks=checks)
                row[f"{label}_s"] = time.perf_counter() - t0
                row[f"{label}_load_1min"] = round((load + os.getloadavg()[0]) / 2, 2)
            finally:
                evolve.MIN_BATCH = saved
            row[f"{label}_valid"] = int((fitness > -1.0).sum())
        row["speedup"] = row["before_s"] / row["after_s"]
        out[name] = row
    return out


if __name__ == "__main__":
    print(run())
