"""Fitness functions against closed forms: modified Dirichlet energy of Fourier modes, staged
ordering, invariances of the target statistics, human selection eq. 3.9."""

import jax.numpy as jnp
import numpy as np
import pytest
from PIL import Image

from morphogen.errors import MorphogenError
from morphogen.search import fitness as fit

N = 64
X = np.arange(N)
YY, XX = np.mgrid[0:N, 0:N]


def mode(kx, ky=0, n=N):
    y, x = np.mgrid[0:n, 0:n]
    return np.sin(2 * np.pi * (kx * x + ky * y) / n)


def as_state(*fields):
    return jnp.asarray(np.stack(fields), jnp.float32)


@pytest.mark.parametrize("k", [1, 3, 8])
def test_dirichlet_energy_of_a_fourier_mode(k):
    # forward difference of sin(2 pi k x / N) is 2 sin(pi k / N) cos(2 pi k (x + 1/2) / N):
    # the mean of its square over its maximum is mean(c^2) / max(c^2) with c that cosine
    c2 = np.cos(2 * np.pi * k * (X + 0.5) / N) ** 2
    expected = c2.mean() / c2.max()
    assert float(fit.dirichlet_energy(as_state(mode(k)))) == pytest.approx(expected, rel=1e-5)


def test_dirichlet_energy_is_scale_free_and_per_cell():
    u = mode(3, 2)
    e = float(fit.dirichlet_energy(as_state(u)))
    assert float(fit.dirichlet_energy(as_state(5 * u + 2))) == pytest.approx(e, rel=1e-5)
    # the same pattern on a grid twice as fine (twice the wavenumber in cells) keeps E
    fine = mode(6, 4, 2 * N)
    assert float(fit.dirichlet_energy(as_state(fine))) == pytest.approx(e, rel=0.02)
    # the sum over cells (eq. 3.8) would have grown 4 times
    assert 0 < e <= 1


def test_dirichlet_energy_rewards_gradients_everywhere():
    # one sharp spot in a flat field: the maximum gradient is rare, so E is small
    spot = np.exp(-((XX - 32) ** 2 + (YY - 32) ** 2) / 4.0)
    stripes = mode(8)
    assert float(fit.dirichlet_energy(as_state(spot))) < 0.05
    assert float(fit.dirichlet_energy(as_state(stripes))) > 0.5


def test_dirichlet_energy_sums_species_and_respects_open_boundaries():
    u, v = mode(2), mode(0, 5)
    g = np.asarray(fit.gradient_energy(as_state(u, v)))
    gu = np.asarray(fit.gradient_energy(as_state(u)))
    gv = np.asarray(fit.gradient_energy(as_state(v)))
    np.testing.assert_allclose(g, gu + gv, rtol=1e-6)
    ramp = np.tile(X / N, (N, 1))  # periodic wrap adds a jump of ~1 at the seam
    assert float(fit.gradient_energy(as_state(ramp), periodic=True).max()) > 0.9
    assert float(fit.gradient_energy(as_state(ramp), periodic=False).max()) < 1e-3


def test_staged_fitness_orders_invalid_flat_patterned():
    states = jnp.asarray(np.stack([
        [mode(4), mode(4)],
        [np.full((N, N), 0.3), np.full((N, N), 5.0)],
        [mode(4), np.where(XX == 3, np.nan, 0.0)],
        [mode(4), np.where(XX == 3, np.inf, 0.0)],
        [mode(4), np.full((N, N), 1e16)],
        [np.full((N, N), 0.3) + 1e-5 * mode(4), np.zeros((N, N))],
    ]), jnp.float32)
    f = np.asarray(fit.dirichlet_fitness()(states))
    assert f[0] > 0
    assert f[1] == fit.FLAT and f[5] == fit.FLAT  # below the flatness tolerance
    np.testing.assert_array_equal(f[2:5], fit.INVALID)
    assert fit.INVALID < fit.FLAT < f[0]


def test_scores_do_not_depend_on_the_batch():
    rng = np.random.default_rng(0)
    states = jnp.asarray(rng.normal(size=(5, 2, 32, 32)), jnp.float32)
    score = fit.dirichlet_fitness()
    whole = np.asarray(score(states))
    parts = np.concatenate([np.asarray(score(states[:2])), np.asarray(score(states[2:]))])
    np.testing.assert_allclose(whole, parts, rtol=1e-6)  # batches of 5 vs 2 + 3: two programs


