"""Time steps, noise terms and the stability limit.

A step maps ``(u, p, t, dt, key) -> u`` for one state of shape ``(S, *spatial)``. The
deterministic right-hand side is

.. math:: f(u) = R(u, p, x, t) + \\nabla\\cdot(D\\nabla u)

advanced by a fixed-step scheme of :data:`morphogen.solvers.registry.SCHEMES`, each a
:class:`~morphogen.solvers.base.Stepper`: explicit Euler (the scheme of every seed) or classic
RK4 (:mod:`morphogen.solvers.explicit`), an implicit-explicit scheme (``imex1``, ``imex``:
diffusion solved exactly in Fourier space or by conjugate gradients on meshes and for varying,
anisotropic or Dirichlet diffusion, :mod:`morphogen.solvers.imex`) or the exponential integrator
``etdrk4`` (:mod:`morphogen.solvers.etd`).
Noise is added after the deterministic update, Euler-Maruyama style, whatever the scheme:

- additive: ``u += sigma * sqrt(dt) * xi``
- multiplicative (Langevin): ``u += sigma * u * sqrt(dt) * xi``

with ``xi ~ N(0, 1)`` per cell, drawn from an explicit key.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.base import Domain
from morphogen.errors import MorphogenError, UnstableTimeStepError
from morphogen.models.model import Array, Model, Params
from morphogen.solvers.base import Stepper, scheme_name, stepper
from morphogen.solvers.registry import ERROR_CONTROLLED


@dataclass(frozen=True)
class Noise:
    """A stochastic term: ``kind`` is ``additive`` or ``multiplicative``; ``species`` limits it
    to some species (all when empty)."""

    amplitude: float
    kind: str = "additive"
    species: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.kind not in ("additive", "multiplicative"):
            raise MorphogenError(
                f"noise kind must be additive or multiplicative, not {self.kind!r}"
            )
        if not (np.isfinite(self.amplitude) and self.amplitude >= 0):
            raise MorphogenError(f"noise amplitude must be >= 0, got {self.amplitude}")


@dataclass(frozen=True, eq=False)
class Step:
    """One time step of a scheme, with its noise, clamping and held values (:func:`make_step`).

    ``step(u, p, t, dt, key[, aux]) -> u`` is pure, jit-, vmap- and grad-friendly;
    ``aux = step.invariants(p, t0, dt)`` is what the scheme precomputes once for a run with
    fixed ``dt`` (ETDRK4's exponentials and φ-coefficients, ``None`` for the others):
    :func:`morphogen.engine.simulate.integrate` computes it before its loop. Without ``aux``
    the step computes what it needs itself.
    """

    invariants: Callable[[Params, Array, Array], Any]
    apply: Callable[..., Array]

    def __call__(self, u: Array, p: Params, t: Array, dt: Array, key: Array,
                 aux: Any = None) -> Array:
        return self.apply(u, p, t, dt, key, aux)


def make_step(
    model: Model,
    domain: Domain,
    *,
    scheme: str | Stepper = "euler",
    noise: Noise | None = None,
    clamp: tuple[float, float] | None = None,
) -> Step:
    """One time step ``step(u, p, t, dt, key) -> u`` of ``scheme`` (a :class:`Step`).

    Dirichlet values are imposed before the step, stay fixed through its stages
    (:func:`morphogen.solvers.base.make_rhs`) and are re-imposed after noise and clamping;
    ``clamp`` (Skaggs §3.2's ``[0, 5]``) bounds values only when asked. A domain with
    stochastic diffusion (``domain.stochastic`` true, e.g. a mesh with Ringham's ``omega``) adds
    ``domain.diffusion_noise(u, D, bcs, dt, key)``, evaluated at the step's starting state,
    after the deterministic update.
    """
    advance = stepper(scheme).advance(model, domain)
    bcs = domain.boundaries(model.species)
    noise_mask = _noise_mask(model, noise)
    flux_noise = domain.diffusion_noise if domain.stochastic else None
    coords = {k: jnp.asarray(v) for k, v in domain.coords.items()}

    def step(u: Array, p: Params, t: Array, dt: Array, key: Array, aux: Any = None) -> Array:
        if flux_noise is not None:
            key, sub = jax.random.split(key)
            du = flux_noise(u, model.diffusion(p, {**coords, "t": t}), bcs, dt, sub)
        u = advance(domain.hold(u, bcs), p, t, dt, aux)
        if noise is not None and noise.amplitude > 0:
            mask = noise_mask.reshape((-1,) + (1,) * (u.ndim - 1))
            xi = jax.random.normal(key, u.shape, u.dtype) * mask
            scale = noise.amplitude * jnp.sqrt(dt)
            u = u + scale * (xi if noise.kind == "additive" else u * xi)
        if flux_noise is not None:
            u = u + du
        if clamp is not None:
            u = jnp.clip(u, clamp[0], clamp[1])
        return domain.hold(u, bcs)

    return Step(advance.invariants, step)


def _noise_mask(model: Model, noise: Noise | None) -> np.ndarray:
    """1 for species that receive noise, 0 otherwise; shape ``(S,)``."""
    if noise is None or not noise.species:
        return np.ones(len(model.species), np.float32)
    mask = np.zeros(len(model.species), np.float32)
    for name in noise.species:
        mask[model.species_index(name)] = 1.0
    return mask


def max_stable_dt(
    model: Model, domain: Domain, params: Params, scheme: str | Stepper = "euler", *,
    batched: bool = False
) -> float:
    """Largest stable explicit ``dt``: diffusion and the reaction's linearisation.

    For pure diffusion with the 5-point stencil and Euler the marginal step is
    ``dx^2 / (2 * dims * D_max)``; in general every decaying eigenvalue ``lambda`` of
    ``J - sigma diag(D)`` (``J`` the reaction Jacobian at the ground state, ``0 <= sigma <=
    rho(L)``) must satisfy ``|R(lambda dt)| <= 1``, and the result keeps a safety margin of
    :data:`morphogen.solvers.stability.SAFETY` below the marginal value (see
    :mod:`morphogen.solvers.stability`); schemes with implicit or exact diffusion are limited by
    the reaction alone (each scheme's :meth:`~morphogen.solvers.base.Stepper.limit`). With
    ``batched`` every parameter has a leading batch axis and the bound is over all members.
    Anisotropic tensors use their largest eigenvalue. The error-controlled schemes
    (``adaptive``, ``etdrk4-adaptive``) have no limit (their controller picks the steps):
    ``inf``.
    """
    if scheme in ERROR_CONTROLLED:
        return float("inf")
    return stepper(scheme).limit(model, domain, params, batched=batched)


def check_stability(
    model: Model, domain: Domain, params: Params, dt: float, scheme: str | Stepper = "euler", *,
    batched: bool = False,
) -> float:
    """Raise :class:`UnstableTimeStepError` if ``dt`` exceeds :func:`max_stable_dt`."""
    dt_max = max_stable_dt(model, domain, params, scheme, batched=batched)
    if dt > dt_max:
        raise UnstableTimeStepError(dt, dt_max, scheme_name(scheme))
    return dt_max


def batch_params(params: Params, size: int, batched: Sequence[str] = ()) -> dict[str, Array]:
    """Give every parameter a leading batch axis of ``size`` (names in ``batched`` have one)."""
    out = {}
    for k, v in params.items():
        arr = jnp.asarray(v, jnp.result_type(float))
        out[k] = arr if k in batched else jnp.broadcast_to(arr, (size, *arr.shape))
    return out
