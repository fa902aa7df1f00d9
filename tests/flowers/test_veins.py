"""Space-colonisation veins on mesh surfaces (Ringham et al. §3.4.1)."""

from __future__ import annotations

import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.flowers import corolla, grid_mesh, tube
from morphogen.flowers.sampling import surface_points
from morphogen.flowers.veins import (
    _pipe_model,
    closest_on_triangles,
    edge_distance,
    space_colonisation,
    vein_fields,
)


def _brute_distance(mesh, points):
    """Distance from each point to the mesh, over every face."""
    tri = mesh.vertices[mesh.faces]
    q = closest_on_triangles(points[:, None], tri[None, :, 0], tri[None, :, 1], tri[None, :, 2])
    return np.sqrt(((q - points[:, None]) ** 2).sum(-1)).min(axis=1)


def test_closest_point_on_a_triangle_by_region():
    a, b, c = np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    cases = {(0.2, 0.2, 5.0): (0.2, 0.2, 0), (2.0, -1.0, 0): (1, 0, 0),
             (0.5, -1.0, 3.0): (0.5, 0, 0), (1.0, 1.0, 0): (0.5, 0.5, 0),
             (-1.0, -1.0, 1.0): (0, 0, 0), (-0.5, 0.3, 0): (0, 0.3, 0), (0, 3.0, 0): (0, 1, 0)}
    for p, want in cases.items():
        assert np.allclose(closest_on_triangles(np.array(p), a, b, c), want)


@pytest.fixture(scope="module", params=["corolla", "tube"])
def grown(request):
    if request.param == "corolla":
        mesh = corolla(edge=0.05)
        seeds = mesh.vertex_set("throat")
    else:
        mesh = tube(edge=0.05, radius=0.3, mouth=0.6, length=0.6)
        seeds = np.flatnonzero((mesh.fields["base"] > 0.5) & (mesh.fields["midline"] > 0.5))
    graph = space_colonisation(mesh, seeds, points=600, seed=4)
    return mesh, seeds, graph


def test_nodes_stay_on_the_surface(grown):
    mesh, _, graph = grown
    assert len(graph.nodes) > 50
    assert _brute_distance(mesh, graph.nodes).max() < 1e-9
    # steps of the step length (2 mean edges), changed by under 2 % by the projection
    seg = np.linalg.norm(graph.nodes[graph.edges[:, 1]] - graph.nodes[graph.edges[:, 0]], axis=1)
    step = 2 * mesh.edge_length
    assert seg.max() <= step * 1.02 and np.median(seg) > 0.98 * step


def test_graph_is_a_forest_rooted_at_the_seeds(grown):
    mesh, seeds, graph = grown
    r = len(seeds)
    assert np.array_equal(graph.seeds, np.sort(seeds))
    assert np.allclose(graph.nodes[:r], mesh.vertices[graph.seeds])
    assert np.all(graph.parent[:r] == -1)
    idx = np.arange(r, len(graph.nodes))
    assert np.all((graph.parent[r:] >= 0) & (graph.parent[r:] < idx))
    # parents precede children, so following parents always ends at a root: a tree per seed
    root = np.arange(len(graph.nodes))
    for v in range(r, len(root)):
        root[v] = root[graph.parent[v]]
    assert set(root) <= set(range(r))


def test_no_surviving_point_within_the_kill_distance(grown):
    mesh, _, graph = grown
    kill = 6 * mesh.edge_length
    if len(graph.remaining):
        d = np.linalg.norm(graph.remaining[:, None] - graph.nodes[None], axis=-1).min(axis=1)
        assert d.min() > kill


def test_reproducible_with_the_same_seed():
    mesh = corolla(edge=0.06)
    seeds = mesh.vertex_set("throat")
    a = space_colonisation(mesh, seeds, points=300, seed=2)
    b = space_colonisation(mesh, seeds, points=300, seed=2)
    c = space_colonisation(mesh, seeds, points=300, seed=3)
    assert np.array_equal(a.nodes, b.nodes) and np.array_equal(a.parent, b.parent)
    assert len(a.nodes) != len(c.nodes) or not np.allclose(a.nodes, c.nodes)


