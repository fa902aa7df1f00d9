"""The simulator: patterns vs theory, batching, gradients, blow-up, noise, schemes."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.fields import resolve_params
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import integrate, simulate, simulate_batch
from morphogen.errors import BlowUpError
from morphogen.models.library import get_model
from morphogen.models.linear import fastest_mode
from morphogen.models.model import Model
from morphogen.solvers.step import Noise, batch_params, make_step
from tests.core_models import pure_diffusion


def test_gray_scott_forms_a_pattern_only_when_perturbed():
    model, grid = get_model("gray-scott"), Grid((64, 64))
    p = model.parameters()
    flat = make_initial("uniform", model, grid, p)
    seeded = make_initial("square", model, grid, p, size=0.2)
    uniform = simulate(model, grid, flat, p, steps=3000, dt=1.0).state[1]
    pattern = simulate(model, grid, seeded, p, steps=3000, dt=1.0).state[1]
    assert np.ptp(uniform) < 1e-6
    assert np.std(pattern) > 0.05
    assert 0.05 < np.mean(pattern > 0.15) < 0.8  # spots/stripes cover part of the grid


def _dominant_wavelength(field: np.ndarray) -> float:
    """Wavelength (cells) at the peak of the radially averaged power spectrum."""
    n = field.shape[0]
    power = np.abs(np.fft.fft2(field - field.mean())) ** 2
    k = np.fft.fftfreq(n) * n
    radius = np.rint(np.hypot(*np.meshgrid(k, k))).astype(int)
    radial = np.bincount(radius.ravel(), power.ravel())[: n // 2]
    radial[0] = 0
    peak = int(np.argmax(radial))
    weights = radial[peak - 1: peak + 2]
    centre = peak + (weights @ np.array([-1, 0, 1])) / weights.sum()
    return n / centre


@pytest.mark.parametrize("name", ["schnakenberg", "gierer-meinhardt"])
def test_turing_wavelength_matches_linear_stability(name):
    model, n = get_model(name), 128
    grid = Grid((n, n))
    p = model.parameters()
    u0 = make_initial("noise", model, grid, p, seed=3, amplitude=0.01)
    steps = int(model.t_end / model.dt)
    field = simulate(model, grid, u0, p, steps=steps, dt=model.dt).state[0]
    predicted = fastest_mode(model, p).wavelength
    assert _dominant_wavelength(field) == pytest.approx(predicted, rel=0.15)


@pytest.mark.slow
def test_batch_equals_loop_of_single_runs():
    model, grid = get_model("gray-scott"), Grid((32, 32))
    fs = [0.03, 0.037, 0.045]
    base = model.parameters()
    u0 = np.stack([make_initial("blobs", model, grid, base, seed=i) for i in range(3)])
    params = batch_params(base, 3, batched=("F",)) | {"F": jnp.array(fs)}
    batch = simulate_batch(model, grid, u0, params, steps=300, dt=1.0).state
    for i, f in enumerate(fs):
        single = simulate(model, grid, u0[i], {**base, "F": f}, steps=300, dt=1.0).state
        np.testing.assert_allclose(batch[i], single, rtol=1e-5, atol=1e-6)


@pytest.mark.slow
def test_gradient_matches_finite_differences():
    model, grid = get_model("gray-scott"), Grid((16, 16))
    base = model.parameters()
    u0 = jnp.asarray(make_initial("square", model, grid, base, size=0.4))
    step = make_step(model, grid)

    def loss(f, k):
        p = {**{n: jnp.asarray(v) for n, v in base.items()}, "F": f, "k": k}
        u, _, _ = integrate(step, u0, p, steps=60, dt=1.0, key=jax.random.PRNGKey(0))
        return jnp.mean(u[1] ** 2)

    grad = jax.grad(loss, argnums=(0, 1))(jnp.float32(0.04), jnp.float32(0.06))
    h = 1e-3
    for i, g in enumerate(grad):
        args_hi = [0.04, 0.06]
        args_lo = [0.04, 0.06]
        args_hi[i] += h
        args_lo[i] -= h
        fd = (loss(*map(jnp.float32, args_hi)) - loss(*map(jnp.float32, args_lo))) / (2 * h)
        assert float(g) == pytest.approx(float(fd), rel=0.02)
        assert abs(float(g)) > 1e-6


def _exploding() -> Model:
    return Model(
        name="explode", species=("a", "b"), params={"r": 1.0},
        reaction=lambda u, p, c: jnp.stack([p["r"] * u[0] ** 2, jnp.zeros_like(u[1])]),
        diffusion=lambda p, c: (0.0, 0.0), ground=lambda p: (1.0, 1.0),
    )


def test_blow_up_names_step_and_species():
    model, grid = _exploding(), Grid((8, 8))
    u0 = np.ones((2, 8, 8), np.float32)
    with pytest.raises(BlowUpError) as info:
        simulate(model, grid, u0, {"r": 1.0}, steps=100, dt=0.1)
    # du/dt = u^2 from 1 diverges at t = 1; Euler passes 1e15 around step 13
    assert info.value.species == ("a",)
    assert 8 <= info.value.step <= 20
    assert "step" in str(info.value) and "a" in str(info.value)


def test_batch_marks_blown_up_members_and_keeps_the_rest():
    model, grid = _exploding(), Grid((8, 8))
    u0 = np.ones((2, 2, 8, 8), np.float32)
    sol = simulate_batch(model, grid, u0, {"r": jnp.array([0.0, 1.0])}, steps=100, dt=0.1)
    assert sol.valid.tolist() == [True, False]
    assert sol.blowup_step[1] > 0


def test_additive_noise_variance_and_reproducibility():
    grid = Grid((64, 64))
    model = pure_diffusion(d=0.0)
    u0 = np.zeros((1, 64, 64), np.float32)
    noise = Noise(0.3)
    a = simulate(model, grid, u0, {"D": 0.0}, steps=50, dt=0.02, noise=noise, seed=5).state
    b = simulate(model, grid, u0, {"D": 0.0}, steps=50, dt=0.02, noise=noise, seed=5).state
    c = simulate(model, grid, u0, {"D": 0.0}, steps=50, dt=0.02, noise=noise, seed=6).state
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert np.var(a) == pytest.approx(0.3**2 * 0.02 * 50, rel=0.05)


def test_multiplicative_noise_leaves_zero_alone():
    grid = Grid((16, 16))
    model = pure_diffusion(d=0.0)
    u0 = np.zeros((1, 16, 16), np.float32)
    sol = simulate(model, grid, u0, {"D": 0.0}, steps=20, dt=0.1,
                   noise=Noise(0.5, "multiplicative"))
    assert np.all(sol.state == 0)


def test_rk4_is_more_accurate_than_euler():
    """Exponential decay du/dt = -u: global error O(dt) for Euler, O(dt^4) for RK4."""
    decay = Model(name="decay", species=("u",), params={},
                  reaction=lambda u, p, c: -u, diffusion=lambda p, c: (0.0,))
    grid = Grid((4, 4))
    u0 = np.ones((1, 4, 4), np.float32)
    exact = np.exp(-1.0)
    errors = {}
    for scheme in ("euler", "rk4"):
        u = simulate(decay, grid, u0, {}, steps=10, dt=0.1, scheme=scheme).state[0, 0, 0]
        errors[scheme] = abs(u - exact)
    assert errors["euler"] > 0.01
    assert errors["rk4"] < 1e-5


def test_parameter_field_from_expression():
    """du/dt = c - u with a field c(x, y): the state relaxes to the field itself."""
    relax = Model(name="relax", species=("u",), params={"c": 0.0, "s": 1.0},
                  reaction=lambda u, p, c: p["c"] - u, diffusion=lambda p, c: (0.0,))
    grid = Grid((24, 48))
    values = relax.parameters({"c": "s * (0.01 + 0.07*x) + y", "s": 2.0})
    params = resolve_params(relax, grid, values)
    x, y = grid.coords["x"], grid.coords["y"]
    expected = 2.0 * (0.01 + 0.07 * x) + y
    np.testing.assert_allclose(params["c"], expected, rtol=1e-6)
    u0 = np.zeros((1, 24, 48), np.float32)
    sol = simulate(relax, grid, u0, params, steps=400, dt=0.1)
    np.testing.assert_allclose(sol.state[0], np.broadcast_to(expected, (24, 48)), atol=1e-5)


def test_snapshots_are_bounded():
    grid = Grid((8, 8))
    u0 = np.zeros((1, 8, 8), np.float32)
    sol = simulate(pure_diffusion(), grid, u0, {"D": 0.1}, steps=1000, dt=0.1, every=1,
                   max_snapshots=50)
    assert len(sol.snapshots) <= 51
    assert sol.snapshot_steps[0] == 0 and sol.snapshot_steps == sorted(sol.snapshot_steps)
