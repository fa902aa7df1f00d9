"""The veins pipeline stage and ``morphogen mesh veins``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.domains.ply import load_mesh, save_ply
from morphogen.errors import MorphogenError
from morphogen.flowers import corolla, space_colonisation, vein_fields
from morphogen.flowers.pipeline import run_pipeline

PIPELINE = """
seed = 5
[mesh]
shape = "corolla"
edge = 0.06

[[stage]]
kind = "veins"
seeds = "throat"
points = 400

[[stage]]
kind = "fields"
fields = { pigment = "exp(-vein_distance / 0.05)" }
show = "pigment"
"""


def test_veins_stage_feeds_later_stages(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text(PIPELINE)
    mesh = run_pipeline(path, tmp_path / "out")
    base = corolla(edge=0.06)
    direct = vein_fields(base, space_colonisation(base, base.vertex_set("throat"), points=400,
                                                  seed=5))
    for key in ("vein", "vein_thickness", "vein_distance"):
        assert np.array_equal(mesh.fields[key], direct[key])
    assert np.allclose(mesh.fields["pigment"], np.exp(-direct["vein_distance"] / 0.05))
    with np.load(tmp_path / "out" / "01-veins" / "veins.npz") as graph:
        assert graph["parent"][0] == -1 and len(graph["edges"]) == len(graph["nodes"]) - len(
            graph["seeds"])
    assert (tmp_path / "out" / "01-veins" / "out.png").is_file()
    assert (tmp_path / "out" / "02-fields" / "out.png").is_file()


@pytest.mark.parametrize("stage, message", [
    ("kind = 'veins'\n", "needs seeds"),
    ("kind = 'veins'\nseeds = 'nowhere + 1'\n", "nowhere"),
    ("kind = 'veins'\nseeds = 'throat'\npoints = 0\n", "attraction points"),
    ("kind = 'veins'\nseeds = 'throat'\npoints = 2.5\n", "points must be an integer"),
    ("kind = 'veins'\nseeds = 'where(x > 9, 1, 0)'\n", "select no vertex"),
    ("kind = 'veins'\nseeds = 'throat'\nkill = 0.001\n", "step < kill"),
    ("kind = 'veins'\nseeds = 'throat'\ndensity = 'nofield'\n", "nofield"),
    ("kind = 'veins'\nseeds = 'throat'\nshow = 'nofield'\n", "nofield"),
])
def test_bad_veins_stages(tmp_path, stage, message):
    path = tmp_path / "p.toml"
    path.write_text(f"[mesh]\nshape = 'corolla'\nedge = 0.1\n[[stage]]\n{stage}")
    with pytest.raises(MorphogenError, match=message):
        run_pipeline(path, tmp_path / "out")


def _tips(parent: np.ndarray) -> int:
    """Vein tips: nodes that are nobody's parent."""
    return int(np.sum(~np.isin(np.arange(len(parent)), parent)))


def test_mesh_veins_command(tmp_path, capsys):
    src = tmp_path / "c.ply"
    save_ply(src, corolla(edge=0.06))
    out = tmp_path / "v.ply"
    assert main(["mesh", "veins", str(src), "--out", str(out), "--seeds", "throat",
                 "--points", "300", "--png"]) == 0
    assert "vein nodes" in capsys.readouterr().out
    mesh = load_mesh(out)
    vein = mesh.fields["vein"]
    assert set(np.unique(vein)) == {0.0, 1.0}
    assert np.all(mesh.fields["vein_distance"][vein > 0] == 0)
    assert mesh.fields["vein_distance"][vein == 0].min() > 0
    with np.load(tmp_path / "v.veins.npz") as graph:
        assert graph["nodes"].shape[1] == 3
    assert (tmp_path / "v.png").is_file()
    lengths = ["--points", "200", "--step", "0.05", "--kill", "0.1", "--influence", "0.5"]
    tips = {}
    for name, extra in (("a", []), ("b", ["--refill", "30"]),
                        ("c", ["--refill", "30", "--min-branch", "0.2"])):
        assert main(["mesh", "veins", str(src), "--out", str(tmp_path / f"{name}.ply"),
                     "--seeds", "throat", *lengths, *extra]) == 0
        with np.load(tmp_path / f"{name}.veins.npz") as graph:
            tips[name] = _tips(graph["parent"])
    assert tips["b"] > tips["a"]  # points drawn as the surface fills grow more branches
    assert 0 < tips["c"] < tips["b"] / 2  # and pruning removes the short terminal ones
    bad = tmp_path / "bad.ply"
    assert main(["mesh", "veins", str(src), "--out", str(bad), "--seeds", "throat",
                 "--points", "0"]) == 2
    assert main(["mesh", "veins", str(src), "--out", str(bad), "--seeds", "nofield"]) == 2
    assert not bad.exists() and not (tmp_path / "bad.veins.npz").exists()


