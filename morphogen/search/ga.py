"""The genetic algorithm of Skaggs §3.1, with genes kept inside their bounds.

One generation (Skaggs §3.1):

1. **Initialisation** (first ask): every gene uniform in ``[low, high]``.
2. **Selection**: each child has two parents drawn independently, by fitness-proportionate
   selection (Skaggs eq. 3.10)

   .. math:: p_i = \\frac{f_i}{\\sum_{j=1}^{N} f_j}

   or, when ``tournament = k >= 2``, each parent is the fittest of ``k`` individuals drawn
   uniformly. Eq. 3.10 needs ``f >= 0``: negative, ``-inf`` and NaN fitness count as 0, and if
   every weight is 0 the parents are drawn uniformly.
3. **Uniform crossover**: each gene comes from either parent with probability 1/2.
4. **Gaussian mutation** (Skaggs eq. 3.5), applied once to every gene of every child:
   :math:`\\gamma \\leftarrow \\gamma + N(0, \\sigma^2)`, ``sigma`` per gene (see
   :mod:`morphogen.search.genes` for how table 3.2 is read).
5. **Bounds**: the child is clipped to ``[low, high]`` (gard let ``F`` go negative; not here).
6. **Elitism** (optional): the ``elitism`` fittest parents replace the first children,
   unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import jax
import jax.numpy as jnp

from morphogen.errors import MorphogenError
from morphogen.search.strategy import Array, State, Strategy


class GAState(NamedTuple):
    """The GA's own state: the last population, shape ``(P, G)``, and its fitness ``(P,)``
    (NaN until told)."""

    population: Array
    fitness: Array


@dataclass(frozen=True)
class GeneticAlgorithm(Strategy):
    """Skaggs's genetic algorithm.

    Args:
        population_size: individuals per generation ``P`` (Skaggs: 30).
        elitism: number of best individuals copied unchanged into the next generation.
        tournament: tournament size; 0 selects by fitness proportion (eq. 3.10).
    """

    elitism: int = 0
    tournament: int = 0

    def __post_init__(self) -> None:
        super().__post_init__()
        if not 0 <= self.elitism < self.population_size:
            raise MorphogenError(
                f"elitism must be between 0 and population - 1 = {self.population_size - 1}, "
                f"got {self.elitism}"
            )
        if self.tournament == 1 or self.tournament < 0:
            raise MorphogenError(
                f"tournament size must be 0 (proportionate selection) or >= 2, got "
                f"{self.tournament}"
            )

    def _init(self, key: Array, low: Array, high: Array, sigma: Array) -> GAState:
        u = jax.random.uniform(key, (self.population_size, low.shape[0]), low.dtype)
        nan = jnp.full((self.population_size,), jnp.nan, jnp.float32)
        return GAState(low + u * (high - low), nan)

    def _ask(self, key: Array, state: State) -> tuple[Array, GAState]:
        inner = state.inner
        genomes = jax.lax.cond(
            state.generation == 0,
            lambda: inner.population,
            lambda: self._breed(key, state),
        )
        return genomes, inner

    def _tell(self, genomes: Array, fitness: Array, state: State) -> GAState:
        return GAState(genomes, fitness)

    def _breed(self, key: Array, state: State) -> Array:
        """Children of the told population, shape ``(P, G)`` (before clipping)."""
        pop, fit = state.inner.population, state.inner.fitness
        n, g = pop.shape
        k_sel, k_cross, k_mut = jax.random.split(key, 3)
        parents = self._select(k_sel, fit, (n, 2))
        take_first = jax.random.bernoulli(k_cross, 0.5, (n, g))
        children = jnp.where(take_first, pop[parents[:, 0]], pop[parents[:, 1]])
        children = children + state.sigma * jax.random.normal(k_mut, (n, g), pop.dtype)
        if self.elitism:
            elite = jnp.argsort(-fit)[: self.elitism]
            children = children.at[: self.elitism].set(pop[elite])
        return children

    def _select(self, key: Array, fitness: Array, shape: tuple[int, ...]) -> Array:
        """Indices of selected parents, shape ``shape``."""
        n = fitness.shape[0]
        if self.tournament:
            entrants = jax.random.randint(key, (*shape, self.tournament), 0, n)
            scores = jnp.where(jnp.isfinite(fitness), fitness, -jnp.inf)[entrants]
            winner = jnp.argmax(scores, axis=-1)
            return jnp.take_along_axis(entrants, winner[..., None], axis=-1)[..., 0]
        return jax.random.choice(key, n, shape, p=proportions(fitness))


def proportions(fitness: Array) -> Array:
    """Selection probabilities of Skaggs eq. 3.10, shape ``(P,)``.

    Non-finite and negative fitness count as 0; all-zero weights give uniform probabilities.
    """
    w = jnp.where(jnp.isfinite(fitness) & (fitness > 0), fitness, 0.0)
    total = w.sum()
    return jnp.where(total > 0, w / jnp.where(total > 0, total, 1.0), 1.0 / fitness.shape[0])
