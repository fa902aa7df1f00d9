"""A model's homogeneous states over a parameter plane: how many there are, and whether any is
Turing-unstable or oscillatory (Hopf) there, for drawing the analysis' boundaries over an atlas.

For every parameter set ``p`` of a population (every leaf with a leading axis ``P``) this finds
every homogeneous fixed point (:func:`morphogen.models.fixed_points.fixed_points_batch`, the
multi-start Newton solver of ``morphogen analyse``) and classes each found one by its dispersion
relation on the given grid modes (:func:`morphogen.models.linear.stability_at`, the same code
as the analysis and the network evolution's fixed-point start). The boundaries between the
regions are the classical ones (Murray, *Mathematical Biology II*, ch. 2; for Gray-Scott,
Pearson 1993):

- **saddle-node**: where the number of fixed points changes (two appear together at a fold;
  for Gray-Scott along ``F = 4 (F + k)²``);
- **Hopf**: the edge of the region where some fixed point is unstable at ``κ² = 0`` with a
  complex leading eigenvalue (``unstable_k0`` and oscillatory);
- **Turing**: the edge of the region where some fixed point is stable at ``κ² = 0`` and
  unstable at some grid mode (``turing``).

Computed in float64 (``jax.enable_x64`` inside), whatever the caller's precision.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.models.fixed_points import default_starts, fixed_points_batch
from morphogen.models.linear import CLASSES, stability_program
from morphogen.models.model import Model

TURING, UNSTABLE_K0 = CLASSES.index("turing"), CLASSES.index("unstable_k0")
CHUNK = 256
"""Parameter sets per slice of :func:`stability_map`."""


class StabilityMap(NamedTuple):
    """Per parameter set, shape ``(P,)``.

    Attributes:
        count: the number of homogeneous fixed points found.
        turing: some fixed point is Turing-unstable.
        hopf: some fixed point is unstable at ``κ² = 0`` with a complex leading eigenvalue.
        saddle: some fixed point is unstable at ``κ² = 0`` with a real leading eigenvalue.
    """

    count: np.ndarray
    turing: np.ndarray
    hopf: np.ndarray
    saddle: np.ndarray


def stability_map(model: Model, params: Mapping[str, Any], kappa2: np.ndarray,
                  starts: np.ndarray | None = None, *, chunk: int = CHUNK) -> StabilityMap:
    """:class:`StabilityMap` of a population ``params`` (every value an array ``(P,)``) on the
    grid modes ``kappa2`` (first entry 0: :func:`morphogen.models.linear.lattice_modes`, or a
    sample of them). ``starts`` ``(K0, S)`` defaults to
    :func:`~morphogen.models.fixed_points.default_starts` of the first parameter set. The
    population goes through in slices of ``chunk`` (every candidate's dispersion relation is
    held at once: ``chunk · K0 · len(kappa2)`` eigenvalue pairs)."""
    values = {k: np.asarray(v, np.float64) for k, v in params.items()}
    n = len(next(iter(values.values())))
    if starts is None:
        starts = default_starts(model, {k: v[0] for k, v in values.items()})
    parts = [_part(model, {k: v[i:i + chunk] for k, v in values.items()}, kappa2, starts)
             for i in range(0, n, chunk)]
    return StabilityMap(*(np.concatenate(field) for field in zip(*parts, strict=True)))



def _part(model: Model, values: dict[str, np.ndarray], kappa2: np.ndarray,
          starts: np.ndarray) -> StabilityMap:
    n = len(next(iter(values.values())))
    with jax.enable_x64(True):
        p = {k: jnp.asarray(v) for k, v in values.items()}
        points = fixed_points_batch(model, p, jnp.asarray(starts, jnp.float64))
        found = np.asarray(points.found)
        k, s = points.u.shape[1:]
        each = {name: jnp.repeat(v, k, axis=0) for name, v in p.items()}
        st = stability_program(model)(each, points.u.reshape(n * k, s),
                                      jnp.asarray(kappa2, jnp.float64),
                                      jnp.asarray(found.reshape(-1)))
        cls = np.asarray(st.cls).reshape(n, k)
        oscillatory = np.asarray(st.oscillatory).reshape(n, k)
    unstable = found & (cls == UNSTABLE_K0)
    return StabilityMap(count=found.sum(axis=1), turing=(found & (cls == TURING)).any(axis=1),
                        hopf=(unstable & oscillatory).any(axis=1),
                        saddle=(unstable & ~oscillatory).any(axis=1))