def test_platycodon_example_at_reduced_size(tmp_path):
    from morphogen.flowers.pipeline import load_pipeline

    spec = load_pipeline("examples/flowers/platycodon.toml")
    assert spec["mesh"]["shape"] == "bell" and spec["mesh"]["point"] > 0  # pointed lobes
    spec["mesh"]["edge"] = 0.04
    veins = spec["stage"][0]
    assert veins["refill"] > 0 and veins["min_branch"] > 2 * veins["step"]
    veins.update(points=100, refill=40, step=0.08, kill=0.1, birth=0.16, influence=0.5,
                 min_branch=0.24)
    mesh = run_pipeline(spec, tmp_path / "out")
    f = mesh.fields
    vein = f["vein"] > 0.5
    record = json.loads((tmp_path / "out" / "pipeline.json").read_text())["stages"][0]
    assert record["stub_share"] == 0.0 and record["max_order"] >= 2  # twigs pruned
    # one main vein per petal, rooted at the pedicel, reaching every lobe
    with np.load(tmp_path / "out" / "01-veins" / "veins.npz") as graph:
        assert len(graph["seeds"]) == 5
    for lobe in range(5):
        assert vein[(f["lobe"] == lobe) & (f["s"] > 1.3)].any()
    # pigment is 1 on the veins and falls off as exp(-d / 0.025) away from them
    assert np.all(f["pigment"][vein] == 1.0)
    assert np.allclose(f["pigment"], np.exp(-f["vein_distance"] / 0.025))
    assert f["pigment"][~vein].max() < 1.0 and f["pigment"][~vein].min() < 0.01


@pytest.mark.slow
def test_dianthus_example_at_reduced_size(tmp_path):
    from morphogen.flowers.pipeline import load_pipeline

    spec = load_pipeline("examples/flowers/dianthus.toml")
    assert spec["mesh"]["shape"] == "dianthus"  # the five-petal flower of fig. 12
    spec["mesh"]["edge"] = 0.175  # final units (scale 5)
    spec["stage"][0].update(points=1500, step=0.3, kill=0.7, influence=3.0)
    spec["stage"][2].update(steps=300, dt=1e-3, omega=1e9)  # t = 0.3, as 3 000 steps of 1e-4
    mesh = run_pipeline(spec, tmp_path / "out")
    f = mesh.fields
    band, vein, m = f["band"] > 0.5, f["vein"] > 0.5, f["m"]
    assert np.allclose(m[band], 1.0) and np.allclose(m[(f["s"] < 0.12) & ~band], 0.0)
    assert np.allclose(f["D"], np.where(vein, 3.0, 0.0075))
    # beyond the band, the morphogen has gone further along the veins than beside them
    ahead = (f["s"] > 0.42) & (f["s"] < 0.6)
    assert np.median(m[ahead & vein]) > 10 * np.median(m[ahead & ~vein])
    assert m[(f["margin"] > 0.5) & (f["s"] > 0.8)].max() < 0.05  # stopped before the margin
    assert np.allclose(f["pigment"], 1 / (1 + np.exp(-(m - 0.3) / 0.03)))
    # every petal has its own veins, each vein on its own petal (same_piece)
    with np.load(tmp_path / "out" / "01-veins" / "veins.npz") as graph:
        organ_of_face = f["organ"][mesh.faces[:, 0]]
        node_organ = organ_of_face[graph["face"]]
        root_organ = f["organ"][graph["seeds"]]
        assert set(np.unique(root_organ)) == {0.0, 1.0, 2.0, 3.0, 4.0}
        edges = graph["edges"]
        assert np.all(node_organ[edges[:, 0]] == node_organ[edges[:, 1]])
    for k in range(5):
        assert (vein & (f["organ"] == k)).sum() > 20


def test_overlay_veins_mixes_by_thickness():
    from morphogen.render.mesh import overlay_veins

    base = np.full((3, 3), 0.5)
    out = overlay_veins(base, np.array([0.0, 1.0, 1.0]), np.array([0.0, 1.0, 2.0]),
                        colour="#000000")
    # off veins unchanged; weight 0.6 + 0.4 t / t_max towards black on veins
    assert out.dtype == np.uint8
    assert np.allclose(out, [[127.5] * 3, [255 * 0.5 * 0.2] * 3, [0] * 3], atol=0.51)
