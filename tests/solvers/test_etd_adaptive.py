"""``etdrk4-adaptive``: ETDRK4 with an embedded second-order estimate under a PI controller."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg

from morphogen.domains.grid import Grid
from morphogen.engine.simulate import simulate
from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.models.registry import load_model
from morphogen.solvers.auto import choose_error_controlled
from morphogen.solvers.etd import phi_coefficients
from morphogen.solvers.etd_adaptive import ERROR_ORDER, EtdRk4Pair, make_pair
from morphogen.solvers.step import max_stable_dt

J = np.array([[-0.3, 1.0], [-1.2, -0.1]])
"""A linear reaction ``R(u) = J u`` with complex eigenvalues (``-0.2 ± 1.09i``)."""

ROTATION = Model(
    name="rotation", species=("u", "v"), params={"Du": 0.4, "Dv": 1.5},
    reaction=lambda u, p, c: jnp.stack([J[0, 0] * u[0] + J[0, 1] * u[1],
                                        J[1, 0] * u[0] + J[1, 1] * u[1]]),
    diffusion=lambda p, c: (p["Du"], p["Dv"]), ground=lambda p: (0.0, 0.0),
)
"""``u' = J u + diag(D) lap(u)``: a Fourier mode evolves exactly by
``expm(t (J + diag(D) lambda(k)))``; ETDRK4 integrates the diagonal diffusion exactly and the
reaction explicitly, so its error is the reaction's alone."""

N = 16
GRID = Grid((N, N))


def _mode() -> tuple[np.ndarray, float]:
    """Species ``u``, ``v`` on the (2, 1) and the same cosine mode, and its 5-point symbol."""
    x = np.arange(N)
    f = np.cos(2 * np.pi * 2 * x / N)[:, None] * np.cos(2 * np.pi * x / N)[None, :]
    lam = (2 * np.cos(2 * np.pi * 2 / N) - 2) + (2 * np.cos(2 * np.pi / N) - 2)
    return np.stack([f, -0.5 * f]), lam


def _exact(t: float) -> np.ndarray:
    u0, lam = _mode()
    a = J + np.diag([ROTATION.params["Du"], ROTATION.params["Dv"]]) * lam
    amp = scipy.linalg.expm(t * a) @ np.array([1.0, -0.5])
    return amp[:, None, None] * u0[0][None]


def test_the_embedded_estimate_has_the_order_the_controller_is_told():
    """The estimate ``u_4 - u_2`` of one step shrinks as ``h^3`` (the order handed to diffrax's
    PI controller), while the step's own local error shrinks as ``h^5``."""
    u0, _ = _mode()
    hs = [0.4, 0.2, 0.1]
    est, true = [], []
    with jax.enable_x64(True):
        pair = make_pair(ROTATION, GRID)
        p = {k: jnp.float64(v) for k, v in ROTATION.params.items()}
        for h in hs:
            u4, err = pair(jnp.asarray(u0), p, jnp.float64(0.0), jnp.float64(h))
            est.append(np.abs(np.asarray(err)).max())
            true.append(np.abs(np.asarray(u4) - _exact(h)).max())
    slope_est = np.polyfit(np.log(hs), np.log(est), 1)[0]
    slope_true = np.polyfit(np.log(hs), np.log(true), 1)[0]
    assert EtdRk4Pair(pair).error_order(None) == ERROR_ORDER == 3
    assert slope_est == pytest.approx(ERROR_ORDER, abs=0.2)
    assert slope_true == pytest.approx(5, abs=0.4)
    assert all(t < e for t, e in zip(true, est, strict=True))


def test_the_estimate_is_the_error_that_survives_the_steps_own_damping():
    """On one Fourier mode the damped estimate is the plain ``u_4 - u_2`` times that mode's
    factor over the step, ``exp(h D_s λ(k))`` per species; the step itself is unchanged."""
    u0, lam = _mode()
    h = 0.3
    with jax.enable_x64(True):
        p = {k: jnp.float64(v) for k, v in ROTATION.params.items()}
        args = (jnp.asarray(u0), p, jnp.float64(0.0), jnp.float64(h))
        u4, damped = make_pair(ROTATION, GRID)(*args)
        u4_plain, plain = make_pair(ROTATION, GRID, damped=False)(*args)
    np.testing.assert_array_equal(np.asarray(u4), np.asarray(u4_plain))
    factor = np.exp(h * np.array([ROTATION.params["Du"], ROTATION.params["Dv"]]) * lam)
    np.testing.assert_allclose(np.asarray(damped), factor[:, None, None] * np.asarray(plain),
                               rtol=1e-9, atol=1e-15)
    assert np.abs(np.asarray(plain)).max() > 1e-4  # a real estimate to compare


