"""The search-strategy interface: ask/tell over batched genomes with explicit state and keys.

A strategy proposes a population of genomes, shape ``(P, G)`` in real (bounded) gene units, and
learns from their fitness. It never sees grids or meshes: everything it knows comes through an
evaluation function

.. code-block:: python

    evaluate(genomes: (P, G), key) -> (fitness: (P,), metrics: dict)

**Fitness convention: higher is better.** ``NaN`` fitness (a failed evaluation) counts as the
worst possible value, ``-inf``.

The public methods live in :class:`Strategy` and handle what every strategy shares: the gene
bounds, clipping to them, NaN -> worst, the best genome so far and the generation counter. A
subclass writes three pure functions over its own state pytree ``inner``:

- ``_init(key, low, high, sigma) -> inner``
- ``_ask(key, state) -> (genomes (P, G), inner)``
- ``_tell(genomes (P, G), fitness (P,), state) -> inner`` (fitness already cleaned)

All of them are pure JAX, so a whole loop can run under ``jit`` or ``lax.scan``:

.. code-block:: python

    state = strategy.init(key, genes)
    for g in range(generations):
        genomes, state = strategy.ask(jax.random.fold_in(key, g), state)
        fitness, _ = evaluate(genomes, key)
        state, metrics = strategy.tell(genomes, fitness, state)

Strategies are frozen dataclasses: their hyper-parameters cannot change after construction, so
the jitted functions cached for them (shared by equal strategies) can never go stale.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, ClassVar, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.search.genes import Gene, bounds

Array = Any

Evaluate = Callable[[Array, Array], tuple[Array, dict]]
"""``evaluate(genomes (P, G), key) -> (fitness (P,), metrics)``; higher fitness is better."""


class State(NamedTuple):
    """A strategy's state (a pytree).

    Attributes:
        low, high: gene bounds, shape ``(G,)``.
        sigma: per-gene mutation standard deviations, shape ``(G,)``.
        best_genome: best genome told so far, shape ``(G,)`` (NaN before the first tell).
        best_fitness: its fitness, ``-inf`` before the first tell.
        generation: number of completed ``tell`` calls.
        inner: the subclass's own state pytree.
    """

    low: Array
    high: Array
    sigma: Array
    best_genome: Array
    best_fitness: Array
    generation: Array
    inner: Any


@dataclass(frozen=True)
class Strategy:
    """Base class: public ``init/ask/tell``; subclasses implement ``_init/_ask/_tell``.

    Args:
        population_size: genomes per generation ``P``.
    """

    population_size: int

    needs_gradient: ClassVar[bool] = False
    """Whether ``tell`` needs ``gradient=d fitness / d genome`` (from a gradient evaluator)."""

    def __post_init__(self) -> None:
        if int(self.population_size) < 2:
            raise MorphogenError(
                f"population size must be at least 2, got {self.population_size}"
            )

    # --- public API -------------------------------------------------------------------------

    def init(self, key: Array, genes: Sequence[Gene]) -> State:
        """A fresh state for searching ``genes``."""
        if not genes:
            raise MorphogenError("no genes to search; give at least one gene")
        low, high, sigma = (jnp.asarray(a) for a in bounds(genes))
        return self._jit_init(key, low, high, sigma)

    def ask(self, key: Array, state: State) -> tuple[Array, State]:
        """Propose genomes, shape ``(P, G)``, inside the bounds."""
        return self._jit_ask(key, state)

    def tell(self, genomes: Array, fitness: Array, state: State) -> tuple[State, dict]:
        """Update the state with the fitness (shape ``(P,)``, higher is better) of ``genomes``.

        Returns ``(state, metrics)`` with ``best_fitness``, ``best_genome`` (so far),
        ``generation_best``, ``generation_mean`` (over finite values) and ``generation``.
        """
        genomes = jnp.asarray(genomes)
        fitness = jnp.asarray(fitness)
        expected = (self.population_size, state.low.shape[0])
        if genomes.shape != expected or fitness.shape != expected[:1]:
            raise MorphogenError(
                f"tell got genomes {genomes.shape} and fitness {fitness.shape}; "
                f"expected {expected} and {expected[:1]}"
            )
        return self._jit_tell(genomes, fitness, state)

    # --- subclass hooks ---------------------------------------------------------------------

    def _init(self, key: Array, low: Array, high: Array, sigma: Array) -> Any:
        raise NotImplementedError

    def _ask(self, key: Array, state: State) -> tuple[Array, Any]:
        raise NotImplementedError

    def _tell(self, genomes: Array, fitness: Array, state: State) -> Any:
        raise NotImplementedError

    # --- shared machinery -------------------------------------------------------------------

    def _init_state(self, key: Array, low: Array, high: Array, sigma: Array) -> State:
        g = low.shape[0]
        return State(
            low=low,
            high=high,
            sigma=sigma,
            best_genome=jnp.full((g,), jnp.nan, low.dtype),
            best_fitness=jnp.asarray(-jnp.inf, jnp.float32),
            generation=jnp.asarray(0, jnp.int32),
            inner=self._init(key, low, high, sigma),
        )

    def _ask_state(self, key: Array, state: State) -> tuple[Array, State]:
        genomes, inner = self._ask(key, state)
        genomes = jnp.clip(genomes, state.low, state.high)
        return genomes, state._replace(inner=inner)

    def _tell_state(self, genomes: Array, fitness: Array, state: State) -> tuple[State, dict]:
        fitness = clean_fitness(fitness.astype(jnp.float32))
        i = jnp.argmax(fitness)
        better = fitness[i] > state.best_fitness
        best_genome = jnp.where(better, genomes[i], state.best_genome)
        best_fitness = jnp.where(better, fitness[i], state.best_fitness)
        finite = jnp.isfinite(fitness)
        mean = jnp.sum(jnp.where(finite, fitness, 0.0)) / jnp.maximum(finite.sum(), 1)
        inner = self._tell(genomes, fitness, state)
        state = state._replace(
            best_genome=best_genome,
            best_fitness=best_fitness,
            generation=state.generation + 1,
            inner=inner,
        )
        metrics = {
            "generation": state.generation,
            "best_fitness": best_fitness,
            "best_genome": best_genome,
            "generation_best": fitness[i],
            "generation_mean": mean,
        }
        return state, metrics

    @property
    def _jit_init(self) -> Callable:
        return _compiled(self)[0]

    @property
    def _jit_ask(self) -> Callable:
        return _compiled(self)[1]

    @property
    def _jit_tell(self) -> Callable:
        return _compiled(self)[2]


@lru_cache(maxsize=64)
def _compiled(strategy: Strategy) -> tuple[Callable, Callable, Callable]:
    """Jitted ``init/ask/tell`` shared by equal strategies (frozen, so compared by value)."""
    return (jax.jit(strategy._init_state), jax.jit(strategy._ask_state),
            jax.jit(strategy._tell_state))


def clean_fitness(fitness: Array) -> Array:
    """Replace NaN by ``-inf`` (the worst value under "higher is better"); shape kept."""
    return jnp.where(jnp.isnan(fitness), -jnp.inf, fitness)


def state_to_arrays(state: State) -> dict[str, np.ndarray]:
    """Flatten a state to named host arrays (``leaf_0``, ``leaf_1``, ...) for saving."""
    leaves = jax.tree_util.tree_leaves(state)
    return {f"leaf_{i}": np.asarray(leaf) for i, leaf in enumerate(leaves)}


def state_from_arrays(template: State, arrays: dict[str, np.ndarray]) -> State:
    """Rebuild a state saved by :func:`state_to_arrays`, given a state of the same structure.

    Raises:
        MorphogenError: the saved arrays do not match the template's structure.
    """
    leaves, treedef = jax.tree_util.tree_flatten(template)
    if len(arrays) != len(leaves):
        raise MorphogenError(
            f"saved strategy state has {len(arrays)} arrays, expected {len(leaves)}; "
            "was the run made with another strategy or gene list?"
        )
    restored = []
    for i, leaf in enumerate(leaves):
        arr = np.asarray(arrays[f"leaf_{i}"])
        if arr.shape != np.shape(leaf):
            raise MorphogenError(
                f"saved strategy state array {i} has shape {arr.shape}, expected "
                f"{np.shape(leaf)}; was the run made with other settings?"
            )
        restored.append(jnp.asarray(arr, dtype=jnp.asarray(leaf).dtype))
    return jax.tree_util.tree_unflatten(treedef, restored)
