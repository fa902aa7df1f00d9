"""MAP-Elites: cells from descriptors, and the archive invariant (only fitter genomes replace
an elite, and only in their own cell)."""

import jax
import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.search.genes import Gene
from morphogen.search.mapelites import MapElites, coverage, qd_score

N = 64
Y, X = np.mgrid[0:N, 0:N].astype(np.float32)
HEX = sum(np.cos(2 * np.pi * (a * X + b * Y) / N) for a, b in ((4, 0), (-2, 4), (-2, -4)))
FIELDS = np.stack([HEX, -HEX, np.sin(2 * np.pi * X / 16), np.sin(2 * np.pi * Y / 8)])
GENES = [Gene("a", 0.0, 1.0, 0.05), Gene("b", -2.0, 2.0, 0.1)]


@pytest.mark.slow
def test_cells_follow_the_descriptor_grid():
    me = MapElites(population_size=4, descriptors=("spot_index",), bins=3)
    # ranges (-1.5, 1.5), three bins of width 1: spots (0.875) -> 2, holes -> 0, stripes -> 1
    cells = np.asarray(me.cells_of(me.measure(FIELDS)))
    assert list(cells) == [2, 0, 1, 1]
    two = MapElites(population_size=4, bins=4)
    assert two.cell_count == 16
    assert int(two.cells_of(np.array([[10.0, 0.3]]))[0]) == 3 + 4 * 1  # clipped to the edge bin


def test_elites_are_replaced_only_by_fitter_genomes_of_their_cell():
    me = MapElites(population_size=4, descriptors=("spot_index",), bins=3)
    key = jax.random.PRNGKey(0)
    state = me.init(key, GENES)
    genomes, state = me.ask(key, state)
    low, high = np.array([0.0, -2.0]), np.array([1.0, 2.0])
    assert np.all((np.asarray(genomes) >= low) & (np.asarray(genomes) <= high))
    rng = np.random.default_rng(1)
    for gen in range(12):
        order = rng.permutation(4)
        fields = FIELDS[order]
        fitness = rng.normal(size=4).astype(np.float32)
        if gen == 3:
            fitness[0] = np.nan  # a failed evaluation never becomes an elite
        cells = np.asarray(me.cells_of(me.measure(fields)))
        before_f = np.asarray(state.inner.fitness).copy()
        before_g = np.asarray(state.inner.genomes).copy()
        state, _ = me.tell(genomes, fitness, state, fields=fields)
        after_f = np.asarray(state.inner.fitness)
        after_g = np.asarray(state.inner.genomes)
        clean = np.where(np.isnan(fitness), -np.inf, fitness)
        for c in range(me.cell_count):
            told = clean[cells == c]
            best = told.max() if told.size else -np.inf
            if best > before_f[c]:
                assert after_f[c] == best
                np.testing.assert_array_equal(after_g[c], np.asarray(genomes)[cells == c][
                    np.argmax(told)])
            else:
                assert after_f[c] == before_f[c]
                np.testing.assert_array_equal(after_g[c], before_g[c])
        genomes, state = me.ask(jax.random.fold_in(key, gen + 1), state)
        g = np.asarray(genomes)
        assert np.all((g >= low) & (g <= high))
    assert coverage(state) == 1.0
    assert qd_score(state) == pytest.approx(float(np.sum(np.asarray(state.inner.fitness))))


@pytest.mark.slow
def test_offspring_are_mutated_elites_except_the_explored_share():
    key = jax.random.PRNGKey(3)
    for explore, near in ((0.0, 8), (0.5, 4)):
        me = MapElites(population_size=8, descriptors=("spot_index",), bins=3, explore=explore)
        state = me.init(key, GENES)
        genomes, state = me.ask(key, state)
        fields = np.concatenate([FIELDS, FIELDS])
        state, _ = me.tell(genomes, np.arange(8, dtype=np.float32), state, fields=fields)
        elites = np.asarray(state.inner.genomes)
        children, _ = me.ask(jax.random.fold_in(key, 1), state)
        # distance to the nearest elite in units of the genes' sigma (0.05, 0.1)
        z = np.abs(np.asarray(children)[:, None] - elites[None]) / np.array([0.05, 0.1])
        close = np.nanmin(z.max(axis=2), axis=1) < 5
        assert close[:near].all()
        if explore:
            assert not close[near:].all()  # uniform draws over a box 20 and 40 sigmas wide


def test_map_elites_needs_fields_and_valid_settings():
    me = MapElites(population_size=4)
    state = me.init(jax.random.PRNGKey(0), GENES)
    with pytest.raises(MorphogenError, match="fields"):
        me.tell(np.zeros((4, 2)), np.zeros(4), state)
    with pytest.raises(MorphogenError, match="descriptors"):
        MapElites(population_size=4, descriptors=("colour",))
    with pytest.raises(MorphogenError, match="ranges"):
        MapElites(population_size=4, descriptors=("euler",))


