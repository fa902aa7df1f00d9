"""Antimony/SBML import and export of mass-action networks, round trips, drawings, CLI."""

import json
from dataclasses import asdict

import jax
import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.errors import MorphogenError
from morphogen.models.network import (
    ReactionNetwork,
    to_toml,
    yamamoto_activator_inhibitor,
    yamamoto_network,
)
from morphogen.models.registry import load_model
from morphogen.models.text.equations import parse_model
from morphogen.models.text.sbml import read_antimony, read_sbml, to_antimony, to_sbml
from morphogen.search.networks.draw import draw_network, reaction_graph
from morphogen.search.networks.evolve import Evaluation, save_state
from morphogen.search.networks.export import genome_network, run_network, table2_network
from morphogen.search.networks.genome import (
    NetworkSpec,
    make_genome,
    stack,
    table2_genome,
    table2_spec,
)
from morphogen.search.networks.operators import Operators
from morphogen.search.networks.reaction import genome_params, padded_reaction

SPOTS = """
model spots
  J1: 2A + C -> 3A + C; k1*A^2*C
  J2: B + C -> B; k2*B*C
  J3: 2A -> 2A + B; k3*A*A
  J4: -> C; rho
  J5: A -> ; mu_a*A
  J6: B -> ; mu_b*B
  k1 = 0.01; k2 = 0.1; k3 = 0.02; rho = 0.1; mu_a = 0.01; mu_b = 0.03
  D_A = 0.005; D_B = 0.2
  A = 1; B = 1.5; C = 1
end
"""

SBML = """<?xml version="1.0" encoding="UTF-8"?>
<sbml xmlns="http://www.sbml.org/sbml/level3/version2/core" level="3" version="2">
  <model id="dimer">
    <listOfCompartments>
      <compartment id="cell" size="1" constant="true"/>
    </listOfCompartments>
    <listOfSpecies>
      <species id="u" compartment="cell" initialConcentration="2" hasOnlySubstanceUnits="false"
               boundaryCondition="false" constant="false"/>
      <species id="v" compartment="cell" initialConcentration="0.5"
               hasOnlySubstanceUnits="false" boundaryCondition="false" constant="false"/>
    </listOfSpecies>
    <listOfParameters>
      <parameter id="kf" value="0.3" constant="true"/>
    </listOfParameters>
    <listOfReactions>
      <reaction id="dimerise" reversible="false">
        <listOfReactants>
          <speciesReference species="u" stoichiometry="2" constant="true"/>
        </listOfReactants>
        <listOfProducts>
          <speciesReference species="v" stoichiometry="1" constant="true"/>
        </listOfProducts>
        <kineticLaw>
          <math xmlns="http://www.w3.org/1998/Math/MathML">
            <apply><times/><ci>cell</ci><ci>kf</ci><ci>u</ci><ci>u</ci></apply>
          </math>
        </kineticLaw>
      </reaction>
      <reaction id="split" reversible="false">
        <listOfReactants>
          <speciesReference species="v" stoichiometry="1" constant="true"/>
        </listOfReactants>
        <kineticLaw>
          <math xmlns="http://www.w3.org/1998/Math/MathML">
            <apply><times/><ci>kb</ci><ci>v</ci></apply>
          </math>
          <listOfLocalParameters><localParameter id="kb" value="0.7"/></listOfLocalParameters>
        </kineticLaw>
      </reaction>
    </listOfReactions>
  </model>
</sbml>
"""


def _states(n, seed=0, shape=(5, 4)):
    return np.random.default_rng(seed).uniform(0.0, 2.0, (n, *shape)).astype(np.float32)


def _term(model, u, **override):
    return np.asarray(jax.jit(model.reaction)(u, {**model.params, **override}, {}))


def test_antimony_import_gives_the_hand_computed_mass_action_term():
    model = read_antimony(SPOTS).model()
    assert model.species == ("A", "C", "B")  # declaration order of the file
    u = _states(3)
    a, c, b = u
    expected = np.stack([0.01 * a**2 * c - 0.01 * a,
                         -0.1 * b * c + 0.1,
                         0.02 * a**2 - 0.03 * b])
    np.testing.assert_allclose(_term(model, u), expected, rtol=1e-5, atol=1e-7)
    assert model.ground(model.params) == (1.0, 1.0, 1.5)


