"""The Ray executor against a local Ray started on loopback: a generation split into batches
over workers gives exactly the in-process result."""


import jax
import numpy as np
import pytest

from morphogen.search.archive import Archive
from morphogen.search.evaluate import Problem
from morphogen.search.executors import LocalExecutor, RayExecutor
from morphogen.search.genes import preset_genes
from morphogen.search.run import evolve, start

ray = pytest.importorskip("ray", reason="the ray package is not installed (pip install ray)")
# Ray starts its processes with fork + exec; JAX's warning about fork does not apply to exec.
pytestmark = pytest.mark.filterwarnings("ignore:os.fork:RuntimeWarning")

PROBLEM = Problem(model="gray-scott", genes=tuple(preset_genes("gray-scott")),
                  preset="skaggs-table-3.1", size=(24, 24), dt=0.5, steps=120, init="skaggs")


def test_ray_batches_equal_the_local_evaluation_and_run(local_ray, tmp_path):
    rng = np.random.default_rng(0)
    genomes = np.stack([rng.uniform(0.02, 0.08, 7), rng.uniform(0.04, 0.06, 7)], 1)
    key = jax.random.PRNGKey(5)
    local, remote = LocalExecutor(PROBLEM), RayExecutor(PROBLEM, batches=3)
    seen = []
    f_ray, m_ray = remote.evaluate(genomes, key, seen.append)
    f_loc, m_loc = local.evaluate(genomes, key)
    assert sorted(seen) == [2, 2, 3] and remote.total(7) == 7
    np.testing.assert_allclose(f_ray, f_loc, rtol=1e-5, atol=1e-6)  # batches of 2, 2, 3 vs 7
    np.testing.assert_array_equal(m_ray["valid"], m_loc["valid"])
    np.testing.assert_allclose(m_ray["fields"], m_loc["fields"], rtol=1e-5, atol=1e-6)
    assert np.ptp(f_loc) > 0  # a real comparison: the individuals differ

    results = []
    for name, executor in (("local", local), ("ray", remote)):
        archive = Archive(tmp_path / f"{name}.sqlite")
        run_id, _ = start(PROBLEM, {"name": "ga", "population": 7}, generations=2, seed=4,
                          out=tmp_path / name, archive=archive)
        evolve(run_id, archive, executor, log=lambda s: None)
        results.append([(r["genome"], r["fitness"]) for r in archive.individuals(run_id)])
    assert results[0] == results[1] and len(results[0]) == 14


def test_map_elites_on_ray_equals_the_local_run(local_ray, tmp_path):
    results = []
    for name, executor in (("local", LocalExecutor(PROBLEM)),
                           ("ray", RayExecutor(PROBLEM, batches=2))):
        archive = Archive(tmp_path / f"{name}.sqlite")
        run_id, directory = start(PROBLEM, {"name": "map-elites", "population": 6},
                                  generations=2, seed=4, out=tmp_path / name, archive=archive)
        evolve(run_id, archive, executor, log=lambda s: None)
        state = archive.last_state(run_id)[1]
        assert (directory / "elites.png").is_file() and (directory / "qd.png").is_file()
        results.append(([(r["genome"], r["fitness"]) for r in archive.individuals(run_id)],
                        state))
    (local, local_state), (remote, remote_state) = results
    assert local == remote and len(local) == 12
    for k, v in local_state.items():
        np.testing.assert_array_equal(v, remote_state[k])
