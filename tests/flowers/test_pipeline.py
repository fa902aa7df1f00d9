"""Multi-stage mesh pipelines and the mesh/pipeline commands."""

from __future__ import annotations

import json

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.domains.ply import load_mesh
from morphogen.engine.simulate import simulate
from morphogen.errors import MorphogenError
from morphogen.flowers import petal, positional_information
from morphogen.flowers.pipeline import load_pipeline, run_pipeline
from morphogen.models.library import get_model

PIPELINE = """
seed = 3
[mesh]
shape = "petal"
edge = 0.08

[[stage]]
name = "positional"
kind = "positional"
field = "g"
sources = "margin"
sinks = "base"

[[stage]]
kind = "fields"
fields = { F = "0.03 + 0.02*g", half = "0.5*g" }

[[stage]]
kind = "points"
field = "seeds"
count = 5
density = "g"

[[stage]]
name = "gs"
kind = "simulate"
model = "gray-scott"
steps = 30
dt = 0.005
init = "uniform"
initial = { v = "where(seeds > 0, 0.25, v)" }
boundary = { u = "dirichlet=half@margin" }
outputs = { v = "v1" }
"""


def _write(tmp_path, text=PIPELINE):
    path = tmp_path / "p.toml"
    path.write_text(text)
    return path


@pytest.mark.slow
def test_stages_feed_each_other_and_match_a_direct_run(tmp_path):
    out = tmp_path / "out"
    mesh = run_pipeline(_write(tmp_path), out)
    base = petal(edge=0.08)
    g = positional_information(base, "margin", "base")
    assert np.allclose(mesh.fields["g"], g)
    assert np.allclose(mesh.fields["F"], 0.03 + 0.02 * g)
    assert (mesh.fields["seeds"] > 0).sum() == 5
    # the same run by hand: parameter field F, seeds as initial v, Dirichlet from a field
    model = get_model("gray-scott")
    domain = base.with_fields(half=0.5 * g).replace(boundary={"u": "dirichlet=half@margin"})
    params = {**model.parameters(), "F": (0.03 + 0.02 * g).astype(np.float32)}
    u0 = np.stack([np.ones(base.n_vertices), np.where(mesh.fields["seeds"] > 0, 0.25, 0.0)])
    direct = simulate(model, domain, u0.astype(np.float32), params, steps=30, dt=0.005, seed=3)
    assert np.allclose(mesh.fields["v1"], direct.state[1], atol=1e-6)
    assert np.allclose(mesh.fields["u"], direct.state[0], atol=1e-6)
    margin = base.vertex_set("margin")
    assert np.allclose(mesh.fields["u"][margin], 0.5 * g[margin], atol=1e-6)
    final = load_mesh(out / "final.ply")
    assert {"g", "F", "seeds", "u", "v1"} <= set(final.fields)
    record = json.loads((out / "pipeline.json").read_text())
    assert [s["kind"] for s in record["stages"]] == ["positional", "fields", "points", "simulate"]
    assert (out / "04-gs" / "out.png").is_file() and (out / "04-gs" / "state.npz").is_file()


@pytest.mark.slow
def test_resume_reuses_finished_stages(tmp_path):
    path = _write(tmp_path)
    first = run_pipeline(path, tmp_path / "out")
    again = run_pipeline(path, tmp_path / "out", resume=True)
    record = json.loads((tmp_path / "out" / "pipeline.json").read_text())
    assert all(s.get("resumed") for s in record["stages"])
    assert np.array_equal(first.fields["v1"], again.fields["v1"])
    changed = _write(tmp_path, PIPELINE.replace("steps = 30", "steps = 10"))
    run_pipeline(changed, tmp_path / "out", resume=True)
    record = json.loads((tmp_path / "out" / "pipeline.json").read_text())
    assert [bool(s.get("resumed")) for s in record["stages"]] == [True, True, True, False]


@pytest.mark.parametrize("text, message", [
    ("[[stage]]\nkind = 'fields'\n", "needs a \\[mesh\\]"),
    ("[mesh]\nshape = 'petal'\n", "no \\[\\[stage\\]\\]"),
    ("[mesh]\nshape = 'petal'\n[[stage]]\nkind = 'magic'\n", "kind must be"),
    ("[mesh]\nshape = 'petal'\n[[stage]]\nkind = 'fields'\ncolour = 1\n", "unknown keys"),
    ("[mesh]\nshape = 'petal'\n[[stage]]\nkind = 'fields'\nfields = { a = 'nope + 1' }\n",
     "nope"),
    ("[mesh]\nshape = 'cube'\n[[stage]]\nkind = 'fields'\nfields = { a = '1' }\n", "shape"),
    ("[mesh\n", "pipeline file"),
    ("seed = " + "[" * 5000 + "]" * 5000 + "\n", "nested more than"),
])
def test_bad_pipelines_are_rejected(tmp_path, text, message):
    with pytest.raises(MorphogenError, match=message):
        run_pipeline(_write(tmp_path, text), tmp_path / "out")


def test_commands(tmp_path, capsys):
    ply = tmp_path / "c.ply"
    assert main(["mesh", "make", "corolla", "--petals", "6", "--edge", "0.1", "--out",
                 str(ply)]) == 0
    mesh = load_mesh(ply)
    assert mesh.fields["petal"].max() == 5 and mesh.vertex_set("margin").size > 10
    assert main(["mesh", "info", str(ply)]) == 0
    assert "triangles" in capsys.readouterr().out
    assert main(["mesh", "make", "petal", "--petals", "3", "--out", str(ply)]) == 2
    assert main(["pipeline", "run", str(_write(tmp_path)), "--out", str(tmp_path / "o"),
                 "--quiet"]) == 0
    assert (tmp_path / "o" / "final.ply").is_file()
    assert main(["pipeline", "run", str(tmp_path / "missing.toml"), "--out",
                 str(tmp_path / "x")]) == 2
    assert not (tmp_path / "x").exists()
    assert load_pipeline(_write(tmp_path))["stage"][0]["kind"] == "positional"
