"""Evolve runs driven from the browser: Skaggs's user-guided GA, or an automatic fitness.

A run is created with :func:`morphogen.search.run.start` (so it lands in the same SQLite archive
as ``morphogen evolve``) and advanced by :func:`morphogen.search.run.evolve` in its own thread.
With human fitness (``fitness="user"``), ``evolve`` asks for a selection after evaluating each
generation; here that call waits until the page posts the chosen indices, which become the
fitness of Skaggs eq. 3.9 (:func:`morphogen.search.fitness.human_fitness`). The page polls the
run's status (``running`` with progress, ``choose`` with the generation's pictures, ``done``,
``stopped`` or ``error``), and every status carries the run's settings, so a page reloaded
while a run exists shows that run's model, genes and sizes instead of its defaults. A run
stopped while its favourites were being chosen keeps that generation's pictures in its status
(evaluated, never chosen, so not in the archive): the page goes on showing them.

A run that waits for a choice longer than ``Limits.session_idle_s`` stops; it stays in the
archive and ``morphogen evolve --resume RUN`` continues it.
"""

from __future__ import annotations

import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.search.archive import Archive
from morphogen.search.evaluate import Problem
from morphogen.search.executors import LocalExecutor
from morphogen.search.fitness import check_selection
from morphogen.search.run import evolve
from morphogen.web.runs_routes import explore_settings

MAX_ACTIVE = 4
"""Runs advancing at once (each holds a thread while it simulates or waits for a choice)."""


class Stopped(MorphogenError):
    """The run was stopped from the page (or waited too long for a choice)."""


def run_to_end(run: Any, body: Callable[[], None]) -> None:
    """Do a run's whole work, ``body``, in its thread, and leave the run (``state``,
    ``message``/``error``, ``progress``) and its archive row saying how it ended: ``done``,
    ``stopped`` from the page, ``failed`` with a one-line error, or ``failed`` with a bug's
    message (a bug must reach the page as a message, not a hang)."""
    try:
        body()
    except Stopped as exc:
        if not getattr(run, "keep_waiting", False):  # else it stays "running", to be taken up
            run.archive.set_status(run.run_id, "stopped")
        run.state, run.message = "stopped", str(exc)
    except MorphogenError as exc:
        run.archive.set_status(run.run_id, "failed")
        run.state, run.error = "error", str(exc)
    except Exception as exc:
        traceback.print_exc()
        run.archive.set_status(run.run_id, "failed")
        run.state, run.error = "error", f"internal error: {type(exc).__name__}: {exc}"
    else:
        run.archive.set_status(run.run_id, "done")
        run.state, run.progress = "done", 1.0
        run.message = f"finished {run.total} generations"


@dataclass
class EvolveRun:
    """One run driven by a thread; the fields are what the page polls."""

    run_id: str
    archive: Archive
    problem: Problem
    total: int
    population: int
    idle_s: float
    strategy: str = "ga"
    state: str = "running"  # running | choose | done | stopped | error
    gen: int = 1
    progress: float = 0.0
    message: str = ""
    error: str | None = None
    log: list[str] = field(default_factory=list)
    genomes: np.ndarray | None = None  # the generation being evaluated or chosen from
    keep_waiting: bool = False  # set when the server stops while the run waits for a choice
    _asking: int | None = None  # the generation whose favourites were asked for, until chosen
    _chosen: list[int] | None = None
    _wake: threading.Event = field(default_factory=threading.Event)
    _stop: threading.Event = field(default_factory=threading.Event)

    # -- called from the page -----------------------------------------------------------------
    def choose(self, indices: Any) -> None:
        """Hand over the favourites of the generation on show (validated)."""
        if self.state != "choose":
            raise MorphogenError("this run is not waiting for a choice")
        if not isinstance(indices, list):
            raise MorphogenError("indices must be a list of individual numbers")
        self._chosen = check_selection(indices, self.population)
        self.state, self.progress = "running", 0.0
        self.message = f"generation {self.gen}: {len(self._chosen)} chosen; breeding the next"
        self._wake.set()

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()

    def shut_down(self) -> None:
        """The server stops: a run waiting for a choice keeps its archive status ``running``
        (the next server takes it up when its page asks); any other run is stopped."""
        self.keep_waiting = self.state == "choose"
        self.stop()

    # -- called by search.run.evolve in the run's thread --------------------------------------
    def select(self, sheet: str, n: int) -> list[int]:
        """Wait for the page's choice (``evolve``'s human-selection callback)."""
        self.gen = len(self.archive.generations(self.run_id)) + 1
        self.progress = 1.0
        self.message = f"generation {self.gen}: choose your favourites"
        self._chosen = None
        self._wake.clear()
        self.state, self._asking = "choose", self.gen
        if not self._wake.wait(self.idle_s) and self._chosen is None:
            self._stop.set()
        if self._stop.is_set():
            raise Stopped("stopped while waiting for a choice")
        self.state, self._asking = "running", None
        return self._chosen or []

    def thread_main(self) -> None:
        def body() -> None:
            executor = _Tracked(LocalExecutor(self.problem), self)
            evolve(self.run_id, self.archive, executor, select=self.select,
                   log=self.log.append)

        run_to_end(self, body)

    def controls(self) -> dict[str, Any]:
        """The run's settings as the Evolve page's controls hold them."""
        p = self.problem
        model = {"equations": p.model_source} if p.model_source else {"library": p.model}
        return {"kind": "params", "model": model, "strategy": self.strategy,
                "fitness": p.fitness, "population": self.population, "generations": self.total,
                "size": int(max(p.size)), "steps": p.steps, "dt": p.dt, "seed": p.seed,
                "init": p.init, "genes": [g.to_dict() for g in p.genes]}

    def to_json(self) -> dict[str, Any]:
        """Status for the page: progress, the settings, what opens an individual in Explore
        (``explore``, with the parameters that are not genes); while waiting for a choice, or
        stopped while waiting, the pictures of that generation."""
        out = {
            "run": self.run_id, "state": self.state, "gen": self.gen, "total": self.total,
            "population": self.population, "progress": round(self.progress, 4),
            "message": self.message, "error": self.error, "log": self.log[-5:],
            "fitness": self.problem.fitness, "settings": self.controls(),
            "explore": {**explore_settings(self.problem), "params": dict(self.problem.params)},
        }
        if self.state == "choose" or (self.state == "stopped" and self._asking == self.gen):
            out["images"] = [
                f"/api/runs/{self.run_id}/files/generations/gen_{self.gen:03d}/ind_{i:02d}.png"
                for i in range(self.population)
            ]
            if self.genomes is not None:  # each picture's gene values, shown on hover
                out["params"] = [{g.name: float(v) for g, v in zip(self.problem.genes, row,
                                                                    strict=True)}
                                 for row in self.genomes]
        return out


