"""Where a generation is evaluated: in this process, or split into batches over Ray workers.

``auto`` (the default of ``evolve`` and ``networks``) chooses by the work of a generation: from
:data:`AUTO_WORK` cell-steps on, on a machine with more than one core and Ray installed, one
single-threaded Ray worker per core, each evaluating one batch of the population; below it, or
without Ray, this process. Measured on 2 cores (``bench/results/threads.json``): XLA's own
intra-op threads make one process no faster (0.95–1.01×), while one single-threaded worker per
core evaluated Skaggs' Table-5.1 generation 2.07× and 150 Table-2 networks 1.59× faster — when
the second core is free (docs/networks.md).

An executor has ``evaluate(genomes (P, G), key, update) -> (fitness (P,), metrics)`` and says
how its progress is counted (``unit``, ``total(P)``); ``update(n)`` is called as work is done.
Both executors give each individual the key ``fold_in(key, i)`` (see
:func:`morphogen.search.evaluate.individual_keys`), so they return the same fitness.
"""

from __future__ import annotations

import importlib.util
import json
from collections.abc import Callable
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.search.evaluate import Evaluator, Problem, cached_evaluator, individual_keys
from morphogen.util.cluster import cores, import_ray, start_ray

Update = Callable[[int], None]
EXECUTORS = ("auto", "local", "ray")
AUTO_WORK = 2e9
"""Cell-steps per generation from which ``auto`` splits a generation over Ray workers (about 5
CPU-seconds: Ray's start and each worker's compilation, a few seconds once, are then repaid
within the first generations)."""


def auto_executor(work: float) -> str:
    """``"ray"`` when a generation of ``work`` cell-steps is worth splitting over the cores
    (module docstring), else ``"local"``."""
    if work < AUTO_WORK or cores() < 2 or importlib.util.find_spec("ray") is None:
        return "local"
    return "ray"


def split_notice(workers: int) -> str:
    """The line printed when ``auto`` splits generations over ``workers`` Ray workers."""
    return (f"evaluating each generation on {workers} Ray workers (one per core); "
            "--executor local keeps it in this process")


class LocalExecutor:
    """The whole population as one batched simulation in this process."""

    name = "local"
    unit = "step"

    def __init__(self, problem: Problem):
        self.problem = problem
        self.evaluator = Evaluator(problem)

    def total(self, population: int) -> int:
        return self.problem.steps

    def evaluate(self, genomes: np.ndarray, key: Any, update: Update | None = None,
                 ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        return self.evaluator(genomes, key, update)


def _evaluate_batch(problem_json: str, genomes: np.ndarray, keys: np.ndarray,
                    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Body of a Ray task: evaluate one batch (the evaluator is built once per worker)."""
    return cached_evaluator(problem_json).evaluate_keys(genomes, keys)


class RayExecutor:
    """Each generation split into ``batches`` Ray tasks, each one batched simulation.

    Args:
        address: a running cluster (``ray://host:10001`` or ``host:6379``); ``None`` starts a
            local Ray on this machine.
        batches: tasks per generation; by default one per CPU of the cluster.
        num_cpus: CPUs of a local Ray started here.

    Ray's usage statistics are switched off and no dashboard is started.
    """

    name = "ray"
    unit = "individual"

    def __init__(self, problem: Problem, *, address: str | None = None,
                 batches: int | None = None, num_cpus: int | None = None):
        import_ray()
        self.problem = problem
        self._json = json.dumps(problem.to_dict(), sort_keys=True)
        Evaluator(problem)  # validate here, before any task is sent
        self._ray = ray = start_ray(address, num_cpus)
        cpus = int(ray.cluster_resources().get("CPU", 1))
        if batches is not None and batches < 1:
            raise MorphogenError(f"--batches must be >= 1, got {batches}")
        self.batches = batches or max(1, cpus)
        self._task = ray.remote(num_cpus=1)(_evaluate_batch)

    def total(self, population: int) -> int:
        return population

    def evaluate(self, genomes: np.ndarray, key: Any, update: Update | None = None,
                 ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        ray = self._ray
        genomes = np.asarray(genomes, np.float32)
        keys = individual_keys(key, genomes.shape[0])
        parts = [p for p in np.array_split(np.arange(genomes.shape[0]), self.batches) if p.size]
        pending = {self._task.remote(self._json, genomes[p], keys[p]): p for p in parts}
        fitness = np.zeros(genomes.shape[0], np.float32)
        valid = np.zeros(genomes.shape[0], bool)
        fields: np.ndarray | None = None
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            idx = pending.pop(done[0])
            f, m = ray.get(done[0])
            fitness[idx], valid[idx] = f, m["valid"]
            if fields is None:
                fields = np.zeros((genomes.shape[0], *m["fields"].shape[1:]), np.float32)
            fields[idx] = m["fields"]
            if update is not None:
                update(idx.size)
        return fitness, {"valid": valid, "fields": fields}


class GradientExecutor:
    """The whole population in this process, with the gradient of each fitness: what the
    gradient strategy (:class:`~morphogen.search.gradient.GradientAscent`) needs.

    One differentiable batched simulation per generation (``metrics["gradient"]``, shape
    ``(P, G)``); progress is reported once it is done.
    """

    name = "local"
    unit = "individual"

    def __init__(self, problem: Problem):
        from morphogen.search.gradient import GradientEvaluator

        self.problem = problem
        self.evaluator = GradientEvaluator(problem)

    def total(self, population: int) -> int:
        return population

    def evaluate(self, genomes: np.ndarray, key: Any, update: Update | None = None,
                 ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        fitness, metrics = self.evaluator(genomes, key)
        if update is not None:
            update(len(genomes))
        return fitness, metrics


Executor = LocalExecutor | RayExecutor | GradientExecutor


def make_executor(name: str, problem: Problem, *, gradient: bool = False,
                  population: int = 1, **options: Any) -> Executor:
    """An executor by name (:data:`EXECUTORS`); ``options`` go to :class:`RayExecutor`.

    ``auto`` chooses by the work of a generation of ``population`` individuals
    (:func:`auto_executor`). ``gradient=True`` (for the gradient strategy) gives a
    :class:`GradientExecutor`, which runs in this process only.
    """
    if name == "auto":
        work = population * int(np.prod(problem.size)) * problem.steps
        name = "local" if gradient else auto_executor(work)
    if gradient:
        if name != "local":
            raise MorphogenError(
                "the gradient strategy runs in this process: use --executor local"
            )
        return GradientExecutor(problem)
    if name == "local":
        return LocalExecutor(problem)
    if name == "ray":
        return RayExecutor(problem, **options)
    raise MorphogenError(f"unknown executor {name!r}; use one of {', '.join(EXECUTORS)}")
