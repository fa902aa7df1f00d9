"""Adaptive steps (Tsit5 + PI controller) and the automatic scheme choice."""

from __future__ import annotations

import json

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.adaptive_loop import simulate_adaptive
from morphogen.engine.simulate import simulate, simulate_batch
from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.models.registry import load_model
from morphogen.runs.config import RunConfig
from morphogen.runs.execute import run_prepared, run_record
from morphogen.runs.prepare import prepare
from morphogen.solvers.adaptive import solve
from morphogen.solvers.auto import AUTO_RATIO, choose_scheme, stiffness_ratio
from morphogen.solvers.step import Noise

LINEAR = Model(
    name="linear", species=("u",), params={"k": 0.5, "D": 0.8},
    reaction=lambda u, p, c: -p["k"] * u, diffusion=lambda p, c: (p["D"],),
    ground=lambda p: (0.0,),
)
"""``du/dt = -k u + D lap(u)``: a Fourier mode decays exactly as ``exp(t (-k + D lambda))``."""

SCHNAKENBERG = load_model("examples/schnakenberg.toml")
N = 16
GRID = Grid((N, N))
BUDGET = 300
"""One grid and one step budget for the runs of LINEAR here: its solver is compiled once."""


def _mode() -> tuple[np.ndarray, float]:
    """The (2, 1) cosine mode on the periodic 16² grid and its 5-point symbol (dx = 1)."""
    x = np.arange(N)
    f = np.cos(2 * np.pi * 2 * x / N)[:, None] * np.cos(2 * np.pi * x / N)[None, :]
    lam = (2 * np.cos(2 * np.pi * 2 / N) - 2) + (2 * np.cos(2 * np.pi / N) - 2)
    return f.astype(np.float32), lam


@pytest.mark.slow
def test_tolerance_controls_the_error_against_the_exact_decay():
    f, lam = _mode()
    results = []
    for rtol in (1e-2, 1e-5):
        run = simulate_adaptive(LINEAR, GRID, f[None], dict(LINEAR.params), steps=40, dt=0.05,
                                rtol=rtol, atol=1e-2 * rtol, max_steps=BUDGET)
        exact = np.exp(2.0 * (-0.5 + 0.8 * lam)) * f
        error = float(np.abs(run.state[0] - exact).max() / np.abs(exact).max())
        assert error < rtol
        results.append((error, run.accepted))
    (loose, loose_steps), (tight, tight_steps) = results
    assert tight < loose / 5
    assert tight_steps > loose_steps
    assert run.t == pytest.approx(2.0)


def test_snapshots_land_on_the_requested_times():
    f, lam = _mode()
    sol = simulate_adaptive(LINEAR, GRID, f[None], dict(LINEAR.params), steps=40, dt=0.05,
                            rtol=1e-5, atol=1e-7, every=15, max_steps=BUDGET)
    assert sol.snapshot_steps == [0, 15, 30, 40]
    assert sol.snapshot_times == pytest.approx([0.0, 0.75, 1.5, 2.0], abs=1e-12)
    times = np.array(sol.snapshot_times)[:, None, None, None]
    np.testing.assert_allclose(sol.snapshots, np.exp(times * (-0.5 + 0.8 * lam)) * f, atol=1e-5)