def test_target_statistics_ignore_translation_and_rotation():
    rng = np.random.default_rng(3)
    spots = np.zeros((N, N))
    for cy, cx in rng.integers(0, N, (25, 2)):
        dy = (YY - cy + N / 2) % N - N / 2
        dx = (XX - cx + N / 2) % N - N / 2
        spots = np.maximum(spots, np.exp(-(dx**2 + dy**2) / 6.0))
    target = fit.pattern_statistics(jnp.asarray(spots, jnp.float32))

    def d(field):
        return float(fit.target_distance(jnp.asarray(field, jnp.float32), target))

    assert d(spots) == pytest.approx(0.0, abs=1e-6)
    assert d(np.roll(spots, (17, -9), axis=(0, 1))) == pytest.approx(0.0, abs=1e-6)
    assert d(np.rot90(spots)) == pytest.approx(0.0, abs=1e-6)
    rotated = np.asarray(Image.fromarray(spots.astype(np.float32)).rotate(30, Image.BILINEAR))
    stripes = mode(5, 3)
    assert d(rotated) < 0.25 * d(stripes)  # an arbitrary angle: close, not exact


def test_target_fitness_prefers_the_right_wavelength():
    target = (mode(8) + 1) / 2
    score = fit.target_fitness(target, species=1)
    states = jnp.asarray(np.stack([
        [np.zeros((N, N)), np.roll(mode(8), 5, axis=1)],
        [np.zeros((N, N)), mode(0, 8)],
        [np.zeros((N, N)), mode(11)],
        [np.zeros((N, N)), mode(16)],
        [np.zeros((N, N)), mode(30)],
        [np.zeros((N, N)), np.zeros((N, N))],
    ]), jnp.float32)
    f = np.asarray(score(states))
    assert f[0] == pytest.approx(1.0, abs=1e-5) and f[1] == pytest.approx(1.0, abs=1e-5)
    assert f[0] > f[2] > f[3] > f[4] > f[5] == fit.FLAT


def test_load_target_resizes_to_the_grid(tmp_path):
    path = tmp_path / "t.png"
    Image.fromarray((255 * (mode(4, n=100) > 0)).astype(np.uint8)).save(path)
    grey = fit.load_target(str(path), (32, 48))
    assert grey.shape == (32, 48) and grey.min() >= 0 and grey.max() <= 1
    with pytest.raises(MorphogenError):
        fit.load_target(str(tmp_path / "missing.png"), (32, 32))
    with pytest.raises(MorphogenError):
        fit.load_target(str(path), (8, 8, 8))


def test_human_fitness_eq_3_9():
    f = fit.human_fitness([1, 3], 10)
    np.testing.assert_allclose(f[[1, 3]], 0.9 / 2)
    np.testing.assert_allclose(np.delete(f, [1, 3]), 0.1 / 8)
    assert f.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(fit.human_fitness(range(4), 4), 0.25)
    np.testing.assert_allclose(fit.human_fitness([0], 3, lam=0.5), [0.5, 0.25, 0.25])


@pytest.mark.parametrize("bad", [[], [10], [-1], [2, 2]])
def test_human_fitness_rejects_bad_selections(bad):
    with pytest.raises(MorphogenError):
        fit.human_fitness(bad, 10)


def test_parse_selection():
    assert fit.parse_selection("0 3, 5-7", 10) == [0, 3, 5, 6, 7]
    for text in ("", "a", "3-x", "9-12", "1 1"):
        with pytest.raises(MorphogenError):
            fit.parse_selection(text, 10)


def test_terminal_selection_reasks_until_valid():
    answers = iter(["", "12", "two", "1 4"])
    shown = []
    chosen = fit.ask_selection("gen_001.png", 5, read=lambda prompt: next(answers),
                               write=shown.append)
    assert chosen == [1, 4]
    assert shown[0] == "contact sheet: gen_001.png"
    assert sum(line.startswith("invalid selection") for line in shown) == 3


def test_terminal_selection_at_end_of_input():
    def eof(prompt):
        raise EOFError

    with pytest.raises(MorphogenError, match="end of input"):
        fit.ask_selection("s.png", 3, read=eof, write=lambda s: None)
