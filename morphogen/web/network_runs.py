"""Reaction-network evolution driven from the Evolve page (Yamamoto §3-4, rates or network mode).

The page posts a small run (bounded by :class:`~morphogen.web.limits.Limits`: grid side, steps
per evaluation × cells × population ≤ ``max_cell_steps``); the run is the same loop as ``morphogen
networks`` (:func:`morphogen.search.networks.evolve.run`, cluster-head fitness, tournament GA)
in its own thread, recorded in the run archive by
:class:`morphogen.search.networks.record.Recorder`, so ``morphogen runs show`` and
``morphogen networks --out DIR --resume`` work on it. After every generation the
:data:`SHOWN` fittest individuals are drawn (a node per reaction, fig. 7) and their final
activator field is saved as a picture; the page polls :meth:`NetworkRun.to_json` for progress and
those pictures, and opens an individual in Explore as its exported model file
(:func:`morphogen.search.networks.export.genome_network`), started from noise around 1 (the
middle of the evaluation's uniform ``[0, 2)`` initial state, §3.1) on the same grid, or on
Explore's smallest if the run's is smaller.

Only valid individuals are listed among the fittest: one that left the bounds or blew up
(fitness ``INVALID``, its state zeroed) is counted in ``invalid`` instead, so a generation with
fewer valid networks than :data:`SHOWN` shows fewer, and one with none says so. A fittest
network whose activator ends uniform (spread within the staged fitness's flat tolerance) is
marked ``uniform``, so its flat picture is labelled, not an unexplained blank tile.
"""

from __future__ import annotations

import hashlib
import threading
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.search.archive import Archive
from morphogen.search.fitness import INVALID
from morphogen.web.evolution import Stopped, run_to_end
from morphogen.web.limits import Limits, check_budget, choice, integer, number

FLAT_TOL = 1e-3
"""Relative spread below which a field counts as uniform (the staged fitness's ``flat_tol``)."""
SHOWN = 3
"""Fittest individuals shown after each generation (a genome already drawn is not drawn
again: the elite usually survives)."""
MAX_GENERATIONS = 50
DEFAULTS = {"mode": "network", "population": 12, "generations": 5, "size": 16, "dt": 0.1,
            "t_start": 100.0, "interval": 25.0, "rounds": 3, "m_max": 12, "seed": 0}
"""A run of a minute or so on two cores: Table 1's loop on a 16² grid and a short evaluation."""


@dataclass(frozen=True)
class NetworkSettings:
    """A validated request: the loop's spec, operators, evaluation and run length."""

    mode: str
    population: int
    generations: int
    seed: int
    spec: Any
    ops: Any
    ev: Any
    template: Any
    explore_size: int


def parse_settings(body: dict[str, Any], limits: Limits) -> NetworkSettings:
    """Validate the page's request against ``limits``; one-line errors for bad values."""
    from morphogen.search.networks.evolve import Evaluation
    from morphogen.search.networks.genome import (
        NetworkSpec,
        make_genome,
        table2_genome,
        table2_spec,
    )
    from morphogen.search.networks.operators import Operators

    d = {**DEFAULTS, **{k: v for k, v in body.items() if k in DEFAULTS and v is not None}}
    mode = choice(d["mode"], "mode", ("rates", "network"))
    population = integer(d["population"], "population", 2, limits.max_population)
    generations = integer(d["generations"], "generations", 1, MAX_GENERATIONS)
    size = integer(d["size"], "grid size", 8, limits.max_tile_size)
    dt = number(d["dt"], "dt", 1e-3, 1.0)
    t_start = number(d["t_start"], "first evaluation time", 0.0, 1e5)
    interval = number(d["interval"], "evaluation interval", 1e-3, 1e5)
    rounds = integer(d["rounds"], "evaluation rounds", 1, 10)
    m_max = integer(d["m_max"], "reaction slots", 7, 12)
    seed = integer(d["seed"], "seed", 0, 2**31 - 1)
    ev = Evaluation(size=size, dt=dt, t_start=t_start, interval=interval, rounds=rounds)
    check_budget(size * size, ev.steps, population,
                 limits)
    if mode == "rates":
        spec = table2_spec()
        template = table2_genome(spec)
    else:
        spec = NetworkSpec(("A", "B", "C"), m_max, (0.005, 0.2, 0.0), fixed=(0, 1),
                           fixed_rates=(0.0, 0.0))
        template = make_genome(spec, [0.0] * spec.m_max)
    return NetworkSettings(mode, population, generations, seed, spec, Operators(mode=mode), ev,
                           template, max(size, limits.min_size))