def _spots(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return (np.array([1.0, 0.9])[:, None, None] + 0.05 * rng.standard_normal((2, n, n))).astype(
        np.float32)


def test_stiff_diffusion_rejects_steps_and_a_spent_budget_is_one_line():
    u0 = np.random.default_rng(1).random((1, N, N)).astype(np.float32)
    stiff = {"k": 0.5, "D": 40.0}
    run = simulate_adaptive(LINEAR, GRID, u0, stiff, steps=10, dt=0.05, rtol=1e-3, atol=1e-6,
                            max_steps=BUDGET)
    # the explicit pair sits near its stability limit, 3.3 / (8 D + k) = 0.01: about 50
    # accepted steps to t = 0.5, with rejections where the step overshoots the limit
    assert run.rejected > 0
    assert 25 < run.accepted < 100
    # by t = 0.5 every non-constant mode has decayed by exp(-0.5 D 0.15) < 0.05
    assert np.abs(run.state - u0.mean() * np.exp(-0.25)).max() < 0.05 * np.ptp(u0)
    with pytest.raises(MorphogenError, match="budget of 300 steps") as info:
        simulate_adaptive(LINEAR, GRID, u0, stiff, steps=200, dt=0.05, rtol=1e-3, atol=1e-6,
                          max_steps=BUDGET)
    assert "\n" not in str(info.value)


def test_a_diverging_run_stops_with_one_line():
    f, _ = _mode()
    # k = -30: u grows as exp(30 t), past 1e4 times its starting scale by t = 0.5
    with pytest.raises(MorphogenError, match="run diverging at t=0.5") as info:
        simulate_adaptive(LINEAR, GRID, f[None], {"k": -30.0, "D": 0.8}, steps=10, dt=0.05,
                          max_steps=BUDGET)
    assert "\n" not in str(info.value)


@pytest.mark.slow
def test_gradient_matches_finite_differences():
    """Reverse mode (``jax.grad``, diffrax's checkpointed adjoint) through the adaptive steps."""
    grid = Grid((6, 6), boundary="neumann")
    with jax.enable_x64(True):
        u0 = jnp.asarray(_spots(6, seed=2), jnp.float64)

        @jax.jit
        @jax.value_and_grad
        def loss(a):
            p = {**{k: jnp.float64(v) for k, v in SCHNAKENBERG.params.items()}, "a": a}
            ys, _ = solve(SCHNAKENBERG, grid, u0, p, jnp.array([0.5]), rtol=1e-9, atol=1e-12,
                          max_steps=256)
            return jnp.mean(ys[-1, 0] ** 2)

        _, g = loss(jnp.float64(0.1))
        h = 1e-5
        fd = (loss(jnp.float64(0.1 + h))[0] - loss(jnp.float64(0.1 - h))[0]) / (2 * h)
    assert float(g) == pytest.approx(float(fd), rel=1e-6)
    assert abs(float(g)) > 0.1


def test_stochastic_terms_and_batches_are_refused_with_one_line():
    f, _ = _mode()
    with pytest.raises(MorphogenError, match="use --scheme euler") as info:
        simulate(LINEAR, GRID, f[None], dict(LINEAR.params), steps=2, dt=0.1,
                 scheme="adaptive", noise=Noise(0.01))
    assert "\n" not in str(info.value)
    with pytest.raises(MorphogenError, match="one state at a time"):
        simulate_batch(LINEAR, GRID, f[None, None], {"k": np.ones(1), "D": np.ones(1)},
                       steps=2, dt=0.1, scheme="adaptive")
    with pytest.raises(MorphogenError, match="--rtol/--atol control --scheme adaptive"):
        simulate(LINEAR, GRID, f[None], dict(LINEAR.params), steps=2, dt=0.1,
                 rtol=1e-4)
    with pytest.raises(MorphogenError, match="--rtol must be a positive number"):
        simulate(LINEAR, GRID, f[None], dict(LINEAR.params), steps=2, dt=0.1,
                 scheme="adaptive", rtol=-1.0)


def test_auto_picks_imex_on_stiffer_schnakenberg_and_euler_on_gray_scott():
    grid = Grid((128, 128))
    p = dict(SCHNAKENBERG.params)
    # dt_R = 0.5 * 2 * 0.1 / |lambda|^2 with lambda = -0.1 +- 0.995i; dt_E = 0.9 / (8 * 40 / 2)
    assert stiffness_ratio(SCHNAKENBERG, grid, p) == pytest.approx(
        0.1 / 0.0056076, rel=1e-3)
    # 17.8: an imex step costs 13-22 Euler steps at 128-256², so explicit Euler is as fast
    assert choose_scheme(SCHNAKENBERG, grid, p) == "euler"
    # Dv doubled halves dt_E, but the spots' Jacobian then halves imex's step too (0.051, the
    # pilot pattern of solvers/pattern_limit.py; imex at 0.07 blew up): ratio 18, still euler
    stiffer = {**p, "Dv": 2 * p["Dv"]}
    assert stiffness_ratio(SCHNAKENBERG, grid, stiffer) < AUTO_RATIO
    assert choose_scheme(SCHNAKENBERG, grid, stiffer) == "euler"
    # a grid twice as fine divides dt_E by 4 and leaves the reaction's step: ratio 71
    fine = Grid((128, 128), dx=0.5)
    assert stiffness_ratio(SCHNAKENBERG, fine, p) > AUTO_RATIO
    assert choose_scheme(SCHNAKENBERG, fine, p) == "imex"
    gray = load_model("gray-scott")
    assert stiffness_ratio(gray, Grid((256, 256)), dict(gray.params)) < AUTO_RATIO
    assert choose_scheme(gray, Grid((256, 256)), dict(gray.params)) == "euler"
    # a Dirichlet boundary has no Fourier solve: imex would solve by conjugate gradients,
    # worth it only above AUTO_RATIO_CG (25), not at this ratio of 17.8
    assert choose_scheme(SCHNAKENBERG, Grid((32, 32), boundary="dirichlet"), p) == "euler"
    # LINEAR: dt_R = 0.5 * 2 / k = 2, dt_E = 0.9 * 2 / (8 D + k): ratio 8.1
    f, _ = _mode()
    sol = simulate(LINEAR, GRID, f[None], dict(LINEAR.params), steps=2, dt=0.05, scheme="auto")
    assert sol.scheme == "euler"


@pytest.mark.slow
def test_run_file_records_adaptive_steps():
    config = RunConfig(model="examples/schnakenberg.toml", size=[N, N], time=0.2, dt=0.01,
                       scheme="adaptive", rtol=1e-3, atol=1e-6)
    prep = prepare(config)
    sol = run_prepared(prep)
    record = json.loads(json.dumps(run_record(prep, sol, sol.wall_time)))
    assert record["config"]["scheme"] == "adaptive"
    assert record["config"]["rtol"] == 1e-3
    assert record["resolved"]["scheme"] == "adaptive"
    assert record["resolved"]["accepted_steps"] == sol.steps > 0
    assert record["resolved"]["rejected_steps"] == sol.rejected_steps
    assert sol.t == pytest.approx(0.2)
    replay = RunConfig.from_dict(record["config"])
    assert (replay.scheme, replay.rtol, replay.atol) == ("adaptive", 1e-3, 1e-6)


def embedded_pair(model: Model, domain) -> diffrax.AbstractAdaptiveSolver:
    """A third error-controlled scheme for the registry test: Bogacki-Shampine 3(2)."""
    return diffrax.Bosh3()


def test_an_error_controlled_scheme_is_a_registry_row_and_its_modules_pair(monkeypatch):
    """A row with ``error_control`` whose module has ``embedded_pair`` is a scheme that
    ``solve`` runs, with no name tested anywhere else; the pair is Bosh3 (its step counts
    differ from Tsit5's on the same tolerance) and it meets the exact decay."""
    from morphogen.solvers import registry

    row = registry.SchemeInfo("bosh3", 3, "Bogacki-Shampine 3(2)", __name__, fixed_step=False,
                              population=False, live=False, error_control=True)
    monkeypatch.setitem(registry.SCHEMES, "bosh3", row)
    f, lam = _mode()
    ts = jnp.array([2.0])
    exact = np.exp(2.0 * (-0.5 + 0.8 * lam)) * f
    counts = {}
    for scheme in ("bosh3", "adaptive"):
        ys, stats = solve(LINEAR, GRID, f[None], dict(LINEAR.params), ts, rtol=1e-5,
                          atol=1e-7, dt0=0.05, max_steps=BUDGET, scheme=scheme)
        assert bool(stats["ok"])
        assert float(np.abs(np.asarray(ys[0, 0]) - exact).max()) < 1e-4
        counts[scheme] = int(stats["accepted"])
    assert counts["bosh3"] > counts["adaptive"]
    with pytest.raises(MorphogenError, match="not error-controlled; use one of adaptive"):
        solve(LINEAR, GRID, f[None], dict(LINEAR.params), ts, scheme="euler")