def test_diffusion_parameters_default_to_zero_and_follow_overrides():
    model = read_antimony(SPOTS).model()
    assert (model.params["D_A"], model.params["D_B"], model.params["D_C"]) == (0.005, 0.2, 0.0)
    assert model.diffusion(model.params, {}) == (0.005, 0.0, 0.2)
    assert model.diffusion({**model.params, "D_C": 0.3}, {})[1] == 0.3


def test_sbml_import_with_compartment_factor_and_local_parameter():
    net = read_sbml(SBML)
    assert net.rate_names == ("kf", "kb") and net.rates == (0.3, 0.7)
    assert net.diffusion == (0.0, 0.0) and net.initial == (2.0, 0.5)
    model = net.model()
    u, v = _states(2, seed=1)
    # dimerise: 2u -> v at cell * 0.3 u^2 (cell = 1); split: v -> ∅ at 0.7 v
    np.testing.assert_allclose(_term(model, np.stack([u, v])),
                               np.stack([-2 * 0.3 * u * u, 0.3 * u * u - 0.7 * v]), rtol=1e-5)


@pytest.mark.parametrize("law", ["Vm*A/(Km + A)", "k*A*B", "k*A^2", "k1*k2*A", "k*A + k2",
                                 "exp(k)*A"])
def test_non_mass_action_rate_law_is_refused_naming_the_reaction(law):
    text = f"model m\n  slow: A -> B; {law}\n  k = 1; k1 = 1; k2 = 1; Vm = 1; Km = 1\n  " \
           "A = 1; B = 1\nend"
    with pytest.raises(MorphogenError, match="reaction slow") as exc:
        read_antimony(text)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("text, message", [
    ("model m\n  J1: A -> B; k*Q\n  k = 1\nend", "uses 'Q', which has no value"),
    ("model m\n  J1: A -> B; k*A*exp\n  k = 1\nend", "line 4: .* SBML error"),
    ("model m\n  J1: A - > B; k*A\nend", "syntax error"),
    ("model m\n  J1: A -> B; k*A\nend", "uses 'k', which has no value"),
    ("model m\n  J1: $A -> B; k*A\n  k = 1\nend", "boundary or constant"),
    ("model m\n  J1: x -> y; k*x\n  k = 1\nend", "'x' is reserved"),
    ("model m\n  J1: 1.5 A -> B; k*A\n  k = 1\nend", "stoichiometry 1.5 of A"),
    ("model m\n  compartment V = 2; species A in V, B in V\n  J1: A -> B; k*A\n  k = 1\nend",
     "size 1"),
])
def test_bad_antimony_gives_one_line_errors(text, message):
    with pytest.raises(MorphogenError, match=message) as exc:
        read_antimony(text)
    assert "\n" not in str(exc.value) and len(str(exc.value)) < 300


def test_bad_files_give_one_line_errors(tmp_path):
    (tmp_path / "latin.ant").write_bytes("model m\n  J1: Ä -> B; k*Ä\nend".encode("latin-1"))
    (tmp_path / "broken.xml").write_text("<sbml><model")
    for path, message in ((tmp_path / "missing.ant", "not found"),
                          (tmp_path / "latin.ant", "not UTF-8"),
                          (tmp_path / "broken.xml", "not valid SBML")):
        with pytest.raises(MorphogenError, match=message) as exc:
            load_model(path)
        assert "\n" not in str(exc.value)


def _random_genome(seed):
    rng = np.random.default_rng(seed)
    spec = NetworkSpec(("A", "B", "C"), 12, (0.005, 0.2, 0.0), fixed=(0, 1), fixed_rates=(0, 0))
    cols = []
    while len(cols) < 5:
        e, p = rng.integers(0, 3, 3), rng.integers(0, 3, 3)
        if e.sum() <= 4 and p.sum() <= 4:
            cols.append((e, p))
    me = np.stack([c[0] for c in cols], 1)
    mp = np.stack([c[1] for c in cols], 1)
    k = 10.0 ** rng.uniform(-3, 0.5, spec.m_max)
    k[rng.integers(2, spec.m_max)] = 0.0
    return make_genome(spec, k, me, mp), spec


