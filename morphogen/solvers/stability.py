"""Time-step limits from the linearised system, and early detection of a diverging run.

Linearising :math:`\\partial_t u = R(u) + D\\nabla^2 u` about the ground state ``u*`` gives, on
a discrete Fourier mode whose Laplacian eigenvalue is ``-sigma`` (``0 <= sigma <= rho(L)``),

.. math:: \\dot{\\hat u} = A(\\sigma)\\,\\hat u,\\qquad
          A(\\sigma) = J - \\sigma\\,\\mathrm{diag}(D),\\qquad J = \\partial R/\\partial u\\,(u^*)

(Murray, Mathematical Biology II, ch. 2; on a grid ``sigma`` is minus the stencil's symbol).
A one-step scheme multiplies the mode by its amplification ``R(z)`` with ``z = lambda dt``
(``1 + z`` for Euler, the degree-4 Taylor polynomial of ``e^z`` for RK4: each scheme's
:meth:`~morphogen.solvers.base.Stepper.amplification`). The step is stable
when ``|R(lambda dt)| <= 1`` for every decaying, diffusion-dominated eigenvalue ``lambda`` of
``A(sigma)`` (``Re lambda < 0`` and ``|Im lambda| <= |Re lambda|``); growing modes are the
physics (Turing or Hopf instabilities) and oscillatory reaction modes are a matter of
accuracy, not stability. The reported limit keeps :data:`SAFETY` below the marginal value,
because the Jacobian is taken at the ground state while the run moves away from it.

During a run, :func:`divergence_flags` looks for what an unstable step does before it
overflows: a grid-scale (checkerboard) component that dominates the field and keeps growing,
or values leaving the observed range by :data:`RANGE_FACTOR`.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.base import Domain
from morphogen.errors import MorphogenError
from morphogen.models.model import Array, Model, Params, Tensor, reaction_jacobian

SAFETY = 0.9
"""Fraction of the marginal step that is reported as the largest stable one."""

SAFETY_IMPLICIT = 0.5
"""The same for the implicit-explicit schemes, whose limit comes from the reaction alone: a
pattern's Jacobian is larger than the ground state's (Schnakenberg's ``-u^2`` reaches ``-22``
in its spots, against ``-1`` at ``u*``)."""

RANGE_FACTOR = 1e4
"""A value this many times beyond the observed scale of its species counts as diverging."""

GRID_SCALE_RATIO = 0.6
"""Share of a species' deviation carried by the grid-scale mode that counts as checkerboard."""

GROWTH = 1.5
"""Growth of the grid-scale amplitude between two checks that counts as growing."""

_SIGMAS = 33

RayLimit = Callable[[np.ndarray], np.ndarray]
"""``ray_limit(lam) -> dt``: a scheme's largest stable ``dt`` per eigenvalue ``lam``."""


def euler_ray_limit(lam: np.ndarray) -> np.ndarray:
    """Largest ``dt`` with ``|1 + lambda dt| <= 1``, per eigenvalue: the explicit Euler disc in
    closed form, ``dt = -2 Re(lambda) / |lambda|^2``."""
    lam = np.asarray(lam, np.complex128)
    mag = np.abs(lam)
    return -2.0 * lam.real / mag**2


def bisect_ray_limit(amplification: Callable[[np.ndarray], np.ndarray], lam: np.ndarray
                     ) -> np.ndarray:
    """Largest ``dt`` with ``|R(lambda dt')| <= 1`` for all ``0 < dt' <= dt``, per eigenvalue,
    for the amplification ``R``: bracketed on a dense ray and refined by bisection."""
    lam = np.asarray(lam, np.complex128)
    mag = np.abs(lam)
    direction = lam / mag
    r = np.linspace(0.0, 4.0, 801)[1:]
    inside = np.abs(amplification(direction[:, None] * r[None])) <= 1.0
    first_out = np.where(inside.all(axis=1), len(r) - 1, np.argmin(inside, axis=1))
    lo = np.where(first_out > 0, r[np.maximum(first_out - 1, 0)], 0.0)
    hi = r[first_out]
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        ok = np.abs(amplification(direction * mid)) <= 1.0
        lo, hi = np.where(ok, mid, lo), np.where(ok, hi, mid)
    return lo / mag


def coefficient_bound(d: Any) -> np.ndarray:
    """Largest diffusion coefficient over space (largest eigenvalue for a :class:`Tensor`),
    keeping a leading batch axis if the coefficient has one."""
    if isinstance(d, Tensor):
        xx, xy, yy = (np.asarray(c, np.float64) for c in d)
        return np.asarray(0.5 * (xx + yy) + np.sqrt((0.5 * (xx - yy)) ** 2 + xy**2))
    return np.abs(np.asarray(d, np.float64))


