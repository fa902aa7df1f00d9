"""The live view solves a model's ground state once per parameter set, not once per request.

FitzHugh-Nagumo has no closed-form ground state: ``Model.ground_state`` runs a 60-step eager
Newton iteration (0.3-0.5 s a call, seconds the first time in a process). A model switch used to
solve it three times (initial condition, ``dt`` limit, the settings returned) and every later
settings request once more; these tests count the solves and check the numbers are unchanged.
"""

from __future__ import annotations

import numpy as np
import pytest

import morphogen.models.model as model_module
from morphogen.models.library import get_model
from morphogen.solvers.step import max_stable_dt
from morphogen.web.limits import Limits
from morphogen.web.live import LiveSim


@pytest.fixture
def solves(monkeypatch):
    """The parameter sets the Newton solver was called with, in order."""
    calls: list[dict] = []
    newton = model_module._newton_steady_state

    def counted(model, params):
        calls.append(dict(params))
        return newton(model, params)

    monkeypatch.setattr(model_module, "_newton_steady_state", counted)
    return calls


def test_a_model_switch_solves_the_ground_state_once(solves):
    sim = LiveSim(Limits())
    state = sim.configure({"library": "fitzhugh-nagumo"}, size=40, height=24)
    for _ in range(3):
        sim.describe()
    sim.set_view(steps_per_frame=4)
    sim.frame()
    sim.paint(0.5, 0.5, mode="erase", stroke=True)
    sim.reset("noise", 3)
    assert len(solves) == 1
    # the same numbers as the model itself gives: its ground state and the Euler dt limit
    model = get_model("fitzhugh-nagumo")
    assert sim.engine.model.ground_state(sim.values) == pytest.approx(
        model.ground_state(sim.values), abs=1e-7)
    limit = max_stable_dt(model, sim.engine.grid, sim.values, "euler")
    assert state["dt_max"] == pytest.approx(limit, rel=1e-9)
    assert 0.005 < limit < 0.0125  # below the diffusive bound 1 / (4 Dv) for Dv = 20


def test_a_parameter_change_solves_once_and_moves_the_dt_limit(solves):
    sim = LiveSim(Limits())
    # a grid of its own: engines (and what they remember) are shared by every session
    before = sim.configure({"library": "fitzhugh-nagumo"}, size=48, height=24)["dt_max"]
    sim.set_params({"Dv": 40.0})
    after = sim.describe()["dt_max"]
    assert len(solves) == 2 and solves[1]["Dv"] == 40.0
    # Euler's diffusive limit scales as 1 / Dv: doubling Dv halves it
    assert after == pytest.approx(before / 2, rel=0.02)
    assert sim.dt <= after
    sim.set_params({"Dv": 20.0})  # a parameter set solved before is remembered
    assert len(solves) == 2
    assert sim.describe()["dt_max"] == pytest.approx(before, rel=1e-9)


def test_painting_the_excited_state_does_not_solve_per_point(solves):
    # activator-inhibitor has neither a closed-form ground nor an excited state
    sim = LiveSim(Limits())
    sim.configure({"library": "activator-inhibitor"}, size=40, height=24)
    for x in np.linspace(0.1, 0.9, 8):
        sim.paint(float(x), 0.5, mode="excite", stroke=x == 0.1)
    assert len(solves) == 1


def test_the_warm_up_leaves_the_ground_state_solved_and_reports(solves, capsys):
    import threading

    from morphogen.web.warmup import warm_and_report

    line = warm_and_report(Limits(), ["fitzhugh-nagumo"], threading.Event())
    assert line.startswith("warm-up: the live views of 1 library models compiled in ")
    assert "(fitzhugh-nagumo " in line and line in capsys.readouterr().out
    solved = len(solves)
    sim = LiveSim(Limits())
    sim.configure({"library": "fitzhugh-nagumo"})  # the warmed default view: 256², periodic
    sim.frame()
    assert len(solves) == solved and solved <= 1  # none more after the warm-up
    stopped = threading.Event()
    stopped.set()
    assert warm_and_report(Limits(), ["fitzhugh-nagumo"], stopped) is None
