"""Homogeneous fixed points (models/fixed_points.py) against closed forms: one, several (all
found, each once), none, a network's decades-away state, a population in one program."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.models.fixed_points import (
    default_starts,
    first_found,
    fixed_points,
    fixed_points_batch,
)
from morphogen.models.library import get_model
from morphogen.models.model import Model
from morphogen.models.registry import load_model
from morphogen.search.networks.genome import stack, table2_genome, table2_spec
from morphogen.search.networks.reaction import genome_params, padded_model

TABLE2 = "examples/networks/table2.ant"


def _gray_scott_points(f: float, k: float) -> np.ndarray:
    """``(1, 0)`` and, for ``F > 4 (F + k)²``, ``v = (F ± √(F² - 4F(F + k)²)) / (2(F + k))``,
    ``u = 1 - (F + k) v / F`` (setting ``u' = v' = 0`` in Gray-Scott)."""
    disc = np.sqrt(f * f - 4 * f * (f + k) ** 2)
    v = np.array([(f + disc) / (2 * (f + k)), (f - disc) / (2 * (f + k))])
    return np.concatenate([[[1.0, 0.0]], np.stack([1 - (f + k) * v / f, v], axis=1)])


def test_schnakenberg_has_its_one_closed_form_fixed_point():
    model = get_model("schnakenberg")
    p = model.parameters({"a": 0.2, "b": 1.3})
    points = fixed_points(model, p)
    np.testing.assert_allclose(points, [[1.5, 1.3 / 1.5**2]], rtol=1e-12)


def test_gray_scott_fixed_points_are_all_found_once_each():
    model = get_model("gray-scott")
    points = fixed_points(model, model.parameters({"F": 0.025, "k": 0.05}))
    want = _gray_scott_points(0.025, 0.05)
    assert points.shape == (3, 2)  # 26 starts and 4 log-Newton runs, deduplicated to three
    np.testing.assert_allclose(points, want[np.argsort(want[:, 0])], rtol=1e-10, atol=1e-14)
    # past the saddle-node F = 4 (F + k)^2 only the trivial state is left
    np.testing.assert_allclose(fixed_points(model, model.parameters({"F": 0.02, "k": 0.06})),
                               [[1.0, 0.0]], atol=1e-14)


def test_float32_finds_the_same_points_within_its_tolerance():
    model = get_model("gray-scott")
    points = fixed_points(model, model.parameters({"F": 0.025, "k": 0.05}), x64=False)
    assert points.shape == (3, 2)
    want = _gray_scott_points(0.025, 0.05)
    np.testing.assert_allclose(points, want[np.argsort(want[:, 0])], rtol=1e-4, atol=1e-6)


def test_a_reaction_without_a_root_has_no_fixed_point():
    model = Model(name="no-root", species=("u", "v"), params={"a": 1.0},
                  reaction=lambda u, p, c: jnp.stack([p["a"] + u[0] ** 2, -u[1]]),
                  diffusion=lambda p, c: (1.0, 1.0))
    assert fixed_points(model, model.parameters()).shape == (0, 2)


def test_table2_from_its_antimony_file_and_as_a_padded_genome():
    """Table 2: ``A' = k1 A²C - μ_A A``, ``B' = k3 A² - μ_B B``, ``C' = ρ_C - k2 BC``; with the
    table's rates ``AC = μ_A/k1 = 1``, ``B = k3 A²/μ_B = A²``, ``BC = ρ_C/k2 = 1``: the one fixed
    point is ``(1, 1, 1)`` (``A = 0`` would need ``C = ∞``)."""
    model = load_model(TABLE2)
    np.testing.assert_allclose(fixed_points(model, model.parameters()), [[1.0, 1.0, 1.0]],
                               rtol=1e-10)
    spec = table2_spec()
    genome = table2_genome(spec)
    padded = padded_model(spec)
    params = jax.tree.map(lambda a: a[0], genome_params(stack([genome]), spec))
    np.testing.assert_allclose(fixed_points(padded, params, balance="mass-action"),
                               [[1.0, 1.0, 1.0]], rtol=1e-6)


def test_a_population_is_one_program_and_equals_one_by_one():
    """Scaling ``ρ_C`` by ``s`` moves Table 2's fixed point to ``(s, s², 1/s)``
    (``AC = 1``, ``B = A²``, ``BC = s``), decades away for ``s = 1e-3 .. 1e3``: the log-Newton
    runs reach it."""
    spec = table2_spec()
    genome = table2_genome(spec)
    scales = np.array([1e-3, 0.1, 1.0, 30.0, 1e3])
    params = genome_params(stack([genome] * len(scales)), spec)
    k = np.asarray(params["k"], np.float64)
    me, mp = np.asarray(params["Me"][0]), np.asarray(params["Mp"][0])
    inflow = np.flatnonzero((me.sum(axis=0) == 0) & (mp[2] == 1) & (k[0] > 0))
    assert inflow.size == 1  # ρ_C: the one active reaction with no educt that makes C
    k[:, inflow[0]] *= scales
    model = padded_model(spec)
    with jax.enable_x64(True):
        p = {"k": jnp.asarray(k), "Me": params["Me"], "Mp": params["Mp"]}
        out = fixed_points_batch(model, p, jnp.ones((1, 3), jnp.float64), balance="mass-action")
        u, found = first_found(out)
    assert np.all(np.asarray(found))
    np.testing.assert_allclose(np.asarray(u), np.stack([scales, scales**2, 1 / scales], 1),
                               rtol=1e-8)
    assert np.asarray(out.found).sum(axis=1).tolist() == [1] * len(scales)
    for i, s in enumerate(scales):
        one = {"k": k[i], "Me": params["Me"][i], "Mp": params["Mp"][i]}
        np.testing.assert_allclose(fixed_points(model, one, np.ones((1, 3)),
                                                balance="mass-action"),
                                   [[s, s * s, 1 / s]], rtol=1e-8)


@pytest.mark.parametrize("name", ["brusselator", "turing", "gierer-meinhardt"])
def test_library_ground_states_are_fixed_points(name):
    model = get_model(name)
    p = model.parameters()
    points = fixed_points(model, p)
    ground = np.asarray(model.ground_state(p))
    assert np.min(np.abs(points - ground).max(axis=1)) < 1e-6 * (1 + np.abs(ground).max())
    assert default_starts(model, p).shape == (26, 2)
