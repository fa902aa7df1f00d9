"""The Ray executors against one local Ray started on loopback (one start for the file, about
7 s): a generation of parameter genomes or of reaction networks split into batches over Ray
workers gives the in-process result, and runs with them the same history."""


import jax
import numpy as np
import pytest

from morphogen.search.archive import Archive
from morphogen.search.evaluate import Problem
from morphogen.search.executors import LocalExecutor, RayExecutor
from morphogen.search.genes import preset_genes
from morphogen.search.networks.evolve import Evaluation, evaluate, initial_state, run
from morphogen.search.networks.genome import stack, table2_genome, table2_spec
from morphogen.search.networks.operators import Operators
from morphogen.search.run import evolve, start

ray = pytest.importorskip("ray", reason="the ray package is not installed (pip install ray)")
# Ray starts its processes with fork + exec; JAX's warning about fork does not apply to exec.
pytestmark = pytest.mark.filterwarnings("ignore:os.fork:RuntimeWarning")

PROBLEM = Problem(model="gray-scott", genes=tuple(preset_genes("gray-scott")),
                  preset="skaggs-table-3.1", size=(24, 24), dt=0.5, steps=120, init="skaggs")
EV = Evaluation(size=8, dt=0.5, t_start=10.0, interval=5.0, rounds=2)

@pytest.mark.slow
def test_parameter_batches_on_ray_equal_the_local_evaluation_and_run(local_ray, tmp_path):
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


@pytest.mark.slow
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


@pytest.mark.slow
def test_network_batches_on_ray_equal_the_local_evaluation_and_run(local_ray, tmp_path):
    from morphogen.search.networks.ray_workers import RayNetworkEvaluator

    spec = table2_spec()
    g = table2_genome(spec)
    pop = stack([g._replace(mantissa=g.mantissa.at[j].set(m))
                 for j, m in ((3, 10), (3, 30), (6, 50), (7, 20), (8, 99))])
    u0 = initial_state(jax.random.key(4), spec, EV)
    remote = RayNetworkEvaluator(batches=2)
    seen = []
    f_ray, states = remote(pop, u0, spec, EV, seen.append)
    f_loc, _ = evaluate(pop, u0, spec, EV)
    assert states is None and sum(seen) == EV.start_steps + EV.round_steps and len(seen) == 2
    np.testing.assert_allclose(f_ray, f_loc, rtol=1e-5, atol=1e-4)  # batches of 3, 2 vs 5
    assert np.ptp(f_loc) > 0  # a real comparison: the individuals differ

    kw = dict(ops=Operators(mode="rates"), ev=EV, population=5, generations=2, seed=2,
              log=lambda s: None)
    _, _, local = run(spec, g, tmp_path / "local", **kw)
    _, _, spread = run(spec, g, tmp_path / "ray", evaluator=remote, **kw)
    np.testing.assert_allclose(spread, local, rtol=1e-5, atol=1e-4)
    assert local.shape == (2, 5)


@pytest.mark.slow
def test_cli_ray_run_records_the_local_history(local_ray, tmp_path):
    from morphogen.cli.main import main

    args = ["networks", "--mode", "rates", "--population", "4", "--size", "8", "--dt", "0.5",
            "--t-start", "10", "--interval", "5", "--rounds", "2", "--generations", "1",
            "--seed", "5", "--quiet", "--archive", str(tmp_path / "index.sqlite")]
    assert main(args + ["--out", str(tmp_path / "local")]) == 0
    assert main(args + ["--out", str(tmp_path / "ray"), "--executor", "ray",
                        "--batches", "2"]) == 0
    local = np.loadtxt(tmp_path / "local" / "history.csv", delimiter=",")
    spread = np.loadtxt(tmp_path / "ray" / "history.csv", delimiter=",")
    np.testing.assert_allclose(spread, local, rtol=1e-5, atol=1e-3)
