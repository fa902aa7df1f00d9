"""Reporting implicit diffusion solves that stop at their iteration cap (solve_watch.py)."""

from __future__ import annotations

import json

import jax.numpy as jnp
import numpy as np
import pytest
import trimesh

from morphogen.domains.mesh import Mesh
from morphogen.engine.simulate import simulate
from morphogen.engine.solve_watch import REPORT_RATIO, SolveWatch
from morphogen.errors import MorphogenWarning
from morphogen.solvers import imex_cg
from tests.solvers.test_imex_cg import linear

P = {"k": np.float32(0.0), "D": np.float32(0.5)}


@pytest.fixture(scope="module")
def sphere() -> Mesh:
    s = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    return Mesh(s.vertices, s.faces, name="icosphere")


def _u0(mesh: Mesh) -> np.ndarray:
    return np.random.default_rng(0).random((1, mesh.n_vertices)).astype(np.float32)


@pytest.mark.slow
def test_a_converged_solve_is_within_its_threshold_and_not_reported(sphere):
    heat = linear("field")
    watch = SolveWatch.for_run(heat, sphere, P, "imex", batched=False)
    p = {k: jnp.asarray(v) for k, v in P.items()}
    for dt in (0.1, 1e2, 1e4):  # 15x to 1.5 million x the explicit limit
        ratio = float(watch.probe(jnp.asarray(_u0(sphere)), p, jnp.float32(0), jnp.float32(dt))[0])
        assert 0.0 < ratio <= 1.0
    sol = simulate(heat, sphere, _u0(sphere), P, steps=4, dt=100.0, scheme="imex", every=2)
    assert sol.warnings == []


def test_a_solve_stopped_at_the_cap_is_reported_with_species_and_step(sphere, monkeypatch):
    monkeypatch.setattr(imex_cg, "CG_MAXITER", 2)
    heat = linear("field")  # a new model: its steps compile with the lowered cap
    ratio = SolveWatch.for_run(heat, sphere, P, "imex", batched=False).probe(
        jnp.asarray(_u0(sphere)), {k: jnp.asarray(v) for k, v in P.items()}, jnp.float32(0),
        jnp.float32(100.0))
    assert float(ratio[0]) > REPORT_RATIO
    with pytest.warns(MorphogenWarning, match=r"species field0 stopped at its 2-iteration cap"):
        sol = simulate(heat, sphere, _u0(sphere), P, steps=4, dt=100.0, scheme="imex", every=2)
    assert len(sol.warnings) == 1 and "after step 2" in sol.warnings[0]
    assert "use a smaller --dt" in sol.warnings[0]


def test_exact_fourier_solves_and_explicit_schemes_are_not_watched(sphere):
    from morphogen.domains.grid import Grid

    heat = linear("scalar")
    assert SolveWatch.for_run(heat, Grid((16, 16)), P, "imex", batched=False) is None
    assert SolveWatch.for_run(heat, sphere, P, "imex", batched=False) is not None
    assert SolveWatch.for_run(heat, sphere, P, "euler", batched=False) is None
    field = linear("field")
    assert SolveWatch.for_run(field, Grid((16, 16)), P, "imex1", batched=False) is not None


@pytest.mark.slow
def test_the_command_line_prints_the_warning_on_one_line_and_records_it(tmp_path, monkeypatch):
    from tests.cli.test_cli import run_cli

    monkeypatch.setattr(imex_cg, "CG_MAXITER", 1)
    out = tmp_path / "run"
    r = run_cli("simulate", "examples/turing-anisotropic.toml", "--size", "24x24", "--steps",
                "4", "--dt", "3", "--scheme", "imex", "--out", str(out))
    assert r.returncode == 0, r.stderr
    lines = [line for line in r.stderr.splitlines() if "warning" in line]
    assert len(lines) == 1 and lines[0].startswith("morphogen: warning: the implicit diffusion")
    assert "species v stopped at its 1-iteration cap" in lines[0]
    record = json.loads((out / "run.json").read_text())
    assert record["resolved"]["warnings"] == [lines[0].removeprefix("morphogen: warning: ")]
