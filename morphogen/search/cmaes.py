"""CMA-ES on normalised gene ranges, through evosax.

Skaggs §6.1 notes that a GA needs a hand-tuned mutation rate per gene. CMA-ES (Hansen's
covariance matrix adaptation, as implemented by ``evosax.algorithms.CMA_ES``) adapts the step
size and the covariance itself. It searches the unit cube: gene ``i`` is

.. math:: x_i = \\mathrm{low}_i + z_i (\\mathrm{high}_i - \\mathrm{low}_i),\\qquad z \\in [0, 1]^G

starting from the centre ``z = 1/2`` with step ``sigma_init`` (a quarter of every range by
default), so no per-gene rate is needed; the genes' ``sigma`` values are ignored. Samples
outside the cube are clipped to it (projection repair), and CMA-ES is told the clipped points,
the ones actually evaluated. evosax minimises, so it is told ``-fitness``; NaN fitness arrives
here as ``-inf`` and so ranks last.

evosax's state is a pytree and its keys are explicit, so this strategy jits, scans and saves
like the GA (the ``cma`` package keeps its state in a mutable object instead).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import jax
import jax.numpy as jnp

from morphogen.errors import MorphogenError
from morphogen.search.strategy import Array, State, Strategy
from morphogen.util.extras import require


@lru_cache(maxsize=16)
def _evosax_cma(population_size: int, num_dims: int) -> Any:
    CMA_ES = require("evosax.algorithms", "cmaes", "the CMA-ES strategy").CMA_ES

    # Built once and cached, possibly while tracing: keep its constants concrete.
    with jax.ensure_compile_time_eval():
        return CMA_ES(population_size=population_size, solution=jnp.zeros(num_dims, jnp.float32))


@dataclass(frozen=True)
class CMAES(Strategy):
    """CMA-ES over the normalised genes.

    Args:
        population_size: samples per generation ``lambda``.
        sigma_init: initial step size in units of the gene ranges.
    """

    sigma_init: float = 0.25

    def __post_init__(self) -> None:
        super().__post_init__()
        require("evosax", "cmaes", "the CMA-ES strategy")
        if not 0 < self.sigma_init <= 1:
            raise MorphogenError(f"CMA-ES sigma_init must be in (0, 1], got {self.sigma_init}")

    def _es(self, num_dims: int) -> Any:
        return _evosax_cma(int(self.population_size), int(num_dims))

    def _params(self, es: Any) -> Any:
        return es.default_params.replace(std_init=jnp.asarray(self.sigma_init, jnp.float32))

    def _init(self, key: Array, low: Array, high: Array, sigma: Array) -> Any:
        es = self._es(low.shape[0])
        return es.init(key, jnp.full(low.shape, 0.5, jnp.float32), self._params(es))

    def _ask(self, key: Array, state: State) -> tuple[Array, Any]:
        es = self._es(state.low.shape[0])
        z, inner = es.ask(key, state.inner, self._params(es))
        z = jnp.clip(z, 0.0, 1.0)
        return state.low + z * (state.high - state.low), inner

    def _tell(self, genomes: Array, fitness: Array, state: State) -> Any:
        es = self._es(state.low.shape[0])
        z = (genomes - state.low) / (state.high - state.low)
        # CMA-ES's update uses no randomness; evosax's signature still asks for a key.
        unused = jax.random.PRNGKey(0)
        inner, _ = es.tell(unused, z, -fitness, state.inner, self._params(es))
        return inner
