"""``--scheme`` beyond ``simulate``: search, fitting and the atlas resolve ``auto`` and refuse
``adaptive`` (a population advances with one ``dt``) with a one-line error."""

from __future__ import annotations

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.domains.grid import Grid
from morphogen.engine.simulate import simulate
from morphogen.errors import MorphogenError
from morphogen.models.library import get_model
from morphogen.models.registry import load_model
from morphogen.runs.atlas import Axis, compute_atlas
from morphogen.runs.settings import BY_NAME
from morphogen.search.evaluate import Evaluator, Problem
from morphogen.search.genes import preset_genes
from morphogen.solvers.auto import population_scheme
from morphogen.solvers.registry import NAMES, SCHEMES

SCHNAKENBERG = "examples/schnakenberg.toml"


def test_command_line_choices_are_the_engine_schemes():
    scheme = BY_NAME["scheme"]
    assert scheme.choices_for("simulate") == NAMES
    for command in ("evolve", "atlas", "fit"):
        assert set(scheme.choices_for(command)) == {n for n in NAMES if SCHEMES[n].population}
        assert "adaptive" not in scheme.choices_for(command)


def test_population_scheme_resolves_auto_and_refuses_adaptive():
    grid = Grid((16, 16))
    stiff = load_model(SCHNAKENBERG)  # Dv/Du = 80 at dx = 1/2: stiffness ratio 69 > 25
    params = {**stiff.parameters(), "Dv": 80.0}
    assert population_scheme("auto", stiff, Grid((16, 16), dx=0.5), params) == "imex"
    # at dx = 1 the spots' Jacobian halves imex's step (0.051, docs/schemes.md): ratio 18
    assert population_scheme("auto", stiff, grid, params) == "euler"
    gray = get_model("gray-scott")  # ratio 9.8
    assert population_scheme("auto", gray, grid, gray.parameters()) == "euler"
    assert population_scheme("rk4", gray, grid, gray.parameters()) == "rk4"
    with pytest.raises(MorphogenError, match="adaptive runs one state at a time.*use euler"):
        population_scheme("adaptive", gray, grid, gray.parameters(), where="search")


@pytest.mark.slow
def test_search_runs_the_scheme_it_is_given():
    problem = Problem(model="gray-scott", genes=tuple(preset_genes("gray-scott")),
                      size=(12, 12), dt=2.0, steps=6, scheme="imex")
    evaluator = Evaluator(problem)
    genomes = np.array([[0.035, 0.06], [0.03, 0.055]], np.float32)[:, :len(problem.genes)]
    _, info = evaluator.evaluate_keys(genomes, np.zeros((2, 2), np.uint32))
    # dt = 2 is twice Euler's limit: only an IMEX step gives these fields
    u0 = evaluator.initial_states(genomes)[0]
    alone = simulate(evaluator.model, evaluator.domain, u0, evaluator.genome_parameters(
        genomes[0]), steps=6, dt=2.0, scheme="imex", clamp=problem.clamp_bounds(
        evaluator.model))
    display = evaluator.display
    np.testing.assert_allclose(info["fields"][0], alone.state[display], atol=1e-5)
    with pytest.raises(MorphogenError, match="adaptive runs one state at a time"):
        Evaluator(Problem(model="gray-scott", genes=problem.genes, size=(12, 12), dt=1.0,
                          steps=2, scheme="adaptive"))


def test_atlas_resolves_auto():
    stiff = load_model(SCHNAKENBERG)
    atlas = compute_atlas(stiff, Grid((12, 12)), Axis("a", np.array([0.1, 0.12])),
                          Axis("Dv", np.array([80.0])), steps=3, dt=0.05, scheme="auto")
    assert atlas.scheme == "imex" and atlas.valid.all()


@pytest.mark.parametrize("command", ["evolve", "atlas", "fit"])
def test_population_commands_list_every_fixed_scheme(command, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "{euler,rk4,imex1,imex,etdrk4,auto}" in text


def test_auto_that_picks_euler_runs_without_a_given_dt(tmp_path):
    from morphogen.runs.config import RunConfig
    from morphogen.runs.prepare import prepare

    prep = prepare(RunConfig(model="gray-scott", size=[16, 16], steps=2, scheme="auto"))
    gray = get_model("gray-scott")
    assert population_scheme("auto", gray, prep.domain, prep.params) == "euler"
    assert 0 < prep.dt <= gray.dt