class _Tracked:
    """An executor that reports evaluation progress to the run and honours its stop flag."""

    def __init__(self, inner: LocalExecutor, run: EvolveRun):
        self.inner, self.run = inner, run
        self.unit = inner.unit

    def total(self, population: int) -> int:
        return self.inner.total(population)

    def evaluate(self, genomes: np.ndarray, key: Any, update: Any = None):
        run = self.run
        run.gen = len(run.archive.generations(run.run_id)) + 1
        total = self.inner.total(len(genomes))
        done = 0

        def tick(n: int) -> None:
            nonlocal done
            if run._stop.is_set():
                raise Stopped("stopped")
            done += n
            run.progress = done / total
            run.message = f"generation {run.gen}/{run.total}: {done} of {total} steps"
            if update is not None:
                update(n)

        run.progress, run.state, run.genomes = 0.0, "running", np.asarray(genomes)
        return self.inner.evaluate(genomes, key, tick)


class EvolveRuns:
    """The runs started from the web app, by run id."""

    def __init__(self, idle_s: float):
        self.idle_s = idle_s
        self._runs: dict[str, EvolveRun] = {}
        self._lock = threading.Lock()

    def launch(self, archive: Archive, run_id: str, problem: Problem, total: int,
               population: int) -> EvolveRun:
        strategy = archive.run(run_id)["config"]["strategy"]["name"]
        return self.add(EvolveRun(run_id, archive, problem, total, population, self.idle_s,
                                  strategy))

    def check_capacity(self) -> None:
        """Refuse a new run while :data:`MAX_ACTIVE` runs are in progress."""
        with self._lock:
            self._check_capacity()

    def _check_capacity(self) -> None:
        active = [r for r in self._runs.values() if r.state in ("running", "choose")]
        if len(active) >= MAX_ACTIVE:
            raise MorphogenError(
                f"{MAX_ACTIVE} evolve runs are already in progress; stop one first"
            )

    def add(self, run: Any) -> Any:
        """Start ``run`` (an :class:`EvolveRun`, or any object with its ``run_id``, ``state``,
        ``thread_main``, ``stop`` and ``to_json``, e.g. a network run) in its own thread."""
        with self._lock:
            self._check_capacity()
            self._runs[run.run_id] = run
        self._start(run)
        return run

    def take_up(self, run_id: str, make: Callable[[], Any | None]) -> Any | None:
        """The run ``run_id`` if this server drives it; else the one ``make()`` builds (or
        ``None``), started once however many requests ask at the same time."""
        with self._lock:
            run = self._runs.get(run_id)
            if run is not None:
                return run
            run = make()
            if run is None:
                return None
            self._check_capacity()
            self._runs[run_id] = run
        self._start(run)
        return run

    @staticmethod
    def _start(run: Any) -> None:
        threading.Thread(target=run.thread_main, name=f"evolve-{run.run_id}",
                         daemon=True).start()

    def get(self, run_id: str) -> Any:
        with self._lock:
            run = self._runs.get(run_id)
        if run is None:
            raise MorphogenError(f"no evolve run {run_id!r} in progress on this server")
        return run

    def stop_all(self) -> None:
        """The server stops: every run stops (:meth:`EvolveRun.shut_down`: one waiting for a
        choice is left to be taken up again)."""
        with self._lock:
            for run in self._runs.values():
                getattr(run, "shut_down", run.stop)()
