"""Time-step limits with the reaction's linearisation, and early divergence detection."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.simulate import simulate
from morphogen.errors import DivergenceError, UnstableTimeStepError
from morphogen.models.model import Model
from morphogen.models.registry import load_model
from morphogen.solvers.base import stepper
from morphogen.solvers.stability import SAFETY
from morphogen.solvers.step import batch_params, check_stability, max_stable_dt
from tests.core_models import pure_diffusion


def _decay(k: float) -> Model:
    """``du/dt = -k u + D lap(u)``: every mode decays at ``-(k + sigma D)``."""
    return Model(
        name="decay", species=("u",), params={"k": k, "D": 0.5},
        reaction=lambda u, p, c: -p["k"] * u,
        diffusion=lambda p, c: (p["D"],), ground=lambda p: (0.0,),
    )


def test_rk4_real_axis_interval():
    # the RK4 stability region meets the negative real axis at -2.785293563...
    assert stepper("rk4").ray_limit(np.array([-1.0 + 0j]))[0] == pytest.approx(2.7852935634,
                                                                               rel=1e-6)
    assert stepper("euler").ray_limit(np.array([-4.0 + 0j]))[0] == pytest.approx(0.5)


def test_limits_include_the_reaction_and_a_margin():
    grid = Grid((16, 16), dx=0.5)
    # pure diffusion: marginal dx^2 / (2 dims D), reported at SAFETY of it
    assert max_stable_dt(pure_diffusion(), grid, {"D": 0.4}) == pytest.approx(
        SAFETY * 0.5**2 / (2 * 2 * 0.4))
    # linear decay k on top: the fastest mode is -(k + 8 D / dx^2) = -(3 + 16) = -19
    model = _decay(3.0)
    assert max_stable_dt(model, grid, model.params) == pytest.approx(SAFETY * 2 / 19)
    assert max_stable_dt(model, grid, model.params, "rk4") == pytest.approx(
        SAFETY * 2.7852935634 / 19, rel=1e-6)
    batch = batch_params({"D": 0.5, "k": jnp.array([1.0, 3.0])}, 2, ["k"])
    assert max_stable_dt(model, grid, batch, batched=True) == pytest.approx(SAFETY * 2 / 19)


def test_schnakenberg_at_the_old_limit_is_refused():
    """Dv = 40, 128^2, dx = 1: the diffusion-only limit 0.00625 diverges; J shifts it lower."""
    model, grid = load_model("examples/schnakenberg.toml"), Grid((128, 128))
    p = dict(model.params)
    # J at u* = (1, 0.9): [[2 u v - 1, u^2], [-2 u v, -u^2]]; checkerboard sigma = 8
    jac = np.array([[0.8, 1.0], [-1.8, -1.0]])
    lam = np.linalg.eigvals(jac - 8 * np.diag([1.0, 40.0]))
    marginal = 2 / np.max(np.abs(lam))
    assert marginal < 0.00625
    limit = max_stable_dt(model, grid, p)
    assert limit == pytest.approx(SAFETY * marginal, rel=1e-4)
    assert limit < 0.006  # the largest step that was seen to work
    for dt, scheme in ((0.00625, "euler"), (0.0087, "rk4")):
        with pytest.raises(UnstableTimeStepError, match=r"use --dt 0\.00"):
            check_stability(model, grid, p, dt, scheme)


def test_schnakenberg_default_step_runs_and_stays_in_range():
    model, grid = load_model("examples/schnakenberg.toml"), Grid((64, 64))
    rng = np.random.default_rng(0)
    u0 = np.array([1.0, 0.9])[:, None, None] + 0.01 * rng.standard_normal((2, 64, 64))
    sol = simulate(model, grid, u0, dict(model.params), steps=6000, dt=model.dt)
    assert 0.0 < sol.state[0].min() and sol.state[0].max() < 6.0
    assert sol.state[0].std() > 0.3  # a Turing pattern, not the ground state


def _stiffening() -> Model:
    """Pure diffusion whose coefficient rises from 0.2 to 0.26 by t = 1: a step that is stable
    at t = 0 (limit 0.9 * 1.25) is not afterwards (checkerboard factor |1 - 8 * 0.26| = 1.08)."""
    return Model(
        name="stiffening", species=("u",), params={},
        reaction=lambda u, p, c: jnp.zeros_like(u),
        diffusion=lambda p, c: (0.2 + 0.06 * jnp.minimum(c["t"], 1.0),),
        ground=lambda p: (0.0,),
    )


def test_growing_checkerboard_is_stopped_with_step_species_and_dt():
    grid = Grid((32, 32))
    u0 = 1e-3 * np.random.default_rng(1).standard_normal((1, 32, 32))
    with pytest.raises(DivergenceError) as info:
        simulate(_stiffening(), grid, u0, {}, steps=2000, dt=1.0, every=50)
    err = info.value
    assert err.species == ("u",) and err.step <= 300 and err.dt_suggested == 0.5
    assert "checkerboard" in str(err) and "--dt 0.5" in str(err)
    # at the same step the values are still small: the NaN/overflow test alone would wait
    sol = simulate(_stiffening(), grid, u0, {}, steps=err.step, dt=1.0, unsafe=True)
    assert np.abs(sol.state).max() < 1e6


def test_values_far_outside_the_starting_range_are_stopped():
    model = Model(
        name="runaway", species=("a",), params={"r": 0.05},
        reaction=lambda u, p, c: p["r"] * u, diffusion=lambda p, c: (0.0,),
        ground=lambda p: (1.0,),
    )
    u0 = np.ones((1, 8, 8))
    # exponential growth e^{0.05 t}: 1e4 times the start near t = 184, i.e. step ~ 1850
    with pytest.raises(DivergenceError, match="orders of magnitude") as info:
        simulate(model, Grid((8, 8)), u0, {"r": 0.05}, steps=4000, dt=0.1)
    assert 1800 <= info.value.step <= 2100


def test_an_implicit_run_whose_reaction_stiffens_is_stopped_and_offered_the_explicit_scheme():
    # u' = -3 u^3 + D lap u: the Jacobian at the ground state u* = 0 is 0, and the pilot pattern
    # (small values near u* = 0) sees only -9 u^2 ~ -0.02, so imex allows dt = 1; but at u = 1
    # the explicit reaction step of dt = 1 overshoots (1 -> -2 -> 22 -> ...)
    model = Model(
        name="cubic", species=("u",), params={"c": 3.0, "D": 2.0},
        reaction=lambda u, p, c: -p["c"] * u**3, diffusion=lambda p, c: (p["D"],),
        ground=lambda p: (0.0,),
    )
    grid, p = Grid((8, 8)), {"c": 3.0, "D": 2.0}
    assert max_stable_dt(model, grid, p, "imex") > 2.0
    with pytest.raises(DivergenceError) as info:
        simulate(model, grid, np.ones((1, 8, 8)), p, steps=50, dt=1.0, scheme="imex", every=1)
    euler = max_stable_dt(model, grid, p, "euler")  # 0.9 * dx^2 / (4 D) = 0.1125
    assert info.value.step <= 4 and info.value.dt_suggested == 0.5
    assert f"or --scheme euler with --dt {euler:.6g} (its limit)" in str(info.value)
    assert euler == pytest.approx(0.1125)
    # where the explicit limit is above the suggested step, it is not offered
    with pytest.raises(DivergenceError) as info:
        simulate(model, grid, np.ones((1, 8, 8)), {**p, "D": 0.1}, steps=50, dt=1.0,
                 scheme="imex", every=1)
    assert "--scheme euler" not in str(info.value)
