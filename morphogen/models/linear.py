"""Linear stability of the homogeneous state: dispersion relation and Turing wavelength.

Linearising :math:`\\partial_t u = R(u) + D\\nabla^2 u` about the homogeneous state ``u*`` gives,
for a Fourier mode with wavenumber ``q``, growth rates equal to the eigenvalues of

.. math:: A(q) = J - q^2 \\operatorname{diag}(D),\\qquad J = \\partial R / \\partial u\\,(u^*)

A Turing instability is a band of ``q > 0`` with ``max Re eig A(q) > 0`` while ``A(0)`` is stable;
the fastest-growing mode sets the pattern's wavelength ``2 pi / q_max`` (Murray, Mathematical
Biology II, ch. 2). On a grid the continuous ``-q^2`` is replaced by the stencil's Fourier symbol.
"""

from __future__ import annotations

from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.model import CENTRE, Model, Params, reaction_jacobian


def jacobian(model: Model, params: Params, state: np.ndarray | None = None) -> np.ndarray:
    """``J = dR/du`` (:func:`morphogen.models.model.reaction_jacobian`, float32) at ``state``
    (default: the ground state) with the spatial means of the parameters, shape (S, S)."""
    u0 = model.ground_state(params) if state is None else np.asarray(state)
    p = {k: jnp.asarray(np.mean(np.asarray(v)), jnp.float32) for k, v in params.items()}
    return np.asarray(reaction_jacobian(model, jnp.asarray(u0, jnp.float32), p), dtype=np.float64)


def diffusion_vector(model: Model, params: Params) -> np.ndarray:
    """Isotropic diffusion coefficient of each species (spatial means), shape (S,)."""
    coeffs = model.diffusion(dict(params), dict(CENTRE))
    return np.array([float(np.mean(np.asarray(d))) for d in coeffs])


def growth_rates(model: Model, params: Params, q: np.ndarray) -> np.ndarray:
    """Largest real part of the eigenvalues of ``A(q)`` for each wavenumber in ``q``."""
    jac = jacobian(model, params)
    d = diffusion_vector(model, params)
    q = np.atleast_1d(np.asarray(q, dtype=np.float64))
    mats = jac[None] - (q**2)[:, None, None] * np.diag(d)[None]
    return np.linalg.eigvals(mats).real.max(axis=1)


@dataclass(frozen=True)
class TuringMode:
    """The fastest-growing mode: wavenumber ``q``, ``wavelength = 2 pi / q`` and its growth."""

    q: float
    wavelength: float
    growth: float
    homogeneous_growth: float

    @property
    def is_turing(self) -> bool:
        """Unstable at ``q > 0`` while the homogeneous mode is stable."""
        return self.growth > 0 and self.homogeneous_growth < 0


def fastest_mode(model: Model, params: Params, *, q_max: float = np.pi) -> TuringMode:
    """Scan ``0 < q <= q_max`` (default: up to the grid Nyquist for ``dx = 1``)."""
    q = np.linspace(q_max / 4000, q_max, 4000)
    rates = growth_rates(model, params, q)
    if not np.all(np.isfinite(rates)):
        raise MorphogenError(f"linear stability of {model.name} is undefined at these parameters")
    i = int(np.argmax(rates))
    best_q = float(q[i])
    return TuringMode(
        q=best_q,
        wavelength=2 * np.pi / best_q,
        growth=float(rates[i]),
        homogeneous_growth=float(growth_rates(model, params, np.array([0.0]))[0]),
    )

