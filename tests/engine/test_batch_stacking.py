"""Public batch stacking: a list of parameter sets and states runs as one batch, member by
member the same as single runs."""

from __future__ import annotations

import numpy as np
import pytest

import morphogen as mg


def test_stacked_batch_matches_single_runs():
    model = mg.load_model("gray-scott")
    grid = mg.Grid((16, 16))
    sets = [model.parameters({"F": f, "k": 0.06}) for f in (0.03, 0.04, 0.05)]
    states = [mg.make_initial("blobs", model, grid, s, seed=i) for i, s in enumerate(sets)]
    params = mg.stack_params(sets)
    assert params["F"].shape == (3,) and params["k"].shape == (3,)
    np.testing.assert_allclose(np.asarray(params["F"]), [0.03, 0.04, 0.05], rtol=1e-6)
    batch = mg.simulate_batch(model, grid, mg.stack_states(states), params, steps=50, dt=1.0)
    for i, (s, u0) in enumerate(zip(sets, states, strict=True)):
        one = mg.simulate(model, grid, u0, s, steps=50, dt=1.0)
        np.testing.assert_allclose(batch.state[i], one.state, rtol=1e-5, atol=1e-6)


def test_a_field_and_a_scalar_stack_to_the_field_shape():
    field = np.linspace(0.0, 1.0, 12).reshape(3, 4)
    params = mg.stack_params([{"F": 0.5, "k": field}, {"F": 0.25, "k": 2.0}])
    assert params["k"].shape == (2, 3, 4)
    np.testing.assert_allclose(np.asarray(params["k"][1]), 2.0)
    np.testing.assert_allclose(np.asarray(params["k"][0]), field, rtol=1e-6)


@pytest.mark.parametrize("call, message", [
    (lambda: mg.stack_params([]), "at least one parameter set"),
    (lambda: mg.stack_params([{"F": 1.0}, {"k": 1.0}]), "differs from set 0 in F, k"),
    (lambda: mg.stack_params([{"F": np.ones(3)}, {"F": np.ones(4)}]), "do not broadcast"),
    (lambda: mg.stack_states([np.ones((2, 4, 4)), np.ones((2, 5, 5))]), "different shapes"),
    (lambda: mg.stack_states([]), "at least one state"),
])
def test_bad_batches_are_one_line(call, message):
    with pytest.raises(mg.MorphogenError, match=message):
        call()
