"""The cheap measurements behind the network evaluation's defaults (docs/networks.md,
"Readings of the seed, measured"): Experiment 1 (Table-2 network, rates searched, §4.1) under
each reading of the seed's open choices, at the full Table-1 evaluation (32², Δt = 0.1, scored
at t = 2000 and every 200 for 10 rounds).

``counts``: ``--genomes`` random initial genomes per rate draw (``log-uniform`` over nine
decades, ``decade`` around Table 2), each evaluated from the three initial conditions
(``fixed``, ``steady``, ``uniform``; one shared field per draw), scored with the graded stage
two and checkerboards *scored*, then classed: invalid, homogeneous, graded (no peak), spots
(a prominent peak), and how many of the spot formers end as a grid-scale checkerboard.

``runs``: short evolution runs (``--generations``, population 150, full scoring) per reading,
best fitness and the count above 256 per generation, CPU seconds per run.

    nice -n 10 python docs/images/networks/readings.py counts OUT.json --genomes 1000
    nice -n 10 python docs/images/networks/readings.py runs OUT.json --generations 8 \\
        --folder /work/netruns/short
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.search.networks.evolve import Evaluation, evaluate, initial_state, network_fitness
from morphogen.search.networks.evolve import run as evolve
from morphogen.search.networks.genome import table2_genome, table2_spec
from morphogen.search.networks.operators import Operators, random_population

TABLE1 = Evaluation()
RUNS = {  # label: (init, draw, stage2)
    "fixed, decade, graded": ("fixed", "decade", "graded"),
    "fixed, decade, literal": ("fixed", "decade", "literal"),
    "fixed, log-uniform, graded": ("fixed", "log-uniform", "graded"),
    "steady, decade, graded": ("steady", "decade", "graded"),
}


def classes(fitness: np.ndarray, states: np.ndarray, ev: Evaluation) -> dict[str, int]:
    """Counts of the classes of a population's evaluation (module docstring)."""
    spots = fitness > 256.0
    strict = np.asarray(network_fitness(replace(ev, reject_checkerboards=True))(
        jnp.asarray(states)))
    return {"genomes": int(fitness.size), "invalid": int((fitness < 0).sum()),
            "homogeneous": int((fitness == 0).sum()),
            "graded": int(((fitness > 0) & (fitness <= 256.0)).sum()),
            "spots": int(spots.sum()),
            "spots_checkerboard_at_end": int((spots & (strict < 0)).sum()),
            "best": float(fitness.max())}


def counts(genomes: int, seed: int) -> dict:
    spec = table2_spec()
    template = table2_genome(spec)
    out: dict = {"genomes": genomes, "seed": seed, "evaluation": "Table 1, graded stage two, "
                 "checkerboards scored (counted at the last round)"}
    for draw in ("log-uniform", "decade"):
        pop = random_population(jax.random.key(seed), template, spec, genomes,
                                Operators(mode="rates", draw=draw))
        for init in ("fixed", "steady", "uniform"):
            ev = replace(TABLE1, init=init, reject_checkerboards=False)
            u0 = initial_state(jax.random.key(seed + 1), spec, ev)
            t0 = time.process_time()
            fitness, states = evaluate(pop, u0, spec, ev)
            row = classes(fitness, states, ev)
            row["cpu_s"] = round(time.process_time() - t0, 1)
            out[f"{draw}, {init}"] = row
            print(draw, init, row, flush=True)
    return out


def runs(generations: int, folder: Path, seed: int) -> dict:
    spec = table2_spec()
    out: dict = {"generations": generations, "population": 150, "seed": seed}
    for label, (init, draw, stage2) in RUNS.items():
        ev = replace(TABLE1, init=init, stage2=stage2)
        where = folder / label.replace(", ", "-")
        t0 = time.process_time()
        _, _, history = evolve(spec, table2_genome(spec), where,
                               ops=Operators(mode="rates", draw=draw), ev=ev, population=150,
                               generations=generations, seed=seed,
                               resume=(where / "state.npz").exists())
        out[label] = {"best": [round(float(h.max()), 2) for h in history],
                      "above_256": [int((h > 256).sum()) for h in history],
                      "valid": [int((h >= 0).sum()) for h in history],
                      "cpu_s": round(time.process_time() - t0, 1)}
        print(label, out[label], flush=True)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("part", choices=("counts", "runs"))
    parser.add_argument("out", type=Path)
    parser.add_argument("--genomes", type=int, default=1000)
    parser.add_argument("--generations", type=int, default=8)
    parser.add_argument("--folder", type=Path, default=Path("/work/netruns/short"))
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    result = (counts(args.genomes, args.seed) if args.part == "counts"
              else runs(args.generations, args.folder, args.seed))
    args.out.write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
