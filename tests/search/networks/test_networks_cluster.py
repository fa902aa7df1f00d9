"""Cluster-head fitness on hand-built states (Yamamoto §3.3, §4; Table 1 values)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.search.networks.cluster import cell_fitness, cluster_head_fitness


def _state(size=32):
    return np.zeros((3, size, size), np.float32)


def test_single_peak_by_hand():
    # one isolated peak: 0.75; the other 112 cells of the radius-6 disk (113 lattice points,
    # Gauss circle) are alive: 112; the remaining 1024 - 113 = 911 cells are dead: 227.75
    u = _state()
    u[0, 5, 5] = 5.0
    f = np.asarray(cluster_head_fitness()(jnp.asarray(u[None])))
    assert f[0] == 340.5
    u2 = _state()
    u2[0, 0, 0] = 5.0  # the disk wraps around the torus: same score
    assert float(cluster_head_fitness()(jnp.asarray(u2[None]))[0]) == 340.5


def test_crowded_peaks_by_hand():
    # two tied peaks side by side on 8x8, d_max = 1.5: each 0.5 (the other is 1 < 1.5 away);
    # alive = the 3x4 block around them minus the peaks = 10; dead = 64 - 12 = 52 -> 13
    u = _state(8)
    u[0, 1, 1] = u[0, 1, 2] = 4.0
    assert float(cluster_head_fitness(d_max=1.5)(jnp.asarray(u[None]))[0]) == 24.0


@pytest.mark.slow
def test_stages_and_thresholds():
    u = _state()
    u[0, 5, 5] = 2.9  # below a_peak: no peaks, every cell dead
    flat = np.full((3, 32, 32), 5.0, np.float32)
    nan = _state()
    nan[0, 5, 5] = 5.0
    nan[1, 20, 20] = np.nan
    big = _state()
    big[2, 3, 3] = 150.0  # beyond s_max = 100
    f = np.asarray(cluster_head_fitness()(jnp.asarray(np.stack([u, flat, nan, big]))))
    np.testing.assert_array_equal(f, [256.0, 0.0, -1.0, -1.0])
    # per cell, the invalid cell scores 0 instead of the 0.25 of a dead cell
    assert float(jnp.sum(cell_fitness(jnp.asarray(nan)))) == 340.25
    norm = cluster_head_fitness(normalise=True)(jnp.asarray(u[None]))
    assert float(norm[0]) == 0.25


@pytest.mark.slow
def test_cluster_fitness_serves_ordinary_parameter_searches():
    from morphogen.search.evaluate import Evaluator, Problem
    from morphogen.search.genes import preset_genes

    problem = Problem(model="gierer-meinhardt", genes=tuple(preset_genes("gierer-meinhardt")),
                      preset="skaggs-table-3.1", size=(16, 16), dt=0.05, steps=60,
                      fitness="cluster")
    ev = Evaluator(problem)
    genomes = np.asarray([[0.25 * g.low + 0.75 * g.high for g in problem.genes],
                          [0.5 * (g.low + g.high) for g in problem.genes]], np.float32)
    fitness, metrics = ev(genomes, jax.random.PRNGKey(0))
    again = cluster_head_fitness(normalise=True)(jnp.asarray(metrics["fields"][:, None]))
    np.testing.assert_allclose(fitness, np.asarray(again), rtol=1e-6)
    assert ((fitness > 0) & (fitness <= 1)).all()
