"""Search from Python: a model, its genes and a strategy in, the best parameters out.

:func:`optimise` is the in-memory door to the strategies that ``morphogen evolve`` runs with an
archive, run folder and pictures: it builds the :class:`~morphogen.search.evaluate.Problem`
from keyword settings, evaluates each generation as one batched program
(:class:`~morphogen.search.evaluate.Evaluator`) and runs the ask/tell loop of
:mod:`morphogen.search.strategy` with the same keys as ``evolve`` (``fold_in(seed, 1)`` to ask,
``fold_in(seed, 2)`` to evaluate, then the generation number), writing nothing::

    import morphogen as mg
    from morphogen.search import CMAES, optimise

    model = mg.load_model("gray-scott")
    result = optimise(model, {"F": (0.02, 0.06), "k": (0.05, 0.07)}, strategy=CMAES(
        population_size=8), generations=5, size=(32, 32), steps=500)
    result.best_params, result.best_fitness

The model may be a name, a file, or a :class:`~morphogen.models.model.Model` object (one built
in Python, without text, is evaluated as it is). A strategy is a name (``"ga"``, ``"cmaes"``,
``"map-elites"``, ``"cvt-map-elites"``) or a strategy object built with its own options.
Gradient ascent needs the target's gradient: use :func:`morphogen.search.gradient.fit`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import jax
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.search.evaluate import Evaluator, Problem
from morphogen.search.genes import Gene
from morphogen.search.run import STRATEGIES
from morphogen.search.strategy import State, Strategy


@dataclass(frozen=True)
class SearchResult:
    """What :func:`optimise` found.

    Attributes:
        best_params: the best individual's genes, ``{name: value}``.
        best_fitness: its fitness (higher is better).
        genomes: every generation's population, ``(generations, P, G)``.
        fitness: their fitness, ``(generations, P)``.
        problem: the settings that were searched (a ``Problem``, as ``evolve`` saves it).
        state: the strategy's final state (its archive of elites, for MAP-Elites).
    """

    best_params: dict[str, float]
    best_fitness: float
    genomes: np.ndarray
    fitness: np.ndarray
    problem: Problem
    state: State


def _genes(genes: Sequence[Gene] | Mapping[str, Sequence[float]]) -> tuple[Gene, ...]:
    if isinstance(genes, Mapping):
        out = []
        for name, span in genes.items():
            if len(span) not in (2, 3):
                raise MorphogenError(f"gene {name}: give (low, high) or (low, high, sigma), "
                                     f"got {tuple(span)}")
            out.append(Gene(name, *(float(v) for v in span)))
        genes = out
    genes = tuple(genes)
    if not genes or not all(isinstance(g, Gene) for g in genes):
        raise MorphogenError("give at least one gene: {name: (low, high)} or Gene objects")
    return genes


def _strategy(strategy: Strategy | str, population: int) -> Strategy:
    if isinstance(strategy, Strategy):
        chosen = strategy
    elif strategy in STRATEGIES and strategy != "gradient":
        chosen = STRATEGIES[strategy](population_size=int(population))
    else:
        names = ", ".join(n for n in STRATEGIES if n != "gradient")
        raise MorphogenError(f"unknown strategy {strategy!r}; use one of {names} or a strategy "
                             "object (gradient ascent: morphogen.search.gradient.fit)")
    if chosen.needs_gradient:
        raise MorphogenError("gradient ascent needs the target's gradient: use "
                             "morphogen.search.gradient.fit")
    return chosen


def _problem(model: Model | str | Path, genes: tuple[Gene, ...], settings: dict[str, Any]
             ) -> tuple[Problem, Model | None]:
    if isinstance(model, Model):
        name = model.name
        return Problem(model=name, genes=genes, model_source=model.source, **settings), (
            None if model.source else model)
    return Problem(model=str(model), genes=genes, **settings), None


def optimise(
    model: Model | str | Path,
    genes: Sequence[Gene] | Mapping[str, Sequence[float]],
    *,
    strategy: Strategy | str = "ga",
    population: int = 16,
    generations: int = 10,
    seed: int = 0,
    log: Callable[[str], Any] | None = None,
    **settings: Any,
) -> SearchResult:
    """Search ``genes`` of ``model`` with ``strategy`` for ``generations`` (module docstring).

    Args:
        genes: ``{name: (low, high)}`` (or ``(low, high, sigma)``) or :class:`Gene` objects.
        population: individuals per generation when ``strategy`` is a name (a strategy object
            brings its own ``population_size``).
        log: receives one line per generation (best and mean valid fitness).
        settings: the run settings of :class:`~morphogen.search.evaluate.Problem`
            (``size``, ``dt``, ``steps``, ``scheme``, ``init``, ``fitness``, ``target``,
            ``params``, ``preset``, …).
    """
    if int(generations) < 1:
        raise MorphogenError(f"generations must be >= 1, got {generations}")
    allowed = sorted(set(Problem.__dataclass_fields__) - {"genes", "model", "model_source"})
    unknown = sorted(set(settings) - set(allowed))
    if unknown:
        raise MorphogenError(f"unknown setting {unknown[0]!r} for a search; use "
                             f"{', '.join(allowed)}")
    genes_ = _genes(genes)
    chosen = _strategy(strategy, population)
    problem, built = _problem(model, genes_, settings)
    evaluator = Evaluator(problem, model=built)
    master = jax.random.PRNGKey(int(seed))
    state = chosen.init(jax.random.fold_in(master, 0), genes_)
    ask_key, eval_key = jax.random.fold_in(master, 1), jax.random.fold_in(master, 2)
    all_genomes, all_fitness = [], []
    for gen in range(1, int(generations) + 1):
        genomes, state = chosen.ask(jax.random.fold_in(ask_key, gen), state)
        genomes = np.asarray(genomes)
        fitness, metrics = evaluator(genomes, jax.random.fold_in(eval_key, gen))
        told = {"fields": metrics["fields"]} if getattr(chosen, "needs_fields", False) else {}
        state, m = chosen.tell(genomes, fitness, state, **told)
        all_genomes.append(genomes)
        all_fitness.append(fitness)
        if log is not None:
            valid = fitness[metrics["valid"]]
            mean = f"{valid.mean():.4g}" if valid.size else "-"
            log(f"generation {gen}/{generations}: best {float(m['best_fitness']):.4g}, "
                f"mean {mean}, valid {valid.size}/{len(fitness)}")
    best = np.asarray(state.best_genome)
    return SearchResult(
        best_params={g.name: float(v) for g, v in zip(genes_, best, strict=True)},
        best_fitness=float(state.best_fitness), genomes=np.stack(all_genomes),
        fitness=np.stack(all_fitness), problem=evaluator.problem, state=state)
