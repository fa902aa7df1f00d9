"""The generation loop: ask, evaluate, (ask a person,) tell, record; resumable after a crash.

Randomness is a pure function of the run's seed and the generation number:

- strategy initialisation: ``fold_in(PRNGKey(seed), 0)``
- ask in generation ``g``: ``fold_in(fold_in(PRNGKey(seed), 1), g)``
- evaluation in generation ``g``: ``fold_in(fold_in(PRNGKey(seed), 2), g)``

and the strategy's whole state after each generation is stored with that generation in the
archive. A run resumed from generation ``g`` therefore continues exactly as the uninterrupted
run would have: same genomes, same fitness, same final result.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import jax
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.search import qd_report, report
from morphogen.search.archive import CONFIG, Archive, Generation, new_run_id
from morphogen.search.cmaes import CMAES
from morphogen.search.cvt import CVTMapElites
from morphogen.search.evaluate import Problem
from morphogen.search.executors import Executor
from morphogen.search.fitness import human_fitness
from morphogen.search.ga import GeneticAlgorithm
from morphogen.search.gradient import GradientAscent, require_target
from morphogen.search.mapelites import MapElites
from morphogen.search.strategy import Strategy, state_from_arrays, state_to_arrays
from morphogen.util.io import ensure_writable_dir, read_text, write_json
from morphogen.util.progress import ProgressBar

STRATEGIES: dict[str, type[Strategy]] = {
    "ga": GeneticAlgorithm,
    "cmaes": CMAES,
    "gradient": GradientAscent,
    "map-elites": MapElites,
    "cvt-map-elites": CVTMapElites,
}
"""Strategy classes by command-line name; options are their dataclass fields. ``gradient``
needs ``fitness="target"`` and a :class:`~morphogen.search.executors.GradientExecutor`."""

BEST_KEPT = 3
"""Number of best individuals written to ``best/``."""

Select = Callable[[str, int], Sequence[int]]
"""``select(contact_sheet_path, population) -> chosen indices`` for human fitness."""


@dataclass
class RunResult:
    """The outcome of a run: its id and directory, and the best individual."""

    run_id: str
    directory: Path
    best_genome: np.ndarray
    best_fitness: float
    generations: int


def make_strategy(spec: Mapping[str, Any]) -> Strategy:
    """A strategy from ``{"name": "ga", "population": 30, ...options}``."""
    spec = dict(spec)
    name = spec.pop("name")
    if name not in STRATEGIES:
        raise MorphogenError(f"unknown strategy {name!r}; use one of {', '.join(STRATEGIES)}")
    population = spec.pop("population")
    try:
        return STRATEGIES[name](population_size=int(population), **spec)
    except TypeError as exc:
        raise MorphogenError(f"bad option for strategy {name}: {exc}") from None


def start(
    problem: Problem,
    strategy: Mapping[str, Any],
    *,
    generations: int,
    seed: int = 0,
    out: str | Path | None = None,
    archive: Archive | None = None,
    cmap: str = "viridis",
) -> tuple[str, Path]:
    """Create a run: its directory with ``config.json`` and its row in the archive.

    Everything is validated first (strategy, problem) so nothing is written for bad input.
    """
    if generations < 1:
        raise MorphogenError(f"generations must be >= 1, got {generations}")
    if make_strategy(strategy).needs_gradient:
        require_target(problem)
    archive = archive or Archive()
    run_id = new_run_id(Path(problem.model).stem)
    directory = Path(out) if out else archive.path.parent / run_id
    if (directory / CONFIG).exists():
        raise MorphogenError(
            f"{directory} already holds a run; resume it with --resume {directory} or choose "
            "another --out"
        )
    ensure_writable_dir(directory)
    config = {
        "id": run_id,
        "archive": str(archive.path),
        "seed": int(seed),
        "generations": int(generations),
        "strategy": dict(strategy),
        "problem": problem.to_dict(),
        "cmap": cmap,
    }
    write_json(directory / CONFIG, config)
    archive.create_run(run_id, directory, config)
    return run_id, directory


def evolve(
    run_id: str,
    archive: Archive,
    executor: Executor,
    *,
    select: Select | None = None,
    progress: bool = False,
    log: Callable[[str], Any] = print,
) -> RunResult:
    """Run (or continue) the generations of a recorded run until the last one.

    Args:
        executor: evaluates each generation; built from the run's problem.
        select: asks a person for the chosen indices (needed for ``fitness="user"``).
        progress: show a progress bar (with ETA) during each generation.
        log: receives one summary line per generation.
    """
    check_resumable(run_id, archive)  # the folder, the archive and its rows, before any change
    run = archive.run(run_id)
    config = run["config"]
    directory = Path(run["dir"])
    problem = Problem.from_dict(config["problem"])
    if problem.fitness == "user" and select is None:
        raise MorphogenError("user fitness needs a way to ask for the selection")
    strategy = make_strategy(config["strategy"])
    total = int(config["generations"])
    master = jax.random.PRNGKey(int(config["seed"]))
    state = strategy.init(jax.random.fold_in(master, 0), problem.genes)
    first = 1
    last = archive.last_state(run_id)
    if last is not None:
        first = last[0] + 1
        state = state_from_arrays(state, last[1])
    ask_key, eval_key = jax.random.fold_in(master, 1), jax.random.fold_in(master, 2)
    label = f"{problem.model} {config['strategy']['name']} {problem.fitness}"
    computing = 0.0  # seconds spent evaluating and breeding, not waiting for a person's choice
    for gen in range(first, total + 1):
        t0 = time.perf_counter()
        waited = 0.0
        genomes, state = strategy.ask(jax.random.fold_in(ask_key, gen), state)
        genomes = np.asarray(genomes)
        bar = ProgressBar(executor.total(len(genomes)), enabled=progress, unit=executor.unit,
                          desc=f"generation {gen}/{total}")
        try:
            fitness, metrics = executor.evaluate(genomes, jax.random.fold_in(eval_key, gen),
                                                 bar.update)
        finally:
            bar.close()
        rgb = report.tiles(metrics["fields"], config.get("cmap", "viridis"), problem.flat_tol)
        images = report.write_individuals(directory, gen, rgb)
        title = f"{label} - generation {gen}"
        if problem.fitness == "user":
            sheet = report.write_sheet(directory, gen, rgb, None, title)
            asked = time.perf_counter()
            chosen = select(str(directory / sheet), len(genomes))
            waited = time.perf_counter() - asked
            fitness = human_fitness(chosen, len(genomes)).astype(np.float32)
        sheet = report.write_sheet(directory, gen, rgb, fitness, title)
        told = {"gradient": metrics.get("gradient")} if strategy.needs_gradient else {}
        if getattr(strategy, "needs_fields", False):
            told["fields"] = metrics["fields"]
        state, m = strategy.tell(genomes, fitness, state, **told)
        seconds = time.perf_counter() - t0 - waited
        computing += seconds
        archive.record_generation(run_id, Generation(
            gen=gen, genomes=genomes, fitness=fitness, valid=metrics["valid"], images=images,
            sheet=sheet, seconds=seconds, best_so_far=float(m["best_fitness"]),
            state=state_to_arrays(state),
        ))
        if problem.fitness != "user":  # favourites' selection weights are no fitness to plot
            report.write_fitness_plot(directory, archive.generations(run_id), label)
        report.write_best(directory, problem, archive.best(run_id, BEST_KEPT), run_id)
        if isinstance(strategy, MapElites):
            _write_qd(directory, problem, strategy, state, archive, run_id, label)
        remaining = computing / (gen - first + 1) * (total - gen)
        log(_summary(gen, total, fitness, metrics["valid"], float(m["best_fitness"]), seconds,
                     remaining))
    if isinstance(strategy, MapElites):
        families = qd_report.write_elite_map(directory, strategy, state, executor.evaluate,
                                             jax.random.fold_in(master, 3),
                                             config.get("cmap", "viridis"))
        qd_report.write_elites(directory, problem, strategy, state, archive, run_id, families)
    archive.set_status(run_id, "done")
    best = archive.best(run_id, 1)[0]
    return RunResult(run_id, directory, np.asarray(best["genome"]), float(best["fitness"]),
                     total)


def _write_qd(directory: Path, problem: Problem, strategy: MapElites, state: Any,
              archive: Archive, run_id: str, label: str) -> None:
    """The MAP-Elites files of a generation: the elites' run files and ``qd.png``."""
    qd_report.write_elites(directory, problem, strategy, state, archive, run_id)
    template = strategy.init(jax.random.PRNGKey(0), problem.genes)
    history = qd_report.qd_history(strategy, template, archive, run_id)
    qd_report.write_qd_plot(directory, history, strategy.cell_count, label)


