"""Closed (reticulate) venation by space colonisation (Runions et al. 2005)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.domains.ply import save_ply
from morphogen.errors import MorphogenError
from morphogen.flowers import corolla, dianthus, grid_mesh
from morphogen.flowers.pipeline import run_pipeline
from morphogen.flowers.sampling import surface_points
from morphogen.flowers.veins import (
    _face_pieces,
    space_colonisation,
    vein_fields,
    vein_statistics,
)
from morphogen.flowers.veins_closed import (
    areoles,
    closed_colonisation,
    colonisation,
    reached,
    relative_neighbourhood,
)


def _pieces_and_loops(graph) -> tuple[int, int]:
    st = vein_statistics(graph, 1.0)
    return st["loops"] - len(graph.edges) + len(graph.nodes), st["loops"]


def test_relative_neighbourhood_of_a_hand_configuration():
    # s at the origin; a = (2, 0) is blocked by c = (1.2, 0.4): |c - s| = 1.26 < 2 and
    # |c - a| = 0.89 < 2; b = (0, -1.5) is not (|c - b| = 2.25 > 1.5, |a - s| = 2 > 1.5);
    # c is not (a and b are farther from s than c); d is beyond the radius
    s = np.zeros((1, 3))
    a, b, c, d = [2, 0, 0], [0, -1.5, 0], [1.2, 0.4, 0], [5, 5, 0]
    src, node, dist = relative_neighbourhood(s, np.array([a, b, c, d], float), 3.0)
    assert src.tolist() == [0, 0] and node.tolist() == [2, 1]  # c, then b: nearest first
    assert dist == pytest.approx([np.hypot(1.2, 0.4), 1.5])
    # without c, a is no longer blocked (|b - a| = 2.5 > 2): both a and b
    _, node, _ = relative_neighbourhood(s, np.array([a, b, d], float), 3.0)
    assert node.tolist() == [1, 0]


def test_relative_neighbourhood_matches_its_definition():
    rng = np.random.default_rng(3)
    sources, nodes = rng.random((25, 3)), rng.random((70, 3))
    sources[:, 2] = nodes[:, 2] = 0
    src, node, _ = relative_neighbourhood(sources, nodes, 0.4)
    want = set()
    for i, s in enumerate(sources):
        for j, v in enumerate(nodes):
            r = np.linalg.norm(v - s)
            lune = np.maximum(np.linalg.norm(nodes - v, axis=1), np.linalg.norm(nodes - s, axis=1))
            lune[j] = np.inf
            if r <= 0.4 and not (lune < r).any():
                want.add((i, j))
    assert set(zip(src.tolist(), node.tolist(), strict=True)) == want


def test_a_source_is_reached_only_when_all_its_nodes_are_within_the_kill_distance():
    # source 0: nodes at 0.5 and 2.0; source 1: at 0.5 and 0.8; source 2: none
    source, dist = np.array([0, 0, 1, 1]), np.array([0.5, 2.0, 0.5, 0.8])
    assert reached(source, dist, 3, kill=1.0).tolist() == [False, True, False]
    assert reached(source, dist, 3, kill=2.5).tolist() == [True, True, False]


@pytest.fixture(scope="module")
def strip():
    """A 2 x 0.25 strip, its single attraction point, and two seeds on the point's row, 0.3
    before it and 0.7 after it."""
    mesh = grid_mesh(81, 11, 0.025)
    seed = next(k for k in range(100) if 0.4 < surface_points(mesh, 1, seed=k)[0, 0] < 1.2)
    p = surface_points(mesh, 1, seed=seed)[0]
    ends = [np.argmin(np.linalg.norm(mesh.vertices - (p + [dx, 0, 0]), axis=1))
            for dx in (-0.3, 0.7)]
    lengths = {"points": 1, "seed": seed, "step": 0.05, "kill": 0.08, "influence": 1.0}
    return mesh, np.array(ends), p, lengths


def test_the_source_waits_for_every_approaching_vein(strip):
    mesh, seeds, p, lengths = strip
    # after 8 steps the near vein has reached the point, the far one (0.7 away) has not
    early = closed_colonisation(mesh, seeds, iterations=8, **lengths)
    assert len(early.remaining) == 1  # the source is still there ...
    root = np.arange(len(early.nodes))
    for v in range(2, len(root)):
        root[v] = root[early.parent[v]]
    d = np.linalg.norm(early.nodes - p, axis=1)
    near_root = int(np.argmin(np.linalg.norm(mesh.vertices[early.seeds] - p, axis=1)))
    assert d[root == near_root].min() < 0.08 < d[root != near_root].min()  # ... waiting
    # the open rule removes it as soon as the nearest vein arrives; the far seed never grows
    open_ = space_colonisation(mesh, seeds, iterations=8, **lengths)
    assert len(open_.remaining) == 0 and len(open_.nodes) < len(early.nodes)
    # given time, both veins reach the point and meet there: one piece, no loop
    late = closed_colonisation(mesh, seeds, iterations=40, **lengths)
    assert len(late.remaining) == 0 and len(late.links) == 1
    assert _pieces_and_loops(late) == (1, 0)
    assert np.linalg.norm(late.nodes[late.links[0]] - p, axis=1).max() < 0.08


@pytest.fixture(scope="module")
def square():
    mesh = grid_mesh(41, 41, 0.025)
    return mesh, np.arange(18, 23)  # the middle of the bottom edge


def test_closed_venation_has_loops_and_open_venation_is_a_tree(square):
    mesh, seeds = square
    tree = space_colonisation(mesh, seeds, points=300, seed=1)
    pieces, loops = _pieces_and_loops(tree)
    assert loops == 0 and len(tree.edges) == len(tree.nodes) - pieces and len(tree.links) == 0
    net = closed_colonisation(mesh, seeds, points=300, seed=1)
    _, loops = _pieces_and_loops(net)
    assert loops >= 1 and len(net.links) >= 1
    r = len(net.seeds)
    assert np.all(net.parent[:r] == -1)
    assert np.all((net.parent[r:] >= 0) & (net.parent[r:] < np.arange(r, len(net.nodes))))
    assert net.links.min() >= 0 and net.links.max() < len(net.nodes)
    assert np.abs(net.nodes[:, 2]).max() == 0  # on the flat surface
    fields = vein_fields(mesh, net)
    assert len(areoles(mesh, fields["vein"])) >= 1
    assert len(areoles(mesh, vein_fields(mesh, tree)["vein"])) == 0


def test_pruning_keeps_every_loop(square):
    mesh, seeds = square
    kw = {"points": 200, "seed": 2, "refill": 20}
    full = closed_colonisation(mesh, seeds, **kw)
    pruned = closed_colonisation(mesh, seeds, min_branch=0.15, **kw)
    assert vein_statistics(pruned, 1.0)["loops"] == vein_statistics(full, 1.0)["loops"] >= 1
    assert len(pruned.nodes) < len(full.nodes)
    assert vein_statistics(pruned, 1.0)["tips"] < vein_statistics(full, 1.0)["tips"]


def test_same_piece_joins_no_two_organs():
    mesh = dianthus(edge=0.05)  # five separate petals that overlap near the centre
    seeds = np.flatnonzero((mesh.fields["base"] > 0.5) & (mesh.fields["midline"] > 0.5))
    net = closed_colonisation(mesh, seeds, points=400, seed=1, same_piece=True, step=0.05,
                              kill=0.08, influence=0.4)
    piece = _face_pieces(mesh)[net.face]
    assert len(net.links) > 0 and np.all(piece[net.links[:, 0]] == piece[net.links[:, 1]])
    assert np.all(piece[net.parent[len(seeds):]] == piece[len(seeds):])


def test_areoles_of_a_hand_ring():
    mesh = grid_mesh(9, 9)
    i, j = np.divmod(np.arange(81), 9)
    ring = (np.maximum(np.abs(i - 4), np.abs(j - 4)) == 2).astype(float)
    assert areoles(mesh, ring).tolist() == [9]  # the 3 x 3 inside
    ring[4 * 9 + 2] = 0  # a gap joins the inside to the margin
    assert areoles(mesh, ring).tolist() == []


def test_venation_option_in_pipeline_and_command(tmp_path, capsys):
    path = tmp_path / "p.toml"
    path.write_text("seed = 5\n[mesh]\nshape = 'corolla'\nedge = 0.06\n[[stage]]\n"
                    "kind = 'veins'\nseeds = 'throat'\npoints = 300\nkill = 0.2\n"
                    "venation = 'closed'\n")
    run_pipeline(path, tmp_path / "out", pictures=False)
    record = json.loads((tmp_path / "out" / "pipeline.json").read_text())["stages"][0]
    assert record["loops"] > 0
    with np.load(tmp_path / "out" / "01-veins" / "veins.npz") as graph:
        assert len(graph["links"]) > 0
    src = tmp_path / "c.ply"
    save_ply(src, corolla(edge=0.06))
    for venation in ("open", "closed"):
        assert main(["mesh", "veins", str(src), "--out", str(tmp_path / f"{venation}.ply"),
                     "--seeds", "throat", "--points", "300", "--kill", "0.2",
                     "--venation", venation]) == 0
        loops = int(capsys.readouterr().out.split(" loops")[0].split()[-1])
        assert (loops > 0) == (venation == "closed")
    with pytest.raises(MorphogenError, match="venation must be one of open, closed"):
        colonisation("reticulate")
