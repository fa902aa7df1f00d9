"""Texture loss and pool training (seed 002): gradients, rotation invariance, training, resume."""

from __future__ import annotations

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.learn.features import RandomFeatures, SpectrumFeatures
from morphogen.learn.loss import texture_loss
from morphogen.learn.seeds import blob_count, seed_state
from morphogen.learn.session import build_loss, load_checkpoint, new_run, train
from morphogen.learn.textures import crop_size, rotated_crops, state_to_rgb, synthetic_texture
from morphogen.learn.train import TrainConfig, grow_samples, init_state, make_objective, preset

pytestmark = pytest.mark.slow

TINY = TrainConfig(channels=5, hidden=8, size=16, pool_size=8, batch_size=2, min_steps=4,
                   max_steps=6, iterations=4, seed_every=2, chunk=3, decay_at=(2,),
                   checkpoint_every=2, sample_every=1000, sample_steps=8)


def pattern_image(seed: int, size: int = 48) -> np.ndarray:
    """A random smooth colour pattern in [0, 1], (size, size, 3)."""
    rng = np.random.default_rng(seed)
    noise = rng.normal(size=(size, size, 3))
    k = np.fft.fftfreq(size)
    low = np.exp(-(k[:, None] ** 2 + k[None, :] ** 2) * 400)[..., None]
    smooth = np.real(np.fft.ifft2(np.fft.fft2(noise, axes=(0, 1)) * low, axes=(0, 1)))
    return ((smooth - smooth.min()) / np.ptp(smooth)).astype(np.float32)


def test_training_loss_gradient_matches_finite_differences():
    """Directional derivative of the full objective (rollout, texture loss with min over
    rotations, overflow penalty) against a central difference, in float64."""
    config = replace(TINY, overflow_limit=0.3)
    target = synthetic_texture("stripes", 24)
    with jax.enable_x64(True):
        loss = texture_loss(target, RandomFeatures(levels=2, width=6, quantiles=4), 4)
        loss = jax.tree_util.tree_map(lambda a: jnp.asarray(a, jnp.float64), loss)
        objective = make_objective(config)
        state = init_state(config)
        rng = np.random.default_rng(0)
        weights = {k: jnp.asarray(np.asarray(v) + 0.2 * rng.normal(size=v.shape), jnp.float64)
                   for k, v in state.weights.items()}
        x = jnp.asarray(state.pool[:2], jnp.float64)

        @jax.jit
        def value(w):
            return objective(w, x, 5, loss)[0]

        grad = jax.jit(jax.grad(value))(weights)
        direction = {k: jnp.asarray(rng.normal(size=v.shape)) for k, v in weights.items()}
        analytic = sum(jnp.vdot(grad[k], direction[k]) for k in weights)
        h = 1e-6
        up = value({k: weights[k] + h * direction[k] for k in weights})
        down = value({k: weights[k] - h * direction[k] for k in weights})
        numeric = (up - down) / (2 * h)
    assert abs(float(analytic)) > 1e-3
    assert float(analytic) == pytest.approx(float(numeric), rel=1e-5)


@pytest.mark.parametrize("extractor", [RandomFeatures(), SpectrumFeatures()],
                         ids=["random", "spectrum"])
def test_loss_is_invariant_to_rotating_the_target(extractor):
    """Rotating the target by 90 degrees changes the loss by < 2 % (N_rot = 8)."""
    target = synthetic_texture("stripes", 64)
    images = jnp.asarray(np.stack([pattern_image(1), pattern_image(2)[::-1],
                                   synthetic_texture("dots", 48)]))
    base = np.asarray(texture_loss(target, extractor, 8)(images))
    turned = np.asarray(texture_loss(np.rot90(target).copy(), extractor, 8)(images))
    np.testing.assert_allclose(turned, base, rtol=0.02)


def test_without_rotations_an_anisotropic_target_is_orientation_sensitive():
    """The check above can fail: with N_rot = 1 the stripes' orientation matters."""
    target = synthetic_texture("stripes", 64)
    image = jnp.asarray(target[None])
    same = float(texture_loss(target, RandomFeatures(), 1)(image)[0])
    turned = float(texture_loss(np.rot90(target).copy(), RandomFeatures(), 1)(image)[0])
    assert turned > 3 * same


def test_rotated_crops_permute_under_a_quarter_turn():
    img = pattern_image(3, 40)
    a = rotated_crops(img, 8)
    b = rotated_crops(np.rot90(img).copy(), 8)
    assert a.shape == (8, crop_size(40), crop_size(40), 3)
    for k in range(8):
        np.testing.assert_allclose(b[k], a[(k + 6) % 8], atol=1e-6)
    assert crop_size(40) == 28  # (40 - 28) / 2 = 6: the unrotated crop is pixel-exact
    np.testing.assert_allclose(a[0], img[6:34, 6:34], atol=1e-6)
    np.testing.assert_allclose(a[4], img[6:34, 6:34][::-1, ::-1], atol=1e-6)


def test_texture_loss_prefers_the_target_texture():
    dots = synthetic_texture("dots", 64)
    stripes = synthetic_texture("stripes", 64)
    loss = texture_loss(dots, RandomFeatures(), 8)
    grey = np.full_like(dots, 0.5)
    values = np.asarray(loss(jnp.asarray(np.stack([dots, stripes, grey]))))
    assert values[0] < 0.1
    assert values[1] > 10 * values[0] and values[2] > 10 * values[0]