def check_resumable(run_id: str, archive: Archive) -> None:
    """Refuse, before anything is written, a run that cannot go on: its folder missing, not a
    folder, or holding another run (the archive and the folder must agree on the run's id); its
    stored configuration unreadable; a generation missing from the record; a stored genome that
    is not one finite number per gene; or a saved strategy state that does not fit the
    strategy. A new run (nothing recorded yet) passes at once.

    Raises:
        MorphogenError: one line naming the run and what is wrong.
    """
    import json

    from morphogen.util.io import file_kind

    run = archive.run(run_id)
    directory = Path(run["dir"])
    where = f"run {run_id}'s folder {directory}"
    if not directory.exists():
        raise MorphogenError(f"{where} does not exist (deleted or moved), so the run cannot be "
                             f"resumed; the archive {archive.path} keeps only its record")
    if not directory.is_dir():
        raise MorphogenError(f"{where} is {file_kind(directory.stat().st_mode)}, not a folder; "
                             "the run cannot be resumed")
    try:
        folder = json.loads(read_text(directory / CONFIG, "run configuration"))
    except MorphogenError as exc:
        raise MorphogenError(f"{where} no longer holds the run ({exc}); it cannot be resumed"
                             ) from None
    except (ValueError, RecursionError):
        folder = None
    if not isinstance(folder, dict) or folder.get("id") != run_id:
        other = folder.get("id") if isinstance(folder, dict) else None
        raise MorphogenError(
            f"{where} holds {'run ' + repr(other) if other else 'no readable run'}, not run "
            f"{run_id}: the archive {archive.path} and the folder disagree; the run cannot be "
            "resumed")
    config = run["config"]
    try:
        problem = Problem.from_dict(config["problem"])
        strategy = make_strategy(config["strategy"])
    except (KeyError, TypeError, ValueError, AttributeError):
        raise MorphogenError(f"run {run_id} has a damaged stored configuration; it cannot be "
                             "resumed") from None
    gens = [int(row["gen"]) for row in archive.generations(run_id)]
    if not gens:
        return
    if gens != list(range(1, len(gens) + 1)):
        raise MorphogenError(f"run {run_id} in the archive {archive.path} records generations "
                             f"{gens[:6]}{'...' if len(gens) > 6 else ''}, not 1 to "
                             f"{len(gens)}; it cannot be resumed")
    n = len(problem.genes)
    for row in archive.individuals(run_id):
        genome = np.asarray(row["genome"], np.float64)
        if genome.shape != (n,) or not np.isfinite(genome).all():
            raise MorphogenError(
                f"run {run_id} in the archive {archive.path} has a damaged row (generation "
                f"{row['gen']}, individual {row['idx']}: a genome of {genome.size} values, "
                f"{'not finite' if genome.shape == (n,) else f'not {n}'}); it cannot be resumed")
    template = strategy.init(jax.random.PRNGKey(0), problem.genes)
    state_from_arrays(template, archive.last_state(run_id)[1])


