"""Neural RD training speed (seed 002, Algorithm 1) next to references measured in the same run.

Reported for the ``cpu`` preset (n = 12, h = 64, 64 x 64, batch 4, 32-64 steps per iteration):

- ``train_iterations_per_s``: full training iterations (rollout, texture loss, backward pass
  through the rematerialised rollout, Adam, pool update), compile excluded;
- ``forward_cell_steps_per_s``: the same model simulated forward only by morphogen;
- ``numpy_cell_steps_per_s``: the reference, a plain NumPy implementation of eq. 1
  (``np.roll`` 9-point Laplacian and two matrix products per step);
- ``jax_vs_numpy``: forward speed-up over NumPy, and ``train_vs_forward``: how many forward
  steps one training step costs (backward pass plus recomputation: about 3-5).

On a GPU the ``paper`` preset (n = 32, h = 128, 128 x 128, 32-96 steps) is timed too and
projected to its 20 000 iterations (the paper: about an hour on an NVIDIA P100).
"""

from __future__ import annotations

import time

import jax
import numpy as np

from morphogen.learn.features import make_extractor
from morphogen.learn.loss import texture_loss
from morphogen.learn.seeds import seed_batch
from morphogen.learn.textures import synthetic_texture
from morphogen.learn.train import (
    TrainConfig,
    init_state,
    make_train_step,
    preset,
    training_grid,
)
from morphogen.models.neural import KERNEL_SCALE, fixed_diffusion, neural_model
from morphogen.simulate import simulate_batch
from morphogen.steppers import batch_params

TIMED_ITERATIONS = 20
FORWARD_STEPS = 200
NUMPY_STEPS = 20


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


def run() -> dict:
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
    }
    if jax.default_backend() == "gpu":
        paper = preset("paper", features="random")
        per_paper, _ = time_training(paper, TIMED_ITERATIONS)
        result["paper_train_iterations_per_s"] = 1.0 / per_paper
        result["paper_projected_hours"] = paper.iterations * per_paper / 3600.0
        result["paper_reference_hours_p100"] = 1.0
    return result