@pytest.mark.slow
def test_evolve_map_elites_end_to_end(tmp_path, quality_diversity_run):
    from morphogen.search.archive import Archive
    from morphogen.search.strategy import state_from_arrays

    db = tmp_path / "index.sqlite"
    quality_diversity_run(db, tmp_path / "run", 3, 2)
    archive = Archive(db)
    run_id = archive.runs()[0]["id"]
    me = MapElites(population_size=6)
    genes = [Gene(g["name"], g["low"], g["high"], g["sigma"])
             for g in archive.run(run_id)["config"]["problem"]["genes"]]
    gen, arrays = archive.last_state(run_id)
    state = state_from_arrays(me.init(jax.random.PRNGKey(0), genes), arrays)
    assert gen == 3
    elites = np.asarray(state.inner.fitness)
    filled = np.isfinite(elites)
    assert 1 <= filled.sum() <= 18
    # the best elite is the best individual the run ever evaluated
    assert elites[filled].max() == pytest.approx(archive.best(run_id, 1)[0]["fitness"])


class _CrashAt:
    """A local executor that fails on the given generation, as a killed run would."""

    def __init__(self, problem, crash_at):
        from morphogen.search.executors import LocalExecutor

        self.inner, self.crash_at, self.calls = LocalExecutor(problem), crash_at, 0
        self.name, self.unit = "local", "step"

    def total(self, population):
        return self.inner.total(population)

    def evaluate(self, genomes, key, update=None):
        self.calls += 1
        if self.calls == self.crash_at:
            raise RuntimeError("killed")
        return self.inner.evaluate(genomes, key, update)


@pytest.mark.slow
def test_map_elites_resume_is_bit_identical(tmp_path):
    from morphogen.search.archive import Archive
    from morphogen.search.evaluate import Problem
    from morphogen.search.genes import preset_genes
    from morphogen.search.run import evolve, start

    problem = Problem(model="gray-scott", genes=tuple(preset_genes("gray-scott")), size=(24, 24),
                      dt=0.5, steps=120, init="skaggs", preset="skaggs-table-3.1")
    strategy = {"name": "map-elites", "population": 6}
    runs = []
    for name, crash in (("whole", 0), ("broken", 3)):
        archive = Archive(tmp_path / f"{name}.sqlite")
        run_id, _ = start(problem, strategy, generations=4, seed=5, archive=archive,
                          out=tmp_path / name)
        if crash:
            with pytest.raises(RuntimeError, match="killed"):
                evolve(run_id, archive, _CrashAt(problem, crash), log=lambda s: None)
            assert archive.last_state(run_id)[0] == 2
        evolve(run_id, archive, _CrashAt(problem, 0), log=lambda s: None)
        runs.append([(r["gen"], r["idx"], r["genome"], r["fitness"])
                     for r in archive.individuals(run_id)])
        runs[-1].append(archive.last_state(run_id)[1])
    whole, broken = runs
    assert whole[:-1] == broken[:-1] and len(whole) == 25
    for k, v in whole[-1].items():
        np.testing.assert_array_equal(v, broken[-1][k])


@pytest.mark.slow
def test_elite_map_draws_each_filled_cell_with_its_family():
    from morphogen.search.elitemap import elite_map

    me = MapElites(population_size=4, bins=3)
    state = me.init(jax.random.PRNGKey(0), GENES)
    genomes = np.array([[0.1, 0.0], [0.4, 0.0], [0.6, 0.0], [0.9, 0.0]], np.float32)

    def evaluate(g, key):  # genome a picks the field: spots, holes, vertical, horizontal stripes
        fields = FIELDS[np.minimum((np.asarray(g)[:, 0] * 4).astype(int), 3)]
        return np.asarray(g)[:, 0], {"fields": fields, "valid": np.ones(len(g), bool)}

    fitness, metrics = evaluate(genomes, None)
    state, _ = me.tell(genomes, fitness, state, fields=metrics["fields"])
    image, families = elite_map(me, state, evaluate, jax.random.PRNGKey(1))
    # spot_index bins over [-1.5, 1.5]: spots 2, holes 0, stripes 1; coherence: low 0, high 2
    assert families == {2: "spots", 0: "holes", 1 + 3 * 2: "stripes"}
    assert image.ndim == 3 and image.shape[2] == 3
    found = {tuple(p) for p in image.reshape(-1, 3)}
    assert {_rgb("spots"), _rgb("holes"), _rgb("stripes")} <= found
    assert _rgb("mixed") not in found


def _rgb(family):
    from morphogen.patterns.classify import COLOURS

    c = COLOURS[family]
    return tuple(int(c[i:i + 2], 16) for i in (1, 3, 5))
