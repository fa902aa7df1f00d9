"""Mesh size: ``edge`` is the final mean edge after ``scale`` in ``mesh make`` and in pipelines,
the vertex count is estimated before meshing, and every shape is reachable from the CLI."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.cli.mesh_cmd import SHAPES as CLI_SHAPES
from morphogen.domains.ply import load_mesh
from morphogen.errors import MorphogenError
from morphogen.flowers import SHAPES, estimate_vertices, make_shape, petal, tube, two_lipped
from morphogen.flowers.pipeline import build_mesh


def test_edge_is_the_final_edge_in_mesh_make_and_in_pipelines(tmp_path: Path) -> None:
    ply = tmp_path / "petal.ply"
    assert main(["mesh", "make", "petal", "--edge", "1.5", "--scale", "20", "--out",
                 str(ply)]) == 0
    made = load_mesh(ply)
    piped = build_mesh({"shape": "petal", "edge": 1.5, "scale": 20.0})
    assert made.n_vertices == piped.n_vertices
    np.testing.assert_allclose(made.vertices, piped.vertices, rtol=1e-6, atol=1e-5)
    # the requested length in final units, on a petal 20 units long
    assert piped.edge_length == pytest.approx(1.5, rel=0.15)
    np.testing.assert_allclose(piped.vertices, 20.0 * petal(edge=1.5 / 20.0).vertices)


@pytest.mark.parametrize("shape", ["petal", "corolla", "orchid", "bell"])
def test_the_estimate_is_near_the_count(shape: str) -> None:
    actual = make_shape(shape, edge=0.025).n_vertices
    assert estimate_vertices(shape, 0.025) == pytest.approx(actual, rel=0.12)


def test_absurd_requests_are_refused_before_meshing(tmp_path: Path, capsys,
                                                    monkeypatch) -> None:
    import triangle

    ply = tmp_path / "tube.ply"
    made, triangulate = [], triangle.triangulate

    def counted(*args, **kwargs):
        out = triangulate(*args, **kwargs)
        made.append(len(out["triangles"]))
        return out

    monkeypatch.setattr(triangle, "triangulate", counted)
    assert main(["mesh", "make", "tube", "--edge", "0.02", "--scale", "50", "--out",
                 str(ply)]) == 2
    err = capsys.readouterr().err.strip()
    assert sum(made) < 10**5  # not 10 minutes of meshing: at most a coarse outline's estimate
    assert len(err.splitlines()) == 1 and not ply.exists()
    # about 2A/(sqrt(3) e^2) vertices: a tube of area ~3.6 at scale 1, edge 0.02/50
    count = int(err.split("about ")[1].split(" vertices")[0].replace(",", ""))
    area = make_shape("tube", edge=0.03).areas.sum()
    assert count == pytest.approx(2 * area / (np.sqrt(3) * 0.0004**2), rel=0.1)
    assert "over the limit of 2,000,000; use edge >=" in err
    with pytest.raises(MorphogenError, match=r"^\[mesh\] tube with edge 0.02 .* about "):
        build_mesh({"shape": "tube", "edge": 0.02, "scale": 50.0})
    with pytest.raises(MorphogenError, match="scale must be a positive number"):
        build_mesh({"shape": "tube", "edge": 0.02, "scale": -1.0})


def test_every_shape_is_available_from_mesh_make(tmp_path: Path) -> None:
    assert CLI_SHAPES == SHAPES
    for shape in ("bell", "two_lipped", "urn", "orchid"):
        ply = tmp_path / f"{shape}.ply"
        assert main(["mesh", "make", "--shape", shape, "--edge", "0.08", "--out",
                     str(ply)]) == 0
        assert load_mesh(ply).n_vertices > 50
    ply = tmp_path / "column.ply"
    assert main(["mesh", "make", "--shape", "orchid", "--set", "column=0.3", "--edge", "0.07",
                 "--out", str(ply)]) == 0
    assert load_mesh(ply).fields["column"].sum() > 0


def test_two_lipped_lobes_and_bad_options(tmp_path: Path, capsys) -> None:
    mesh = two_lipped(lobes=5, upper=0.6, lower=1.2, edge=0.06)
    f = mesh.fields
    reach = [f["s"][f["lobe"] == k].max() for k in range(5)]
    # lobes 1 and 2 (sin theta > 0) form the small upper lip
    assert max(reach[1:3]) < min(reach[0], reach[3], reach[4])
    same = tube(5, 0.9, 0.22, lobe_length=0.35, lobe_scales=[1.2, 0.6, 0.6, 1.2, 1.2],
                edge=0.06, flare=45.0, bend=0.25, notch=0.05)
    np.testing.assert_array_equal(mesh.vertices, same.vertices)
    out = str(tmp_path / "x.ply")
    assert main(["mesh", "make", "petal", "--set", "flare=40", "--out", out]) == 2
    assert "--flare do(es) not apply to a petal" in capsys.readouterr().err
    assert main(["mesh", "make", "--out", out]) == 2
    assert "name one shape" in capsys.readouterr().err
    assert not Path(out).exists()
