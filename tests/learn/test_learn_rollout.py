"""Faster training pieces compute what the generic ones do: the channels-last batch step of
eq. 1, the integer-key quantiles, and the training objective's value and gradient."""

from __future__ import annotations

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.learn.features import RandomFeatures, quantiles, sortable_bits
from morphogen.learn.loss import texture_loss
from morphogen.learn.rollout import rollout
from morphogen.learn.rollout_neural import batch_step, to_first, to_last
from morphogen.learn.textures import state_to_rgb, synthetic_texture
from morphogen.learn.train import TrainConfig, init_state, make_objective, overflow_penalty
from morphogen.models.neural import NeuralConfig, init_weights, neural_model
from morphogen.solvers.step import make_step


def random_params(config: NeuralConfig, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    w = init_weights(config, jax.random.PRNGKey(seed))
    w["b0"] = (0.1 * rng.standard_normal(config.hidden)).astype(np.float32)
    w["W1"] = (0.1 * rng.standard_normal((config.hidden, config.channels))).astype(np.float32)
    return {**{k: jnp.asarray(v) for k, v in w.items()}, "r": 0.8, "d": 0.9}


@pytest.mark.parametrize(("stencil", "learn"), [(9, False), (5, True), ("spectral", False)])
def test_batch_step_equals_the_generic_step(stencil, learn):
    """Ten steps of a batch of 3 on a 16 x 16 torus, channels last, against the
    generic stepper vmapped over the batch: equal to float rounding."""
    config = NeuralConfig(6, 16, learn)
    p = random_params(config, 1)
    grid = Grid((16, 16), dx=1.0, boundary="periodic", stencil=stencil)
    generic = make_step(neural_model(config, init_weights(config, jax.random.PRNGKey(0))), grid)
    fast = batch_step(config, 16, stencil)
    x = jnp.asarray(np.random.default_rng(2).uniform(-0.5, 0.5, (3, 6, 16, 16)), jnp.float32)
    want, got = x, to_last(x)
    for _ in range(10):
        want = jax.vmap(lambda u: generic(u, p, 0.0, 1.0, None))(want)
        got = fast(got, p, 0.0, 1.0, None)
    assert float(jnp.abs(want - x).max()) > 0.1  # the states moved
    np.testing.assert_allclose(np.asarray(to_first(got)), np.asarray(want), rtol=0, atol=2e-6)


def sort_quantiles(values, q):
    n = values.shape[1]
    pick = ((np.arange(q) + 0.5) / q * n).astype(int)
    return jnp.sort(values, axis=1)[:, pick]


@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64])
@pytest.mark.slow
def test_integer_key_quantiles_equal_sorting(dtype):
    """Values bit-identical to ``jnp.sort`` (also with many tied ReLU zeros and negative zeros),
    gradients identical on tie-free values; the keys order as the floats do."""
    rng = np.random.default_rng(0)
    with jax.enable_x64(dtype == jnp.float64):
        v = jnp.asarray(rng.standard_normal((2, 500, 5)) * 3, dtype)
        for arr in (v, jax.nn.relu(v), -jax.nn.relu(v), jnp.asarray([[[-0.0], [0.0], [-1.0]]],
                                                                    dtype)):
            np.testing.assert_array_equal(np.asarray(quantiles(arr, 3)),
                                          np.asarray(sort_quantiles(arr, 3)))
            assert np.all(np.signbit(quantiles(arr, 3)) == np.signbit(sort_quantiles(arr, 3)))
        ct = jnp.asarray(rng.standard_normal((2, 16, 5)), dtype)
        got = jax.vjp(lambda a: quantiles(a, 16), v)[1](ct)[0]
        want = jax.vjp(lambda a: sort_quantiles(a, 16), v)[1](ct)[0]
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
        assert int(jnp.count_nonzero(got)) == 2 * 16 * 5
        keys = np.asarray(sortable_bits(v)).ravel()
        assert np.all(np.diff(np.asarray(v).ravel()[np.argsort(keys)]) >= 0)


def generic_objective(config: TrainConfig):
    """The objective as it was written before the channels-last step: the generic stepper
    vmapped over the channels-first batch."""
    model = neural_model(config.neural, init_weights(config.neural, jax.random.PRNGKey(0)))
    grid = Grid((config.size,) * 2, dx=1.0, boundary="periodic", stencil=config.stencil)
    step = make_step(model, grid)

    def objective(weights, x, n_steps, loss):
        p = {**weights, "r": 1.0, "d": 1.0}
        x = jax.vmap(lambda u: rollout(step, u, p, max_steps=config.max_steps, n_steps=n_steps,
                                       chunk=config.chunk))(x)
        texture = jnp.mean(loss(state_to_rgb(x)))
        over = overflow_penalty(x, config.overflow_limit)
        return texture + config.overflow_weight * over, (x, texture, over)

    return objective


@pytest.mark.slow
def test_objective_value_and_gradient_equal_the_generic_objective():
    """The training objective (channels-last rollout, integer-key quantiles) against the
    generic formulation: value, final states and gradient agree to float32 rounding."""
    config = replace(TrainConfig(channels=6, hidden=16, size=24, pool_size=4, batch_size=2,
                                 min_steps=8, max_steps=12, chunk=1), overflow_limit=0.3)
    loss = texture_loss(synthetic_texture("dots", 32), RandomFeatures(levels=3, width=8), 8)
    weights = {k: v for k, v in random_params(config.neural, 3).items() if k not in "rd"}
    x = init_state(config).pool[:2]
    (v1, (x1, t1, o1)), g1 = jax.jit(jax.value_and_grad(make_objective(config), has_aux=True))(
        weights, x, 10, loss)
    (v0, (x0, t0, o0)), g0 = jax.jit(jax.value_and_grad(generic_objective(config),
                                                        has_aux=True))(weights, x, 10, loss)
    assert float(o0) > 0 and float(t0) > 0
    np.testing.assert_allclose(np.asarray(x1), np.asarray(x0), rtol=0, atol=1e-5)
    np.testing.assert_allclose([float(v1), float(t1), float(o1)], [float(v0), float(t0), float(o0)],
                               rtol=1e-5)
    for k in g0:
        scale = float(jnp.abs(g0[k]).max())
        assert scale > 0
        np.testing.assert_allclose(np.asarray(g1[k]), np.asarray(g0[k]), rtol=0,
                                   atol=1e-4 * scale)
