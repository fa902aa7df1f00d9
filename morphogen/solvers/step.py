"""Time steppers, noise terms and the explicit stability limit.

A step maps ``(u, p, t, dt, key) -> u`` for one state of shape ``(S, *spatial)``. The
deterministic right-hand side is

.. math:: f(u) = R(u, p, x, t) + \\nabla\\cdot(D\\nabla u)

advanced by explicit Euler (the scheme of every seed), classic RK4, or an implicit-explicit
scheme (``imex1``, ``imex``: diffusion solved exactly in Fourier space,
:mod:`morphogen.solvers.imex`,
or by conjugate gradients on meshes and for varying, anisotropic or Dirichlet diffusion,
:mod:`morphogen.solvers.imex_cg`) or the exponential integrator ``etdrk4``
(:mod:`morphogen.solvers.etd`).
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

from morphogen.errors import MorphogenError, UnstableTimeStepError
from morphogen.models.model import Array, Model, Params
from morphogen.solvers.etd import make_etd_advance
from morphogen.solvers.imex import IMEX_SCHEMES, make_imex_advance
from morphogen.solvers.imex_cg import ImplicitDiffusion
from morphogen.solvers.stability import linear_limit

EXPLICIT_SCHEMES = ("euler", "rk4")
SCHEMES = EXPLICIT_SCHEMES + IMEX_SCHEMES + ("etdrk4",)
RUN_SCHEMES = ("adaptive", "auto")
"""Schemes resolved per run by :func:`morphogen.engine.simulate.simulate`: error-controlled steps
(:mod:`morphogen.solvers.adaptive`) and the automatic choice (:mod:`morphogen.solvers.auto`)."""


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


def make_rhs(model: Model, domain: Any) -> Callable[[Array, Params, Array], Array]:
    """The deterministic right-hand side ``f(u, p, t)`` of the model on the domain.

    ``f = 0`` on held Dirichlet values (:func:`held_mask`): a state whose held cells carry
    their values keeps them through every stage of a Runge-Kutta step, so the boundary enters
    each stage and the scheme keeps its order (resetting it only after the step would leave the
    inner stages with drifted boundary values, an ``O(dt)`` error per unit time).
    """
    bcs = domain.boundaries(model.species)
    coords = {k: jnp.asarray(v) for k, v in domain.coords.items()}
    held = held_mask(model, domain)

    def rhs(u: Array, p: Params, t: Array) -> Array:
        c = {**coords, "t": t}
        du = model.reaction(u, p, c) + domain.diffuse(u, model.diffusion(p, c), bcs)
        return du if held is None else jnp.where(held, 0.0, du)

    return rhs


def held_mask(model: Model, domain: Any) -> np.ndarray | None:
    """Where ``domain.hold`` imposes Dirichlet values, shape ``(S, *spatial)``; ``None`` when
    nothing is held."""
    bcs = domain.boundaries(model.species)
    probe = np.full((len(model.species), *domain.spatial_shape), np.nan, np.float32)
    with jax.ensure_compile_time_eval():
        held = np.isfinite(np.asarray(domain.hold(jnp.asarray(probe), bcs)))
    return held if held.any() else None


def make_step(
    model: Model,
    domain: Any,
    *,
    scheme: str = "euler",
    noise: Noise | None = None,
    clamp: tuple[float, float] | None = None,
) -> Callable[[Array, Params, Array, Array, Array], Array]:
    """One time step ``step(u, p, t, dt, key) -> u`` (pure, jit- and grad-friendly).

    Dirichlet values are imposed before the step, stay fixed through its stages
    (:func:`make_rhs`) and are re-imposed after noise and clamping; ``clamp`` (Skaggs §3.2's
    ``[0, 5]``)
    bounds values only when asked. A domain with stochastic diffusion (``domain.stochastic``
    true, e.g. a mesh with Ringham's ``omega``) adds ``domain.diffusion_noise(u, D, bcs, dt,
    key)``, evaluated at the step's starting state, after the deterministic update.
    """
    if scheme in RUN_SCHEMES:
        raise MorphogenError(f"scheme {scheme} is chosen per run, not per step; pass it to "
                             f"simulate, or use one of {', '.join(SCHEMES)} here")
    if scheme not in SCHEMES:
        raise MorphogenError(f"unknown scheme {scheme!r}; use one of {', '.join(SCHEMES)}")
    if scheme in IMEX_SCHEMES:
        solver = ImplicitDiffusion(domain, model.species, held_mask(model, domain))
        advance = make_imex_advance(model, domain, scheme, solver)
    elif scheme == "etdrk4":
        advance = make_etd_advance(model, domain)
    else:
        advance = _explicit_advance(make_rhs(model, domain), scheme)
    bcs = domain.boundaries(model.species)
    noise_mask = _noise_mask(model, noise)
    flux_noise = domain.diffusion_noise if getattr(domain, "stochastic", False) else None
    coords = {k: jnp.asarray(v) for k, v in domain.coords.items()}

    def step(u: Array, p: Params, t: Array, dt: Array, key: Array, aux: Any = None) -> Array:
        if flux_noise is not None:
            key, sub = jax.random.split(key)
            du = flux_noise(u, model.diffusion(p, {**coords, "t": t}), bcs, dt, sub)
        held = domain.hold(u, bcs)
        u = advance(held, p, t, dt) if aux is None else advance(held, p, t, dt, aux)
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

    if hasattr(advance, "invariants"):
        step.invariants = advance.invariants
    return step


RK4_STAGES = np.array([[0.0, 0.5, 1.0 / 6.0], [0.5, 0.5, 2.0 / 6.0], [0.5, 1.0, 2.0 / 6.0],
                       [1.0, 0.0, 1.0 / 6.0]])
"""Classic RK4 per stage: its time offset ``c_i`` and the next stage's state offset (both in
units of ``dt``), and its weight ``b_i``."""


def _explicit_advance(rhs: Callable, scheme: str) -> Callable:
    """Explicit Euler or classic RK4 on ``rhs``.

    RK4's four stages are one ``lax.scan`` over :data:`RK4_STAGES`, carrying the stage state
    ``y_i = u + a_i dt k_{i-1}`` and the weighted sum ``sum b_i k_i``. Written out as four
    chained right-hand sides, XLA on CPU fused the stencils of successive stages into a few
    large loops and a 256² step took 22 Euler steps' time; with the stage state a loop carry,
    each stage compiles like an Euler step (3x faster).
    """

    def advance(u: Array, p: Params, t: Array, dt: Array) -> Array:
        if scheme == "euler":
            return u + dt * rhs(u, p, t)
        table = jnp.asarray(RK4_STAGES, u.dtype)

        def stage(carry, row):
            y, total = carry
            k = rhs(y, p, t + row[0] * dt)
            return (u + row[1] * dt * k, total + row[2] * k), None

        (_, total), _ = jax.lax.scan(stage, (u, jnp.zeros_like(u)), table)
        return u + dt * total

    return advance


def _noise_mask(model: Model, noise: Noise | None) -> np.ndarray:
    """1 for species that receive noise, 0 otherwise; shape ``(S,)``."""
    if noise is None or not noise.species:
        return np.ones(len(model.species), np.float32)
    mask = np.zeros(len(model.species), np.float32)
    for name in noise.species:
        mask[model.species_index(name)] = 1.0
    return mask


def max_stable_dt(
    model: Model, domain: Any, params: Params, scheme: str = "euler", *, batched: bool = False
) -> float:
    """Largest stable explicit ``dt``: diffusion and the reaction's linearisation.

    For pure diffusion with the 5-point stencil and Euler the marginal step is
    ``dx^2 / (2 * dims * D_max)``; in general every decaying eigenvalue ``lambda`` of
    ``J - sigma diag(D)`` (``J`` the reaction Jacobian at the ground state, ``0 <= sigma <=
    rho(L)``) must satisfy ``|R(lambda dt)| <= 1``, and the result keeps a safety margin of
    :data:`morphogen.solvers.stability.SAFETY` below the marginal value (see
    :mod:`morphogen.solvers.stability`). With ``batched`` every parameter has a leading batch axis
    and the bound is over all members. Anisotropic tensors use their largest eigenvalue.
    ``adaptive`` has no limit (its controller picks the steps): ``inf``.
    """
    if scheme == "adaptive":
        return float("inf")
    return linear_limit(model, domain, params, scheme, batched=batched)


def check_stability(
    model: Model, domain: Any, params: Params, dt: float, scheme: str = "euler", *,
    batched: bool = False,
) -> float:
    """Raise :class:`UnstableTimeStepError` if ``dt`` exceeds :func:`max_stable_dt`."""
    dt_max = max_stable_dt(model, domain, params, scheme, batched=batched)
    if dt > dt_max:
        raise UnstableTimeStepError(dt, dt_max, scheme)
    return dt_max


def batch_params(params: Params, size: int, batched: Sequence[str] = ()) -> dict[str, Array]:
    """Give every parameter a leading batch axis of ``size`` (names in ``batched`` have one)."""
    out = {}
    for k, v in params.items():
        arr = jnp.asarray(v, jnp.result_type(float))
        out[k] = arr if k in batched else jnp.broadcast_to(arr, (size, *arr.shape))
    return out
