"""Differentiable rollouts with bounded memory.

Back-propagation through ``T`` explicit steps stores every intermediate state unless told
otherwise. :func:`rollout` scans over chunks of ``chunk`` steps and wraps each chunk in
``jax.checkpoint``: the forward pass keeps only the ``T / chunk`` chunk boundaries and the
backward pass recomputes one chunk at a time, so memory grows like ``T / chunk + chunk`` states
instead of ``T`` (at the price of one extra forward pass).

The number of steps actually taken, ``n_steps <= max_steps``, may be a traced value (Algorithm 1
draws it at random every iteration): chunks that start at or past ``n_steps`` are skipped by
``lax.cond`` (and, within a chunk of several steps, the steps past it), so one compiled program
serves every rollout length and skipped steps cost nothing. The ``cond`` sits outside
``jax.checkpoint``: a ``cond`` inside it would be linearised into one that hands every
intermediate of the step (the ``(B S S, h)`` hidden activations of a neural RD step) out of the
branch as a residual, copying them at every step; outside, its residual is the chunk's input
state. For the cpu training preset that took the gradient of a 48-step rollout from 0.48-0.53
to 0.41-0.48 s (same values and gradients, bit for bit). Without ``n_steps`` (and with ``chunk``
dividing ``max_steps``) there is no ``cond``.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from morphogen.engine.simulate import Step
from morphogen.models.model import Array, Params


def rollout(
    step: Step,
    u: Array,
    p: Params,
    *,
    max_steps: int,
    n_steps: Any = None,
    dt: Any = 1.0,
    chunk: int = 8,
    key: Array | None = None,
) -> Array:
    """Apply ``step(u, p, t, dt, key)`` ``n_steps`` times (default ``max_steps``).

    Args:
        step: a stepper from :func:`morphogen.solvers.step.make_step`.
        u: state, shape ``(S, *spatial)`` (or whatever ``step`` maps, e.g. a batch).
        max_steps: static upper bound on the number of steps.
        n_steps: steps to take (traced or concrete), at most ``max_steps``.
        chunk: steps per rematerialised chunk.
        key: PRNG key for stochastic steppers (step ``i`` gets ``fold_in(key, i)``).

    Returns:
        The state after ``n_steps`` steps, shaped as ``u``.
    """
    chunk = max(1, min(int(chunk), int(max_steps)))
    n_chunks = -(-int(max_steps) // chunk)
    dt = jnp.asarray(dt, u.dtype)
    base = jax.random.PRNGKey(0) if key is None else key
    if n_steps is None and max_steps % chunk:
        n_steps = max_steps  # the last chunk runs past max_steps

    def advance(u: Array, i: Array) -> Array:
        return step(u, p, i * dt, dt, jax.random.fold_in(base, i))

    def one(u: Array, i: Array) -> tuple[Array, None]:
        if n_steps is None or chunk == 1:
            return advance(u, i), None
        return jax.lax.cond(i < n_steps, advance, lambda u, i: u, u, i), None

    @jax.checkpoint
    def run_chunk(u: Array, c: Array) -> Array:
        u, _ = jax.lax.scan(one, u, c * chunk + jnp.arange(chunk))
        return u

    def outer(u: Array, c: Array) -> tuple[Array, None]:
        if n_steps is None:
            return run_chunk(u, c), None
        return jax.lax.cond(c * chunk < n_steps, run_chunk, lambda u, c: u, u, c), None

    u, _ = jax.lax.scan(outer, u, jnp.arange(n_chunks))
    return u
