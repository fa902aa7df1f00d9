"""Neural RD training speed (seed 002, Algorithm 1) next to references measured in the same run.

Reported for the ``cpu`` preset (n = 12, h = 64, 64 x 64, batch 4, 32-64 steps per iteration):

- ``train_iterations_per_s``: full training iterations (rollout, texture loss, backward pass
  through the rematerialised rollout, Adam, pool update), compile excluded;
- ``forward_cell_steps_per_s``: the same model simulated forward only by morphogen;
- ``numpy_cell_steps_per_s``: the reference, a plain NumPy implementation of eq. 1
  (``np.roll`` 9-point Laplacian and two matrix products per step);
- ``jax_vs_numpy``: forward speed-up over NumPy, and ``train_vs_forward``: how many forward
  steps one training step costs (the backward pass, its recomputation and the loss).

``profile``: the parts of one cpu-preset iteration, each compiled on its own and timed in
interleaved rounds (median and fastest, ms), at a rollout of 48 steps (the mean of 32-64):
the forward rollout without gradient, the texture loss of the final batch (feature extraction,
Gram matrices and quantiles) and its gradient, the full ``value_and_grad`` of the objective
(rollout, loss and the backward pass through the rematerialised rollout), the optimiser
update, the pool's sampling and write-back, and pool ageing (``age_steps`` forward steps of
the batch, every ``age_every``-th iteration from ``age_start`` on); next to whole iterations
(random lengths, before ageing starts) and the 1-minute load average before and after. (XLA's
``cost_analysis`` is no guide here: it counts a loop's body once, so it reports 0.06 GFLOP for
a forward rollout of 48 steps that does 2.4.) The measurement holds ``/tmp/heavy.lock``
(shared machine: one heavy measurement at a time).

On a GPU the ``paper`` preset (n = 32, h = 128, 128 x 128, 32-96 steps) is timed too and
projected to its 20 000 iterations (the paper: about an hour on an NVIDIA P100).
"""

from __future__ import annotations

import fcntl
import os
import time
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
import optax

from bench.timing import interleaved
from morphogen.engine.simulate import simulate_batch
from morphogen.learn.extractors import make_extractor
from morphogen.learn.loss import texture_loss
from morphogen.learn.rollout import rollout
from morphogen.learn.rollout_neural import batch_step, rgb_last, to_last
from morphogen.learn.seeds import seed_batch, seed_state
from morphogen.learn.textures import synthetic_texture
from morphogen.learn.train import (
    TrainConfig,
    init_state,
    make_ager,
    make_objective,
    make_train_step,
    normalise_gradients,
    optimizer,
    preset,
    training_grid,
)
from morphogen.models.neural import KERNEL_SCALE, fixed_diffusion, neural_model
from morphogen.solvers.step import batch_params

TIMED_ITERATIONS = 20
FORWARD_STEPS = 200
NUMPY_STEPS = 20
PROFILE_STEPS = 48
PROFILE_ROUNDS = 7
LOCK = "/tmp/heavy.lock"


def numpy_neural_step(x: np.ndarray, w: dict, c: np.ndarray) -> np.ndarray:
    """Eq. 1 with ``r = d = 1`` in NumPy: ``x`` of shape ``(n, H, W)``, periodic."""
    edges = sum(np.roll(x, s, axis=a) for a in (1, 2) for s in (1, -1))
    corners = sum(np.roll(np.roll(x, s, axis=1), t, axis=2) for s in (1, -1) for t in (1, -1))
    lap = edges * (2.0 / 3.0) + corners * (1.0 / 6.0) - x * (10.0 / 3.0)
    flat = x.reshape(x.shape[0], -1).T
    z = flat @ w["W0"] + w["b0"]
    f = (z / (1.0 + np.exp(-5.0 * z))) @ w["W1"]
    return x + (c * KERNEL_SCALE)[:, None, None] * lap + f.T.reshape(x.shape)


def time_training(config: TrainConfig, iterations: int) -> tuple[float, float]:
    """Seconds per training iteration (compile excluded) and mean rollout length."""
    loss = texture_loss(synthetic_texture("dots", config.size), make_extractor("random"),
                        config.n_rot)
    step = make_train_step(config)
    state, metrics = step(init_state(config), loss)
    jax.block_until_ready(state.weights)
    lengths = []
    start = time.perf_counter()
    for _ in range(iterations):
        state, metrics = step(state, loss)
        lengths.append(int(metrics["steps"]))
    jax.block_until_ready(state.weights)
    return (time.perf_counter() - start) / iterations, float(np.mean(lengths))