_JACOBIANS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _jacobian_program(model: Model) -> Any:
    """The model's batched reaction Jacobian ``(B, S), params -> (B, S, S)``
    (:func:`morphogen.models.model.reaction_jacobian` under ``vmap``) as one compiled program,
    kept for the model's lifetime: op by op it compiles dozens of tiny programs, and a new
    ``jit`` per call (a search checks every generation) would trace and compile again."""
    if model not in _JACOBIANS:
        _JACOBIANS[model] = jax.jit(jax.vmap(partial(reaction_jacobian, model)))
    return _JACOBIANS[model]


def reaction_jacobians(model: Model, params: Params, batched: bool) -> np.ndarray:
    """``J = dR/du`` at the ground state, shape ``(B, S, S)`` (``B = 1`` unless batched).

    Parameter fields enter through their spatial means. A batch uses the model's closed-form
    ground state per member when it has one, otherwise the ground state of the batch mean.
    A ground state that cannot be found or gives a non-finite Jacobian counts as ``J = 0``.
    """
    n = len(model.species)
    if batched:
        means = {k: np.asarray(v, np.float64).reshape(len(np.asarray(v)), -1).mean(axis=1)
                 for k, v in params.items()}
        size = len(next(iter(means.values()))) if means else 1
    else:
        means = {k: np.asarray(np.mean(np.asarray(v, np.float64)))[None] for k, v in params.items()}
        size = 1
    mean_all = {k: float(np.mean(v)) for k, v in means.items()}
    try:
        ground = None
        if batched and model.ground is not None:
            try:
                ground = np.stack([np.broadcast_to(np.asarray(g, np.float64), (size,))
                                   for g in model.ground(means)], axis=1)
            except TypeError:
                ground = None
        if ground is None:
            ground = np.broadcast_to(model.ground_state(mean_all), (size, n))
    except (MorphogenError, ArithmeticError, ValueError, TypeError):
        return np.zeros((size, n, n))

    p = {k: jnp.asarray(v, jnp.float32) for k, v in means.items()}
    out = np.asarray(_jacobian_program(model)(jnp.asarray(ground, jnp.float32), p), np.float64)
    return np.where(np.isfinite(out).all(axis=(1, 2), keepdims=True), out, 0.0)


def linear_limit(
    model: Model, domain: Domain, params: Params, ray_limit: RayLimit | None, *,
    batched: bool = False
) -> float:
    """Largest stable ``dt`` over ``0 <= sigma <= rho(L)`` of an explicit scheme whose
    ``ray_limit`` is given, with :data:`SAFETY`; ``ray_limit=None`` for a scheme with implicit or
    exact diffusion, with :data:`SAFETY_IMPLICIT`.

    The implicit-explicit and exponential schemes treat diffusion implicitly or exactly
    (unconditionally stable), so only the reaction's eigenvalues (``sigma = 0``) limit them,
    all decaying ones, oscillatory included, against the explicit Euler disc (the explicit part
    of ARS(2,2,2) has the same real interval, 2): the step follows the reaction's time scale.
    """
    coords = {**domain.coords, "t": 0.0}
    p = {k: jnp.asarray(v) for k, v in params.items()}
    if batched:
        coeffs = jax.vmap(lambda q: tuple(model.diffusion(q, coords)))(p)
        d = np.stack([coefficient_bound(c).reshape(c_len(c), -1).max(axis=1) for c in coeffs], 1)
    else:
        d = np.array([[float(np.max(coefficient_bound(c))) for c in model.diffusion(p, coords)]])
    jac = reaction_jacobians(model, params, batched)
    sigma = np.linspace(0.0, domain.spectral_radius(), _SIGMAS)
    implicit = ray_limit is None
    if implicit:
        sigma, ray_limit = np.zeros(1), euler_ray_limit
    diag = d[:, :, None] * np.eye(d.shape[1])[None]
    mats = jac[:, None] - sigma[None, :, None, None] * diag[:, None]
    lam = np.linalg.eigvals(mats).reshape(-1)
    lam = np.concatenate([lam, -(sigma[-1] * d).reshape(-1)])
    keep = (lam.real < 0) & (implicit | (np.abs(lam.imag) <= np.abs(lam.real)))
    if not keep.any():
        return float("inf")
    margin = SAFETY_IMPLICIT if implicit else SAFETY
    return float(margin * np.min(ray_limit(lam[keep])))


def c_len(c: Any) -> int:
    """Batch size of a batched diffusion coefficient (a Tensor's first component)."""
    return len(np.asarray(c[0] if isinstance(c, Tensor) else c))


