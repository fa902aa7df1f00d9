"""Vein statistics, tip pruning, refilled attraction points and per-piece growth
(Runions et al. 2005 as used by Ringham et al. §3.4.1)."""

from __future__ import annotations

import numpy as np
import pytest

from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError
from morphogen.flowers import grid_mesh, tube
from morphogen.flowers.veins import (
    VeinGraph,
    _pipe_model,
    space_colonisation,
    vein_statistics,
)


def _hand_tree() -> VeinGraph:
    # a trunk 0 - 1 - 2 - 3 - 4 - 5 along x, a one-node twig 2 - 6, a branch 1 - 7 - 8 - 9
    nodes = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0], [4, 0, 0], [5, 0, 0],
                      [2, 1, 0], [1, -1, 0], [1, -2, 0], [1, -3, 0]], float)
    parent = np.array([-1, 0, 1, 2, 3, 4, 2, 1, 7, 8])
    order, thick = _pipe_model(parent, 3.0, 0.1)
    return VeinGraph(nodes, parent, np.zeros(10, int), order, thick, np.array([0]),
                     np.zeros((0, 3)))


def test_statistics_of_a_hand_tree():
    st = vein_statistics(_hand_tree(), area=18.0)
    assert st["nodes"] == 10 and st["tips"] == 3
    assert st["stubs"] == 1 and st["stub_share"] == pytest.approx(1 / 3)  # the twig 2 - 6
    assert st["strahler"] == 2  # the twig and the trunk's end meet at node 2
    assert st["length"] == pytest.approx(9.0)
    assert st["spacing"] == pytest.approx(2.0)  # area / length
    assert st["order_length"] == pytest.approx([7.0, 2.0])  # segments 0-1 and 1-2: order 2
    assert vein_statistics(_hand_tree(), area=18.0, stub=3)["stubs"] == 3


@pytest.fixture(scope="module")
def bell_like():
    mesh = tube(edge=0.04, radius=0.3, mouth=0.6, length=0.6)
    seeds = np.flatnonzero((mesh.fields["base"] > 0.5) & (mesh.fields["midline"] > 0.5))
    return mesh, seeds


def test_pruning_removes_the_stubs_and_keeps_a_forest(bell_like):
    mesh, seeds = bell_like
    area = float(mesh.areas.sum())
    kwargs = dict(points=1500, step=0.08, kill=0.12, influence=0.6, seed=2)
    raw = space_colonisation(mesh, seeds, **kwargs)
    pruned = space_colonisation(mesh, seeds, min_branch=2.5 * 0.08, **kwargs)
    before, after = vein_statistics(raw, area), vein_statistics(pruned, area)
    assert before["stub_share"] > 0.2  # one-node twigs pulled out of the veins by near points
    assert after["stubs"] == 0 and after["tips"] < before["tips"]
    assert after["length"] > 0.8 * before["length"]  # only twigs went
    kept = {tuple(np.round(p, 9)) for p in raw.nodes}
    assert all(tuple(np.round(p, 9)) in kept for p in pruned.nodes)
    child = np.flatnonzero(pruned.parent >= 0)
    assert np.all(pruned.parent[child] < child)  # parents still precede their children
    assert np.all(pruned.parent[: len(seeds)] == -1)


def test_refilled_points_give_a_deeper_hierarchy(bell_like):
    mesh, seeds = bell_like
    area = float(mesh.areas.sum())
    common = dict(step=0.04, kill=0.06, influence=0.3, min_branch=0.12, seed=3)
    once = vein_statistics(space_colonisation(mesh, seeds, points=2000, **common), area)
    refilled = vein_statistics(space_colonisation(mesh, seeds, points=60, refill=40,
                                                  birth=0.1, **common), area)
    assert refilled["strahler"] > once["strahler"]
    assert refilled["stub_share"] < 0.1


def test_refill_respects_the_birth_distance():
    mesh = grid_mesh(21, 21, dx=0.05)
    graph = space_colonisation(mesh, [0], points=5, refill=50, birth=0.2, step=0.05, kill=0.1,
                               influence=0.5, iterations=1, seed=1)
    pts = graph.remaining
    d = np.linalg.norm(pts[:, None] - pts[None], axis=2) + np.eye(len(pts)) * 9
    assert len(pts) > 5 and d[5:, :].min() > 0.2  # every refilled point, from every other


def test_same_piece_keeps_veins_on_their_organ():
    left = grid_mesh(12, 12, dx=0.05)
    right = left.vertices + [0.58, 0.0, 0.0]  # a parallel square 0.03 to the right
    mesh = Mesh(np.vstack([left.vertices, right]),
                np.vstack([left.faces, left.faces + left.n_vertices]))
    seed = [int(np.argmin(np.linalg.norm(left.vertices - [0.5, 0.25, 0], axis=1)))]
    kwargs = dict(points=400, step=0.05, kill=0.08, influence=0.5, seed=0)
    free = space_colonisation(mesh, seed, **kwargs)
    kept = space_colonisation(mesh, seed, same_piece=True, **kwargs)
    assert (free.nodes[:, 0] > 0.56).any()  # unrestricted, veins jump the gap
    assert (kept.nodes[:, 0] <= 0.55 + 1e-9).all() and len(kept.nodes) > 20


@pytest.mark.parametrize("kwargs, message", [
    (dict(refill=-1), "refill"), (dict(birth=0.0), "birth"), (dict(min_branch=-1.0), "birth"),
])
def test_bad_hierarchy_options(kwargs, message):
    mesh = grid_mesh(6, 6, dx=0.1)
    with pytest.raises(MorphogenError, match=message):
        space_colonisation(mesh, [0], points=10, **kwargs)
