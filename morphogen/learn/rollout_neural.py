"""Eq. 1 of seed 002 on a whole training batch, channels last.

The generic stepper (:func:`morphogen.solvers.step.make_step`) advances one state ``(n, S, S)``;
training ``vmap``-s it over the batch, so the reaction network ``f(x) = act(x W0 + b0) W1``
contracts the channel axis of a ``(B, n, S, S)`` array. XLA on a CPU then transposes the
``(B, h, S, S)`` hidden activations and their cotangents around every matrix product of the
backward pass: a cpu-preset step's forward and backward pass took 9.3-10.9 ms against 1.1-1.5 ms
forward only (docs/neural-rd.md, "Where a training iteration's time goes"); channels last it
takes 4.5-5.3 ms. Here the batch is stored channels last,
``(B, S, S, n)``: the network is two plain ``(B S S, n) x (n, h)`` and ``(B S S, h) x (h, n)``
matrix products and the Laplacian shifts the two spatial axes.

The step is the same update as the generic one,

.. math::

    x^{t+1} = x^t + \\Delta_t \\left( r\\, f_\\theta(x^t)
        + c_i\\, d\\, K \\,(L * x^t) \\right),\\qquad K = \\mathrm{KERNEL\\_SCALE},

with the periodic 5- or 9-point Laplacian ``L`` of :mod:`morphogen.domains.stencils` (same
weights and summation order; unit grid spacing), so it agrees with the generic step to float
rounding (tests/learn/test_learn_rollout.py). Other stencils (spectral) run the generic step, moving
the channel axis around it.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from morphogen.domains.grid import Grid
from morphogen.models.model import Array, Params
from morphogen.models.neural import (
    KERNEL_SCALE,
    NeuralConfig,
    activation,
    diffusion_coefficients,
    init_weights,
    neural_model,
)
from morphogen.solvers.step import make_step

FAST_STENCILS = (5, 9)
"""Stencils of the channels-last step; others use the generic step."""


def to_last(x: Array) -> Array:
    """``(B, n, S, S)`` -> ``(B, S, S, n)``."""
    return jnp.moveaxis(x, 1, -1)


def to_first(x: Array) -> Array:
    """``(B, S, S, n)`` -> ``(B, n, S, S)``."""
    return jnp.moveaxis(x, -1, 1)


def rgb_last(x: Array) -> Array:
    """The loss's image of channels-last states: ``x[..., :3] + 0.5`` (as
    :func:`morphogen.learn.textures.state_to_rgb` of the channels-first state)."""
    return x[..., :3] + 0.5


def laplacian_last(x: Array, points: int) -> Array:
    """Periodic 5- or 9-point Laplacian (unit spacing) over axes 1 and 2 of ``(B, S, S, n)``."""
    g = jnp.pad(x, ((0, 0), (1, 1), (1, 1), (0, 0)), mode="wrap")
    c = g[:, 1:-1, 1:-1]
    edges = g[:, :-2, 1:-1] + g[:, 2:, 1:-1] + g[:, 1:-1, :-2] + g[:, 1:-1, 2:]
    if points == 5:
        return edges - 4.0 * c
    corners = g[:, :-2, :-2] + g[:, :-2, 2:] + g[:, 2:, :-2] + g[:, 2:, 2:]
    return edges * (2.0 / 3.0) + corners * (1.0 / 6.0) - c * (10.0 / 3.0)


def batch_step(config: NeuralConfig, size: int, stencil: int | str | None
               ) -> Callable[[Array, Params, Array, Array, Array], Array]:
    """``step(x, p, t, dt, key) -> x`` for a channels-last batch ``(B, S, S, n)`` on the
    periodic ``size x size`` unit grid; ``p`` holds the weights (``W0``, ``b0``, ``W1``, maybe
    ``c_hat``) and the rates ``r``, ``d`` (scalars). The signature is the generic stepper's, so
    :func:`morphogen.learn.rollout.rollout` drives it; ``t`` and ``key`` are unused."""
    if stencil not in FAST_STENCILS:
        model = neural_model(config, init_weights(config, jax.random.PRNGKey(0)))
        one = make_step(model, Grid((size, size), dx=1.0, boundary="periodic", stencil=stencil))

        def generic(x: Array, p: Params, t: Array, dt: Array, key: Array) -> Array:
            return to_last(jax.vmap(lambda u: one(u, p, t, dt, key))(to_first(x)))

        return generic

    def step(x: Array, p: Params, t: Array, dt: Array, key: Array) -> Array:
        reaction = activation(x @ p["W0"] + p["b0"]) @ p["W1"] * p["r"]
        coeff = diffusion_coefficients(config, p) * (p["d"] * KERNEL_SCALE)
        return x + dt * (reaction + coeff * laplacian_last(x, stencil))

    return step
