"""Exact implicit diffusion solves in Fourier space, for grids with constant coefficients.

For :math:`\\partial_t u = D\\,L u` on a grid with constant, isotropic, per-species ``D``, the
discrete Laplacian ``L`` of the grid's stencil is diagonal in the Fourier basis of the boundary
condition: complex exponentials (FFT) for periodic species and the cosines
``cos(pi m (i + 1/2) / n)``, ``m = 0 .. n - 1`` (a DCT-II on the grid's own size,
:mod:`morphogen.solvers.cosine`) for no-flux species. On mode ``k`` it multiplies by the
stencil's own symbol ``lambda(k) / dx^2``, e.g.
``sum_axes (2 cos k_a - 2)`` for the 5- and 7-point stencils, with ``k_a = 2 pi m / n``
(periodic) or ``pi m / n`` (no flux), so ``(I - c D L)^{-1}`` is a division by
``1 - c D lambda(k)``: exact for the stencil the explicit schemes apply. The implicit-explicit
schemes (:mod:`morphogen.solvers.imex`) and ETDRK4 (:mod:`morphogen.solvers.etd`) use it.
"""

from __future__ import annotations

from typing import Any

import jax.numpy as jnp
import numpy as np

from morphogen.domains.base import Domain
from morphogen.errors import MorphogenError
from morphogen.models.model import Array, Tensor
from morphogen.solvers.cosine import dct, idct


def require_spectral_grid(domain: Domain, species: tuple[str, ...], scheme: str) -> None:
    """Raise a one-line error unless the domain is a grid with periodic / no-flux species."""
    if domain.kind != "grid":
        raise MorphogenError(
            f"scheme {scheme} solves diffusion in Fourier space on grids; use imex, euler or "
            "rk4 on meshes")
    for bc in domain.boundaries(species):
        if bc.kind not in ("periodic", "neumann"):
            raise MorphogenError(
                f"scheme {scheme} supports periodic and neumann boundaries; use imex, euler or "
                f"rk4 for {bc.kind}")


class SpectralDiffusion:
    """``(I - c D_i L)^{-1}`` per species on a grid, with ``L`` the grid's own stencil, and the
    transforms it is diagonal in."""

    def __init__(self, domain: Domain, species: tuple[str, ...]):
        self.shape = tuple(domain.shape)
        self.bcs = domain.boundaries(species)
        self.mirror = [bc.kind == "neumann" for bc in self.bcs]
        self.symbols = {m: _symbol(domain, m) for m in set(self.mirror)}

    def forward(self, f: Array, mirror: bool) -> Array:
        """``rfftn`` of one field, or its cosine coefficients (real, the field's shape) for a
        no-flux species."""
        return dct(f, f.ndim) if mirror else jnp.fft.rfftn(f)

    def inverse(self, g: Array, mirror: bool, dtype: Any) -> Array:
        """Inverse of :meth:`forward`, back on the grid."""
        v = idct(g, g.ndim) if mirror else jnp.fft.irfftn(g, s=self.shape)
        return v.astype(dtype)

    def groups(self) -> list[tuple[tuple[int, ...], bool]]:
        """The species that share a transform: ``(indices, mirror)`` per boundary kind."""
        return [(tuple(i for i, m in enumerate(self.mirror) if m == kind), kind)
                for kind in dict.fromkeys(self.mirror)]

    def forward_stack(self, f: Array, mirror: bool) -> Array:
        """:meth:`forward` of a stack ``(k, *spatial)`` of fields, as one batched transform."""
        if mirror:
            return dct(f, f.ndim - 1)
        return jnp.fft.rfftn(f, axes=tuple(range(1, f.ndim)))

    def inverse_stack(self, g: Array, mirror: bool, dtype: Any) -> Array:
        """Inverse of :meth:`forward_stack`, back on the grid."""
        if mirror:
            return idct(g, g.ndim - 1).astype(dtype)
        return jnp.fft.irfftn(g, s=self.shape, axes=tuple(range(1, g.ndim))).astype(dtype)

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


def _symbol(domain: Domain, mirror: bool) -> np.ndarray:
    """Laplacian symbol ``lambda(k) / dx^2`` (the stencil's, or ``-|k|^2`` for the spectral
    operator) on the modes of :meth:`SpectralDiffusion.forward`: the ``rfftn`` frequency grid
    ``k = 2 pi m / n`` of a periodic field, the cosines' ``k = pi m / n``, ``m = 0 .. n - 1``,
    of a no-flux one."""
    if mirror:
        freqs = [np.pi * np.arange(n) / n for n in domain.shape]
    else:
        freqs = [2 * np.pi * np.fft.fftfreq(n) for n in domain.shape[:-1]]
        freqs.append(2 * np.pi * np.fft.rfftfreq(domain.shape[-1]))
    ks = np.meshgrid(*freqs, indexing="ij")
    return domain.symbol(*ks)
