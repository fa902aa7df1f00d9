"""Where a population's evaluation should run on a multi-core CPU: one single-threaded
process, one process with XLA's intra-op threads, or one single-threaded process per core.

Two workloads, each timed in a fresh Python process per variant (so every variant gets its
own XLA flags and compiles from scratch; the first evaluation compiles, the later ones are
timed):

- ``networks``: Yamamoto's evaluation (§3.3, Table 1: 32², Δt = 0.1) of 150 copies of the
  hand-made Table-2 network, shortened to 4 000 steps (scored at t = 200 and 400) so that
  every individual stays valid: the work of a late, all-valid generation;
- ``skaggs``: Skaggs' Table 5.1 generation, 20 Gray-Scott individuals on 256², T = 2000,
  Δt = 0.5 (4 000 steps), the GA's evaluation (seed 000 §5: 39.72 s on one CPU thread, 27.03 s
  on 16, 6.39 s on a GPU).

Variants: ``one_thread`` (``XLA_FLAGS`` single-threaded, the project's test setting),
``xla_threads`` (no flags: XLA's own thread pool over the machine's cores) and ``processes``
(single-threaded workers, one per core, through the Ray executors, which split the
population into one batch per core). A Skaggs generation takes the fused CPU step
(:func:`morphogen.solvers.fused.fused_population`, where Numba is installed) by default; the
``*_jax_step`` variants run the same with ``MORPHOGEN_FUSED=off``, the JAX step, in the same
run. Reported: wall seconds per evaluation (median of
:data:`REPEATS` after the compiling one), the driver's CPU seconds, the load average before and
after, and each variant's speed-up over ``one_thread`` in the same run.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from morphogen.util.cluster import SINGLE_THREAD

VARIANTS = ("one_thread", "xla_threads", "processes")
JAX_STEP = ("one_thread_jax_step", "processes_jax_step")
"""The Skaggs workload's variants on the JAX step (``MORPHOGEN_FUSED=off``)."""
WORKLOADS = ("networks", "skaggs")
REPEATS = 3
ROOT = Path(__file__).resolve().parent.parent


def _networks(variant: str):
    """``evaluate()`` of the networks workload in this process or over Ray workers."""
    import jax

    from bench.bench_networks import populations
    from morphogen.search.networks import evolve

    spec, pop = populations()["table2"]
    ev = evolve.Evaluation(t_start=200.0, interval=200.0, rounds=2)
    u0 = evolve.initial_state(jax.random.key(0), spec, ev)
    if variant == "processes":
        from morphogen.search.networks.ray_workers import RayNetworkEvaluator

        evaluate = RayNetworkEvaluator()
    else:
        evaluate = evolve.evaluate

    def once() -> int:
        fitness, _ = evaluate(pop, u0, spec, ev)
        return int((fitness > evolve.INVALID).sum())

    return once


def _skaggs(variant: str):
    """One Skaggs generation's evaluation in this process or over Ray workers."""
    import jax
    import numpy as np

    from bench.bench_search import POPULATION, STEPS, _problem
    from morphogen.search.executors import LocalExecutor, RayExecutor
    from morphogen.search.ga import GeneticAlgorithm
    from morphogen.search.genes import preset_genes

    problem = _problem(STEPS)
    ga = GeneticAlgorithm(POPULATION)
    state = ga.init(jax.random.PRNGKey(0), tuple(preset_genes("gray-scott")))
    genomes = np.asarray(ga.ask(jax.random.PRNGKey(1), state)[0])
    executor = (RayExecutor(problem) if variant.startswith("processes")
                else LocalExecutor(problem))

    def once() -> int:
        fitness, _ = executor.evaluate(genomes, jax.random.PRNGKey(1))
        return int((np.asarray(fitness) > -1).sum())

    return once


def child(workload: str, variant: str) -> dict:
    """Run in the variant's own process: compile once, then time :data:`REPEATS` times."""
    once = {"networks": _networks, "skaggs": _skaggs}[workload](variant)
    t0 = time.perf_counter()
    valid = once()
    first = time.perf_counter() - t0
    walls, cpus = [], []
    for _ in range(REPEATS):
        c0, t0 = time.process_time(), time.perf_counter()
        once()
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    return {"first_s": round(first, 2), "wall_s": [round(w, 3) for w in walls],
            "driver_cpu_s": [round(c, 3) for c in cpus], "valid": valid}


def _spawn(workload: str, variant: str) -> dict:
    env = {**os.environ, "JAX_PLATFORMS": "cpu", "RAY_USAGE_STATS_ENABLED": "0"}
    env.pop("XLA_FLAGS", None)
    env.pop("MORPHOGEN_FUSED", None)
    if variant != "xla_threads":
        env["XLA_FLAGS"] = SINGLE_THREAD
    if variant in JAX_STEP:
        env["MORPHOGEN_FUSED"] = "off"
    load = os.getloadavg()
    out = subprocess.run([sys.executable, "-m", "bench.bench_threads", workload, variant],
                         cwd=ROOT, env=env, capture_output=True, text=True, check=True)
    row = json.loads(out.stdout.strip().splitlines()[-1])
    row["wall_s_median"] = statistics.median(row["wall_s"])
    row["load_before_after"] = [round(load[0], 2), round(os.getloadavg()[0], 2)]
    return row


def run() -> dict:
    result: dict = {"cpus": os.cpu_count(), "repeats": REPEATS}
    for workload in WORKLOADS:
        variants = VARIANTS + (JAX_STEP if workload == "skaggs" else ())
        rows = {variant: _spawn(workload, variant) for variant in variants}
        base = rows["one_thread"]["wall_s_median"]
        for row in rows.values():
            row["speedup_over_one_thread"] = round(base / row["wall_s_median"], 2)
        result[workload] = rows
    skaggs = result["skaggs"]
    result["skaggs_jax_step_over_fused"] = {
        v: round(skaggs[f"{v}_jax_step"]["wall_s_median"] / skaggs[v]["wall_s_median"], 2)
        for v in ("one_thread", "processes")}
    result["skaggs_table_5_1_s"] = {"cpu_1": 39.72, "cpu_16": 27.03, "gpu": 6.39}
    return result


if __name__ == "__main__":
    if len(sys.argv) == 3:
        print(json.dumps(child(sys.argv[1], sys.argv[2])))
    else:
        print(json.dumps(run(), indent=1))
