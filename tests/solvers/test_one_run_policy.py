"""One run policy for every front end: the same settings given to the command line, the web
app's live view, a search and Python give the same ``dt`` and steps (and ``auto`` the same
scheme), since each asks :func:`morphogen.solvers.policy.plan_run`."""

from __future__ import annotations

import json

import pytest

import morphogen as mg
from morphogen.cli.main import main
from morphogen.search.evaluate import Problem, policy_problem
from morphogen.web.limits import Limits
from morphogen.web.live import LiveSim

SIZE, TIME = 32, 20.0


@pytest.mark.parametrize("model_name,scheme", [("schnakenberg", "euler"),
                                               ("schnakenberg", "imex"),
                                               ("gray-scott", "etdrk4"),
                                               ("brusselator", "auto")])
def test_the_command_line_the_web_search_and_python_take_the_same_step(tmp_path, capsys,
                                                                        model_name, scheme):
    assert main(["simulate", model_name, "--size", f"{SIZE}x{SIZE}", "--scheme", scheme,
                 "--time", str(TIME), "--init", "noise", "--out", str(tmp_path / "run")]) == 0
    resolved = json.loads((tmp_path / "run" / "run.json").read_text())["resolved"]

    model = mg.load_model(model_name)
    grid = mg.Grid((SIZE, SIZE))
    params = model.parameters()
    u0 = mg.make_initial("noise", model, grid, params, seed=0)
    sol = mg.simulate(model, grid, u0, params, scheme=scheme, t_end=TIME)
    assert (sol.scheme, sol.steps) == (resolved["scheme"], resolved["steps"])
    assert sol.dt == pytest.approx(resolved["dt"], rel=1e-6)

    # the live view offers the registry's schemes by name (auto is the command line's)
    live = LiveSim(Limits()).configure({"library": model_name}, size=SIZE,
                                       scheme=resolved["scheme"], init="noise", seed=0)
    assert live["dt"] == pytest.approx(resolved["dt"], rel=1e-6)

    if scheme == "euler":  # a search advances a population with one explicit step
        genes = (mg.Gene("a", 0.05, 0.2),)
        problem = policy_problem(Problem(model=model_name, genes=genes, size=(SIZE, SIZE),
                                         init="noise"), time=TIME)
        assert (problem.dt, problem.steps) == pytest.approx((resolved["dt"],
                                                             resolved["steps"]), rel=1e-6)


def test_simulate_takes_an_end_time_or_two_of_three():
    model, grid = mg.load_model("gray-scott"), mg.Grid((16, 16))
    params = model.parameters()
    u0 = mg.make_initial("square", model, grid, params)
    by_time = mg.simulate(model, grid, u0, params, dt=0.5, t_end=10.0)
    assert (by_time.steps, by_time.dt) == (20, 0.5)
    by_steps = mg.simulate(model, grid, u0, params, steps=20, t_end=10.0)
    assert by_steps.dt == 0.5
    default = mg.simulate(model, grid, u0, params, t_end=10.0)
    assert (default.dt, default.steps) == (model.dt, round(10.0 / model.dt))
    with pytest.raises(mg.MorphogenError, match="at most two"):
        mg.simulate(model, grid, u0, params, steps=20, dt=0.5, t_end=10.0)