def test_a_requested_tolerance_is_met_on_a_known_solution():
    """Against ``expm``: the error at ``t = 4`` is below ``rtol`` (relative to the largest
    value), tightening ``rtol`` shrinks it and takes more steps."""
    u0, _ = _mode()
    exact = _exact(4.0)
    results = []
    with jax.enable_x64(True):
        for rtol in (1e-3, 1e-5, 1e-7):
            sol = simulate(ROTATION, GRID, u0, dict(ROTATION.params), steps=40, dt=0.1,
                           scheme="etdrk4-adaptive", rtol=rtol, atol=1e-2 * rtol)
            assert sol.scheme == "etdrk4-adaptive"
            error = float(np.abs(sol.state - exact).max() / np.abs(exact).max())
            assert error < rtol, (rtol, error)
            results.append((error, sol.steps))
    errors, steps = zip(*results, strict=True)
    assert errors[2] < errors[1] < errors[0]
    assert steps[2] > steps[1] > steps[0]


def test_steps_are_not_bound_by_the_linear_limit():
    """On Schnakenberg (float32, 32², T = 10) a loose tolerance takes steps well above the
    fixed-step ``etdrk4`` limit (0.1), and the pattern stays finite."""
    model, grid = load_model("examples/schnakenberg.toml"), Grid((32, 32))
    p = model.parameters()
    u0 = 1.0 + 0.01 * np.random.default_rng(0).standard_normal((2, 32, 32))
    limit = max_stable_dt(model, grid, p, "etdrk4")
    sol = simulate(model, grid, u0, p, steps=100, dt=0.1, scheme="etdrk4-adaptive", rtol=1e-3)
    assert np.isfinite(sol.state).all()
    assert 10.0 / sol.steps > 2 * limit
    assert max_stable_dt(model, grid, p, "etdrk4-adaptive") == float("inf")


def test_auto_with_a_tolerance_picks_the_exact_diffusion_pair_where_it_applies():
    model = load_model("examples/schnakenberg.toml")
    p = model.parameters()
    assert choose_error_controlled(model, Grid((16, 16)), p) == "etdrk4-adaptive"
    assert choose_error_controlled(model, Grid((16, 16), boundary="neumann"), p) == (
        "etdrk4-adaptive")
    assert choose_error_controlled(model, Grid((16, 16), boundary="dirichlet"), p) == "adaptive"
    u0 = 1.0 + 0.01 * np.random.default_rng(0).standard_normal((2, 16, 16))
    sol = simulate(model, Grid((16, 16)), u0, p, steps=10, dt=0.1, scheme="auto", rtol=1e-3)
    assert sol.scheme == "etdrk4-adaptive"


def test_refuses_what_an_exact_fourier_diffusion_cannot_carry():
    model = load_model("examples/schnakenberg.toml")
    u0 = np.ones((2, 8, 8))
    with pytest.raises(MorphogenError, match="periodic and neumann"):
        simulate(model, Grid((8, 8), boundary="dirichlet"), u0, model.parameters(), steps=2,
                 dt=0.1, scheme="etdrk4-adaptive")
    with pytest.raises(MorphogenError, match="one state at a time"):
        from morphogen.engine.simulate import simulate_batch

        simulate_batch(model, Grid((8, 8)), u0[None], {k: np.asarray([v]) for k, v in
                                                       model.parameters().items()},
                       steps=2, dt=0.1, scheme="etdrk4-adaptive")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_phi_coefficients_are_smooth_across_the_series_cut(dtype):
    """The series (``|z| < 2``) and closed forms (``|z| >= 2``) join without a jump, and the
    coefficients' derivative in ``z`` is finite everywhere (no NaN from the branch not taken)."""
    with jax.enable_x64(dtype == np.float64):
        z = jnp.asarray([-2.0 + 1e-3, -2.0, -2.0 - 1e-3, 0.0, -1e3], dtype)
        got = np.asarray(phi_coefficients(z, jnp.asarray(1.0, dtype)), np.float64)
        grad = jax.grad(lambda x: sum(c.sum() for c in phi_coefficients(x, 1.0)))(z)
    assert np.isfinite(np.asarray(grad)).all()
    # no jump at the cut: the differences on either side match (second differences are 3e-8)
    np.testing.assert_allclose(got[:, 0] - got[:, 1], got[:, 1] - got[:, 2],
                               atol=3e-7 if dtype == np.float32 else 1e-7)
