"""Implicit-explicit steps: diffusion solved exactly in Fourier space, reaction explicit.

For :math:`\\partial_t u = R(u) + D\\,L u` on a grid with constant, isotropic, per-species
``D``, the discrete Laplacian ``L`` of the grid's stencil is diagonal in the Fourier basis of
the boundary condition: complex exponentials (FFT) for periodic species and the cosines
``cos(pi m (i + 1/2) / n)`` (a DCT-II, computed as an FFT of the mirrored extension) for no-flux
species. On mode ``k`` it multiplies by the stencil's own symbol ``lambda(k) / dx^2``, e.g.
``sum_axes (2 cos k_a - 2)`` for the 5- and 7-point stencils, with ``k_a = 2 pi m / n`` (periodic)
or ``pi m / n`` (no flux). The implicit solves are therefore exact for the stencil used by the
explicit schemes, so a Fourier mode of pure diffusion decays by the scheme's rational function of
``dt D lambda(k)``.

- ``imex1`` (first order, semi-implicit Euler):
  ``(I - dt D L) u' = u + dt R(u)``.
- ``imex`` (second order, Ascher, Ruuth & Spiteri 1997, ARS(2,2,2), L-stable, stiffly accurate),
  with ``g = 1 - 1/sqrt(2)``, ``d = 1 - 1/(2 g)``:
  ``(I - g dt D L) U = u + g dt R(u)``;
  ``(I - g dt D L) u' = u + dt (d R(u) + (1 - d) R(U)) + (1 - g) dt D L U``.

The step size is then limited by the reaction only (:mod:`morphogen.solvers.stability`). Where the
solve is not diagonal in Fourier space (meshes, Dirichlet boundaries, spatially varying or
anisotropic diffusion) the same steps solve it by conjugate gradients
(:mod:`morphogen.solvers.imex_cg`); :func:`make_imex_advance` takes either solver.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.model import Array, Model, Params, Tensor

IMEX_SCHEMES = ("imex1", "imex")

ARS_GAMMA = 1.0 - 1.0 / np.sqrt(2.0)
"""ARS(2,2,2)'s implicit weight: each of its two solves is ``(I - ARS_GAMMA dt L) x = b``."""
_D = 1.0 - 1.0 / (2.0 * ARS_GAMMA)


def require_spectral_grid(domain: Any, species: tuple[str, ...], scheme: str) -> None:
    """Raise a one-line error unless the domain is a grid with periodic / no-flux species."""
    if not hasattr(domain, "laplacian") or not hasattr(domain, "symbol"):
        raise MorphogenError(
            f"scheme {scheme} solves diffusion in Fourier space on grids; use imex, euler or "
            "rk4 on meshes")
    for bc in domain.boundaries(species):
        if bc.kind not in ("periodic", "neumann"):
            raise MorphogenError(
                f"scheme {scheme} supports periodic and neumann boundaries; use imex, euler or "
                f"rk4 for {bc.kind}")


