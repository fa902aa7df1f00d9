"""Explicit schemes: forward Euler (the scheme of every seed) and classic RK4.

Both advance the whole right-hand side ``f(u) = R(u) + ∇·(D∇u)``
(:func:`morphogen.solvers.base.make_rhs`):

- ``euler``: ``u' = u + dt f(u)`` (Skaggs §3.2, Ringham et al. eqs. 2-4), first order;
- ``rk4``: ``u' = u + dt (k_1 + 2 k_2 + 2 k_3 + k_4) / 6`` with ``k_i = f(u + a_i dt k_{i-1},
  t + c_i dt)``, fourth order.

On ``dot u = lambda u`` a step multiplies by ``R(z)``, ``z = lambda dt``: ``1 + z`` and the
degree-4 Taylor polynomial of ``e^z``. Their step is limited by diffusion and the reaction
together (:func:`morphogen.solvers.stability.linear_limit`): every decaying eigenvalue of the
linearisation must stay inside ``|R| <= 1``.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.base import Domain
from morphogen.models.model import Array, Model, Params
from morphogen.solvers.base import Advance, Stepper, make_rhs
from morphogen.solvers.stability import bisect_ray_limit, euler_ray_limit, linear_limit

RK4_STAGES = np.array([[0.0, 0.5, 1.0 / 6.0], [0.5, 0.5, 2.0 / 6.0], [0.5, 1.0, 2.0 / 6.0],
                       [1.0, 0.0, 1.0 / 6.0]])
"""Classic RK4 per stage: its time offset ``c_i`` and the next stage's state offset (both in
units of ``dt``), and its weight ``b_i``."""


class _Explicit(Stepper):
    """What the explicit schemes share: the limit from their stability region."""

    def limit(self, model: Model, domain: Domain, params: Params, *,
              batched: bool = False) -> float:
        return linear_limit(model, domain, params, self.ray_limit, batched=batched)

    def ray_limit(self, lam: np.ndarray) -> np.ndarray:
        """Largest ``dt`` with ``|R(lambda dt')| <= 1`` for all ``0 < dt' <= dt``, per
        eigenvalue ``lam`` (bisection on the ray)."""
        return bisect_ray_limit(self.amplification, lam)


class Euler(_Explicit):
    """Forward Euler."""

    name = "euler"

    def amplification(self, z: np.ndarray) -> np.ndarray:
        """``1 + z``."""
        return 1.0 + z

    def ray_limit(self, lam: np.ndarray) -> np.ndarray:
        """The Euler disc in closed form, ``dt = -2 Re(lambda) / |lambda|^2``."""
        return euler_ray_limit(lam)

    def advance(self, model: Model, domain: Domain) -> Advance:
        rhs = make_rhs(model, domain)

        def update(u: Array, p: Params, t: Array, dt: Array, aux: None = None) -> Array:
            return u + dt * rhs(u, p, t)

        return Advance(update)


class RK4(_Explicit):
    """Classic fourth-order Runge-Kutta."""

    name = "rk4"

    def amplification(self, z: np.ndarray) -> np.ndarray:
        """The degree-4 Taylor polynomial of ``e^z``."""
        return 1.0 + z + z**2 / 2.0 + z**3 / 6.0 + z**4 / 24.0

    def advance(self, model: Model, domain: Domain) -> Advance:
        """RK4's four stages are one ``lax.scan`` over :data:`RK4_STAGES`, carrying the stage
        state ``y_i = u + a_i dt k_{i-1}`` and the weighted sum ``sum b_i k_i``. Written out as
        four chained right-hand sides, XLA on CPU fused the stencils of successive stages into a
        few large loops and a 256² step took 22 Euler steps' time; with the stage state a loop
        carry, each stage compiles like an Euler step (3x faster)."""
        rhs = make_rhs(model, domain)

        def update(u: Array, p: Params, t: Array, dt: Array, aux: None = None) -> Array:
            table = jnp.asarray(RK4_STAGES, u.dtype)

            def stage(carry, row):
                y, total = carry
                k = rhs(y, p, t + row[0] * dt)
                return (u + row[1] * dt * k, total + row[2] * k), None

            (_, total), _ = jax.lax.scan(stage, (u, jnp.zeros_like(u)), table)
            return u + dt * total

        return Advance(update)
