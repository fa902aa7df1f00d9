"""The explicit reaction's step limit along a pattern's trajectory, for the IMEX schemes.

An implicit-explicit step solves diffusion implicitly and advances the reaction explicitly, so
its stable step is the reaction's: ``|1 + λ dt| ≤ 1`` for the decaying eigenvalues ``λ`` of the
reaction Jacobian ``J = ∂R/∂u`` (the explicit Euler disc; ARS(2,2,2)'s explicit part, ``1 + z +
z²/2``, contains it). :func:`morphogen.solvers.stability.linear_limit` takes ``J`` at the ground
state, with a margin of 0.5. A pattern's own states can be much stiffer: Schnakenberg with ``a =
0.2, b = 1.3`` (``Dv/Du = 40``) has ``λ = −0.76 ± 1.29i`` at ``u* = 1.5`` (limit 0.337), but its
spots reach ``u ≈ 3.95, v ≈ 0.28``, where ``J`` has ``λ ≈ −12.8`` (Euler disc 0.156); ``imex``
at ``dt = 0.32`` blew up at ``t ≈ 47-50`` on 128² grids (periodic and no-flux) once the spots
formed, and ran to ``t = 60`` at 0.28 (issue 33, item 12).

:func:`pattern_limit` therefore follows the trajectory: a pilot run of the model on a small
periodic grid (:data:`PILOT_SIZE`² cells with the domain's ``dx``, the parameters' spatial
means) from the ground state with a seeded 1 % noise and a centred square at the model's excited
state (so that models whose ground state is linearly stable, Gray-Scott, also form their
pattern), by ``imex1``: :data:`PILOT_STEPS` steps of ``min(t_end / PILOT_STEPS, limit / 4)``
to 3 digits (so float32 and float64 parameters give one pilot), the model's ``t_end`` unless a
quarter of the ground-state limit is shorter. At :data:`SAMPLES`
times along it, the Jacobian of every cell's state gives its eigenvalues; the limit is the
smallest Euler-disc step over the decaying, relaxation-dominated ones (``Re λ < 0``, ``|Im λ| ≤
|Re λ|``: a weakly damped oscillation of the pattern is its dynamics, a matter of accuracy, and
the ground state's oscillatory eigenvalues are already covered by its own limit). This
frozen-coefficient, zero-wavenumber bound ignores that the implicit diffusion also damps a
perturbation localised in a spot, so it errs on the safe side (the pilot gives 0.162 above,
where the marginal step was near 0.3), and needs no further margin.

A pilot that blows up is repeated once at a quarter of its step (the states of a diverging run
are the scheme's, not the model's); if that blows up too the ground-state limit stands alone.
Meshes and batched parameter sets (populations) keep the ground-state limit alone.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.grid import Grid
from morphogen.models.model import Model, Params, reaction_jacobian
from morphogen.solvers.stability import euler_ray_limit

PILOT_SIZE = 32
"""Cells along each side of the pilot grid."""

PILOT_STEPS = 2000
"""Steps of a pilot (one compiled program per model, whatever the parameters)."""

SAMPLES = 8
"""States of the pilot whose Jacobians are taken (evenly spaced in time, the last one final)."""

NOISE = 0.01
"""Relative amplitude of the pilot's seeded noise around the ground state."""

_PROGRAMS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


_LIMITS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_KEPT = 256
"""Pilot limits remembered per model (one per parameter set and ``dx``)."""


def _programs(model: Model, grid: Grid, advance: Any) -> tuple[Callable, Callable]:
    """``run(u, p, dt) -> states (SAMPLES, S, n, n)`` and ``jacobians(states, p) -> (C, S, S)``,
    compiled once per model and ``dx`` (parameters and ``dt`` are runtime values)."""
    per_model = _PROGRAMS.setdefault(model, {})
    key = float(np.mean(grid.dx))
    chunk = PILOT_STEPS // SAMPLES
    if key not in per_model:
        update = advance(model, grid)

        def run(u, p, dt):
            def chunk_body(u, _):
                def step(u, i):
                    return update(u, p, i * dt, dt, None), None

                u, _ = jax.lax.scan(step, u, jnp.arange(chunk, dtype=u.dtype))
                return u, u

            _, states = jax.lax.scan(chunk_body, u, None, length=SAMPLES)
            return states

        def jacobians(states, p):
            cells = jnp.moveaxis(states, 1, -1).reshape(-1, states.shape[1])
            return jax.vmap(lambda s: reaction_jacobian(model, s, p))(cells)

        per_model[key] = (jax.jit(run), jax.jit(jacobians))
    return per_model[key]


