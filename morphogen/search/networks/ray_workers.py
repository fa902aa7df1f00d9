"""Network-population evaluation split over Ray workers (Yamamoto §3.1, §3.3).

Individuals of a generation are independent once the shared initial state ``u0`` is drawn
(§3.1), so a population can be cut into batches of genomes, each batch evaluated by
:func:`morphogen.search.networks.evolve.evaluate` in a Ray task, and the fitness put back in
order. The generation loop, its random stream and ``state.npz`` stay in the calling process,
so a Ray run breeds exactly as a local one; the fitness equals the local one up to float
rounding of differently batched compiled programs.

As :class:`morphogen.search.executors.RayExecutor` (:func:`~morphogen.util.cluster.start_ray`):
``address=None`` starts a local Ray, without usage statistics or dashboard, its workers
single-threaded; ``batches`` defaults to one per CPU of the cluster.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.search.networks.genome import Genome, NetworkSpec
from morphogen.util.cluster import start_ray


def _evaluate_batch(spec: dict[str, Any], ev: dict[str, Any], genomes: tuple[np.ndarray, ...],
                    u0: np.ndarray) -> np.ndarray:
    """Body of a Ray task: the fitness of one batch of genomes."""
    import jax.numpy as jnp

    from morphogen.search.networks.evolve import Evaluation, evaluate
    from morphogen.search.networks.record import spec_from_dict

    pop = Genome(*(jnp.asarray(x) for x in genomes))
    fitness, _ = evaluate(pop, jnp.asarray(u0), spec_from_dict(spec), Evaluation(**ev))
    return fitness


class RayNetworkEvaluator:
    """``evaluate(pop, u0, spec, ev, progress)`` over ``batches`` Ray tasks per generation.

    Returns the fitness ``(P,)`` and no final states (``None``); ``progress`` receives the
    generation's integration steps in proportion to the individuals done.
    """

    def __init__(self, *, address: str | None = None, batches: int | None = None,
                 num_cpus: int | None = None):
        if batches is not None and batches < 1:
            raise MorphogenError(f"--batches must be >= 1, got {batches}")
        self._ray = ray = start_ray(address, num_cpus)
        self.batches = batches or max(1, int(ray.cluster_resources().get("CPU", 1)))
        self._task = ray.remote(num_cpus=1)(_evaluate_batch)

    def __call__(self, pop: Genome, u0: Any, spec: NetworkSpec, ev: Any,
                 progress: Callable[[int], None] | None = None) -> tuple[np.ndarray, None]:
        ray = self._ray
        arrays = [np.asarray(x) for x in pop]
        size = arrays[0].shape[0]
        u0 = np.asarray(u0, np.float32)
        spec_d, ev_d = asdict(spec), asdict(ev)
        parts = [p for p in np.array_split(np.arange(size), self.batches) if p.size]
        pending = {self._task.remote(spec_d, ev_d, tuple(a[p] for a in arrays), u0): p
                   for p in parts}
        fitness = np.zeros(size, np.float32)
        per_gen = ev.steps
        done = reported = 0
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            idx = pending.pop(ready[0])
            fitness[idx] = ray.get(ready[0])
            done += idx.size
            if progress is not None:
                step = per_gen * done // size - reported
                reported += step
                progress(step)
        return fitness, None