@pytest.mark.parametrize("fmt", ["toml", "antimony", "sbml"])
@pytest.mark.parametrize("source", ["table2", "random"])
def test_export_import_round_trip_keeps_the_reaction_term(fmt, source):
    genome, spec = (table2_genome(), table2_spec()) if source == "table2" else _random_genome(3)
    net = genome_network(genome, spec)
    if fmt == "toml":
        model = parse_model(to_toml(net))
    elif fmt == "antimony":
        model = read_antimony(to_antimony(net)).model()
    else:
        model = read_sbml(to_sbml(net)).model()
    assert model.species == spec.species
    u = _states(spec.n, seed=7)
    p = genome_params(genome, spec)
    want = np.asarray(padded_reaction(u, p["k"], p["Me"], p["Mp"]))
    assert np.abs(want).max() > 0.1
    np.testing.assert_allclose(_term(model, u), want, rtol=2e-5, atol=1e-5 * np.abs(want).max())
    assert model.diffusion(model.params, {}) == spec.diffusion


def test_library_network_round_trips_through_sbml():
    library = yamamoto_activator_inhibitor()
    back = read_sbml(to_sbml(yamamoto_network())).model()
    u = _states(3, seed=2)
    np.testing.assert_allclose(_term(back, u), _term(library, u), rtol=1e-6)


def test_table2_example_file_is_the_exported_table2_network():
    model = load_model("examples/networks/table2.ant")
    u = _states(3, seed=4)
    np.testing.assert_allclose(_term(model, u), _term(table2_network().model(), u), rtol=1e-6)


@pytest.mark.slow
def test_drawing_graph_has_one_node_per_reaction_and_fig7_edges():
    net = table2_network()
    g = reaction_graph(net)
    reactions = [v for v, kind in g.nodes(data="kind") if kind == "reaction"]
    assert len(reactions) == len(net.reaction_ids) == 6  # rate-0 slots left out
    r1 = ("reaction", "R1")  # 2A + C -> 3A + C
    assert g.edges[("species", "A"), r1] == {"kind": "educt", "coefficient": 2}
    assert g.edges[r1, ("species", "A")] == {"kind": "product", "coefficient": 3}
    assert g.edges[("species", "C"), r1] == {"kind": "catalyst", "coefficient": 1}
    evolvable = reaction_graph(net, [3, 4, 5])
    assert sum(k == "reaction" for _, k in evolvable.nodes(data="kind")) == 3
    genome, spec = _random_genome(5)
    active = np.asarray(genome.active) & (np.asarray(genome.mantissa) > 0)
    g = reaction_graph(genome_network(genome, spec))
    assert sum(k == "reaction" for _, k in g.nodes(data="kind")) == int(active.sum())
    assert b"<svg" in draw_network(net, "svg")[:2000]


@pytest.mark.slow
def test_cli_simulates_antimony_with_diffusion_override(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["simulate", "examples/networks/table2.ant", "--size", "16x16", "--steps", "10",
                 "-p", "D_C=0.2", "--out", str(out), "--quiet"]) == 0
    record = json.loads((out / "run.json").read_text())
    assert "0.2" in str(record["resolved"]["params"]["D_C"])
    assert parse_model(record["config"]["model_source"]).params["D_C"] == 0.0  # file default
    bad = tmp_path / "bad.ant"
    bad.write_text("model m\n  J1: A -> B; Vm*A/(Km + A)\n  Vm = 1; Km = 1\nend")
    capsys.readouterr()
    assert main(["simulate", str(bad), "--size", "16x16", "--steps", "10",
                 "--out", str(tmp_path / "bad")]) == 2
    err = capsys.readouterr().err.strip()
    assert "reaction J1" in err and "\n" not in err
    assert not (tmp_path / "bad").exists()


def test_cli_exports_table2_and_refuses_bad_sources(tmp_path, capsys):
    toml = tmp_path / "t2.toml"
    assert main(["networks", "export", "table2", "--out", str(toml)]) == 0
    model, want = parse_model(toml.read_text()), table2_network().model()
    assert (model.dt, model.t_end, model.init) == (0.1, 3800.0, "noise")
    u = _states(3, seed=5)
    np.testing.assert_allclose(_term(model, u), _term(want, u), rtol=1e-6)
    assert main(["networks", "export", "yamamoto-network", "--out", str(tmp_path / "y.xml")]) == 0
    u = _states(3, seed=6)
    np.testing.assert_allclose(_term(load_model(tmp_path / "y.xml"), u),
                               _term(yamamoto_activator_inhibitor(), u), rtol=1e-6)
    assert main(["networks", "export", "table2", "--out", str(tmp_path / "t2.png")]) == 0
    assert (tmp_path / "t2.png").read_bytes()[:4] == b"\x89PNG"
    capsys.readouterr()
    for argv in (["networks", "export", str(tmp_path / "nowhere"), "--out",
                  str(tmp_path / "x.xml")],
                 ["networks", "export", "table2", "--out", str(tmp_path / "x.foo")]):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("morphogen: error:") and "\n" not in err
    assert not (tmp_path / "x.xml").exists()


