"""Linear stability of the homogeneous state: dispersion relation and Turing wavelength.

Linearising :math:`\\partial_t u = R(u) + D\\nabla^2 u` about the homogeneous state ``u*`` gives,
for a Fourier mode with wavenumber ``q``, growth rates equal to the eigenvalues of

.. math:: A(q) = J - q^2 \\operatorname{diag}(D),\\qquad J = \\partial R / \\partial u\\,(u^*)

A Turing instability is a band of ``q > 0`` with ``max Re eig A(q) > 0`` while ``A(0)`` is stable;
the fastest-growing mode sets the pattern's wavelength ``2 pi / q_max`` (Murray, Mathematical
Biology II, ch. 2). On a grid the continuous ``-q^2`` is replaced by the stencil's Fourier symbol.

The batched part (:func:`lattice_modes`, :func:`spectrum`, :func:`stability`; pure JAX, ``vmap``
it over a population with :mod:`morphogen.models.fixed_points`) evaluates the dispersion
relation ``σ(κ²) = max Re eig(J - κ² D)`` on every distinct mode of a grid, ``-κ²`` the
stencil's symbol there, and classifies the fixed point:

- ``turing``: ``σ(0) < -tol`` and ``σ(κ²) > tol`` for some ``κ² > 0`` (diffusion-driven);
- ``stable``: ``σ(0) < -tol`` and ``σ(κ²) <= tol`` for every ``κ² > 0``;
- ``unstable_k0``: ``σ(0) > tol``: the homogeneous state itself grows (a saddle) or
  oscillates (``oscillatory``: the leading eigenvalue at ``κ² = 0`` is complex, Hopf side);
- ``marginal``: ``|σ(0)| <= tol`` (e.g. a conserved quantity);
- ``no_fixed_point``.

``tol`` is :data:`TOL_ABS` (per time unit) plus :data:`TOL` (float64; :data:`TOL_32` in
float32) times ``max|J̃|``, with ``J̃ = diag(u*)⁻¹ J diag(u*)`` (zeros of ``u*`` taken as 1):
the same eigenvalues, and with them ``σ``, since ``D`` is diagonal, but entries in units of
1/time where ``J``'s span tens of decades when ``u*`` does (a network's fixed point,
Yamamoto et al. §3.1); LAPACK's backward error is ``~1e-16 max|J̃|`` in float64.
"""

from __future__ import annotations

import itertools
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.fixed_points import first_found, fixed_points_batch
from morphogen.models.model import CENTRE, Array, Model, Params, reaction_jacobian

CLASSES = ("turing", "stable", "unstable_k0", "marginal", "no_fixed_point")
"""The classes of :func:`stability`, by index."""
TOL = 1e-14
TOL_32 = 1e-5
TOL_ABS = 1e-9
"""Growth rates within ``TOL_ABS + TOL max|J̃|`` of 0 count as 0 (module docstring)."""


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



class Modes(NamedTuple):
    """The distinct Fourier modes of a grid (module docstring).

    Attributes:
        kappa2: ``κ² = -symbol(k)`` of each mode, shape ``(K,)``; the homogeneous mode first.
        wavelength: its wavelength in cells, shape ``(K,)`` (``inf`` for the first).
        index: its lattice numbers ``(m_0, ..., m_{d-1})``, shape ``(K, d)``.
    """

    kappa2: np.ndarray
    wavelength: np.ndarray
    index: np.ndarray


