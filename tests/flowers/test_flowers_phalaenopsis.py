"""Phalaenopsis Nankung's 4.55PM (Ringham et al. 2021, §4.9): on the orchid mesh, random seed
points of the activator-substrate model coalesce into fewer, larger blotches, and isolated
points fade."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError
from morphogen.flowers import Organ, assemble, orchid, petal
from morphogen.flowers.pipeline import build_mesh, load_pipeline, run_pipeline
from tests.paths import EXAMPLES

pytestmark = pytest.mark.slow

EXAMPLE = EXAMPLES / "flowers" / "phalaenopsis-nankung.toml"


def _patches(mesh: Mesh, mask: np.ndarray) -> np.ndarray:
    """Sizes (in vertices) of the connected patches of ``mask`` over mesh edges."""
    e = mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    keep = mask[e[:, 0]] & mask[e[:, 1]]
    n = mesh.n_vertices
    graph = coo_matrix((np.ones(keep.sum()), (e[keep, 0], e[keep, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    return np.unique(label[mask], return_counts=True)[1]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The pipeline on a 5 400-vertex orchid (same edge, 1.2 units, so the same dt), 800 seeds
    (the shipped seed density), stopped after 30 and after 175 steps."""
    out = {}
    for steps in (30, 175):
        spec = load_pipeline(EXAMPLE)
        spec["mesh"] = {**spec["mesh"], "edge": 1.2, "scale": 100.0}
        spec["stage"][0]["count"] = 800
        spec["stage"][1]["steps"] = steps
        out[steps] = run_pipeline(spec, tmp_path_factory.mktemp(f"phal{steps}"))
    return out


def test_the_file_has_the_fig20_parameters_and_table1_steps() -> None:
    spec = load_pipeline(EXAMPLE)
    points, sim = spec["stage"]
    assert (points["count"], points["low"], points["high"]) == (5000, 0.0, 1.0)
    assert (sim["model"], sim["preset"], sim["steps"], sim["dt"]) == (
        "activator-substrate", "phalaenopsis", 175, 0.3)
    assert spec["mesh"]["shape"] == "orchid"


def test_seed_points_coalesce_into_fewer_larger_blotches(runs) -> None:
    seeds = runs[175].fields["seeds"] > 0
    clusters = len(_patches(runs[175], seeds))
    assert clusters > 450  # 800 points: mostly single vertices at the start
    early, late = (_patches(m, m.fields["a"] > 0.3) for m in (runs[30], runs[175]))
    # coalescence: the number of blotches keeps falling, their size keeps growing
    assert len(late) < len(early) < clusters / 5
    assert np.median(late) > 2 * np.median(early) and np.median(late) > 20
    # isolated points disappear: a third of the seed vertices end below 0.1
    a = runs[175].fields["a"]
    assert 0.2 < float(np.mean(a[seeds] < 0.1)) < 0.6
    assert float(a.max()) < 1.0 and float(runs[175].fields["substrate"].min()) >= 0.0


def test_orchid_organs_are_separate_blades() -> None:
    mesh = orchid(edge=0.03)
    f = mesh.fields
    assert sorted(np.unique(f["organ"])) == [0, 1, 2, 3, 4, 5]
    assert (f["sepal"] + f["petal"] + f["lip"] == 1).all()
    assert [int(f[k][f["organ"] == i][0]) for i, k in enumerate(
        ["sepal", "sepal", "sepal", "petal", "petal", "lip"])] == [1] * 6
    e = mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    assert np.all(f["organ"][e[:, 0]] == f["organ"][e[:, 1]])  # no edge joins two organs
    assert len(_patches(mesh, np.ones(mesh.n_vertices, bool))) == 6
    assert f["r"].max() == pytest.approx(1.0) and f["s"].max() == pytest.approx(1.0, abs=0.01)
    # the dorsal sepal points up (+y), the lip down; petals lie in front of the sepals
    assert mesh.vertices[f["organ"] == 0, 1].min() > 0 > mesh.vertices[f["lip"] > 0, 1].max()
    assert mesh.vertices[f["petal"] > 0, 2].mean() > mesh.vertices[f["sepal"] > 0, 2].mean()


def test_assemble_places_a_blade_by_angle_offset_and_lift() -> None:
    blade = petal(edge=0.1)
    mesh = assemble([Organ(blade, "petal", 0.0, 0.5, 0.2)])
    base = mesh.vertices[mesh.fields["base"] > 0.5]
    np.testing.assert_allclose(base[:, 0], 0.5, atol=1e-9)  # turned to +x, moved out 0.5
    np.testing.assert_allclose(base[:, 2], blade.vertices[blade.fields["base"] > 0.5, 2] + 0.2)
    tip = mesh.vertices[np.argmax(mesh.fields["s"])]
    assert tip[0] == pytest.approx(1.5, abs=0.05)


def test_bad_orchids_are_one_line_errors(tmp_path: Path) -> None:
    with pytest.raises(MorphogenError, match="unknown organ kind 'stamen'"):
        assemble([Organ(petal(edge=0.1), "stamen", 0.0)])
    with pytest.raises(MorphogenError, match="at least one organ"):
        assemble([])
    with pytest.raises(MorphogenError, match="size must be a positive"):
        orchid(size=-1.0)
    with pytest.raises(MorphogenError, match="too coarse"):
        orchid(edge=0.2)
    with pytest.raises(MorphogenError, match=r"^\[mesh\] orchid: .*petals") as err:
        build_mesh({"shape": "orchid", "petals": 3, "edge": 0.05})
    assert "\n" not in str(err.value)