def test_seed_states_are_periodic_gaussian_blobs():
    s = np.asarray(seed_state(jax.random.PRNGKey(0), 3, (32, 48)))
    assert s.shape == (3, 32, 48)
    np.testing.assert_array_equal(s[0], s[2])
    assert blob_count((64, 64)) == 16 and blob_count((128, 128)) == 64
    assert blob_count((32, 32, 32)) == 8 and blob_count((8, 8)) == 1
    assert 0.9 < s.max() < 2.5 and s.min() >= 0
    assert np.asarray(seed_state(jax.random.PRNGKey(1), 2, (8, 8, 8))).shape == (2, 8, 8, 8)


def test_short_training_halves_the_loss():
    """A short run at least halves the texture loss of seeds grown over the training horizon.

    With N_pool = N_batch = 1 and R_seed = 1 every iteration grows a fresh seed, so forty
    iterations learn the first thing Algorithm 1 must learn: turning a seed into the target's
    colours and blobs. (Full pool training, which also learns to persist and fill the plane,
    takes a few hundred iterations of the cpu preset: docs/neural-rd.md.)
    """
    config = replace(TINY, channels=8, hidden=24, size=24, pool_size=1, batch_size=1,
                     seed_every=1, min_steps=16, max_steps=24, chunk=8, iterations=40,
                     learning_rate=1e-2, decay_at=(32,))
    run = new_run(config, synthetic_texture("dots", 24))
    loss = build_loss(config, run.target)

    def grown_loss(weights):
        grown = grow_samples(config, weights, 4, config.max_steps, 99)
        return float(jnp.mean(loss(state_to_rgb(grown))))

    before = grown_loss(run.state.weights)
    run = train(run, None)
    after = grown_loss(run.state.weights)
    assert after < 0.5 * before, (before, after)


def test_resumed_run_equals_uninterrupted_run(tmp_path):
    target = synthetic_texture("dots", 24)
    straight = train(new_run(TINY, target), tmp_path / "a", iterations=4)
    train(new_run(TINY, target), tmp_path / "b", iterations=2)
    resumed = load_checkpoint(tmp_path / "b")
    assert resumed.iteration == 2
    resumed = train(resumed, tmp_path / "b", iterations=4)
    for k in straight.state.weights:
        np.testing.assert_array_equal(np.asarray(straight.state.weights[k]),
                                      np.asarray(resumed.state.weights[k]))
    np.testing.assert_array_equal(np.asarray(straight.state.pool), np.asarray(resumed.state.pool))
    assert resumed.losses == straight.losses
    assert (tmp_path / "b" / "model.npz").is_file() and (tmp_path / "b" / "loss.png").is_file()


def test_presets():
    paper = preset("paper")
    assert (paper.channels, paper.hidden, paper.size, paper.pool_size, paper.batch_size) == (
        32, 128, 128, 1024, 4)
    assert (paper.min_steps, paper.max_steps, paper.iterations) == (32, 96, 20000)
    assert paper.decay_at == (1000, 10000) and paper.decay == 0.2
    assert paper.learning_rate == 1e-3 and paper.seed_every == 32
    assert preset("cpu", iterations=7).iterations == 7


def test_a_new_run_records_the_extractor_auto_chose(monkeypatch):
    from morphogen.learn import session, vgg

    config = preset("cpu", features="auto", size=16, pool_size=4, iterations=1)
    target = synthetic_texture("dots", 16)
    monkeypatch.setattr(vgg, "find_vgg_weights", lambda: None)
    assert session.new_run(config, target).config.features == "random"
    monkeypatch.setattr(vgg, "find_vgg_weights", lambda: "weights.ckpt")
    assert session.new_run(config, target).config.features == "vgg"


def test_pool_ageing_advances_the_batch_without_gradient_before_the_rollout():
    """With R_age = 1 every iteration first advances the batch A = 5 steps, then rolls it out
    n = 3 steps: the pool state written back (the one not replaced by a fresh seed) is its old
    value after 8 steps of the still untrained rule (pure diffusion, W1 starts at zero)."""
    from morphogen.learn.rollout import rollout
    from morphogen.learn.train import make_train_step, template_model, training_grid
    from morphogen.solvers.step import make_step

    config = replace(TINY, pool_size=2, batch_size=2, min_steps=3, max_steps=3, seed_every=1000,
                     age_every=1, age_steps=5)
    state = init_state(config)
    pool0 = np.asarray(state.pool)
    loss = build_loss(config, synthetic_texture("dots", 24))
    got = np.asarray(make_train_step(config)(state, loss)[0].pool)
    step = make_step(template_model(config), training_grid(config))
    p = {**init_state(config).weights, "r": 1.0, "d": 1.0}

    def grown(j, n):
        return np.asarray(rollout(step, jnp.asarray(pool0[j]), p, max_steps=n, chunk=n))

    aged = [j for j in range(2) if np.allclose(got[j], grown(j, 8), atol=1e-6)]
    assert len(aged) == 1
    assert np.abs(got[aged[0]] - grown(aged[0], 3)).max() > 1e-3
    assert preset("cpu").age_every > 0 and preset("paper").age_every == 0


@pytest.mark.parametrize("kind", ["checker", "lined", "blotchy", "lizards", "labyrinth"])
def test_synthetic_targets_tile_the_torus(kind):
    """Each synthetic target is in [0, 1], not flat, and periodic: the jump across the seam
    (last row/column to first) is no larger than the largest between neighbouring rows/columns
    inside (a non-periodic drawing, e.g. stripes of a period that does not divide 64, fails)."""
    img = synthetic_texture(kind, 64)
    assert img.shape == (64, 64, 3) and img.min() >= 0 and img.max() <= 1
    for axis in (0, 1):
        steps = np.abs(np.diff(img, axis=axis, append=img.take([0], axis=axis)))
        per_row = steps.mean(axis=(1 - axis, 2))
        assert per_row[-1] <= 1.01 * per_row[:-1].max()
    assert img.std() > 0.1
