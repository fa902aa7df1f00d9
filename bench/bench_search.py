"""One GA generation of 20 Gray-Scott individuals on 256x256, T = 2000, dt = 0.5 (4000 steps).

Skaggs table 5.1 (seed 000 §5) times this generation at 39.72 s on 1 CPU thread, 27.03 s on
16 and 6.39 s on a GPU; the target here is under 27 s. Measured in the same run:

- the generation (ask, evaluate, tell) with compilation, then again compiled;
- 250 steps of the population one individual at a time (the CPU default) against the whole
  population vmapped as one batch (the GPU layout), best of 3 interleaved runs each;
- a NumPy float64 reference of the kind gard used (np.roll Laplacian; 50 steps of one
  individual, scaled to 20 x 4000).
"""

from __future__ import annotations

import time

import jax
import numpy as np

from morphogen.search.evaluate import Evaluator, Problem
from morphogen.search.ga import GeneticAlgorithm
from morphogen.search.genes import SKAGGS_SCHEDULE, preset_genes

SIZE, POPULATION = 256, 20
DT, T = SKAGGS_SCHEDULE["gray-scott"]
STEPS = int(T / DT)
SKAGGS_TABLE_5_1 = {"cpu_1": 39.72, "cpu_16": 27.03, "gpu": 6.39}


def _problem(steps: int) -> Problem:
    return Problem(model="gray-scott", genes=tuple(preset_genes("gray-scott")),
                   preset="skaggs-table-3.1", size=(SIZE, SIZE), dt=DT, steps=steps,
                   init="skaggs")


def _generation(ga: GeneticAlgorithm, evaluator: Evaluator, state, g: int):
    key = jax.random.PRNGKey(g)
    genomes, state = ga.ask(key, state)
    fitness, _ = evaluator(np.asarray(genomes), key)
    state, _ = ga.tell(genomes, fitness, state)
    jax.block_until_ready(state)
    return state, fitness


def numpy_gray_scott(u: np.ndarray, v: np.ndarray, f: float, k: float, steps: int) -> None:
    """gard-style float64 NumPy Euler steps (Skaggs eqs. 2.3-2.4, table 3.1 D), in place."""
    du, dv = 0.32768, 0.16384
    for _ in range(steps):
        lu = np.roll(u, 1, 0) + np.roll(u, -1, 0) + np.roll(u, 1, 1) + np.roll(u, -1, 1) - 4 * u
        lv = np.roll(v, 1, 0) + np.roll(v, -1, 0) + np.roll(v, 1, 1) + np.roll(v, -1, 1) - 4 * v
        uvv = u * v * v
        u += DT * (du * lu - uvv + f * (1 - u))
        v += DT * (dv * lv + uvv - (f + k) * v)


def run() -> dict:
    genes = preset_genes("gray-scott")
    ga = GeneticAlgorithm(POPULATION)
    evaluator = Evaluator(_problem(STEPS))

    start = time.perf_counter()
    state = ga.init(jax.random.PRNGKey(0), genes)
    state, fitness = _generation(ga, evaluator, state, 1)
    first = time.perf_counter() - start
    start = time.perf_counter()
    state, fitness = _generation(ga, evaluator, state, 2)
    second = time.perf_counter() - start

    short = 250
    genomes = np.asarray(ga.ask(jax.random.PRNGKey(3), state)[0])
    layouts = {"one_at_a_time": Evaluator(_problem(short), batch_size=1),
               "vmapped": Evaluator(_problem(short), batch_size=POPULATION)}
    best = dict.fromkeys(layouts, float("inf"))
    for ev in layouts.values():
        ev(genomes, jax.random.PRNGKey(3))  # compile
    for _ in range(3):
        for name, ev in layouts.items():
            start = time.perf_counter()
            ev(genomes, jax.random.PRNGKey(3))
            best[name] = min(best[name], time.perf_counter() - start)
    rates = {name: POPULATION * SIZE * SIZE * short / t for name, t in best.items()}

    ref_steps = 50
    u0 = evaluator.initial_states(genomes[:1])[0].astype(np.float64)
    u, v = u0[0].copy(), u0[1].copy()
    start = time.perf_counter()
    numpy_gray_scott(u, v, float(genomes[0, 0]), float(genomes[0, 1]), ref_steps)
    numpy_generation = (time.perf_counter() - start) * POPULATION * STEPS / ref_steps

    cell_steps = POPULATION * SIZE * SIZE * STEPS
    return {
        "benchmark": "one GA generation: 20 Gray-Scott individuals, 256x256, T=2000, dt=0.5",
        "generation_s_with_compile": first,
        "generation_s": second,
        "cell_steps_per_s": cell_steps / second,
        "valid_individuals": int(np.sum(fitness > -1)),
        "cell_steps_per_s_250_steps": rates,
        "ratio_one_at_a_time_vs_vmapped": rates["one_at_a_time"] / rates["vmapped"],
        "numpy_float64_generation_s_estimate": numpy_generation,
        "ratio_vs_numpy": numpy_generation / second,
        "skaggs_table_5_1_s": SKAGGS_TABLE_5_1,
        "ratio_vs_skaggs_cpu_16": SKAGGS_TABLE_5_1["cpu_16"] / second,
        "target_s": 27.0,
    }