def pattern_limit(model: Model, domain: Any, params: Params, ground_limit: float,
                  advance: Any) -> float:
    """Smallest Euler-disc step over the reaction Jacobians of a pilot pattern's states (see
    the module docstring); ``inf`` where no state has a decaying eigenvalue. ``advance`` is
    the ``imex1`` update factory (``advance(model, grid)(u, p, t, dt, aux) -> u``) and
    ``ground_limit`` the ground-state limit, which sets the pilot's step."""
    if domain.kind != "grid" or len(domain.spatial_shape) != 2:
        return float("inf")
    means = tuple(sorted((k, float(np.float32(np.mean(np.asarray(v, np.float64)))))
                         for k, v in params.items()))
    if not all(np.isfinite(v) for _, v in means):
        return float("inf")
    dx = float(np.mean(np.asarray(domain.dx, np.float64)))
    t_end = float(model.t_end) if np.isfinite(model.t_end) and model.t_end > 0 else 100.0
    dt = float(f"{min(t_end / PILOT_STEPS, 0.25 * ground_limit):.3g}")  # float32 or 64 alike
    kept = _LIMITS.setdefault(model, {})
    key = (dx, means, dt)
    if key not in kept:
        if len(kept) >= _KEPT:
            kept.pop(next(iter(kept)))
        kept[key] = _pilot(model, dx, dict(means), dt, advance)
    return kept[key]


def _pilot(model: Model, dx: float, p_np: dict[str, float], dt: float, advance: Any) -> float:
    """The pilot run and its Jacobians (:func:`pattern_limit`)."""
    try:
        ground = np.asarray(model.ground_state(p_np), np.float64)
        excited = np.asarray(model.excited_state(p_np), np.float64)
    except Exception:  # noqa: BLE001 - no ground state: the ground-state limit stands alone
        return float("inf")
    grid = Grid((PILOT_SIZE, PILOT_SIZE), dx=dx, boundary="periodic")
    n = PILOT_SIZE
    rng = np.random.default_rng(0)
    u0 = ground[:, None, None] * (1.0 + NOISE * rng.standard_normal((len(ground), n, n)))
    u0 = u0 + NOISE * rng.standard_normal(u0.shape) * (ground[:, None, None] == 0)
    q = slice(3 * n // 8, 5 * n // 8)
    u0[:, q, q] = excited[:, None, None]
    p = {k: jnp.asarray(v, jnp.float32) for k, v in p_np.items()}
    run, jacobians = _programs(model, grid, advance)
    limit = float("inf")
    for _ in range(2):
        states = np.asarray(run(jnp.asarray(u0, jnp.float32), p, jnp.float32(dt)), np.float64)
        finite = np.isfinite(states).all(axis=tuple(range(1, states.ndim)))
        finite &= np.abs(np.where(np.isfinite(states), states, 0)).max(
            axis=tuple(range(1, states.ndim))) < 1e6
        good = states if finite.all() else states[:0]
        if len(good):
            jac = np.asarray(jacobians(jnp.asarray(good, jnp.float32), p), np.float64)
            jac = jac[np.isfinite(jac).all(axis=(1, 2))]
            lam = np.linalg.eigvals(jac).reshape(-1) if len(jac) else np.zeros(0)
            lam = lam[(lam.real < 0) & (np.abs(lam.imag) <= np.abs(lam.real))]
            if len(lam):
                limit = min(limit, float(np.min(euler_ray_limit(lam))))
        if finite.all():
            break
        dt *= 0.25
    return limit
