"""The files of a MAP-Elites run: its elites as replayable run files, coverage and QD-score per
generation, and the picture of the archive.

Written into the run directory by :func:`morphogen.search.run.evolve` (all atomically, all
rebuilt from the archive, so a resumed run rewrites them whole):

- ``elites/cell_CCCC.json`` after every generation, one per filled cell ``C`` (the flat index
  of :meth:`~morphogen.search.mapelites.MapElites.cells_of`): a ``run.json`` that
  ``morphogen simulate --config`` replays, plus an ``elite`` record (cell, bin of every
  descriptor, descriptor values, fitness, and the generation, index and image of the evaluated
  individual it is). Cells never empty and elites are only replaced by fitter ones, so a file is
  only ever overwritten.
- ``elites/index.json``: the same records, in cell order, with the descriptor grid; after the
  last generation each record also has its ``family``.
- ``qd.png``: coverage (filled cells) and QD-score per generation. The QD-score is
  ``Σ_c (f_c − QD_OFFSET)`` (Mouret & Clune 2015 with a fixed offset): the staged fitness is
  never below ``INVALID = −1`` (:mod:`morphogen.search.fitness`), so every elite adds ≥ 0,
  an invalid one 0, and the curve never falls.
- ``elites.png`` after the last generation: :func:`morphogen.search.elitemap.elite_map`, the
  elites re-evaluated in batches of the population size, one tile per filled cell, framed by
  family (grid cells over two descriptors; not for :mod:`morphogen.search.cvt` cells, whose
  ``index.json`` lists the centroids in the unit cube instead of bins).

Skaggs (seed 000, §6.1) kept only the best genomes; these files keep one good genome of every
kind of pattern the search met, each one command away from being run again.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import jax
import numpy as np

from morphogen.search.archive import Archive
from morphogen.search.cvt import CVTMapElites
from morphogen.search.evaluate import Problem
from morphogen.search.fitness import INVALID
from morphogen.search.mapelites import MapElites, coverage, qd_score
from morphogen.search.report import individual_run_file
from morphogen.search.strategy import Evaluate, State, state_from_arrays
from morphogen.util.io import write_atomic, write_json

QD_OFFSET = INVALID
"""Fitness offset of the QD-score: the lowest staged fitness (an invalid run)."""

ELITES = "elites"
INDEX = "index.json"


def cell_bins(strategy: MapElites, cell: int) -> list[int] | None:
    """The bin of every descriptor of a flat cell index: ``b_i = (cell // B^i) mod B`` (``None``
    for CVT cells, which are not a grid)."""
    if isinstance(strategy, CVTMapElites):
        return None
    b = int(strategy.bins)
    return [(int(cell) // b**i) % b for i in range(len(strategy.descriptors))]


def elite_records(strategy: MapElites, state: State, individuals: list[dict[str, Any]]
                  ) -> list[dict[str, Any]]:
    """One record per filled cell: cell, bins, descriptors, fitness, genome and the evaluated
    individual (``gen``, ``idx``, ``image``) it is (the first one with its genome, as the archive
    keeps the first of equally fit genomes)."""
    fitness = np.asarray(state.inner.fitness)
    genomes = np.asarray(state.inner.genomes, np.float32)
    values = np.asarray(state.inner.descriptors)[: strategy.cell_count]
    origin: dict[bytes, dict[str, Any]] = {}
    for ind in individuals:
        origin.setdefault(np.asarray(ind["genome"], np.float32).tobytes(), ind)
    records = []
    for cell in np.flatnonzero(np.isfinite(fitness)):
        found = origin.get(genomes[cell].tobytes(), {})
        records.append({
            "cell": int(cell),
            "bins": cell_bins(strategy, cell),
            "descriptors": {n: float(v) for n, v in zip(strategy.descriptors, values[cell],
                                                          strict=True)},
            "fitness": float(fitness[cell]),
            "genome": [float(g) for g in genomes[cell]],
            "generation": found.get("gen"),
            "index": found.get("idx"),
            "image": found.get("image"),
            "run_file": f"{ELITES}/cell_{int(cell):04d}.json",
        })
    return records


def write_elites(directory: Path, problem: Problem, strategy: MapElites, state: State,
                 archive: Archive, run_id: str,
                 families: dict[int, str] | None = None) -> list[dict[str, Any]]:
    """Write ``elites/cell_CCCC.json`` for every filled cell and ``elites/index.json``."""
    records = elite_records(strategy, state, archive.individuals(run_id))
    out = Path(directory)
    (out / ELITES).mkdir(parents=True, exist_ok=True)
    for rec in records:
        if families is not None and rec["cell"] in families:
            rec["family"] = families[rec["cell"]]
        data = individual_run_file(problem, rec["genome"])
        data["elite"] = {"run": run_id, "fitness_kind": problem.fitness, **rec}
        write_json(out / rec["run_file"], data)
    grid = {"descriptors": list(strategy.descriptors), "bins": int(strategy.bins),
            "ranges": [list(r) for r in strategy.ranges]}
    if isinstance(strategy, CVTMapElites):
        grid.update(bins=None, centroids=strategy.points.tolist())
    write_json(out / ELITES / INDEX, {"run": run_id, "grid": grid, "cells": int(
        strategy.cell_count), "qd_offset": QD_OFFSET, "elites": records})
    return records


def qd_history(strategy: MapElites, template: State, archive: Archive, run_id: str
               ) -> list[dict[str, float]]:
    """Filled cells, coverage and QD-score after every recorded generation."""
    out = []
    for gen, arrays in archive.states(run_id):
        state = state_from_arrays(template, arrays)
        share = coverage(state)
        out.append({"gen": gen, "filled": round(share * strategy.cell_count),
                    "coverage": share, "qd_score": qd_score(state, QD_OFFSET)})
    return out


def write_qd_plot(directory: Path, history: list[dict[str, float]], cells: int,
                  title: str) -> Path:
    """``qd.png``: filled cells (left axis) and QD-score (right axis) per generation."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    gens = [h["gen"] for h in history]
    fig = Figure(figsize=(5.0, 3.2), dpi=120)
    ax = fig.add_subplot()
    ax.plot(gens, [h["filled"] for h in history], "o-", color="tab:blue", markersize=3)
    ax.set_xlabel("generation")
    ax.set_ylabel(f"filled cells (of {cells})", color="tab:blue")
    ax.set_ylim(0, max(1, max((h["filled"] for h in history), default=1)) * 1.1)
    right = ax.twinx()
    right.plot(gens, [h["qd_score"] for h in history], "s--", color="tab:red", markersize=3)
    right.set_ylabel(f"QD-score  Σ (f − ({QD_OFFSET:g}))", color="tab:red")
    right.set_ylim(bottom=0)
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    if gens:
        step = max(1, -(-len(gens) // 20))
        ax.set_xticks(gens[::step])
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return write_atomic(Path(directory) / "qd.png", lambda fh: fh.write(buf.getvalue()))


def chunked(evaluate: Evaluate, size: int) -> Evaluate:
    """``evaluate`` applied ``size`` genomes at a time (the last chunk padded by repeating its
    last genome), so elites re-use the population's compiled program. Chunk ``j`` gets the key
    ``fold_in(key, j)``."""

    def run(genomes: Any, key: Any) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        genomes = np.asarray(genomes)
        n = len(genomes)
        pad = -n % size
        padded = np.concatenate([genomes, np.repeat(genomes[-1:], pad, axis=0)])
        parts = [evaluate(padded[i:i + size], jax.random.fold_in(key, i // size))
                 for i in range(0, len(padded), size)]
        fitness = np.concatenate([np.asarray(f) for f, _ in parts])[:n]
        metrics = {k: np.concatenate([np.asarray(m[k]) for _, m in parts])[:n]
                   for k in ("fields", "valid")}
        return fitness, metrics

    return run


def write_elite_map(directory: Path, strategy: MapElites, state: State, evaluate: Evaluate,
                    key: Any, cmap: str = "viridis") -> dict[int, str]:
    """``elites.png`` (grid cells over two descriptors only); returns the family of every
    filled cell."""
    from morphogen.render import write_png
    from morphogen.search.elitemap import elite_map

    if (len(strategy.descriptors) != 2 or isinstance(strategy, CVTMapElites)
            or not np.isfinite(np.asarray(state.inner.fitness)).any()):
        return {}
    image, families = elite_map(strategy, state, chunked(evaluate, strategy.population_size),
                                key, cmap=cmap)
    write_png(Path(directory) / "elites.png", image)
    return families
