"""The model library: steady states, GenRD, mass-action networks, validation."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate
from morphogen.errors import MorphogenError
from morphogen.models.genrd import coefficient_name
from morphogen.models.library import LIBRARY, get_model
from morphogen.models.linear import fastest_mode
from morphogen.models.network import mass_action

COORDS = {"x": 0.5, "y": 0.5, "z": 0.5, "t": 0.0}


@pytest.mark.parametrize("name", sorted(LIBRARY))
def test_ground_state_is_steady(name):
    model = get_model(name)
    p = model.parameters()
    g = model.ground_state(p)
    rate = model.reaction(jnp.asarray(g, jnp.float32).reshape(-1, 1), p, COORDS)
    assert np.max(np.abs(np.asarray(rate))) < 1e-4


@pytest.mark.parametrize("name", sorted(LIBRARY))
def test_default_run_is_finite_and_patterned(name):
    """Each model at its defaults forms a pattern on a small grid (short of full time)."""
    model = get_model(name)
    grid = Grid((48, 48))
    p = model.parameters()
    u0 = make_initial(model.init, model, grid, p, seed=2)
    steps = int(model.t_end / model.dt)
    state = simulate(model, grid, u0, p, steps=steps, dt=model.dt).state
    shown = state[model.species_index(model.display_species)]
    assert np.all(np.isfinite(state))
    assert np.std(shown) > 1e-2 * max(1.0, abs(float(np.mean(shown))))


@pytest.mark.parametrize(
    "name", ["schnakenberg", "brusselator", "fitzhugh-nagumo", "gierer-meinhardt",
             "activator-inhibitor", "turing", "yamamoto-network"],
)
def test_turing_models_are_turing_unstable(name):
    model = get_model(name)
    assert fastest_mode(model, model.parameters()).is_turing


def test_gierer_meinhardt_skaggs_table_diffusion_forms_no_turing_pattern():
    model = get_model("gierer-meinhardt")
    assert not fastest_mode(model, model.parameters(preset="skaggs-table-3.1")).is_turing


def test_genrd_defaults_reproduce_gray_scott():
    gs, gen = get_model("gray-scott"), get_model("genrd")
    rng = np.random.default_rng(0)
    u = jnp.asarray(rng.uniform(0, 1, (2, 16, 16)), jnp.float32)
    a = gs.reaction(u, gs.parameters(), COORDS)
    b = gen.reaction(u, gen.parameters(), COORDS)
    np.testing.assert_allclose(np.asarray(a), np.asarray(b), atol=1e-6)


def test_genrd_zero_denominator_is_finite():
    gen = get_model("genrd")
    p = gen.parameters({coefficient_name("beta", "u", 1, 0, 0): 0.0,
                        coefficient_name("beta", "u", 1, 1, 0): 1.0})
    u = jnp.zeros((2, 4, 4), jnp.float32)  # denominator u = 0 exactly
    rate = np.asarray(gen.reaction(u, p, COORDS))
    assert np.all(np.isfinite(rate))


def test_mass_action_rates_follow_eqs_2_and_3():
    """A + 2B -> C at rate k: v = k a b^2; da = -v, db = -2v, dc = +v."""
    model = mass_action("abc", ("a", "b", "c"), educts=[[1], [2], [0]], products=[[0], [0], [1]],
                        rates=[0.5], diffusion=[0.1, 0.2, 0.0])
    u = jnp.array([[2.0], [3.0], [1.0]])
    rate = np.asarray(model.reaction(u, model.parameters(), COORDS))[:, 0]
    v = 0.5 * 2.0 * 9.0
    np.testing.assert_allclose(rate, [-v, -2 * v, v], rtol=1e-6)
    assert model.diffusion(model.parameters(), COORDS) == (0.1, 0.2, 0.0)


def test_yamamoto_network_reduces_to_gierer_meinhardt():
    """With the catalyst at its quasi-steady state c = rho_c/(k3 h), the activator rate is
    Yamamoto eq. 4: sigma_a a^2/h - mu_a a with sigma_a = k1 rho_c / k3."""
    model = get_model("yamamoto-network")
    p = model.parameters()
    a, h = 1.7, 0.8
    c = p["k6"] / (p["k3"] * h)
    rate = np.asarray(model.reaction(jnp.array([[a], [h], [c]]), p, COORDS))[:, 0]
    sigma_a = p["k1"] * p["k6"] / p["k3"]
    assert rate[0] == pytest.approx(sigma_a * a * a / h - p["k4"] * a, rel=1e-5)
    assert rate[1] == pytest.approx(p["k2"] * a * a - p["k5"] * h, rel=1e-5)
    assert rate[2] == pytest.approx(0.0, abs=1e-6)


def test_unknown_names_give_clear_errors():
    with pytest.raises(MorphogenError, match="known models"):
        get_model("grey-scot")
    with pytest.raises(MorphogenError, match="parameters are F, k"):
        get_model("gray-scott").parameters({"kill": 0.06})
    with pytest.raises(MorphogenError, match="presets"):
        get_model("gray-scott").parameters(preset="nope")


def test_gray_scott_presets_hold_the_explorer_table():
    presets = get_model("gray-scott").presets
    assert presets["u-skate"] == {"F": 0.062, "k": 0.06093}
    assert presets["worms"] == {"F": 0.078, "k": 0.061}
    assert len([n for n in presets if not n.startswith(("richard", "skaggs"))]) == 12
