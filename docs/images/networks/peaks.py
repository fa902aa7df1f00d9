"""Are the evolved Experiment-1 peaks taller and narrower than the hand-made ones (Yamamoto
§4.1: "tall and narrow activator peaks", "depletes the catalyst almost entirely")?

    python docs/images/networks/peaks.py RUNS_DIR

For the hand-made Table-2 rates, the seed's Fig. 4 rates (Table 2, right) and the fittest genome
of the last generation of every finished Experiment-1 run in ``RUNS_DIR`` (``exp1-seedS``, as
``make_figures.py`` names them), the state at the last scoring round (t = 3800) of the
Table-1 evaluation from the shared start of key 0 (the one ``make_figures.py`` draws), and:

- the fitness there, the homogeneous fixed point ``A*``, ``C*`` (the evaluation's start);
- the prominent peaks (:func:`~morphogen.search.networks.cluster.peaks`, the fitness's test):
  how many, their median height and that height over ``A*``;
- the width of a peak: the cells within ``d_max`` of it above half its height over the field's
  median (its area at half maximum), the median over the peaks;
- C under the pattern: its mean, and its mean and minimum over ``C*`` (a catalyst consumed
  where A peaks falls well below its homogeneous value);
- the rates next to Table 2's.

Prints a table; writes nothing. About a minute of CPU.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.search.networks.cluster import D_MAX, PROMINENCE, peaks
from morphogen.search.networks.evolve import (
    Evaluation,
    evaluate,
    fixed_states,
    initial_state,
    load_state,
)
from morphogen.search.networks.genome import (
    Genome,
    make_genome,
    rates,
    stack,
    table2_genome,
    table2_spec,
)
from morphogen.search.networks.reaction import genome_params

EVAL = Evaluation()
SLOTS = {"2A + C → 3A + C": 6, "B + C → B": 7, "2A → 2A + B": 8, "∅ → C": 2, "A → ∅": 3,
         "B → ∅": 4}
"""Table 2's reactions and their slots in :func:`table2_spec`."""


def fig4_genome() -> Genome:
    """The seed's Fig. 4 rates (Table 2, right) on the Table-2 network."""
    spec = table2_spec()
    hand = table2_genome(spec)
    return make_genome(spec, [0, 0, 0.031, 0.015, 0.02, 0, 0.094, 0.3, 0.0019],
                       np.asarray(hand.educts)[:, 6:], np.asarray(hand.products)[:, 6:])


def measure(genome: Genome) -> dict[str, float]:
    spec = table2_spec()
    u0 = initial_state(jax.random.key(0), spec, EVAL)
    pop = stack([genome])
    fitness, states = evaluate(pop, u0, spec, EVAL)
    u_star, ok = fixed_states(genome_params(pop, spec), spec)
    a_star, c_star = (float(u_star[0, 0]), float(u_star[0, 2])) if bool(ok[0]) else (np.nan,
                                                                                      np.nan)
    a, c = states[0, 0], states[0, 2]
    top = np.asarray(peaks(jnp.asarray(a), prominence=PROMINENCE))
    base = float(np.median(a))
    yy, xx = np.mgrid[: a.shape[0], : a.shape[1]]
    widths = []
    for y, x in zip(*np.nonzero(top), strict=True):
        dy = np.minimum(abs(yy - y), a.shape[0] - abs(yy - y))
        dx = np.minimum(abs(xx - x), a.shape[1] - abs(xx - x))
        disc = dy ** 2 + dx ** 2 <= D_MAX ** 2
        widths.append(int((disc & (a > base + (a[y, x] - base) / 2)).sum()))
    heights = a[top]
    return {"fitness": float(fitness[0]), "A*": a_star, "C*": c_star,
            "peaks": int(top.sum()),
            "height": float(np.median(heights)) if heights.size else np.nan,
            "height/A*": float(np.median(heights)) / a_star if heights.size else np.nan,
            "cells at half max": float(np.median(widths)) if widths else np.nan,
            "C mean": float(c.mean()), "C mean/C*": float(c.mean()) / c_star,
            "C min/C*": float(c.min()) / c_star}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs_dir", type=Path)
    args = parser.parse_args()
    genomes = {"hand-made": table2_genome(), "Fig. 4": fig4_genome()}
    for folder in sorted(args.runs_dir.glob("exp1-seed*")):
        pop, history, done, _ = load_state(folder / "state.npz")
        if done < 100:
            continue
        i = int(np.argmax(history[-1]))
        genomes[folder.name.split("-")[1]] = Genome(*(np.asarray(x)[i] for x in pop))
    rows = {name: measure(g) for name, g in genomes.items()}
    keys = list(next(iter(rows.values())))
    print("| | " + " | ".join(genomes) + " |")
    print("|---" * (len(genomes) + 1) + "|")
    for key in keys:
        print(f"| {key} | " + " | ".join(f"{rows[n][key]:.5g}" for n in genomes) + " |")
    for reaction, slot in SLOTS.items():
        print(f"| `{reaction}` | " + " | ".join(
            f"{float(np.asarray(rates(g))[slot]):.2g}" for g in genomes.values()) + " |")


if __name__ == "__main__":
    main()
