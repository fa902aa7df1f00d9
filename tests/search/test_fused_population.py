"""A population on the fused CPU step (:func:`morphogen.solvers.fused.fused_population`, used by
:class:`~morphogen.search.evaluate.Evaluator`): the JAX step's fitness and final fields within
float32 rounding, the same program however the population is split, and taken by default only
from :data:`~morphogen.solvers.fused.MIN_MEMBER_WORK` cell-steps a member."""

from __future__ import annotations

import jax
import numpy as np

from morphogen.search.evaluate import Evaluator, Problem, individual_keys
from morphogen.search.genes import preset_genes
from morphogen.solvers import fused
from tests.fused_support import needs_numba

pytestmark = needs_numba

PROBLEM = Problem(model="gray-scott", genes=tuple(preset_genes("gray-scott")),
                  preset="skaggs-table-3.1", size=(24, 20), dt=0.5, steps=300, init="skaggs",
                  clamp=[0, 5])
# Skaggs' F and k for spots, stripes and a uniform state, and one beyond the stability limit
GENOMES = np.array([[0.037, 0.06], [0.03, 0.055], [0.09, 0.059], [0.062, 0.0609],
                    [0.025, 0.06]], np.float32)


def _evaluate(monkeypatch, mode: str, genomes=GENOMES, keys=None):
    monkeypatch.setenv(fused.ENV, mode)
    ev = Evaluator(PROBLEM)
    assert (ev._fused is not None) == (mode == "on")
    keys = individual_keys(jax.random.PRNGKey(3), len(genomes)) if keys is None else keys
    return ev.evaluate_keys(genomes, keys)


def test_the_fused_population_gives_the_jax_steps_fitness_and_fields(monkeypatch):
    want_f, want = _evaluate(monkeypatch, "off")
    got_f, got = _evaluate(monkeypatch, "on")
    np.testing.assert_array_equal(got["valid"], want["valid"])
    assert want["valid"].sum() >= 4 and np.ptp(want["fields"].reshape(5, -1).std(1)) > 0
    # 300 steps, about 80 roundings: each field within 1e-5 of its scale, fitness alike
    scale = np.abs(want["fields"]).max()
    assert np.abs(got["fields"] - want["fields"]).max() <= 1e-5 * scale
    np.testing.assert_allclose(got_f, want_f, rtol=1e-4, atol=1e-5)


def test_a_split_population_runs_the_same_program(monkeypatch):
    keys = individual_keys(jax.random.PRNGKey(3), len(GENOMES))
    whole_f, whole = _evaluate(monkeypatch, "on", keys=keys)
    parts = [_evaluate(monkeypatch, "on", GENOMES[s], keys[s]) for s in (slice(0, 2),
                                                                         slice(2, 5))]
    np.testing.assert_array_equal(np.concatenate([f for f, _ in parts]), whole_f)
    np.testing.assert_array_equal(np.concatenate([m["fields"] for _, m in parts]),
                                  whole["fields"])


def test_by_default_only_a_large_member_takes_the_fused_step(monkeypatch):
    monkeypatch.delenv(fused.ENV, raising=False)
    cells = PROBLEM.size[0] * PROBLEM.size[1]
    steps = -(-fused.MIN_MEMBER_WORK // cells)
    assert Evaluator(PROBLEM)._fused is None
    assert Evaluator(Problem(**{**PROBLEM.__dict__, "steps": steps - 1}))._fused is None
    assert Evaluator(Problem(**{**PROBLEM.__dict__, "steps": steps}))._fused is not None
    # a batch size asked for is the JAX step's layout
    assert Evaluator(Problem(**{**PROBLEM.__dict__, "steps": steps}), batch_size=2
                     )._fused is None
