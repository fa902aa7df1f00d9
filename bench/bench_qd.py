"""Quality-diversity against single-objective search: pattern families found for one budget.

Skaggs (seed 000, §6.1) saw his GA with the modified Dirichlet energy lose the variety of its
first generation. With the same number of evaluations, Skaggs's GA (fitness-proportionate,
Dirichlet energy), CMA-ES and MAP-Elites (``spot_index`` × ``coherence``, 8 × 8 cells) search

- Gray-Scott over F ∈ [0.01, 0.08], k ∈ [0.04, 0.07] (Richard et al.'s fig. 9 box, seed 001
  §5.2.2), against the dense 12 × 12 (F, k) atlas of the same settings, with a quarter of its
  evaluations;
- GenRD (Skaggs eqs. 3.1-3.2, his 108 coefficient genes on [-1, 1], ``Du = Dv = 1``).

Every evaluated genome is run by the evaluator's own compiled chunks of steps with its last
``WATCH`` snapshots kept (as :func:`morphogen.patterns.watch.simulate_watched` does), so its
fitness (the staged Dirichlet energy of :mod:`morphogen.search.fitness`, on the final state)
and its family (:mod:`morphogen.patterns.classify`, spatial and temporal rules) come from one
simulation. A run is invalid when its state is not finite or overflows (the evaluator's
explicit stability bound, slow for GenRD's 108 genes, is not applied).
Reported per model, strategy and seed: families found (over every evaluated genome), the
descriptor cells they reach (the MAP-Elites grid, measured the same way for every strategy) and
the best fitness.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.models.registry import load_model
from morphogen.patterns.classify import classify
from morphogen.patterns.descriptors import describe_batch
from morphogen.search import fitness as fit
from morphogen.search.archive import Archive
from morphogen.search.evaluate import CHUNK, Evaluator, Problem, individual_keys
from morphogen.search.genes import Gene, preset_genes
from morphogen.search.mapelites import MapElites
from morphogen.search.run import evolve, start

STRATEGIES = ("ga", "cmaes", "map-elites")
SEEDS = (0, 1, 2)
POPULATION, GENERATIONS = 9, 4
WATCH = (4, 50)
STATIC = ("uniform", "blown-up")
"""Families that are no pattern: the homogeneous state and a failed run."""

GRAY_SCOTT = Problem(
    model="gray-scott", genes=(Gene("F", 0.01, 0.08, 0.006), Gene("k", 0.04, 0.07, 0.003)),
    size=(48, 48), dt=1.0, steps=3000, init="blobs")
ATLAS_SIDE = 12


def genrd_problem() -> Problem:
    genes = tuple(preset_genes("genrd", list(load_model("genrd").params)))
    return Problem(model="genrd", genes=genes, preset="skaggs-table-3.1", size=(24, 24),
                   dt=0.01, steps=1500, init="blobs")


class WatchedExecutor:
    """A local executor that also keeps each genome's family: one watched simulation per
    batch gives the staged Dirichlet fitness of the final state and the snapshots the
    classifier needs. ``seen`` collects ``(genome, family, cell)`` of every evaluation."""

    name, unit = "local", "genome"

    def __init__(self, problem: Problem):
        self.ev = Evaluator(problem)
        self.problem = problem
        self.score = jax.jit(fit.dirichlet_fitness(True, problem.flat_tol))
        self.cells = MapElites(population_size=POPULATION)
        self.seen: list[tuple[np.ndarray, str, int]] = []

    def total(self, population: int) -> int:
        return population

    def evaluate(self, genomes: np.ndarray, key: Any, update: Any = None
                 ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        genomes = np.asarray(genomes, np.float32)
        ev, p, n = self.ev, self.problem, len(genomes)
        params = ev.population_params(genomes)
        u = jnp.asarray(ev.initial_states(genomes))
        keys = jnp.asarray(individual_keys(jax.random.PRNGKey(0) if key is None else key, n))
        t = jnp.asarray(0.0, u.dtype)
        count, gap = WATCH
        head = p.steps - count * gap
        chunks = [CHUNK] * (head // CHUNK) + [head % CHUNK] * bool(head % CHUNK) + [gap] * count
        snaps = []
        for i, m in enumerate(chunks):  # the evaluator's compiled chunks, reused every call
            u, ts, keys = ev._advance(m, n)(u, params, t, keys)
            t = ts[0]
            if i >= len(chunks) - count - 1:
                snaps.append(np.asarray(u[:, ev.display], np.float32))
        state = np.asarray(u)
        valid = np.asarray(jax.vmap(fit.is_valid)(state))
        fitness = np.where(valid, np.asarray(self.score(state)), fit.INVALID).astype(np.float32)
        display = np.stack(snaps[-count - 1:], axis=1)
        families = classify(describe_batch(np.nan_to_num(display)), valid)
        fields = display[:, -1]
        cells = np.asarray(self.cells.cells_of(self.cells.measure(np.nan_to_num(fields))))
        self.seen += list(zip(genomes, families, cells.tolist(), strict=True))
        if update is not None:
            update(n)
        return fitness, {"valid": valid, "fields": fields}


def summary(seen: list[tuple[np.ndarray, str, int]], fitness: list[float]) -> dict[str, Any]:
    families = sorted({f for _, f, _ in seen})
    return {"evaluations": len(seen), "families": families,
            "family_count": len(families),
            "pattern_families": len([f for f in families if f not in STATIC]),
            "cells": len({c for _, _, c in seen}),
            "best_fitness": float(np.max(fitness))}


def search(problem: Problem, strategy: str, seed: int, executor: WatchedExecutor,
           root: Path) -> dict[str, Any]:
    executor.seen = []
    archive = Archive(root / f"{problem.model}-{strategy}-{seed}.sqlite")
    run_id, _ = start(problem, {"name": strategy, "population": POPULATION},
                      generations=GENERATIONS, seed=seed, archive=archive,
                      out=root / f"{problem.model}-{strategy}-{seed}")
    t0 = time.perf_counter()
    evolve(run_id, archive, executor, log=lambda s: None)
    fitness = [r["fitness"] for r in archive.individuals(run_id) if r["fitness"] is not None]
    searched = executor.seen[:POPULATION * GENERATIONS]  # not the elite map's re-evaluation
    result = {**summary(searched, fitness), "seconds": round(time.perf_counter() - t0, 1)}
    print(f"{problem.model} {strategy} seed {seed}: {result}", flush=True)
    return result


def atlas(executor: WatchedExecutor) -> dict[str, Any]:
    f = np.linspace(0.01, 0.08, ATLAS_SIDE)
    k = np.linspace(0.04, 0.07, ATLAS_SIDE)
    genomes = np.stack([a.reshape(-1) for a in np.meshgrid(f, k, indexing="ij")], 1)
    executor.seen = []
    t0 = time.perf_counter()
    fitness, _ = executor.evaluate(genomes.astype(np.float32), None)
    return {**summary(executor.seen, list(fitness)),
            "seconds": round(time.perf_counter() - t0, 1)}


def compare(problem: Problem, root: Path) -> dict[str, Any]:
    executor = WatchedExecutor(problem)
    out: dict[str, Any] = {"problem": {"model": problem.model, "genes": len(problem.genes),
                                       "size": list(problem.size), "dt": problem.dt,
                                       "steps": problem.steps, "init": problem.init,
                                       "preset": problem.preset}}
    for strategy in STRATEGIES:
        runs = {str(seed): search(problem, strategy, seed, executor, root) for seed in SEEDS}
        out[strategy] = {
            "runs": runs,
            "families_union": sorted(set().union(*(r["families"] for r in runs.values()))),
            "mean_family_count": float(np.mean([r["family_count"] for r in runs.values()])),
            "mean_pattern_families": float(np.mean([r["pattern_families"]
                                                    for r in runs.values()])),
            "mean_cells": float(np.mean([r["cells"] for r in runs.values()])),
            "best_fitness": max(r["best_fitness"] for r in runs.values()),
        }
    return out


def run() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        gray = compare(GRAY_SCOTT, root)
        gray["atlas"] = atlas(WatchedExecutor(GRAY_SCOTT))
        shown = set(gray["atlas"]["families"])
        for strategy in STRATEGIES:
            gray[strategy]["all_atlas_families"] = {
                seed: shown <= set(r["families"]) for seed, r in gray[strategy]["runs"].items()}
        genrd = compare(genrd_problem(), root)
    ga = genrd["ga"]["runs"]
    me = genrd["map-elites"]["runs"]
    return {
        "budget": {"population": POPULATION, "generations": GENERATIONS,
                   "evaluations": POPULATION * GENERATIONS, "seeds": list(SEEDS),
                   "atlas_evaluations": ATLAS_SIDE**2, "watch": list(WATCH)},
        "gray_scott": gray,
        "genrd": genrd,
        "claims": {
            "gray_scott_map_elites_finds_every_atlas_family": gray["map-elites"][
                "all_atlas_families"],
            "genrd_map_elites_more_pattern_families_than_ga": {
                s: me[s]["pattern_families"] > ga[s]["pattern_families"] for s in me},
        },
    }