def test_pipe_model_and_strahler_order_on_a_hand_tree():
    # 0 - 1 - 2 - 4, and 1 - 3: tips 3, 4; node 1 joins two order-1 branches
    order, radius = _pipe_model(np.array([-1, 0, 1, 1, 2]), gamma=3.0, tip_radius=0.1)
    assert order.tolist() == [2, 2, 1, 1, 1]
    assert np.allclose(radius, 0.1 * np.array([2, 2, 1, 1, 1]) ** (1 / 3))
    # unequal orders do not raise the order: root 0 meets an order-2 branch (1) and a tip (4)
    order, radius = _pipe_model(np.array([-1, 0, 1, 1, 0]), gamma=2.0, tip_radius=1.0)
    assert order.tolist() == [2, 2, 1, 1, 1]
    assert np.allclose(radius ** 2, [3, 2, 1, 1, 1])


def test_edge_distance_on_a_grid():
    mesh = grid_mesh(6, 5, dx=0.5)
    d = edge_distance(mesh, np.array([0]))
    assert np.allclose(d[:6], 0.5 * np.arange(6))
    assert np.allclose(d[np.arange(5) * 6], 0.5 * np.arange(5))


def test_vein_fields_zero_on_veins_and_increasing_away(grown):
    mesh, _, graph = grown
    f = vein_fields(mesh, graph)
    vein = f["vein"] > 0.5
    assert 0.02 < vein.mean() < 0.6
    assert np.all(f["vein_distance"][vein] == 0) and np.all(f["vein_distance"][~vein] > 0)
    assert np.all(f["vein_thickness"][vein] > 0) and np.all(f["vein_thickness"][~vein] == 0)
    # every off-vein vertex has a neighbour nearer the veins (a descent path to a vein), and
    # the path length is at least the straight-line distance to the nearest vein vertex
    fa = mesh.faces
    lowest = np.full(mesh.n_vertices, np.inf)
    for i, j in [(0, 1), (1, 2), (2, 0), (1, 0), (2, 1), (0, 2)]:
        np.minimum.at(lowest, fa[:, i], f["vein_distance"][fa[:, j]])
    assert np.all(lowest[~vein] < f["vein_distance"][~vein])
    on = mesh.vertices[vein]
    straight = np.linalg.norm(mesh.vertices[~vein][:, None] - on[None], axis=-1).min(axis=1)
    assert np.all(f["vein_distance"][~vein] >= straight - 1e-12)


def test_surface_points_are_uniform_by_area_and_follow_a_density():
    mesh = grid_mesh(11, 11, dx=0.1)
    pts = surface_points(mesh, 4000, seed=0)
    assert np.abs(pts[:, 2]).max() == 0 and pts[:, :2].min() >= 0 and pts[:, :2].max() <= 1
    assert abs((pts[:, 0] < 0.5).mean() - 0.5) < 0.03
    # density x: accepted with probability x, so the mean x is E[x^2]/E[x] = 2/3
    dense = surface_points(mesh, 4000, density=mesh.vertices[:, 0], seed=0)
    assert abs(dense[:, 0].mean() - 2 / 3) < 0.02


@pytest.mark.parametrize("kwargs, message", [
    ({"seeds": []}, "at least one seed"),
    ({"points": 0}, "positive number of attraction points"),
    ({"step": 0.5, "kill": 0.1}, "0 < step < kill < influence"),
    ({"iterations": 0}, "iterations"),
    ({"seeds": [10**6]}, "seed vertices"),
])
def test_bad_arguments(kwargs, message):
    mesh = corolla(edge=0.1)
    args = {"seeds": mesh.vertex_set("throat"), **kwargs}
    with pytest.raises(MorphogenError, match=message):
        space_colonisation(mesh, args.pop("seeds"), **args)
