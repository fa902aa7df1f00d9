"""Network-evolution runs in the run archive (Yamamoto §3.4, with :mod:`morphogen.search.archive`).

A ``morphogen networks`` run folder keeps its own resumable ``state.npz``
(:mod:`morphogen.search.networks.evolve`); this module records the same run in the SQLite
archive that ``morphogen evolve`` uses, so ``morphogen runs`` lists it and ``morphogen runs
show`` summarises it:

- ``config.json`` in the run folder (id, archive path, settings, ``"kind": "networks"``) and a
  row in ``runs`` (strategy ``net-rates`` or ``net-network``, fitness ``cluster``);
- per generation, one ``generations`` row and one ``individuals`` row per genome, the genome
  flattened by :func:`genome_vectors` (mantissas, exponents, ``M_e``, ``M_p``, active mask);
- ``best/best_1.json``: a ``run.json`` whose model is the exported model file
  (:func:`~morphogen.search.networks.export.genome_network`) of the fittest genome so far, so
  ``morphogen simulate --config best/best_1.json`` replays it on the evaluation's grid, time
  step and number of steps, from the evaluation's kind of initial state: noise of ±``init_noise``
  around the genome's fixed point (``init = "fixed"``) or well-mixed state (``"steady"``), or
  uniform in ``[0, init_high)``.

A generation is recorded *before* ``state.npz`` is saved: a run killed between the two repeats
that generation on ``--resume`` and records it again (replacing the row), with the same numbers,
since the resumed run is bit-identical.
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.search.archive import CONFIG, Archive, Generation, new_run_id
from morphogen.search.fitness import INVALID
from morphogen.search.networks.genome import Genome, NetworkSpec, describe
from morphogen.util.io import write_json

KIND = "networks"
"""``config["kind"]`` of a network-evolution run."""


def spec_from_dict(s: dict[str, Any]) -> NetworkSpec:
    """A :class:`NetworkSpec` from its ``asdict`` form (lists back to tuples)."""
    return NetworkSpec(tuple(s["species"]), int(s["m_max"]), tuple(s["diffusion"]),
                       tuple(s["fixed"]), tuple(s["fixed_rates"]), int(s["exp_min"]),
                       int(s["exp_max"]))


def genome_vectors(pop: Genome) -> np.ndarray:
    """``(P, m + m + 2·n·m + m)`` floats: mantissas, exponents, ``M_e``, ``M_p`` (row-major
    ``n × m``), active mask — a population as the archive's genome rows."""
    parts = [np.asarray(x, np.float64) for x in pop]
    size = parts[0].shape[0]
    return np.concatenate([p.reshape(size, -1) for p in parts], axis=1)


def vector_genome(vector: Sequence[float], spec: NetworkSpec) -> Genome:
    """Inverse of :func:`genome_vectors` for one genome."""
    n, m = spec.n, spec.m_max
    v = np.asarray(vector, np.float64)
    if v.shape != (3 * m + 2 * n * m,):
        raise MorphogenError(f"archived genome has {v.size} numbers; this spec needs "
                             f"{3 * m + 2 * n * m}")
    cut = np.cumsum([m, m, n * m, n * m])
    mant, expo, me, mp, active = np.split(v, cut)
    return Genome(mant.astype(np.int32), expo.astype(np.int32),
                  me.reshape(n, m).astype(np.int32), mp.reshape(n, m).astype(np.int32),
                  active.astype(bool))


