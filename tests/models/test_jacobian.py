"""The one reaction Jacobian (models/model.py ``reaction_jacobian``) against its closed form, and
its three users: the ground-state Newton iteration, the dispersion relation (models/linear.py)
and the time-step limits (solvers/stability.py)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.models.linear import jacobian
from morphogen.models.model import Model, reaction_jacobian
from morphogen.solvers.stability import reaction_jacobians

SCHNAKENBERG = Model(
    name="schnakenberg-closed-form", species=("u", "v"), params={"a": 0.1, "b": 0.9},
    reaction=lambda u, p, c: jnp.stack([p["a"] - u[0] + u[0] ** 2 * u[1],
                                        p["b"] - u[0] ** 2 * u[1]]),
    diffusion=lambda p, c: (1.0, 40.0),
)
"""``R = (a - u + u²v, b - u²v)``, ground state ``(a + b, b / (a + b)²)`` (Murray II, ch. 2)."""


def _closed_form(u: float, v: float) -> np.ndarray:
    return np.array([[-1 + 2 * u * v, u * u], [-2 * u * v, -u * u]])


def test_the_jacobian_is_the_closed_form_and_maps_over_states_and_parameters():
    p = {"a": jnp.float32(0.1), "b": jnp.float32(0.9)}
    j = reaction_jacobian(SCHNAKENBERG, jnp.array([1.5, 0.5], jnp.float32), p)
    np.testing.assert_allclose(np.asarray(j), _closed_form(1.5, 0.5), rtol=1e-6)
    states = jnp.array([[1.0, 0.9], [2.0, 0.25]], jnp.float32)
    batch = {"a": jnp.array([0.1, 0.2]), "b": jnp.array([0.9, 0.8])}
    many = jax.jit(jax.vmap(lambda u, q: reaction_jacobian(SCHNAKENBERG, u, q)))(states, batch)
    np.testing.assert_allclose(np.asarray(many), [_closed_form(1.0, 0.9),
                                                  _closed_form(2.0, 0.25)], rtol=1e-6)


def test_newton_dispersion_and_stability_share_it_at_the_ground_state():
    params = dict(SCHNAKENBERG.params)
    ground = SCHNAKENBERG.ground_state(params)  # no closed form given: the Newton iteration
    np.testing.assert_allclose(ground, [1.0, 0.9], rtol=1e-5)
    expected = _closed_form(1.0, 0.9)
    np.testing.assert_allclose(jacobian(SCHNAKENBERG, params), expected, rtol=1e-5)
    np.testing.assert_allclose(reaction_jacobians(SCHNAKENBERG, params, False)[0], expected,
                               rtol=1e-5)