@dataclass
class NetworkRun:
    """One network run driven by a thread; the fields are what the page polls (the same
    interface as :class:`morphogen.web.evolution.EvolveRun`)."""

    run_id: str
    archive: Archive
    out: Path
    settings: NetworkSettings
    state: str = "running"  # running | done | stopped | error
    gen: int = 1
    progress: float = 0.0
    message: str = ""
    error: str | None = None
    log: list[str] = field(default_factory=list)
    best: list[dict[str, Any]] = field(default_factory=list)
    invalid: int = 0  # individuals of the generation shown that left the bounds or blew up
    _final: Any = None
    _done: int = 0
    _stop: threading.Event = field(default_factory=threading.Event)

    @property
    def total(self) -> int:
        return self.settings.generations

    @property
    def population(self) -> int:
        return self.settings.population

    def choose(self, indices: Any) -> None:
        raise MorphogenError("a network run is scored by the cluster-head fitness; it takes no "
                             "favourites")

    def stop(self) -> None:
        self._stop.set()

    def thread_main(self) -> None:
        from morphogen.search.networks import record
        from morphogen.search.networks.evolve import run

        s = self.settings
        recorder = record.Recorder(self.archive, self.run_id, self.out, s.spec, asdict(s.ev))
        per_gen = s.ev.steps

        def on_generation(gen: int, pop: Any, fitness: np.ndarray) -> None:
            recorder(gen, pop, fitness)
            self._show(gen + 1, pop, np.asarray(fitness))

        def tick(n: int) -> None:
            if self._stop.is_set():
                raise Stopped("stopped")
            self._done += n
            self.progress = min(self._done / per_gen, 1.0)
            self.message = f"generation {self.gen}/{self.total}: {self._done} of {per_gen} steps"

        run_to_end(self, lambda: run(
            s.spec, s.template, self.out, ops=s.ops, ev=s.ev, population=s.population,
            generations=s.generations, seed=s.seed, log=self.log.append, progress=tick,
            evaluator=self._evaluate, on_generation=on_generation))

    def _evaluate(self, pop: Any, u0: Any, spec: Any, ev: Any, progress: Any):
        """:func:`~morphogen.search.networks.evolve.evaluate`, keeping the final states for
        the pictures."""
        from morphogen.search.networks.evolve import evaluate

        self.gen = min(len(self.archive.generations(self.run_id)) + 1, self.total)
        self._done, self.progress, self.state = 0, 0.0, "running"
        fitness, final = evaluate(pop, u0, spec, ev, progress)
        self._final = final
        return fitness, final

    def _show(self, gen: int, pop: Any, fitness: np.ndarray) -> None:
        """Draw the fittest :data:`SHOWN` individuals of generation ``gen``."""
        from morphogen.models.network import to_toml
        from morphogen.render.images import state_image, write_png
        from morphogen.search.networks.draw import draw_network
        from morphogen.search.networks.export import genome_network
        from morphogen.search.networks.genome import Genome, describe
        from morphogen.util.io import write_atomic

        s = self.settings
        folder = self.out / "web"
        folder.mkdir(exist_ok=True)
        best = []
        valid = np.flatnonzero(fitness > INVALID)
        ranked = valid[np.argsort(-fitness[valid], kind="stable")][:SHOWN]
        for rank, idx in enumerate(ranked):
            genome = Genome(*(np.asarray(x[idx]) for x in pop))
            field_ = np.asarray(self._final[idx][s.ev.activator])
            entry: dict[str, Any] = {
                "idx": int(idx), "fitness": float(fitness[idx]), "uniform": uniform(field_),
                "reactions": [f"{r['reaction']}  k = {r['k']:g}"
                              for r in describe(genome, s.spec) if r["k"]],
            }
            # a new name each generation: a file replaced while being served would arrive cut
            pattern = folder / f"pattern_{gen:03d}_{rank}.png"
            write_png(pattern, state_image(field_, scale=max(1, 128 // s.ev.size)))
            entry["pattern"] = self._url(pattern)
            try:
                net = genome_network(genome, s.spec, name=f"{self.run_id}-{gen}-{int(idx)}",
                                     dt=s.ev.dt, initial=(1.0,) * s.spec.n)
                key = hashlib.sha1(b"".join(x.tobytes() for x in genome)).hexdigest()[:12]
                drawing = folder / f"network_{key}.png"
                if not drawing.exists():
                    png = draw_network(net, "png", title=f"{len(net.reaction_ids)} reactions")
                    write_atomic(drawing, lambda fh, png=png: fh.write(png))
                entry["network"] = self._url(drawing)
                entry["explore"] = {"model": {"equations": to_toml(net)}, "init": "noise",
                                    "seed": s.seed, "size": s.explore_size}
            except MorphogenError as exc:  # e.g. every rate zero: nothing to draw or run
                entry["network"], entry["explore"], entry["note"] = None, None, str(exc)
            best.append(entry)
        self.best, self.invalid = best, int(len(fitness) - len(valid))

    def _url(self, path: Path) -> str:
        """The page's address of a file of the run."""
        return f"/api/runs/{self.run_id}/files/{path.relative_to(self.out).as_posix()}"

    def to_json(self) -> dict[str, Any]:
        """Status for the page: progress, log and the fittest individuals drawn so far."""
        return {
            "run": self.run_id, "kind": "networks", "mode": self.settings.mode,
            "state": self.state, "gen": self.gen, "total": self.total,
            "population": self.population, "progress": round(self.progress, 4),
            "message": self.message, "error": self.error, "log": self.log[-5:],
            "fitness": "cluster", "best": self.best, "invalid": self.invalid,
            "settings": self.controls(),
        }

    def controls(self) -> dict[str, Any]:
        """The run's settings as the Evolve page's controls hold them."""
        s = self.settings
        return {"kind": s.mode, "population": s.population, "generations": s.generations,
                "seed": s.seed, "size": s.ev.size, "dt": s.ev.dt, "t_start": s.ev.t_start,
                "interval": s.ev.interval, "rounds": s.ev.rounds}


def uniform(field_: np.ndarray) -> bool:
    """Whether a field is flat: its spread within :data:`FLAT_TOL` of its largest value."""
    f = np.asarray(field_, np.float64)
    return bool(np.ptp(f) <= FLAT_TOL * max(1.0, float(np.abs(f).max())))


def start_network_run(body: dict[str, Any], limits: Limits, archive: Archive) -> NetworkRun:
    """Validate the request, register the run in ``archive`` and return it (not yet running)."""
    from morphogen.search.networks import record

    s = parse_settings(body, limits)
    run_id = record.start(None, archive, {
        "mode": s.mode, "generations": s.generations, "population": s.population,
        "seed": s.seed, "spec": asdict(s.spec), "ops": asdict(s.ops), "ev": asdict(s.ev)})
    return NetworkRun(run_id, archive, Path(archive.run(run_id)["dir"]), s)
