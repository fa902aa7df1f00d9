"""How varied each generation of Skaggs' §3.2 Gray-Scott search is (docs/evolution.md).

    python docs/images/evolution/diversity.py [OUT.json]

Runs the search of docs/evolution.md's pictures (`morphogen evolve gray-scott --preset
skaggs-table-3.1 --dt 0.5 --time 2000 --init skaggs --clamp 0:5 --population 30
--generations 10 --size 128 --seed 1`, no elitism) into a temporary folder, evaluates every
recorded generation's genomes again (the start is deterministic, so the final fields are the
run's), and measures each generation's variety from the final ``v`` fields:

- ``patterned``: individuals whose field is neither uniform nor numerically unstable;
- ``families``: the pattern families among them (`patterns.classify` on the final field; the
  field alone, so no temporal family);
- ``spread``: the mean pairwise distance between the patterned individuals' descriptors
  (``wavelength / N``, ``spot_index``, ``coherence``, ``covered``, each divided by its
  standard deviation over every patterned individual of the run), 0 when fewer than two.
"""

from __future__ import annotations

import json
import sys
import tempfile
from itertools import combinations
from pathlib import Path

import jax
import numpy as np

from morphogen.cli.main import main
from morphogen.patterns.classify import classify
from morphogen.patterns.descriptors import describe_batch
from morphogen.search.archive import Archive
from morphogen.search.evaluate import Evaluator, Problem

ARGS = ["evolve", "gray-scott", "--preset", "skaggs-table-3.1", "--dt", "0.5", "--time", "2000",
        "--init", "skaggs", "--clamp", "0:5", "--population", "30", "--generations", "10",
        "--size", "128", "--seed", "1", "--quiet"]
KEYS = ("wavelength", "spot_index", "coherence", "covered")


def generations(tmp: Path) -> tuple[Problem, list[np.ndarray]]:
    """The run's problem and each generation's genomes."""
    if main([*ARGS, "--archive", str(tmp / "index.sqlite"), "--out", str(tmp / "gs")]):
        raise SystemExit("the search failed")
    archive = Archive(tmp / "index.sqlite", create=False)
    (run,) = archive.runs()
    info = archive.run(run["id"])
    rows = [archive.individuals(run["id"], g) for g in range(1, info["generations"] + 1)]
    return Problem.from_dict(info["config"]["problem"]), [
        np.array([r["genome"] for r in sorted(gen, key=lambda r: r["idx"])], np.float32)
        for gen in rows]


def measure(problem: Problem, genomes: list[np.ndarray]) -> list[dict]:
    evaluator = Evaluator(problem)
    per_gen = []
    for g in genomes:
        _, metrics = evaluator(g, jax.random.PRNGKey(0))
        fields = np.asarray(metrics["fields"], np.float32)
        d = {k: np.asarray(v) for k, v in describe_batch(np.stack([fields, fields], 1)).items()}
        labels = classify(d, metrics["valid"])
        patterned = ~np.isin(labels, ("uniform", "blown-up"))
        d["wavelength"] = d["wavelength"] / fields.shape[-1]
        per_gen.append({"labels": labels, "patterned": patterned,
                        "x": np.stack([d[k] for k in KEYS], 1)})
    every = np.concatenate([g["x"][g["patterned"]] for g in per_gen])
    scale = np.maximum(every.std(axis=0), 1e-12)
    out = []
    for i, g in enumerate(per_gen, start=1):
        x = g["x"][g["patterned"]] / scale
        pairs = [float(np.linalg.norm(a - b)) for a, b in combinations(x, 2)]
        families = {f: int((g["labels"][g["patterned"]] == f).sum())
                    for f in sorted(set(g["labels"][g["patterned"]]))}
        out.append({"gen": i, "patterned": int(g["patterned"].sum()), "families": families,
                    "spread": round(float(np.mean(pairs)), 3) if pairs else 0.0})
    return out


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as tmp:
        table = measure(*generations(Path(tmp)))
    text = json.dumps(table, indent=1)
    print(text)
    if len(sys.argv) > 1:
        Path(sys.argv[1]).write_text(text + "\n")
