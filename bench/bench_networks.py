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
"""

from __future__ import annotations

import time

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.grid import Grid
from morphogen.models.network import yamamoto_activator_inhibitor
from morphogen.search.networks.genome import stack, table2_genome, table2_spec
from morphogen.search.networks.reaction import genome_params, padded_model
from morphogen.simulate import integrate
from morphogen.steppers import make_step

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
    }


if __name__ == "__main__":
    print(run())
