"""The analysis against simulation: from its Turing-unstable fixed point plus small noise, a
model's pattern at early times has the dominant wavelength of the fastest-growing grid mode
(within 15 %, the measure of the Turing-growth test in tests/engine/test_simulate.py), and a
model the analysis calls stable forms no pattern (the noise decays)."""

from __future__ import annotations

import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.simulate import simulate
from morphogen.models.library import get_model
from morphogen.models.registry import load_model
from morphogen.runs.analysis import analyse
from tests.engine.test_simulate import _dominant_wavelength

N = 64


def _grow(model, params, u_star, growth: float, dt: float, efolds: float = 5.0):
    """``u* (1 + 1e-3 ξ)`` (``ξ`` standard normal, fixed seed) run for ``efolds / growth`` time
    units: the early, linear regime, the fastest mode grown by ``e^efolds``."""
    rng = np.random.default_rng(7)
    u_star = np.asarray(u_star, np.float32)
    u0 = u_star[:, None, None] * (1 + 1e-3 * rng.standard_normal((len(u_star), N, N)))
    steps = int(np.ceil(efolds / growth / dt))
    return np.asarray(simulate(model, Grid((N, N)), u0.astype(np.float32), params, steps=steps,
                               dt=dt).state), u0


@pytest.mark.parametrize("name, overrides, dt, efolds", [
    # Gray-Scott's trivial state (1, 0) is stable, and with the library's D_u / D_v = 2 its
    # non-trivial states are Turing-unstable only in a thin tongue along the saddle-node fold
    # F = 4 (F + k)^2 (found by the analysis; F = 0.1004 further in gives a flat band whose
    # early peak is 17 % off). Here: (0.485, 0.347), band 11.3-15.1 cells, growth 9e-4; the
    # saddle beside it takes over after a few e-folds, so the pattern is read after three.
    ("gray-scott", {"F": 0.113, "k": 0.055}, 1.0, 3.0),
    ("schnakenberg", {}, 0.005, 5.0),
    ("examples/networks/table2.ant", {}, 0.5, 5.0),
])
def test_fastest_grid_mode_is_the_early_pattern_wavelength(name, overrides, dt, efolds):
    model = load_model(name)
    params = model.parameters(overrides)
    result = analyse(model, params, size=N)
    (fp,) = result.turing
    state, u0 = _grow(model, params, fp.state, fp.grid_fastest.growth, dt, efolds)
    assert np.all(np.isfinite(state))
    field = state[0]
    assert np.std(field) > 2 * np.std(u0[0])  # it grew
    assert _dominant_wavelength(field) == pytest.approx(fp.grid_fastest.wavelength_cells,
                                                        rel=0.15)


def test_a_stable_model_forms_no_pattern():
    """Schnakenberg with equal diffusion: ``stable``; the same noise decays instead."""
    model = get_model("schnakenberg")
    params = model.parameters({"Dv": 1.0})
    (fp,) = analyse(model, params, size=N).fixed_points
    assert fp.cls == "stable" and fp.grid_band is None
    state, u0 = _grow(model, params, fp.state, abs(fp.growth0), 0.05, efolds=2.0)
    assert np.std(state[0]) < 0.5 * np.std(u0[0])
