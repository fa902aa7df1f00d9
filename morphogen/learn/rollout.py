"""Differentiable rollouts with bounded memory.

Back-propagation through ``T`` explicit steps stores every intermediate state unless told
otherwise. :func:`rollout` scans over chunks of ``chunk`` steps and wraps each chunk in
``jax.checkpoint``: the forward pass keeps only the ``T / chunk`` chunk boundaries and the
backward pass recomputes one chunk at a time, so memory grows like ``T / chunk + chunk`` states
instead of ``T`` (at the price of one extra forward pass).

The number of steps actually taken, ``n_steps <= max_steps``, may be a traced value (Algorithm 1
draws it at random every iteration): steps past ``n_steps`` are skipped by ``lax.cond``, so one
compiled program serves every rollout length and skipped steps cost nothing.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from morphogen.models.model import Array, Params
from morphogen.simulate import Step


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
        step: a stepper from :func:`morphogen.steppers.make_step`.
        u: state, shape ``(S, *spatial)``.
        max_steps: static upper bound on the number of steps.
        n_steps: steps to take (traced or concrete), at most ``max_steps``.
        chunk: steps per rematerialised chunk.
        key: PRNG key for stochastic steppers (step ``i`` gets ``fold_in(key, i)``).

    Returns:
        The state after ``n_steps`` steps, shape ``(S, *spatial)``.
    """
    chunk = max(1, min(int(chunk), int(max_steps)))
    n_chunks = -(-int(max_steps) // chunk)
    n_steps = max_steps if n_steps is None else n_steps
    dt = jnp.asarray(dt, u.dtype)
    base = jax.random.PRNGKey(0) if key is None else key

    def one(u: Array, i: Array) -> tuple[Array, None]:
        def advance(u: Array) -> Array:
            return step(u, p, i * dt, dt, jax.random.fold_in(base, i))

        return jax.lax.cond(i < n_steps, advance, lambda u: u, u), None

    @jax.checkpoint
    def run_chunk(u: Array, c: Array) -> tuple[Array, None]:
        u, _ = jax.lax.scan(one, u, c * chunk + jnp.arange(chunk))
        return u, None

    u, _ = jax.lax.scan(run_chunk, u, jnp.arange(n_chunks))
    return u
