"""Primula (Ringham et al. 2021, §4.3): the pipeline at reduced size gives two spots per petal,
one per lobe, around the source lines and bounded by the diffusion length."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.special import erfcinv

from morphogen.flowers.pipeline import load_pipeline, run_pipeline

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "flowers" / "primula.toml"
EDGE = 0.03


@pytest.fixture(scope="module")
def primula(tmp_path_factory):
    spec = load_pipeline(EXAMPLE)
    spec["mesh"] = {**spec["mesh"], "edge": EDGE}
    sources = spec["stage"][0]["fields"]
    sources["src"] = sources["src"].replace("0.0122", str(EDGE / 2))  # a line a vertex wide
    out = tmp_path_factory.mktemp("primula")
    return spec, run_pipeline(spec, out)


def test_primula_is_deterministic_diffusion_for_2000_steps_of_the_fig9b_step() -> None:
    stage = load_pipeline(EXAMPLE)["stage"][1]
    assert (stage["steps"], stage["dt"], stage["params"]["D"]) == (2000, 1e-3, 1e-3)
    assert "omega" not in stage


def test_ten_spots_one_in_each_lobe(primula) -> None:
    _, mesh = primula
    f = mesh.fields
    dark = f["pigment"] > 0.5
    assert set(np.unique(f["pigment"])) == {0.0, 1.0}  # a step map
    assert np.all(dark[f["src"] > 0.5]) and not np.any(dark[f["margin"] > 0.5])
    e = mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    keep = dark[e[:, 0]] & dark[e[:, 1]]
    n = mesh.n_vertices
    graph = coo_matrix((np.ones(keep.sum()), (e[keep, 0], e[keep, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    spots = [np.flatnonzero(label == k) for k in np.unique(label[dark])]
    assert len(spots) == 10
    lobes = {(int(f["petal"][s[0]]), bool(f["phi"][s[0]] > 0)) for s in spots}
    assert len(lobes) == 10  # one spot per (petal, side of the notch)
    for s in spots:
        assert len(np.unique(f["petal"][s])) == 1 and len(np.unique(np.sign(f["phi"][s]))) == 1


def test_spots_stay_within_the_diffusion_length_of_their_sources(primula) -> None:
    # A line held at m = 1 in the plane gives m = erfc(d / (2 sqrt(D t))); the sink and the
    # line's finite length only lower m, so m > 0.08 needs d < 2 sqrt(D t) erfcinv(0.08).
    _, mesh = primula
    f = mesh.fields
    reach = 2 * math.sqrt(1e-3 * 2.0) * float(erfcinv(0.08))
    assert reach == pytest.approx(0.111, abs=1e-3)
    src = mesh.vertices[f["src"] > 0.5]
    dark = mesh.vertices[f["pigment"] > 0.5]
    d = np.min(np.linalg.norm(dark[:, None, :] - src[None, :, :], axis=2), axis=1)
    assert d.max() < reach + EDGE
    assert d.max() > 2 * EDGE  # the spot grows well beyond its source line