def lattice_modes(shape: Sequence[int], symbol: Callable[..., np.ndarray], *,
                  periodic: bool = True) -> Modes:
    """Every distinct mode of a grid of ``shape`` whose Laplacian has Fourier ``symbol``
    (angular wavenumbers per cell, one per axis -> eigenvalue; e.g.
    :meth:`morphogen.domains.grid.Grid.symbol`, which includes ``1/dx²``).

    Periodic: ``k_a = 2π m_a / n_a``, ``0 <= m_a <= n_a / 2`` (the symbols are even in each
    ``k_a``), wavelength ``1 / |(m_a / n_a)|`` cells. No-flux: the cosines ``cos(π m_a (x + ½) /
    n_a)``, ``k_a = π m_a / n_a``, ``0 <= m_a < n_a``, wavelength ``2 / |(m_a / n_a)|``. Where all
    axes are equal only non-decreasing ``m`` are kept (the symbols are symmetric in the axes):
    the 5-point Laplacian on 32² has 153 modes, ``κ² = 4 - 2 cos(2πm/32) - 2 cos(2πn/32)``.
    """
    shape = tuple(int(n) for n in shape)
    ranges = [range(n // 2 + 1) if periodic else range(n) for n in shape]
    index = np.array(list(itertools.product(*ranges)), dtype=np.int64)
    if len(set(shape)) == 1:
        index = index[np.all(np.diff(index, axis=1) >= 0, axis=1)]
    frac = index / np.asarray(shape, np.float64)
    k = (2 * np.pi if periodic else np.pi) * frac
    kappa2 = -np.asarray(symbol(*k.T), np.float64)
    with np.errstate(divide="ignore"):
        wavelength = (1.0 if periodic else 2.0) / np.sqrt((frac**2).sum(axis=1))
    return Modes(kappa2, wavelength, index)


def spectrum(jac: Array, d: Array, kappa2: Array) -> Array:
    """Eigenvalues of ``J - κ² diag(d)`` for each ``κ²``: ``jac`` ``(S, S)``, ``d`` ``(S,)``,
    ``kappa2`` ``(K,)`` -> complex ``(K, S)``. Pure JAX (``jit``, ``vmap``); non-finite entries
    are zeroed first (NaN input made LAPACK spin)."""
    jac = jnp.nan_to_num(jac)
    return jax.vmap(lambda q: jnp.linalg.eigvals(jac - q * jnp.diag(d)))(kappa2)


class Stability(NamedTuple):
    """The dispersion relation at one fixed point and its class (a leading population axis
    under ``vmap``).

    Attributes:
        cls: index into :data:`CLASSES`, ``()``.
        eigenvalues: of ``J - κ² D`` at every ``κ²``, complex ``(K, S)``.
        sigma: ``σ(κ²) = max Re`` of them, ``(K,)``; ``sigma[0]`` is the homogeneous mode's.
        fastest: index of the largest ``σ`` over ``κ² > 0`` (``>= 1``), ``()``.
        unstable: ``σ(κ²) > tol`` for each ``κ²`` (``False`` for ``κ² = 0``), ``(K,)``.
        oscillatory: the leading eigenvalue at ``κ² = 0`` is complex, ``()``.
        tol: the tolerance of the class, ``()``.
    """

    cls: Array
    eigenvalues: Array
    sigma: Array
    fastest: Array
    unstable: Array
    oscillatory: Array
    tol: Array


def stability(jac: Array, u: Array, d: Array, kappa2: Array, found: Array = True) -> Stability:
    """Class and dispersion relation of the fixed point ``u`` ``(S,)`` with reaction Jacobian
    ``jac`` ``(S, S)`` and diffusion ``d`` ``(S,)`` over ``kappa2`` ``(K,)``, whose first entry
    must be 0 (module docstring: the classes, and ``tol`` from ``J̃``). Not ``found`` (or a
    non-finite ``J``): ``no_fixed_point``. Pure JAX, in ``jac``'s dtype."""
    f64 = jnp.dtype(jac.dtype) == jnp.float64
    found = jnp.asarray(found) & jnp.all(jnp.isfinite(jac))
    scale = jnp.where(jnp.abs(u) > 1e-100, u, 1.0)
    scaled = jnp.nan_to_num(jac * scale[None, :] / scale[:, None])
    lam = spectrum(scaled, d, kappa2)
    sigma = jnp.max(jnp.real(lam), axis=1)
    tol = TOL_ABS + (TOL if f64 else TOL_32) * jnp.max(jnp.abs(scaled))
    s0, rest = sigma[0], sigma[1:]
    fastest = jnp.argmax(rest) + 1
    cls = jnp.where(~found, 4, jnp.where(s0 > tol, 2, jnp.where(
        s0 >= -tol, 3, jnp.where(rest.max() > tol, 0, 1))))
    lead = lam[0, jnp.argmax(jnp.real(lam[0]))]
    unstable = (sigma > tol).at[0].set(False)
    return Stability(cls, lam, sigma, fastest, unstable, jnp.abs(jnp.imag(lead)) > tol, tol)


def diffusion_of(model: Model, params: Params) -> Array:
    """The isotropic diffusion coefficients ``(S,)`` of one (traced) parameter set, in JAX."""
    return jnp.stack([jnp.asarray(c) for c in model.diffusion(dict(params), dict(CENTRE))])


def stability_at(model: Model, params: Params, u: Array, kappa2: Array,
                 found: Array = True) -> Stability:
    """:func:`stability` of ``model`` at the fixed point ``u`` ``(S,)`` of one parameter set:
    ``J`` from :func:`~morphogen.models.model.reaction_jacobian`, ``D`` from the model."""
    jac = reaction_jacobian(model, u, params)
    d = diffusion_of(model, params).astype(jac.dtype)
    return stability(jac, u, d, jnp.asarray(kappa2, jac.dtype), found)


def turing_batch(model: Model, params: Params, starts: Array, kappa2: Array, *,
                 balance: str = "generic") -> tuple[Array, Array, Stability]:
    """The whole analysis of a population at once: the first found fixed point of each
    parameter set (:func:`morphogen.models.fixed_points.fixed_points_batch`, ``starts``
    ``(K0, S)`` or ``(P, K0, S)``) and :func:`stability_at` there over ``kappa2`` (first entry
    0; e.g. :func:`lattice_modes`). Returns ``u`` ``(P, S)``, ``found`` ``(P,)`` and the
    batched :class:`Stability`. Computes in the dtype of ``starts``."""
    points = fixed_points_batch(model, params, starts, balance=balance)
    u, found = first_found(points)
    dtype = jnp.asarray(starts).dtype
    return u, found, stability_program(model)(params, u, jnp.asarray(kappa2, dtype), found)


_STABILITY: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def stability_program(model: Model) -> Callable:
    """``jit(vmap(stability_at))`` for ``model``, kept for the model's lifetime: ``(params
    (P, ...), u (P, S), kappa2 (K,), found (P,)) -> Stability`` with a leading ``P``."""
    if model not in _STABILITY:
        _STABILITY[model] = jax.jit(jax.vmap(
            lambda p, u, q, f: stability_at(model, p, u, q, f), in_axes=(0, 0, None, 0)))
    return _STABILITY[model]