def test_run_folder_export_takes_the_best_genome_of_the_last_generation(tmp_path):
    genomes = [_random_genome(s) for s in (11, 12, 13)]
    spec = genomes[0][1]
    pop = stack([g for g, _ in genomes])
    history = np.array([[9.0, 0.0, 0.0], [-1.0, 7.5, 2.0]], np.float32)
    meta = {"spec": asdict(spec), "ops": asdict(Operators()), "population": 3, "seed": 0,
            "ev": asdict(Evaluation(dt=0.25, t_start=100.0, rounds=3))}
    save_state(tmp_path / "state.npz", pop, history, 2, meta)
    net, fitness = run_network(tmp_path)
    assert fitness == 7.5 and (net.dt, net.t_end) == (0.25, 500.0)
    out = tmp_path / "best.xml"
    assert main(["networks", "export", str(tmp_path), "--out", str(out)]) == 0
    model = load_model(out)
    genome = genomes[1][0]
    p = genome_params(genome, spec)
    u = _states(3, seed=8)
    want = np.asarray(padded_reaction(u, p["k"], p["Me"], p["Mp"]))
    np.testing.assert_allclose(_term(model, u), want, rtol=2e-5, atol=1e-5 * np.abs(want).max())


def test_reaction_network_rejects_inconsistent_data():
    with pytest.raises(MorphogenError, match="two values"):
        ReactionNetwork("n", ("a",), np.ones((1, 2), int), np.zeros((1, 2), int), ("r1", "r2"),
                        ("k", "k"), (1.0, 2.0), (0.0,))


@pytest.mark.parametrize("old, new, message", [
    ('species="v" stoichiometry="1"', 'species="v" stoichiometry="INF"', "stoichiometry inf"),
    ('species="v" stoichiometry="1"', 'species="v" stoichiometry="NaN"', "stoichiometry nan"),
    ('species="u" stoichiometry="2"', 'species="u" stoichiometry="1e30"', "from 0 to 100"),
    ("<ci>u</ci><ci>u</ci>", "<apply><power/><ci>u</ci><cn>1e30</cn></apply>",
     "not mass action"),
    ('value="0.3"', 'value="INF"', "rate constant kf is inf"),
    ('value="0.3"', 'value="NaN"', "rate constant kf is nan"),
    ('initialConcentration="2"', 'initialConcentration="NaN"', "initial value of u is nan"),
    ('<parameter id="kf"', '<parameter id="D_v" value="-1" constant="true"/><parameter id="kf"',
     "D_v is -1; give it a finite number >= 0"),
])
def test_absurd_numbers_in_sbml_give_one_line_errors(old, new, message):
    """Values the fuzzer's mutations reach: each once crashed the reader with OverflowError,
    ValueError or was accepted as an infinite rate."""
    with pytest.raises(MorphogenError, match=message) as exc:
        read_sbml(SBML.replace(old, new))
    assert "\n" not in str(exc.value)


def test_deeply_nested_rate_law_is_read_without_recursion():
    nested = "<apply><times/>" * 3000 + "<ci>kf</ci>" + "</apply>" * 3000
    net = read_sbml(SBML.replace("<ci>kf</ci>", nested))
    assert net.rates == (0.3, 0.7) and net.educts.tolist() == [[2, 0], [0, 1]]


@pytest.mark.parametrize("char", ["\u00c4", "\u065c"])
def test_antimony_error_about_a_non_ascii_character_is_one_line(char):
    # libAntimony quotes the first byte of the character alone, which is not UTF-8: the binding
    # raised UnicodeDecodeError (found by fuzzing)
    with pytest.raises(MorphogenError, match="line 2: .*unknown character") as exc:
        read_antimony(f"model m\n  J1: {char} -> B; k*{char}\nend")
    assert "\n" not in str(exc.value)
