"""The one run policy (morphogen.solvers.policy / morphogen.runs.policy): scheme, dt and steps
from what the user gave, and an IMEX step that runs (issue 33, item 12)."""

import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate
from morphogen.errors import BlowUpError, MorphogenError, UnstableTimeStepError
from morphogen.models.registry import load_model
from morphogen.runs.policy import resolve_run, step_count
from morphogen.solvers.stability import linear_limit
from morphogen.solvers.step import max_stable_dt


def test_explicit_default_is_the_models_dt_within_the_limit():
    gray = load_model("gray-scott")
    p = gray.parameters()
    coarse = resolve_run(gray, Grid((16, 16)), p)
    assert coarse.scheme == "euler" and coarse.dt == gray.dt
    assert coarse.steps == round(gray.t_end / gray.dt) and coarse.t_end == coarse.steps * gray.dt
    assert coarse.dt < coarse.limit < 1.1  # Gray-Scott's dt = 1 is just inside Euler's limit
    fine = Grid((16, 16), dx=0.5)  # the limit shrinks as dx^2, below dt = 1
    limit = max_stable_dt(gray, fine, p)
    plan = resolve_run(gray, fine, p, t_end=100.0)
    assert plan.dt == limit < gray.dt and plan.limit == limit
    assert plan.steps == round(100.0 / plan.dt)
    assert "euler's stability limit" in plan.reason


def test_given_settings_are_used_and_checked():
    gray = load_model("gray-scott")
    grid, p = Grid((16, 16)), gray.parameters()
    plan = resolve_run(gray, grid, p, dt=0.5, steps=7)
    assert (plan.dt, plan.steps, plan.t_end, plan.reason) == (0.5, 7, 3.5, "given")
    limit = max_stable_dt(gray, grid, p)
    with pytest.raises(UnstableTimeStepError, match="use --dt") as info:
        resolve_run(gray, grid, p, dt=2 * limit)
    assert "\n" not in str(info.value)
    assert resolve_run(gray, grid, p, dt=2 * limit, steps=1, unsafe=True).dt == 2 * limit
    with pytest.raises(MorphogenError, match="positive"):
        resolve_run(gray, grid, p, dt=-1.0)


def test_one_rounding_rule_for_steps():
    assert step_count(2.5, 1.0) == 2  # half to even
    assert step_count(3.5, 1.0) == 4
    assert step_count(1.0, 0.3) == 3
    assert step_count(0.1, 1.0) == 1  # a positive time takes at least one step
    with pytest.raises(MorphogenError, match="finite --time or --steps"):
        step_count(float("inf"), 1.0)


def test_auto_is_resolved_once_and_an_implicit_scheme_runs_at_its_limit():
    stiff = load_model("examples/schnakenberg.toml")
    grid = Grid((32, 32), dx=0.5)
    p = {**stiff.parameters(), "Dv": 80.0}
    plan = resolve_run(stiff, grid, p, scheme="auto", t_end=5.0)
    assert plan.scheme == "imex" and plan.dt == plan.limit == max_stable_dt(stiff, grid, p,
                                                                                "imex")
    gray = load_model("gray-scott")
    grid = Grid((32, 32))
    assert resolve_run(gray, grid, gray.parameters(), scheme="auto").scheme == "euler"
    adaptive = resolve_run(gray, grid, gray.parameters(), scheme="auto", rtol=1e-3)
    assert adaptive.scheme == "etdrk4-adaptive" and adaptive.limit == float("inf")
    with pytest.raises(MorphogenError, match="one state at a time"):
        resolve_run(gray, grid, gray.parameters(), scheme="adaptive", batched=True)


@pytest.mark.parametrize("boundary", ["periodic", "neumann"])
def test_the_imex_step_of_the_policy_runs_where_the_ground_state_step_blew_up(boundary):
    # issue 33 item 12: Explore's imex on Schnakenberg a = 0.2, b = 1.3 took 0.95 of the
    # ground-state limit (0.3202) and blew up at t ~ 42-50 once the spots formed
    model = load_model("schnakenberg")
    grid = Grid((128, 128), boundary=boundary)
    p = model.parameters({"a": 0.2, "b": 1.3})
    ground = linear_limit(model, grid, p, None)
    plan = resolve_run(model, grid, p, scheme="imex", t_end=60.0)
    # the spots' Jacobian (u ~ 3.95, v ~ 0.28: lambda ~ -12.8) sets it, not the ground state's
    assert ground == pytest.approx(0.337, abs=1e-3)
    assert 0.13 < plan.dt == plan.limit < 0.5 * ground
    u0 = make_initial("noise", model, grid, p, seed=0)
    sol = simulate(model, grid, u0, p, steps=plan.steps, dt=plan.dt, scheme="imex")
    u = np.asarray(sol.state)
    assert np.isfinite(u).all() and sol.t >= 60.0
    assert 3.0 < u[0].max() < 5.0  # the spots formed
    old = 0.95 * ground
    with pytest.raises(BlowUpError):
        simulate(model, grid, u0, p, steps=round(60.0 / old), dt=old, scheme="imex",
                 unsafe=True)