class SpectralDiffusion:
    """``(I - c D_i L)^{-1}`` per species on a grid, with ``L`` the grid's own stencil."""

    def __init__(self, domain: Any, species: tuple[str, ...]):
        self.shape = tuple(domain.shape)
        self.bcs = domain.boundaries(species)
        self.mirror = [bc.kind == "neumann" for bc in self.bcs]
        self.symbols = {m: _symbol(domain, m) for m in set(self.mirror)}

    def solve(self, u: Array, coeffs: tuple[Any, ...], c: Array, x0: Array | None = None
              ) -> Array:
        """Solve ``(I - c D_i L) v_i = u_i`` for every species ``i``; ``u`` is ``(S, *shape)``
        (``x0``, a first guess for iterative solvers, is not needed: the solve is exact)."""
        self.check(coeffs, "imex")
        return jnp.stack([self.solve_one(u[i], d, c, self.mirror[i])
                          for i, d in enumerate(coeffs)])

    def forward(self, f: Array, mirror: bool) -> Array:
        """``rfftn`` of one field, mirrored along every axis first for a no-flux species."""
        if mirror:
            for ax in range(f.ndim):
                f = jnp.concatenate([f, jnp.flip(f, ax)], axis=ax)
        return jnp.fft.rfftn(f)

    def inverse(self, g: Array, mirror: bool, dtype: Any) -> Array:
        """Inverse of :meth:`forward`, back on the grid."""
        ext = tuple(2 * n if mirror else n for n in self.shape)
        v = jnp.fft.irfftn(g, s=ext)
        if mirror:
            v = v[tuple(slice(0, n) for n in self.shape)]
        return v.astype(dtype)

    def solve_one(self, f: Array, d: Array, c: Array, mirror: bool) -> Array:
        """``(I - c d L)^{-1} f`` for one field, ``mirror`` for a no-flux species."""
        lam = jnp.asarray(self.symbols[mirror], f.dtype)
        return self.inverse(self.forward(f, mirror) / (1.0 - c * d * lam), mirror, f.dtype)

    def check(self, coeffs: tuple[Any, ...], scheme: str) -> None:
        """Refuse spatially varying or anisotropic coefficients with a one-line error."""
        for d in coeffs:
            if isinstance(d, Tensor) or jnp.ndim(d) > 0:
                raise MorphogenError(
                    f"scheme {scheme} needs constant isotropic diffusion; use imex, euler or rk4 "
                    "for spatially varying or anisotropic coefficients")


def _symbol(domain: Any, mirror: bool) -> np.ndarray:
    """Laplacian symbol ``lambda(k) / dx^2`` (the stencil's, or ``-|k|^2`` for the spectral
    operator) on the ``rfftn`` frequency grid of the (mirrored)
    field: ``k = 2 pi m / N`` with ``N = n`` (periodic) or ``2 n`` (mirrored, i.e. ``pi m / n``)."""
    sizes = [2 * n if mirror else n for n in domain.shape]
    freqs = [2 * np.pi * np.fft.fftfreq(n) for n in sizes[:-1]]
    freqs.append(2 * np.pi * np.fft.rfftfreq(sizes[-1]))
    ks = np.meshgrid(*freqs, indexing="ij")
    return domain.symbol(*ks)


def make_imex_advance(
    model: Model, domain: Any, scheme: str, solver: Any
) -> Callable[[Array, Params, Array, Array], Array]:
    """The deterministic update ``advance(u, p, t, dt) -> u`` of ``imex1`` or ``imex``.

    ``solver.solve(b, coeffs, c, x0)`` returns ``(I - c L_D)^{-1} b`` per species (``x0``: a
    first guess, the current state): a :class:`SpectralDiffusion` or a
    :class:`morphogen.solvers.imex_cg.ImplicitDiffusion`.
    """
    bcs = domain.boundaries(model.species)
    coords = {k: jnp.asarray(v) for k, v in domain.coords.items()}

    def advance(u: Array, p: Params, t: Array, dt: Array) -> Array:
        c = {**coords, "t": t}
        d = tuple(model.diffusion(p, c))
        r0 = model.reaction(u, p, c)
        if scheme == "imex1":
            return solver.solve(u + dt * r0, d, dt, u)
        stage = solver.solve(u + ARS_GAMMA * dt * r0, d, ARS_GAMMA * dt, u)
        c2 = {**coords, "t": t + ARS_GAMMA * dt}
        r1 = model.reaction(stage, p, c2)
        rhs = u + dt * (_D * r0 + (1.0 - _D) * r1)
        rhs = rhs + (1.0 - ARS_GAMMA) * dt * domain.diffuse(stage, d, bcs)
        return solver.solve(rhs, d, ARS_GAMMA * dt, stage)

    return advance


def amplification(scheme: str, z: np.ndarray) -> np.ndarray:
    """Factor on a pure-diffusion mode, ``z = dt D lambda(k)`` (no reaction)."""
    z = np.asarray(z, np.float64)
    if scheme == "imex1":
        return 1.0 / (1.0 - z)
    stage = 1.0 / (1.0 - ARS_GAMMA * z)
    return (1.0 + (1.0 - ARS_GAMMA) * z * stage) / (1.0 - ARS_GAMMA * z)
