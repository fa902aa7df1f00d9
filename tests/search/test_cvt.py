"""CVT-MAP-Elites: k-means centroids against the known centroidal tessellations, and cells as
nearest centroids."""

import jax
import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.search.cvt import CVTMapElites, kmeans_centroids
from morphogen.search.genes import Gene


@pytest.mark.slow
def test_kmeans_on_an_interval_gives_equal_cells():
    # the centroidal Voronoi tessellation of [0, 1] with K points: (2j + 1) / (2K)
    c = np.sort(kmeans_centroids(4, 1, 20_000, seed=1)[:, 0])
    np.testing.assert_allclose(c, [0.125, 0.375, 0.625, 0.875], atol=0.01)
    np.testing.assert_array_equal(kmeans_centroids(4, 1, 20_000, seed=1)[:, 0],
                                  kmeans_centroids(4, 1, 20_000, seed=1)[:, 0])


def test_kmeans_in_a_square_gives_centres_of_mass():
    c = kmeans_centroids(16, 2, 20_000, seed=0, iterations=100)
    x = np.asarray(jax.random.uniform(jax.random.PRNGKey(5), (50_000, 2)))
    nearest = np.argmin(((x[:, None] - c[None]) ** 2).sum(-1), axis=1)
    for j in range(16):  # each centroid is the mean of its own region (fresh samples)
        np.testing.assert_allclose(x[nearest == j].mean(0), c[j], atol=0.02)
    counts = np.bincount(nearest, minlength=16) / len(x)
    assert counts.min() > 0.5 / 16 and counts.max() < 1.5 / 16


@pytest.mark.slow
def test_cells_are_nearest_centroids_and_the_archive_keeps_its_invariant():
    me = CVTMapElites(population_size=4, descriptors=("spot_index", "coherence"),
                      centroids=10, samples=2000)
    assert me.cell_count == 10
    lo, hi = np.array([-1.5, 0.0]), np.array([1.5, 1.0])
    values = lo + me.points * (hi - lo)
    np.testing.assert_array_equal(np.asarray(me.cells_of(values)), np.arange(10))
    genes = [Gene("a", 0.0, 1.0, 0.1)]
    state = me.init(jax.random.PRNGKey(0), genes)
    assert state.inner.fitness.shape == (10,)
    fields = np.zeros((4, 16, 16), np.float32)  # uniform: all in one cell, the fittest wins
    genomes = np.array([[0.1], [0.2], [0.3], [0.4]], np.float32)
    state, _ = me.tell(genomes, np.array([0.5, 2.0, 1.0, 2.0], np.float32), state,
                       fields=fields)
    f = np.asarray(state.inner.fitness)
    assert np.isfinite(f).sum() == 1 and f[np.isfinite(f)][0] == 2.0
    assert np.asarray(state.inner.genomes)[np.isfinite(f)][0, 0] == pytest.approx(0.2)
    with pytest.raises(MorphogenError, match="centroids"):
        CVTMapElites(population_size=4, centroids=20, samples=10)


@pytest.mark.slow
def test_evolve_cvt_map_elites_writes_its_elites(tmp_path, quality_diversity_run):
    import json


    out = tmp_path / "run"
    quality_diversity_run(tmp_path / "index.sqlite", out, 2, 1, strategy="cvt-map-elites")
    index = json.loads((out / "elites" / "index.json").read_text())
    me = CVTMapElites(population_size=6)
    assert index["cells"] == 64 and np.allclose(index["grid"]["centroids"], me.points)
    assert 1 <= len(index["elites"]) <= 12
    for e in index["elites"]:
        assert e["bins"] is None
        assert int(me.cells_of(np.array([list(e["descriptors"].values())]))[0]) == e["cell"]
    assert (out / "qd.png").is_file() and not (out / "elites.png").exists()
