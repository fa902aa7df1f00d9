"""The Python door to search: optimise() runs the same generations as `evolve` (same keys,
same fitness), over a model given by name, text or object, with a strategy named or built."""

from __future__ import annotations

import numpy as np
import pytest

import morphogen as mg
from morphogen.search import (
    CMAES,
    Archive,
    Gene,
    GeneticAlgorithm,
    Problem,
    evolve,
    optimise,
    start,
)
from morphogen.search.executors import LocalExecutor

SETTINGS = {"size": (20, 20), "dt": 0.5, "steps": 80, "init": "skaggs",
            "preset": "skaggs-table-3.1"}
GENES = {"F": (0.02, 0.06), "k": (0.05, 0.07)}


def test_optimise_gives_the_generations_evolve_records(tmp_path):
    result = optimise("gray-scott", GENES, population=6, generations=2, seed=3, **SETTINGS)
    archive = Archive(tmp_path / "index.sqlite")
    problem = Problem(model="gray-scott", genes=tuple(Gene(n, *s) for n, s in GENES.items()),
                      **SETTINGS)
    run_id, _ = start(problem, {"name": "ga", "population": 6}, generations=2, seed=3,
                      out=tmp_path / "run", archive=archive)
    evolve(run_id, archive, LocalExecutor(problem), log=lambda _: None)
    rows = archive.individuals(run_id)
    np.testing.assert_array_equal(result.fitness.ravel(), [r["fitness"] for r in rows])
    np.testing.assert_allclose(result.genomes.reshape(-1, 2), [r["genome"] for r in rows],
                               rtol=1e-6)
    assert result.fitness.shape == (2, 6) and result.genomes.shape == (2, 6, 2)
    assert result.best_fitness == pytest.approx(np.nanmax(result.fitness))
    best = np.unravel_index(np.nanargmax(result.fitness), result.fitness.shape)
    assert result.best_params == pytest.approx(dict(zip(GENES, result.genomes[best],
                                                        strict=True)))


def test_a_model_object_from_text_or_python_searches_like_its_name():
    text = mg.load_model("examples/gray-scott.toml").source
    settings = {**SETTINGS, "preset": None}
    by_text = optimise(mg.parse_model(text), GENES, population=4, generations=1, **settings)
    gs = mg.load_model("examples/gray-scott.toml")
    built = mg.Model(name="gs-python", species=gs.species, params=gs.params,
                     reaction=gs.reaction, diffusion=gs.diffusion, presets=gs.presets,
                     ground=gs.ground, excited=gs.excited)
    assert built.source is None
    in_python = optimise(built, GENES, population=4, generations=1, **settings)
    np.testing.assert_array_equal(by_text.fitness, in_python.fitness)
    assert by_text.problem.model_source == text and in_python.problem.model_source is None


def test_strategy_objects_with_their_own_options():
    ga = optimise("gray-scott", GENES, strategy=GeneticAlgorithm(population_size=4, elitism=1),
                  generations=2, **SETTINGS)
    assert ga.fitness.shape == (2, 4)
    # elitism: the best of generation 1 comes back unchanged in generation 2
    np.testing.assert_array_equal(ga.genomes[1, 0], ga.genomes[0, np.nanargmax(ga.fitness[0])])
    cma = optimise("gray-scott", [Gene("F", 0.02, 0.06)], strategy=CMAES(population_size=4),
                   generations=2, **SETTINGS)
    assert cma.genomes.shape == (2, 4, 1)
    assert np.all((cma.genomes >= 0.02) & (cma.genomes <= 0.06))


def test_a_gene_without_sigma_mutates_by_a_tenth_of_its_range():
    assert Gene("F", 0.0, 0.5).sigma == pytest.approx(0.05)
    assert Gene("F", 0.0, 0.5, 0.2).sigma == 0.2


@pytest.mark.parametrize("kwargs, message", [
    ({"strategy": "simplex"}, "unknown strategy 'simplex'"),
    ({"strategy": "gradient"}, "unknown strategy 'gradient'"),
    ({"sizes": (8, 8)}, "unknown setting 'sizes'"),
    ({"generations": 0}, "generations must be >= 1"),
    ({"fitness": "beauty"}, "unknown fitness 'beauty'"),
])
def test_bad_searches_are_one_line(kwargs, message):
    with pytest.raises(mg.MorphogenError, match=message):
        optimise("gray-scott", GENES, **kwargs)


def test_bad_genes_are_one_line():
    with pytest.raises(mg.MorphogenError, match="at least one gene"):
        optimise("gray-scott", {})
    with pytest.raises(mg.MorphogenError, match=r"give \(low, high\)"):
        optimise("gray-scott", {"F": (0.1,)})
    with pytest.raises(mg.MorphogenError, match="not a parameter|unknown|no parameter"):
        optimise("gray-scott", {"Q": (0.0, 1.0)}, size=(8, 8), steps=2)
