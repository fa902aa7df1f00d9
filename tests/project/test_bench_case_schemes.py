"""The case-study scheme benchmark (bench/bench_case_schemes.py) runs each case study's simulate
stage as the pipeline runs it, and judges pictures as it says."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest

from bench import bench_case_schemes as bench
from morphogen.engine.simulate import simulate
from morphogen.flowers.pipeline import load_pipeline, run_pipeline


@pytest.mark.slow
def test_prepared_stage_equals_the_pipeline_stage() -> None:
    """Arctostaphylos (stochastic, Dirichlet margins, a parameter expression), 20 steps: the
    benchmark's inputs give the pipeline's own final state, bit for bit."""
    file, stage = bench.CASES["arctostaphylos"]
    spec = load_pipeline(bench.EXAMPLES / file)
    stages = [{**s, "steps": 20} if s.get("name") == stage else s for s in spec["stage"]]
    k = [s.get("name") for s in stages].index(stage)
    with tempfile.TemporaryDirectory() as tmp:
        run_pipeline({**spec, "stage": stages[:k + 1]}, tmp, pictures=False)
        with np.load(next(Path(tmp).glob(f"{k + 1:02d}-*")) / "state.npz") as data:
            piped = data["m"]
    case = bench.prepare(file, stage)
    assert case.domain.omega == 1e7 and case.show == "pigment"
    sol = simulate(case.model, case.domain, case.u0, case.params, steps=20, dt=case.dt,
                   seed=case.seed)
    np.testing.assert_array_equal(sol.state[0], piped)
    picture, pigment = case.picture(sol.state)
    assert picture.shape == (case.mesh.n_vertices,) and pigment is not None


def test_compare() -> None:
    """Pearson correlation and relative L2; a uniform field has no correlation."""
    ref = np.array([0.0, 1.0, 2.0, 3.0])
    same = bench._compare(2 * ref + 1, ref)
    assert same["correlation"] == pytest.approx(1.0)
    assert same["relative_l2"] == pytest.approx(np.linalg.norm(ref + 1) / np.linalg.norm(ref))
    assert bench._compare(np.ones(4), ref)["correlation"] is None