def observed_scale(u0: Array, model: Model, params: Params, batched: bool) -> np.ndarray:
    """Per-species magnitude a run starts from: ``max(1, max |u0|, |u*|)``, shape ``(B, S)``."""
    u = np.asarray(u0, np.float64)
    if not batched:
        u = u[None]
    scale = np.abs(u).reshape(u.shape[0], u.shape[1], -1).max(axis=2)
    try:
        mean = {k: float(np.mean(np.asarray(v, np.float64))) for k, v in params.items()}
        ground = np.abs(np.asarray(model.ground_state(mean), np.float64))
        scale = np.maximum(scale, ground[None])
    except (MorphogenError, ArithmeticError, ValueError, TypeError):
        pass
    return np.maximum(scale, 1.0)


@partial(jax.jit, static_argnames="batched")
def grid_scale(u: Array, batched: bool) -> tuple[Array, Array]:
    """RMS of the grid-scale component and of the deviation from the mean, per species.

    The grid-scale component is ``u`` filtered by ``prod_axes (2 u_i - u_{i-1} - u_{i+1}) / 4``
    on interior cells: gain 1 on the checkerboard ``(pi, pi, ...)`` mode, 0 on any mode that is
    smooth along some axis. Returns two arrays of shape ``(B, S)``. Compiled once per shape
    (op by op, each check of a run's first chunk compiled a dozen tiny programs).
    """
    return _grid_scale(u if batched else u[None], jnp)


def _grid_scale(v: Any, xp: Any) -> tuple[Any, Any]:
    """:func:`grid_scale` of a batch ``v`` ``(B, S, *spatial)`` with the array module ``xp``
    (``jax.numpy`` inside the compiled program, NumPy for a NumPy state)."""
    spatial = tuple(range(2, v.ndim))
    h = v
    for ax in spatial:
        n = h.shape[ax]
        cut = [slice(None)] * h.ndim
        mid, lo, hi = (h[tuple(cut[:ax] + [slice(a, b)] + cut[ax + 1:])]
                       for a, b in ((1, n - 1), (0, n - 2), (2, n)))
        h = (2.0 * mid - lo - hi) / 4.0
    dev = v - v.mean(axis=spatial, keepdims=True)
    return xp.sqrt(xp.mean(h * h, axis=spatial)), xp.sqrt(xp.mean(dev * dev, axis=spatial))


def grid_scale_dominated(g: Array, dev: Array, scale: Array) -> Array:
    """The checkerboard test on :func:`grid_scale`'s ``(g, dev)``: the grid-scale RMS ``g``
    carries more than :data:`GRID_SCALE_RATIO` of the deviation RMS ``dev`` and is above
    round-off (``g > 1e-4 scale``). Elementwise, for NumPy or JAX arrays (pure, so it serves
    inside a jitted fitness too); an explicit step beyond its stability limit leaves exactly
    this, while a pattern's wavelength spans several cells (an isolated one-cell spot carries
    3/8 of its deviation at grid scale, a dense checkerboard all of it)."""
    return (g > GRID_SCALE_RATIO * dev) & (g > 1e-4 * scale)


def _peak(v: Any, xp: Any) -> Any:
    """``max |v|`` per member and species of a batch ``v``, shape ``(B, S)``."""
    return xp.max(xp.abs(v), axis=tuple(range(2, v.ndim)))


@partial(jax.jit, static_argnames="batched")
def _peak_compiled(u: Array, batched: bool) -> Array:
    """:func:`_peak` of a JAX state, compiled once per shape."""
    return _peak(u if batched else u[None], jnp)


def divergence_flags(
    u: Array, scale: np.ndarray, prev_grid: np.ndarray | None, batched: bool, on_grid: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Species that are diverging: ``(out_of_range, growing_checkerboard, grid_amplitude)``.

    ``out_of_range``: ``max |u| > RANGE_FACTOR * scale``. ``growing_checkerboard`` (grids only):
    the grid-scale RMS exceeds :data:`GRID_SCALE_RATIO` of the deviation RMS, is not round-off
    (``> 1e-4 scale``) and grew by :data:`GROWTH` since ``prev_grid``. All ``(B, S)``.
    """
    host = isinstance(u, np.ndarray)  # the fused CPU step's state: no copy into XLA, no threads
    v = u if batched else u[None]
    peak = np.asarray(_peak(v, np) if host else _peak_compiled(u, batched), np.float64)
    out = peak > RANGE_FACTOR * scale
    if not on_grid:
        zeros = np.zeros_like(out)
        return out, zeros, np.zeros(out.shape)
    stats = _grid_scale(v, np) if host else grid_scale(u, batched)
    g, dev = (np.asarray(a, np.float64) for a in stats)
    growing = grid_scale_dominated(g, dev, scale)
    if prev_grid is None:
        growing = np.zeros_like(growing)
    else:
        growing &= g > GROWTH * prev_grid
    return out, growing, g