def start(out: Path | None, archive: Archive, settings: dict[str, Any]) -> str:
    """Register a new run for the folder ``out`` (default: the run id's folder next to the
    archive, as for ``morphogen evolve``): ``config.json`` and the archive's row.

    ``settings`` is the loop's ``meta`` (spec, ops, ev, population, seed) plus ``mode`` and
    ``generations``.
    """
    mode = settings["mode"]
    run_id = new_run_id(f"net-{mode}")
    if out is None:
        out = archive.path.parent / run_id
        out.mkdir(parents=True)
    config = {
        "id": run_id, "archive": str(archive.path), "kind": KIND,
        "seed": int(settings["seed"]), "generations": int(settings["generations"]),
        "strategy": {"name": f"net-{mode}", "population": int(settings["population"]),
                     **settings["ops"]},
        "problem": {"model": "table2" if mode == "rates" else "network", "fitness": "cluster",
                    "spec": settings["spec"], "ev": settings["ev"]},
    }
    write_json(Path(out) / CONFIG, config)
    archive.create_run(run_id, Path(out), config)
    return run_id


def _config(out: Path) -> dict[str, Any]:
    try:
        config = json.loads((Path(out) / CONFIG).read_text())
        kind = config.get("kind")
    except (OSError, ValueError, AttributeError):
        raise MorphogenError(f"{out} has no readable {CONFIG}; it was not recorded in a run "
                             "archive (start a new run with another --out)") from None
    if kind != KIND:
        raise MorphogenError(f"{out} holds a parameter search (morphogen evolve), not a "
                             f"network run; resume it with `morphogen evolve --resume {out}`")
    return config


def saved_settings(out: Path) -> dict[str, Any]:
    """The command-line settings a run folder was started with (``morphogen networks`` names:
    mode, population, seed, generations, size, dt, t_start, interval, rounds, m_max,
    tournament, init, init_noise, stage2, checkerboards, draw), so ``--resume`` needs no more
    than ``--out``; a run saved before an option existed gets its earlier behaviour (uniform
    starts, the literal stage two, checkerboards scored, the log-uniform draw)."""
    config = _config(out)
    try:
        strategy, problem = config["strategy"], config["problem"]
        ev = problem["ev"]
        return {"mode": strategy["name"].removeprefix("net-"),
                "population": int(strategy["population"]), "seed": int(config["seed"]),
                "generations": int(config["generations"]), "size": int(ev["size"]),
                "dt": float(ev["dt"]), "t_start": float(ev["t_start"]),
                "interval": float(ev["interval"]), "rounds": int(ev["rounds"]),
                "m_max": int(problem["spec"]["m_max"]),
                "tournament": int(strategy["tournament"]),
                "init": str(ev.get("init", "uniform")),
                "init_noise": float(ev.get("init_noise", 0.1)),
                "stage2": str(ev.get("stage2", "literal")),
                "checkerboards": "invalid" if ev.get("reject_checkerboards") else "scored",
                "draw": str(strategy.get("draw", "log-uniform"))}
    except (KeyError, TypeError, ValueError, AttributeError):
        raise MorphogenError(f"{Path(out) / CONFIG} is damaged; the run cannot be resumed"
                             ) from None


def resume_hint(run_id: str, directory: str) -> str:
    """The one-line answer to ``morphogen evolve --resume`` given a network run."""
    return (f"run {run_id} is a reaction-network run (morphogen networks), not a parameter "
            f"search; resume it with `morphogen networks --out {directory} --resume`")


def resume(out: Path, archive_path: str | None, generations: int) -> tuple[str, Archive]:
    """The run id and archive of the folder ``out``, its planned generations set to
    ``generations`` (``--resume`` may extend a run)."""
    config = _config(out)
    try:
        run_id, path = config["id"], archive_path or config["archive"]
    except KeyError:
        raise MorphogenError(f"{Path(out) / CONFIG} is damaged; the run cannot be resumed"
                             ) from None
    archive = Archive(path, create=False)
    archive.run(run_id)
    if config.get("generations") != generations:
        config["generations"] = int(generations)
        write_json(Path(out) / CONFIG, config)
        _set_generations(archive, run_id, config)
    return run_id, archive


def _set_generations(archive: Archive, run_id: str, config: dict[str, Any]) -> None:
    import sqlite3
    from contextlib import closing

    with closing(sqlite3.connect(archive.path, timeout=30.0)) as db, db:
        db.execute("UPDATE runs SET generations=?, config=? WHERE id=?",
                   (config["generations"], json.dumps(config), run_id))