def profile_parts(config: TrainConfig) -> dict[str, Callable[[], object]]:
    """Each part of one iteration, jitted on its own, as a callable that runs it once."""
    loss = texture_loss(synthetic_texture("dots", config.size), make_extractor("random"),
                        config.n_rot)
    state = init_state(config)
    weights = dict(state.weights)  # a small reaction: the states stay within [-2, 2]
    weights["W1"] = jnp.asarray(0.01 * np.random.default_rng(0).standard_normal(
        weights["W1"].shape), jnp.float32)
    x = state.pool[:config.batch_size]
    step = batch_step(config.neural, config.size, config.stencil)
    p = {**weights, "r": 1.0, "d": 1.0}

    def forward(x, n):
        return rollout(step, to_last(x), p, max_steps=config.max_steps, n_steps=n,
                       chunk=config.chunk)

    forward_j = jax.jit(forward)
    final = forward_j(x, PROFILE_STEPS)
    loss_j = jax.jit(lambda y, loss: jnp.mean(loss(rgb_last(y))))
    loss_grad_j = jax.jit(jax.value_and_grad(lambda y, loss: jnp.mean(loss(rgb_last(y)))))
    value_and_grad = jax.jit(jax.value_and_grad(make_objective(config), has_aux=True))
    grads = value_and_grad(weights, x, PROFILE_STEPS, loss)[1]
    opt = optimizer(config)

    def update(w, g, s):
        updates, s = opt.update(normalise_gradients(g), s, w)
        return optax.apply_updates(w, updates), s

    update_j = jax.jit(update)

    def pool(pool, key, y):
        """Sampling (batch, fresh seed) and write-back of one iteration."""
        idx = jax.random.choice(key, config.pool_size, (config.batch_size,), replace=False)
        batch = pool[idx].at[0].set(seed_state(key, config.channels, (config.size,) * 2))
        return batch, pool.at[idx].set(y)

    pool_j = jax.jit(pool)
    age_j = jax.jit(make_ager(config))
    train = make_train_step(config)
    run_state = [init_state(config)]

    def whole():
        run_state[0], metrics = train(run_state[0], loss)
        jax.block_until_ready(run_state[0].weights)
        return metrics

    key = jax.random.PRNGKey(1)
    parts = {
        "forward_rollout": lambda: forward_j(x, PROFILE_STEPS),
        "texture_loss": lambda: loss_j(final, loss),
        "texture_loss_value_and_grad": lambda: loss_grad_j(final, loss),
        "value_and_grad": lambda: value_and_grad(weights, x, PROFILE_STEPS, loss),
        "optimiser_update": lambda: update_j(weights, grads, state.opt_state),
        "pool_update": lambda: pool_j(state.pool, key, jnp.moveaxis(final, -1, 1)),
        "pool_ageing": lambda: age_j(weights, x),
        "iteration": whole,
    }
    timed = {k: (lambda f=f: jax.block_until_ready(f())) for k, f in parts.items()}
    for f in timed.values():
        f()  # compile
    return timed


def profile(config: TrainConfig, rounds: int = PROFILE_ROUNDS) -> dict:
    """Interleaved timings of the parts of one iteration (``profile_parts``), in ms."""
    times, load_before, load_after = interleaved(profile_parts(config), rounds)
    return {
        "rollout_steps": PROFILE_STEPS,
        "rounds": rounds,
        "median_ms": {k: 1e3 * float(np.median(v)) for k, v in times.items()},
        "fastest_ms": {k: 1e3 * float(np.min(v)) for k, v in times.items()},
        "load_average_1min": [load_before[0], load_after[0]],
    }


def run() -> dict:
    with open(LOCK, "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        return measure()


def measure() -> dict:
    load_before = os.getloadavg()[0]
    config = preset("cpu")
    per_iteration, mean_steps = time_training(config, TIMED_ITERATIONS)
    state = init_state(config)
    rng = np.random.default_rng(0)
    weights = {k: np.asarray(v) for k, v in state.weights.items()}
    weights["W1"] = (0.05 * rng.standard_normal(weights["W1"].shape)).astype(np.float32)
    model = neural_model(config.neural, weights)
    grid = training_grid(config)
    batch = config.batch_size
    x0 = np.asarray(seed_batch(jax.random.PRNGKey(0), batch, config.channels,
                               (config.size, config.size)))
    params = batch_params(model.params, batch)
    simulate_batch(model, grid, x0, params, steps=FORWARD_STEPS, dt=1.0)  # compile
    start = time.perf_counter()
    simulate_batch(model, grid, x0, params, steps=FORWARD_STEPS, dt=1.0)
    forward = time.perf_counter() - start
    cells = config.size * config.size
    forward_rate = batch * cells * FORWARD_STEPS / forward

    c = fixed_diffusion(config.channels)
    x = x0[0].copy()
    start = time.perf_counter()
    for _ in range(NUMPY_STEPS):
        x = numpy_neural_step(x, weights, c)
    numpy_rate = cells * NUMPY_STEPS / (time.perf_counter() - start)

    train_cell_steps = batch * cells * mean_steps / per_iteration
    result = {
        "preset": "cpu",
        "train_iterations_per_s": 1.0 / per_iteration,
        "train_seconds_per_iteration": per_iteration,
        "mean_rollout_steps": mean_steps,
        "forward_cell_steps_per_s": forward_rate,
        "numpy_cell_steps_per_s": numpy_rate,
        "jax_vs_numpy": forward_rate / numpy_rate,
        "train_vs_forward": forward_rate / train_cell_steps,
        "cpu_preset_minutes": config.iterations * per_iteration / 60.0,
        "profile": profile(config),
    }
    if jax.default_backend() == "gpu":
        paper = preset("paper", features="random")
        per_paper, _ = time_training(paper, TIMED_ITERATIONS)
        result["paper_train_iterations_per_s"] = 1.0 / per_paper
        result["paper_projected_hours"] = paper.iterations * per_paper / 3600.0
        result["paper_reference_hours_p100"] = 1.0
    result["load_average_1min"] = [load_before, os.getloadavg()[0]]
    return result
