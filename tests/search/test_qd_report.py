"""The files `evolve --strategy map-elites` writes: every elite a replayable run file in its
cell, coverage and QD-score per generation that never fall, the elite map."""

import json

import jax
import numpy as np
import pytest

from morphogen.search.genes import Gene
from morphogen.search.mapelites import MapElites, qd_score
from morphogen.search.qd_report import QD_OFFSET, cell_bins, chunked


def test_cell_bins_invert_the_flat_cell_index():
    me = MapElites(population_size=4, descriptors=("spot_index", "coherence", "covered"),
                   bins=5)
    assert cell_bins(me, 0) == [0, 0, 0]
    assert cell_bins(me, 2 + 5 * 3 + 25 * 4) == [2, 3, 4]
    values = np.array([[0.2, 0.55, 0.95]])  # bins floor(5 * 1.7 / 3) = 2, 2, 4
    assert cell_bins(me, int(me.cells_of(values)[0])) == [2, 2, 4]


def test_chunked_evaluation_pads_and_keeps_order():
    seen = []

    def evaluate(genomes, key):
        seen.append(len(genomes))
        g = np.asarray(genomes)
        return g[:, 0] * 2, {"fields": g[:, :1, None] * np.ones((1, 1, 3)),
                             "valid": np.ones(len(g), bool)}

    genomes = np.arange(14, dtype=np.float32).reshape(7, 2)
    fitness, metrics = chunked(evaluate, 3)(genomes, jax.random.PRNGKey(0))
    assert seen == [3, 3, 3]  # 7 genomes padded to 9
    np.testing.assert_array_equal(fitness, genomes[:, 0] * 2)
    assert metrics["fields"].shape == (7, 1, 3) and metrics["valid"].shape == (7,)


@pytest.mark.slow
def test_evolve_writes_replayable_elites_and_qd_curves(tmp_path, quality_diversity_run):
    from morphogen.cli.main import main
    from morphogen.patterns.descriptors import describe
    from morphogen.search.archive import Archive
    from morphogen.search.strategy import state_from_arrays

    db, out = tmp_path / "index.sqlite", tmp_path / "run"
    quality_diversity_run(db, out, 3, 2)
    archive = Archive(db)
    run_id = archive.runs()[0]["id"]
    genes = [Gene(g["name"], g["low"], g["high"], g["sigma"])
             for g in archive.run(run_id)["config"]["problem"]["genes"]]
    me = MapElites(population_size=6)
    template = me.init(jax.random.PRNGKey(0), genes)
    state = state_from_arrays(template, archive.last_state(run_id)[1])
    fitness = np.asarray(state.inner.fitness)
    index = json.loads((out / "elites" / "index.json").read_text())
    cells = [e["cell"] for e in index["elites"]]
    assert cells == list(np.flatnonzero(np.isfinite(fitness)))
    individuals = {(r["gen"], r["idx"]): r for r in archive.individuals(run_id)}
    for e in index["elites"]:
        assert e["fitness"] == pytest.approx(float(fitness[e["cell"]]))
        origin = individuals[(e["generation"], e["index"])]
        np.testing.assert_allclose(origin["genome"], e["genome"], rtol=1e-6)
        assert origin["fitness"] == pytest.approx(e["fitness"])
        assert e["family"] and (out / e["image"]).is_file()
        assert me.cells_of(np.array([list(e["descriptors"].values())]))[0] == e["cell"]
    assert (out / "elites.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "qd.png").read_bytes()[:4] == b"\x89PNG"

    history = []
    for _, arrays in archive.states(run_id):
        s = state_from_arrays(template, arrays)
        history.append((int(np.isfinite(np.asarray(s.inner.fitness)).sum()),
                        qd_score(s, QD_OFFSET)))
    assert len(history) == 3
    pairs = zip(history[:-1], history[1:], strict=True)
    assert all(a[0] <= b[0] and a[1] <= b[1] for a, b in pairs)
    assert history[-1][1] == pytest.approx(float(np.sum(fitness[np.isfinite(fitness)] + 1)))

    # the best elite, replayed with `simulate --config`, lands in its cell with its descriptors
    best = max(index["elites"], key=lambda e: e["fitness"])
    assert main(["simulate", "--config", str(out / best["run_file"]), "--out",
                 str(tmp_path / "replay"), "--quiet"]) == 0
    v = np.load(tmp_path / "replay" / "state.npz")["v"]
    replayed = describe(v.astype(np.float32))
    for name, value in best["descriptors"].items():
        assert float(replayed[name]) == pytest.approx(value, abs=1e-3)