class Recorder:
    """The loop's per-generation hook: one archive generation and ``best/best_1.json``."""

    def __init__(self, archive: Archive, run_id: str, out: Path, spec: NetworkSpec,
                 ev: dict[str, Any]):
        self.archive, self.run_id, self.out, self.spec, self.ev = archive, run_id, out, spec, ev
        self._clock = time.perf_counter()

    def __call__(self, gen: int, pop: Genome, fitness: np.ndarray) -> None:
        now = time.perf_counter()
        seconds, self._clock = now - self._clock, now
        fitness = np.asarray(fitness, np.float32)
        previous = [g["best_so_far"] for g in self.archive.generations(self.run_id)
                    if g["gen"] < gen + 1 and g["best_so_far"] is not None]
        size = fitness.shape[0]
        self.archive.record_generation(self.run_id, Generation(
            gen=gen + 1, genomes=genome_vectors(pop), fitness=fitness, valid=fitness > INVALID,
            images=[""] * size, sheet="", seconds=seconds,
            best_so_far=max([float(fitness.max()), *previous]), state={}))
        best = self.archive.best(self.run_id, 1)[0]
        (self.out / "best").mkdir(exist_ok=True)
        write_json(self.out / "best" / "best_1.json", self.best_run_file(best))

    def best_run_file(self, best: dict[str, Any]) -> dict[str, Any]:
        """A ``run.json`` object replaying the archived individual ``best``."""
        return best_run_file(best, self.spec, self.ev, self.run_id, self.out)


_LEGACY_EV = {"init": "uniform"}
"""A run recorded before ``init`` existed started from uniform states."""


def best_run_file(best: dict[str, Any], spec: NetworkSpec, ev: dict[str, Any], run_id: str,
                  out: Path) -> dict[str, Any]:
    """``run.json`` for an archived individual: the exported model file embedded, the
    evaluation's grid, ``dt`` and steps to its last round, and its kind of initial state
    (noise around the genome's fixed point or well-mixed state, or uniform)."""
    from morphogen.models.network import to_toml
    from morphogen.runs.config import FORMAT, RunConfig
    from morphogen.search.networks.evolve import Evaluation, fixed_states, homogeneous_states
    from morphogen.search.networks.export import genome_network
    from morphogen.search.networks.genome import stack
    from morphogen.search.networks.reaction import genome_params

    dt = float(ev["dt"])
    steps = int(round(ev["t_start"] / dt)) + (int(ev["rounds"]) - 1) * max(
        1, int(round(ev["interval"] / dt)))
    genome = vector_genome(best["genome"], spec)
    evaluation = Evaluation(**{**_LEGACY_EV, **ev})
    initial, init = None, ("random", {"low": 0.0, "high": float(evaluation.init_high)})
    params = genome_params(stack([genome]), spec)
    state = None
    if evaluation.init == "fixed":
        u_star, ok = fixed_states(params, spec)
        state = np.asarray(u_star)[0] if bool(ok[0]) else None
    elif evaluation.init == "steady":
        state = np.asarray(homogeneous_states(params, spec, evaluation))[0]
    if state is not None and np.isfinite(state).all():
        initial = tuple(float(x) for x in state)
        init = ("noise", {"amplitude": float(evaluation.init_noise)})
    net = genome_network(genome, spec, name=f"{run_id}-best", dt=dt, t_end=steps * dt,
                         initial=initial, description=f"best genome of run {run_id} (fitness "
                         f"{best['fitness']:.2f})")
    config = RunConfig(model=f"{out.name}-best.toml", model_source=to_toml(net),
                       size=[int(ev["size"])] * 2, dt=dt, steps=steps, init=init[0],
                       init_options=init[1], clamp=None)
    record = {"format": FORMAT, "config": asdict(config)}
    record["evolved"] = {"run": run_id, "generation": best["gen"], "index": best["idx"],
                         "fitness": best["fitness"], "fitness_kind": "cluster"}
    return record


