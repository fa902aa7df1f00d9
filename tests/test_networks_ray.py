"""Network populations split over Ray workers (a local Ray on loopback) give the in-process
fitness, and a run with them the same history."""


import jax
import numpy as np
import pytest

from morphogen.search.networks.evolve import Evaluation, evaluate, initial_state, run
from morphogen.search.networks.genome import stack, table2_genome, table2_spec
from morphogen.search.networks.operators import Operators

ray = pytest.importorskip("ray", reason="the ray package is not installed (pip install ray)")
pytestmark = pytest.mark.filterwarnings("ignore:os.fork:RuntimeWarning")

EV = Evaluation(size=8, dt=0.5, t_start=10.0, interval=5.0, rounds=2)


def test_ray_batches_equal_the_local_evaluation_and_run(local_ray, tmp_path):
    from morphogen.search.networks.executors import RayNetworkEvaluator

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