def set_generations(run_id: str, archive: Archive, generations: int) -> None:
    """Make ``generations`` the new total of a recorded run (``evolve --resume RUN
    --generations N``): more than planned extends it, fewer ends it early, but never below the
    generations already recorded. The run's ``config.json`` and its archive row both change, so
    every later resume keeps the new total; a changed run is ``running`` until it ends.

    Raises:
        MorphogenError: ``generations`` is below the generations done (or below 1).
    """
    run = archive.run(run_id)
    config = run["config"]
    done = len(archive.generations(run_id))
    if generations < max(done, 1):
        raise MorphogenError(
            f"run {run_id} has already done {done} generations; --generations is the run's new "
            f"total, so give at least {max(done, 1)} (or leave it out to keep "
            f"{config['generations']})"
        )
    if generations == config["generations"]:
        return
    config = {**config, "generations": int(generations)}
    config_file = Path(run["dir"]) / CONFIG
    if config_file.is_file():
        write_json(config_file, config)
    archive.set_generations(run_id, int(generations), config)


def resolve_run(ref: str, archive_path: str | None = None) -> tuple[str, Archive]:
    """Find a run by directory (reading its ``config.json``) or by id in the archive."""
    import json

    config_file = Path(ref) / CONFIG
    if config_file.exists():  # a FIFO or folder there is named by read_text
        try:
            config = json.loads(read_text(config_file, "run configuration"))
            run_id, path = str(config["id"]), archive_path or str(config["archive"])
        except MorphogenError:
            raise
        except (ValueError, KeyError, TypeError, RecursionError):
            raise MorphogenError(f"{config_file} is not a run configuration") from None
        archive = Archive(path, create=False)
        recorded = Path(archive.run(run_id)["dir"])
        if recorded.resolve() != Path(ref).resolve():
            raise MorphogenError(
                f"{ref} is a copy of run {run_id}, which the archive {archive.path} keeps at "
                f"{recorded}; resume that directory instead"
            )
        return run_id, archive
    if Path(ref).is_dir():
        raise MorphogenError(f"{ref} is a directory but holds no run ({CONFIG} missing)")
    archive = Archive(archive_path, create=False)
    return archive.run(ref)["id"], archive


def _summary(gen: int, total: int, fitness: np.ndarray, valid: np.ndarray, best: float,
             seconds: float, remaining: float) -> str:
    finite = fitness[np.isfinite(fitness)]
    mean = float(finite.mean()) if finite.size else float("nan")
    return (f"generation {gen}/{total}: best {float(np.max(fitness)):.4f}  mean {mean:.4f}  "
            f"valid {int(np.sum(valid))}/{len(valid)}  best so far {best:.4f}  "
            f"{seconds:.1f} s  eta {_clock(remaining)}")


def _clock(seconds: float) -> str:
    m, s = divmod(int(round(seconds)), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"