def show(archive: Archive, run_id: str) -> str:
    """``morphogen runs show`` for a network run: settings, generations, best reactions."""
    r = archive.run(run_id)
    c = r["config"]
    p, s, ev = c["problem"], c["strategy"], c["problem"]["ev"]
    spec = spec_from_dict(p["spec"])
    lines = [
        f"run {r['id']} ({r['status']}), created "
        f"{time.strftime('%Y-%m-%d %H:%M', time.localtime(r['created']))}",
        f"  directory  {r['dir']}",
        f"  network    {p['model']}  species {', '.join(spec.species)}  slots {spec.m_max}  "
        f"D {', '.join(f'{d:g}' for d in spec.diffusion)}",
        f"  evaluation grid {ev['size']}x{ev['size']}  dt {ev['dt']:g}  from t = "
        f"{ev['t_start']:g} every {ev['interval']:g}, {ev['rounds']} rounds",
        f"  strategy   {s['name']}  population {s['population']}  tournament "
        f"{s.get('tournament', '-')}",
        f"  fitness    cluster  seed {c['seed']}  generations {c['generations']}",
        "",
        f"  {'gen':>4} {'best':>9} {'mean':>9} {'so far':>9} {'valid':>6} {'seconds':>8}",
    ]
    for g in archive.generations(run_id):
        cells = [f"{'-':>9}" if g[k] is None else f"{g[k]:>9.2f}"
                 for k in ("best", "mean", "best_so_far")]
        lines.append(f"  {g['gen']:>4} {' '.join(cells)} {g['valid']:>6} {g['seconds']:>8.1f}")
    best = archive.best(run_id, 1)
    if best:
        b = best[0]
        lines += ["", f"  best individual: fitness {b['fitness']:.2f} (generation {b['gen']}, "
                      f"#{b['idx']})"]
        for row in describe(vector_genome(b["genome"], spec), spec):
            if row["k"] or not row["fixed"]:
                lines.append(f"    {row['reaction']:<28} k = {row['k']:.2g}")
        lines.append(f"  replay: morphogen simulate --config {r['dir']}/best/best_1.json")
    return "\n".join(lines)


def summary(archive: Archive, run_id: str, k: int = 3) -> dict[str, Any]:
    """A network run for the web app's Runs page: its settings, one row per generation (best,
    mean, valid count) and the ``k`` fittest archived genomes that were valid (an invalid one,
    fitness -1, is never listed as fittest), each with its non-zero reactions and its
    ``run.json`` (:func:`best_run_file`), which Explore and ``morphogen simulate --config``
    replay."""
    r = archive.run(run_id)
    c = r["config"]
    p, ev = c["problem"], c["problem"]["ev"]
    spec = spec_from_dict(p["spec"])
    best = []
    for b in archive.best(run_id, k):
        if not b["fitness"] >= 0:  # sorted fittest first: the rest are invalid too
            break
        reactions = [f"{row['reaction']}  k = {row['k']:.3g}"
                     for row in describe(vector_genome(b["genome"], spec), spec) if row["k"]]
        best.append({"gen": b["gen"], "idx": b["idx"], "fitness": b["fitness"],
                     "reactions": reactions,
                     "run_file": best_run_file(b, spec, ev, run_id, Path(r["dir"]))})
    return {
        "kind": KIND, "id": run_id, "model": r["model"], "status": r["status"],
        "strategy": r["strategy"], "fitness": r["fitness"], "population": r["population"],
        "generations": r["generations"], "species": list(spec.species),
        "evaluation": {"size": int(ev["size"]), "dt": float(ev["dt"]),
                       "t_start": float(ev["t_start"]), "interval": float(ev["interval"]),
                       "rounds": int(ev["rounds"])},
        "history": [{key: g[key] for key in ("gen", "best", "mean", "valid", "seconds")}
                    for g in archive.generations(run_id)],
        "best": best,
        "resume": resume_hint(run_id, r["dir"]),
    }
