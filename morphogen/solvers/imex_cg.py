"""Implicit diffusion solved matrix-free by conjugate gradients: IMEX on meshes and on grids
with spatially varying, anisotropic or Dirichlet diffusion.

The ``imex1`` and ``imex`` (ARS(2,2,2)) steps of :mod:`morphogen.solvers.imex` need, per species and
stage, the solution of

.. math:: (I - c L_D)\\,x = b,\\qquad c = \\gamma\\,dt,

with ``L_D u = div(D grad u)`` the domain's own discrete operator (the one the explicit schemes
apply). Where it is not diagonal in a Fourier basis this module solves it iteratively, on a
symmetric positive definite form, so conjugate gradients (CG) apply:

- **Meshes** (Ringham eqs. 4, 9-12): ``L_D = M^{-1} K_D`` with the lumped mass matrix
  ``M = diag(A_i)`` (mixed Voronoi areas) and ``K_D`` the symmetric negative semi-definite
  flux matrix (cotangent weights ``w_ij`` for scalar ``D``, ``w_ij (D_i + D_j)/2`` for a
  per-vertex field, the per-face tensor form of eqs. 8, 18 for a :class:`Tensor`). The
  mass-weighted system ``(M - c K_D) x = M b`` is symmetric positive definite.
- **Grids, isotropic** ``D(x)``: the operator is ``D(x) L_h`` (``L_h`` the stencil, symmetric
  with periodic or mirrored no-flux ghost cells; ``D`` may vanish somewhere). With
  ``S = diag(sqrt(D))`` and ``x = b + S w``, ``(I - c S L_h S) w = c S L_h b``: symmetric
  positive definite.
- **Grids, anisotropic** (a :class:`Tensor`, conservative face fluxes): the mixed-derivative
  fluxes with a varying ``D_xy`` make the discrete operator slightly non-symmetric, so these
  solves use BiCGSTAB instead of CG (same tolerance, cap and warm start).

Each solve is written for the correction ``v = x - z`` (``z`` = ``b`` with Dirichlet values on
held cells; held rows are the identity with zero right-hand side, which keeps the matrix a
symmetric principal block): the right-hand side is the diffusion increment ``c M L_D z``, so
the tolerance is relative to what diffusion changes in the step, not to the state. The
iteration starts from the current state (``x0 = u``; the second ARS stage from the first),
which near a steady pattern is already close to the answer, and is preconditioned by the
diagonal (Jacobi). It stops when

.. math:: \\|r\\|_2 \\le \\max(\\mathrm{tol}\\,\\|c M L_D z\\|_2,\\;
          10^{-2}\\,\\mathrm{tol}\\,\\|M z\\|_2)

with ``tol`` = :data:`CG_RTOL` (float32; :data:`CG_RTOL_X64` in float64), or after
:data:`CG_MAXITER` iterations (a solve stopped there, far from its tolerance, is reported
after the run by :mod:`morphogen.engine.solve_watch`). Where the fluxes are conservative (meshes,
grid tensors) and no value is held, the ``M``-weighted mass is then restored exactly (the true
solution has ``1^T M x = 1^T M b`` because ``1^T K_D = 0``): a uniform shift of the size of the
residual.
(``D(x) L_h`` on grids does not conserve mass, and is left as solved.) Species with constant
scalar ``D`` and periodic or no-flux grid boundaries keep the exact Fourier solve of
:mod:`morphogen.solvers.fourier`.

Gradients: every solve is a ``lax.custom_linear_solve``, so reverse mode solves the transposed
system (from zero, tolerance relative to the cotangent) instead of differentiating the
iterations. Everything is ``jit``- and ``vmap``-friendly (the iterations are a
``lax.while_loop``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.sparse.linalg import bicgstab

from morphogen.domains.base import Domain
from morphogen.models.model import Array, Tensor
from morphogen.solvers.fourier import SpectralDiffusion

CG_RTOL = 1e-5
"""Relative residual at which a float32 solve stops (relative to the diffusion increment)."""

CG_RTOL_X64 = 1e-10
"""The same in float64."""

CG_MAXITER = 300
"""Iteration cap per solve; a solve that reaches it returns its last iterate."""


def _dot(a: Array, b: Array) -> Array:
    return jnp.vdot(a, b).real


def pcg(matvec: Any, b: Array, x0: Array | None, inv_diag: Array, tol: float, atol: Array,
        maxiter: int | None = None) -> tuple[Array, Array]:
    """Jacobi-preconditioned CG for a symmetric positive definite ``matvec``, from ``x0``
    (``None``: zero); returns ``(x, iterations)``. Stops at
    ``||b - A x|| <= max(tol ||b||, atol)`` or after ``maxiter`` (default
    :data:`CG_MAXITER`, read when the solve is traced) iterations.

    The same iteration as ``jax.scipy.sparse.linalg.cg`` with ``M = inv_diag``, written out
    because that one squares ``tol`` in the working precision (in float32 ``1e-5**2`` comes out
    one unit in the last place below ``1e-10``, which moves the stopping point of a borderline
    solve)."""
    maxiter = CG_MAXITER if maxiter is None else maxiter
    limit = jnp.maximum(tol * tol * _dot(b, b), atol * atol)
    x0, r = (jnp.zeros_like(b), b) if x0 is None else (x0, b - matvec(x0))
    z = inv_diag * r
    state = (x0, r, z, _dot(r, z), _dot(r, r), jnp.asarray(0))

    def cond(s):
        return (s[4] > limit) & (s[5] < maxiter)

    def body(s):
        x, r, p, gamma, _, k = s
        ap = matvec(p)
        alpha = gamma / _dot(p, ap)
        x = x + alpha * p
        r = r - alpha * ap
        z = inv_diag * r
        gamma_new = _dot(r, z)
        return x, r, z + (gamma_new / gamma) * p, gamma_new, _dot(r, r), k + 1

    x, *_, k = jax.lax.while_loop(cond, body, state)
    return x, k


def _linear_solve(matvec: Any, rhs: Array, v0: Array, inv_diag: Array, tol: float,
                  atol: Array, symmetric: bool) -> Array:
    """``A v = rhs`` by CG (symmetric) or BiCGSTAB, differentiable through
    ``lax.custom_linear_solve``: the forward solve starts at ``v0``; the transposed one at 0,
    with no absolute floor (cotangents have their own scale)."""
    if symmetric:
        def forward(mv, r):
            return pcg(mv, r, v0, inv_diag, tol, atol)[0]

        def backward(mv, r):
            return pcg(mv, r, None, inv_diag, tol, 0.0)[0]
    else:
        def forward(mv, r):
            return bicgstab(mv, r, v0, tol=tol, atol=atol, maxiter=CG_MAXITER)[0]

        def backward(mv, r):
            return bicgstab(mv, r, tol=tol, maxiter=CG_MAXITER)[0]
    return jax.lax.custom_linear_solve(matvec, rhs, forward, backward, symmetric=symmetric)


class ImplicitDiffusion:
    """``(I - c L_{D_i})^{-1}`` for every species: Fourier where exact, else CG.

    Args:
        domain: a :class:`~morphogen.domains.grid.Grid` or :class:`~morphogen.domains.mesh.Mesh`.
        species: species names, in state order.
        held: where Dirichlet values are held, ``(S, *spatial)`` booleans, or ``None``.
    """

    def __init__(self, domain: Domain, species: tuple[str, ...], held: np.ndarray | None):
        self.domain = domain
        self.bcs = domain.boundaries(species)
        self.on_mesh = domain.kind == "mesh"
        shape = (len(species), *domain.spatial_shape)
        self.free = np.ones(shape, bool) if held is None else ~np.asarray(held, bool)
        self.spectral = None if self.on_mesh else SpectralDiffusion(domain, species)
        if self.on_mesh:
            self.weights = domain.areas
            self.row_sum = domain.ops.row_sum
        else:
            self.weights = np.ones(domain.spatial_shape)
            self.centre = 0.5 * domain.spectral_radius()

    def fourier(self, i: int, d: Any) -> bool:
        """Whether species ``i`` with coefficient ``d`` is solved exactly in Fourier space."""
        return (not self.on_mesh and self.bcs[i].kind in ("periodic", "neumann")
                and not isinstance(d, Tensor) and jnp.ndim(d) == 0)

    def iterative(self, i: int, d: Any) -> bool:
        """Whether species ``i`` with coefficient ``d`` is solved by iteration (not a zero
        coefficient, not an exact Fourier solve)."""
        return not (isinstance(d, int | float) and d == 0) and not self.fourier(i, d)

    def solve(self, b: Array, coeffs: tuple[Any, ...], c: Array, x0: Array) -> Array:
        """Solve ``(I - c L_{D_i}) x_i = b_i`` for every species; ``b``, ``x0`` are
        ``(S, *spatial)``; held values of ``b`` are replaced by the Dirichlet ones."""
        z = self.domain.hold(b, self.bcs)
        rows = []
        for i, d in enumerate(coeffs):
            if isinstance(d, int | float) and d == 0:
                rows.append(z[i])
            elif self.iterative(i, d):
                rows.append(self._iterate(i, z[i], d, c, x0[i]))
            else:
                rows.append(self.spectral.solve_one(z[i], d, c, self.bcs[i].kind == "neumann"))
        return jnp.stack(rows)

    def _iterate(self, i: int, z: Array, d: Any, c: Array, x0: Array) -> Array:
        system = self._system(i, z, d, c, x0)
        return system.finish(system.solve())

    def residual_ratios(self, b: Array, coeffs: tuple[Any, ...], c: Array, x0: Array) -> Array:
        """Per species, the final residual of the iterative solve of ``(I - c L_{D_i}) x = b_i``
        over its stopping threshold, shape ``(S,)``: at most 1 when the solve converged, above
        1 when it stopped at :data:`CG_MAXITER` first; 0 for species solved exactly."""
        z = self.domain.hold(b, self.bcs)
        ratios = []
        for i, d in enumerate(coeffs):
            if not self.iterative(i, d):
                ratios.append(jnp.zeros((), b.dtype))
                continue
            system = self._system(i, z[i], d, c, x0[i])
            ratios.append(system.ratio(system.solve()))
        return jnp.stack(ratios)

    def _system(self, i: int, z: Array, d: Any, c: Array, x0: Array) -> _System:
        dtype = z.dtype
        tol = CG_RTOL_X64 if dtype == np.float64 else CG_RTOL
        m = jnp.asarray(self.free[i], dtype)
        bc = self.bcs[i]

        def op(f: Array) -> Array:
            return self.domain.diffuse(f[None], (d,), (bc,))[0]

        if not self.on_mesh and not isinstance(d, Tensor):
            return self._grid_isotropic(z, d, bc, c, x0, m, tol)
        w = jnp.asarray(self.weights, dtype)
        cw = c * m * w  # hoisted, and no all-ones mask in the loop: steps measured 2-3x faster
        held = not self.free[i].all()

        def matvec(v: Array) -> Array:
            return w * v - cw * op(m * v if held else v)

        def finish(v: Array) -> Array:
            if not held:  # conservative fluxes: restore the exact M-weighted mass
                v = v - jnp.sum(w * v) / jnp.sum(w)
            return z + v

        inv_diag = 1.0 / (w * (1.0 + c * m * self._diagonal(d, dtype)))
        atol = 1e-2 * tol * jnp.sqrt(_dot(w * z, w * z))
        return _System(matvec, cw * op(z), m * (x0 - z), inv_diag, tol, atol, self.on_mesh,
                       finish)

    def _diagonal(self, d: Any, dtype: Any) -> Array:
        """Approximate diagonal of ``-L_D`` for the Jacobi preconditioner, ``(*spatial)``."""
        if isinstance(d, Tensor):
            d = 0.5 * (jnp.asarray(d.xx, dtype) + jnp.asarray(d.yy, dtype))
        rate = jnp.maximum(jnp.asarray(d, dtype), 0.0)
        if self.on_mesh:
            return rate * jnp.asarray(self.row_sum, dtype)
        return rate * self.centre

    def _grid_isotropic(self, z: Array, d: Any, bc: Any, c: Array, x0: Array, m: Array,
                        tol: float) -> _System:
        """``x = z + S w`` with ``(I - c S L_h S) w = c S L_h z``, ``S = diag(sqrt(D) free)``."""
        d = jnp.broadcast_to(jnp.asarray(d, z.dtype), z.shape)
        pos = d > 0
        s = jnp.where(pos, jnp.sqrt(jnp.where(pos, d, 1.0)), 0.0) * m

        cs = c * s  # loop invariant

        def matvec(w: Array) -> Array:
            return w - cs * self.domain.laplacian(s * w, bc)

        w0 = jnp.where(s > 0, (x0 - z) / jnp.where(s > 0, s, 1.0), 0.0)
        inv_diag = 1.0 / (1.0 + c * s * s * self.centre)
        atol = 1e-2 * tol * jnp.sqrt(_dot(z, z))
        return _System(matvec, cs * self.domain.laplacian(z, bc), w0, inv_diag, tol, atol, True,
                       lambda w: z + s * w)


@dataclass
class _System:
    """One species' linear system ``A v = rhs`` (``matvec`` applies ``A``), the solver's
    settings, and ``finish``, which turns the solution ``v`` into the new state."""

    matvec: Callable[[Array], Array]
    rhs: Array
    v0: Array
    inv_diag: Array
    tol: float
    atol: Array
    symmetric: bool
    finish: Callable[[Array], Array]

    def solve(self) -> Array:
        return _linear_solve(self.matvec, self.rhs, self.v0, self.inv_diag, self.tol, self.atol,
                             self.symmetric)

    def ratio(self, v: Array) -> Array:
        """``||rhs - A v||`` over the stopping threshold ``max(tol ||rhs||, atol)``."""
        r = self.rhs - self.matvec(v)
        limit = jnp.maximum(self.tol * jnp.sqrt(_dot(self.rhs, self.rhs)), self.atol)
        return jnp.sqrt(_dot(r, r)) / jnp.maximum(limit, jnp.finfo(r.dtype).tiny)
