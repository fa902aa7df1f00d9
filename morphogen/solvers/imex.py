"""Implicit-explicit steps: diffusion implicit, reaction explicit.

For :math:`\\partial_t u = R(u) + L_D u` with ``L_D u = div(D grad u)`` the domain's own discrete
operator:

- ``imex1`` (first order, semi-implicit Euler):
  ``(I - dt L_D) u' = u + dt R(u)``.
- ``imex`` (second order, Ascher, Ruuth & Spiteri 1997, ARS(2,2,2), L-stable, stiffly accurate),
  with ``g = 1 - 1/sqrt(2)``, ``d = 1 - 1/(2 g)``:
  ``(I - g dt L_D) U = u + g dt R(u)``;
  ``(I - g dt L_D) u' = u + dt (d R(u) + (1 - d) R(U)) + (1 - g) dt L_D U``.

Each solve ``(I - c L_D)^{-1}`` is exact in Fourier space on grids with constant isotropic
diffusion and periodic or no-flux boundaries (:mod:`morphogen.solvers.fourier`), so a Fourier
mode of pure diffusion decays by the scheme's rational function of ``dt D lambda(k)``
(:meth:`Imex1.amplification`, :meth:`Ars222.amplification`); elsewhere (meshes, Dirichlet
boundaries, spatially varying or anisotropic diffusion) it is solved by conjugate gradients
(:mod:`morphogen.solvers.imex_cg`). The step size is then limited by the reaction only: at the
ground state (:mod:`morphogen.solvers.stability`) and, on 2D grids, along a pilot run of the
pattern (:mod:`morphogen.solvers.pattern_limit`).
"""

from __future__ import annotations

from typing import ClassVar

import jax.numpy as jnp
import numpy as np

from morphogen.domains.base import Domain
from morphogen.models.model import Array, Model, Params
from morphogen.solvers.base import Advance, Stepper, held_mask
from morphogen.solvers.imex_cg import ImplicitDiffusion
from morphogen.solvers.pattern_limit import pattern_limit
from morphogen.solvers.registry import SCHEMES
from morphogen.solvers.stability import linear_limit

IMEX_SCHEMES = tuple(n for n, s in SCHEMES.items() if s.module == __name__)
"""The implicit-explicit schemes (their registry rows name this module)."""

ARS_GAMMA = 1.0 - 1.0 / np.sqrt(2.0)
"""ARS(2,2,2)'s implicit weight: each of its two solves is ``(I - ARS_GAMMA dt L) x = b``."""
_D = 1.0 - 1.0 / (2.0 * ARS_GAMMA)


class _Imex(Stepper):
    """What the implicit-explicit schemes share: the reaction-limited step and the solver."""

    gamma: ClassVar[float]
    """Implicit weight of the first solve, ``(I - gamma dt L_D) x = u + gamma dt R(u)``."""

    def limit(self, model: Model, domain: Domain, params: Params, *,
              batched: bool = False) -> float:
        """The reaction's limit: the ground state's (with its margin) and, for one parameter
        set on a 2D grid, the pattern's (:func:`~morphogen.solvers.pattern_limit.pattern_limit`),
        whichever is smaller."""
        ground = linear_limit(model, domain, params, None, batched=batched)
        if batched:
            return ground
        return min(ground, pattern_limit(model, domain, params, ground, Imex1().advance))

    @staticmethod
    def solver(model: Model, domain: Domain) -> ImplicitDiffusion:
        """``(I - c L_{D_i})^{-1}`` per species: Fourier where exact, else CG."""
        return ImplicitDiffusion(domain, model.species, held_mask(model, domain))


class Imex1(_Imex):
    """Semi-implicit Euler."""

    name = "imex1"
    gamma = 1.0

    def amplification(self, z: np.ndarray) -> np.ndarray:
        """``1 / (1 - z)`` on a pure-diffusion mode, ``z = dt D lambda(k)``."""
        z = np.asarray(z, np.float64)
        return 1.0 / (1.0 - z)

    def advance(self, model: Model, domain: Domain) -> Advance:
        solver = self.solver(model, domain)
        coords = {k: jnp.asarray(v) for k, v in domain.coords.items()}

        def update(u: Array, p: Params, t: Array, dt: Array, aux: None = None) -> Array:
            c = {**coords, "t": t}
            d = tuple(model.diffusion(p, c))
            r0 = model.reaction(u, p, c)
            return solver.solve(u + dt * r0, d, dt, u)

        return Advance(update)


class Ars222(_Imex):
    """ARS(2,2,2): second order, L-stable, stiffly accurate."""

    name = "imex"
    gamma = ARS_GAMMA

    def amplification(self, z: np.ndarray) -> np.ndarray:
        """``(1 + (1 - g) z / (1 - g z)) / (1 - g z)`` on a pure-diffusion mode,
        ``z = dt D lambda(k)``."""
        z = np.asarray(z, np.float64)
        stage = 1.0 / (1.0 - ARS_GAMMA * z)
        return (1.0 + (1.0 - ARS_GAMMA) * z * stage) / (1.0 - ARS_GAMMA * z)

    def advance(self, model: Model, domain: Domain) -> Advance:
        solver = self.solver(model, domain)
        bcs = domain.boundaries(model.species)
        coords = {k: jnp.asarray(v) for k, v in domain.coords.items()}

        def update(u: Array, p: Params, t: Array, dt: Array, aux: None = None) -> Array:
            c = {**coords, "t": t}
            d = tuple(model.diffusion(p, c))
            r0 = model.reaction(u, p, c)
            stage = solver.solve(u + ARS_GAMMA * dt * r0, d, ARS_GAMMA * dt, u)
            c2 = {**coords, "t": t + ARS_GAMMA * dt}
            r1 = model.reaction(stage, p, c2)
            rhs = u + dt * (_D * r0 + (1.0 - _D) * r1)
            rhs = rhs + (1.0 - ARS_GAMMA) * dt * domain.diffuse(stage, d, bcs)
            return solver.solve(rhs, d, ARS_GAMMA * dt, stage)

        return Advance(update)
