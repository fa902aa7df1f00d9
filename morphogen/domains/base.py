"""What every domain offers the solvers and the engine: the :class:`Domain` protocol.

A domain is where species diffuse: a regular grid (:class:`morphogen.domains.grid.Grid`) or a
triangle mesh (:class:`morphogen.domains.mesh.Mesh`). Both give the same pure functions, so
every model, scheme, batch and gradient runs on either; what differs is declared, not guessed:

- ``kind`` is ``"grid"`` or ``"mesh"``. A grid also has ``laplacian(f, bc)`` and the stencil's
  Fourier ``symbol(*k)`` (the exact Fourier solves of :mod:`morphogen.solvers.imex` and
  :mod:`morphogen.solvers.etd`, the checkerboard test of :mod:`morphogen.solvers.stability`); a
  mesh has per-vertex ``areas`` (lumped masses) and ``edge_length``.
- ``stochastic`` says whether :meth:`Domain.diffusion_noise` adds Chemical-Langevin flux noise
  (Ringham et al. eqs. 14-17; meshes with ``omega``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal, Protocol, runtime_checkable

import numpy as np

from morphogen.models.model import Array

DomainKind = Literal["grid", "mesh"]


@runtime_checkable
class Domain(Protocol):
    """The interface of a grid or a mesh (see the module docstring)."""

    kind: DomainKind

    @property
    def spatial_shape(self) -> tuple[int, ...]:
        """Shape of one species' field: ``(H, W)``, ``(D, H, W)`` or ``(V,)``."""
        ...

    @property
    def coords(self) -> dict[str, np.ndarray]:
        """Coordinate fields ``x``, ``y`` (``z``) for parameter expressions."""
        ...

    @property
    def stochastic(self) -> bool:
        """Whether :meth:`diffusion_noise` is active."""
        ...

    def boundaries(self, species: Sequence[str]) -> tuple[Any, ...]:
        """One boundary condition per species."""
        ...

    def diffuse(self, u: Array, coeffs: Sequence[Any], bcs: Sequence[Any]) -> Array:
        """``∇·(D ∇u)`` for every species, shape ``(S, *spatial)``."""
        ...

    def hold(self, u: Array, bcs: Sequence[Any]) -> Array:
        """Impose Dirichlet values."""
        ...

    def spectral_radius(self) -> float:
        """Largest eigenvalue magnitude of the diffusion operator for ``D = 1``."""
        ...

    def diffusion_noise(self, u: Array, coeffs: Sequence[Any], bcs: Sequence[Any], dt: Array,
                        key: Array) -> Array:
        """Stochastic diffusion increment (zero where the domain is not stochastic)."""
        ...
