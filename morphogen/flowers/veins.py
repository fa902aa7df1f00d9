"""Vein patterns by space colonisation on a triangle-mesh surface (Ringham et al. §3.4.1).

Runions et al. (2005) grow an open venation towards attraction points; Ringham et al. follow
Hädrich et al. (2017) to keep it on a curved corolla: tips grow through space, then are
projected back onto the mesh. One iteration, with vein nodes ``v`` and the surviving
attraction points ``s``:

1. each point ``s`` is associated with its nearest node, if that node is closer than the
   influence radius ``d_i``;
2. a node ``v`` with associated points ``S(v)`` grows a new node
   ``v' = P(v + D t / |t|)``, where ``t`` is the average direction
   ``sum_{s in S(v)} (s - v)/|s - v|`` projected on the tangent plane of the face under ``v``,
   ``D`` the step length and ``P`` the closest point on the mesh;
3. every point closer than the kill distance ``d_k`` to a node is removed.

Growth stops when no point is left, no node grows, or after ``iterations``. Two options give
denser, more hierarchical venation. ``refill`` draws new candidate points each iteration and
keeps those farther than the birth distance ``d_b`` from every vein node and every other point
(in Runions et al. new sources appear as the leaf grows; here the surface is fixed, so points
keep appearing in the gaps the veins leave, and late veins branch off early ones).
``min_branch`` removes terminal branches shorter than that length once growth ends (a point
near an existing vein pulls one node out of it and is killed: a stub of one or two nodes that
is not a vein). The result is a forest rooted at the seed vertices. Thickness follows the pipe
model (Murray's law):
``r(v)^gamma = sum_children r(c)^gamma`` with radius ``r_tip`` at the tips, i.e.
``r(v) = r_tip n(v)^(1/gamma)`` for ``n(v)`` tips downstream of ``v``; the Strahler order is
1 at tips and rises by one where two branches of equal order meet.

Per-vertex fields: ``vein`` (1 on vertices the veins pass over: the nearest vertex of points
spaced at most half an edge along every segment, and vertices within the segment's radius),
``vein_thickness`` (the largest radius of a segment marking the vertex, 0 elsewhere) and
``vein_distance`` (shortest path over mesh edges to the nearest vein vertex, an upper bound
of the geodesic distance, in mesh units).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from morphogen.domains.mesh import Mesh
from morphogen.domains.mesh_geometry import face_normals
from morphogen.errors import MorphogenError
from morphogen.flowers.sampling import surface_points

_NEIGHBOUR_FACES = 12


@dataclass(frozen=True)
class VeinGraph:
    """A vein forest on a mesh, or with ``links`` a vein network with loops.

    Attributes:
        nodes: ``(N, 3)`` positions on the surface; roots first, every parent before its
            children.
        parent: ``(N,)`` index of each node's parent, ``-1`` for the roots (the seeds).
        face: ``(N,)`` face under each node.
        order: ``(N,)`` Strahler order of the segment ending at each node.
        thickness: ``(N,)`` radius of that segment (pipe model).
        seeds: ``(R,)`` mesh vertices the roots sit on.
        remaining: ``(M, 3)`` attraction points never reached.
        links: ``(L, 2)`` segments beyond the forest, ``(node, junction)`` pairs that close
            loops (closed venation, :mod:`morphogen.flowers.veins_closed`); empty for a
            tree. ``order`` and ``thickness`` are those of the forest alone.
    """

    nodes: np.ndarray
    parent: np.ndarray
    face: np.ndarray
    order: np.ndarray
    thickness: np.ndarray
    seeds: np.ndarray
    remaining: np.ndarray
    links: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))

    @property
    def edges(self) -> np.ndarray:
        """``(N - R + L, 2)`` ``(parent, child)`` node pairs, then the ``links``."""
        child = np.flatnonzero(self.parent >= 0)
        tree = np.stack([self.parent[child], child], 1)
        return np.concatenate([tree, self.links.astype(tree.dtype)]) if len(self.links) \
            else tree

    def arrays(self) -> dict[str, np.ndarray]:
        """Every array by name (for ``.npz`` files)."""
        return {"nodes": self.nodes, "parent": self.parent, "face": self.face,
                "order": self.order, "thickness": self.thickness, "seeds": self.seeds,
                "edges": self.edges, "remaining": self.remaining, "links": self.links}


def closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray,
                         c: np.ndarray) -> np.ndarray:
    """Closest point to ``p`` on triangle ``abc`` (Ericson, *Real-Time Collision Detection*
    §5.1.5: the Voronoi region of ``p`` among the corners, edges and interior). All arrays
    ``(..., 3)``, broadcast together."""
    ab, ac = b - a, c - a
    ap, bp, cp = p - a, p - b, p - c
    d1, d2 = (ab * ap).sum(-1), (ac * ap).sum(-1)
    d3, d4 = (ab * bp).sum(-1), (ac * bp).sum(-1)
    d5, d6 = (ab * cp).sum(-1), (ac * cp).sum(-1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2

    def ratio(num, den):
        return (num / np.where(np.abs(den) > 1e-300, den, 1.0))[..., None]

    total = va + vb + vc
    out = a + ab * ratio(vb, total) + ac * ratio(vc, total)
    regions = [
        ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),
         b + (c - b) * ratio(d4 - d3, (d4 - d3) + (d5 - d6))),
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + ac * ratio(d2, d2 - d6)),
        ((d6 >= 0) & (d5 <= d6), np.broadcast_to(c, out.shape)),
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + ab * ratio(d1, d1 - d3)),
        ((d3 >= 0) & (d4 <= d3), np.broadcast_to(b, out.shape)),
        ((d1 <= 0) & (d2 <= 0), np.broadcast_to(a, out.shape)),
    ]
    for mask, value in regions:
        out = np.where(mask[..., None], value, out)
    return out


class SurfaceProjector:
    """Closest points on a mesh, searching the faces whose centroids are nearest the query
    (adequate for meshes of nearly uniform triangles, such as the generated flowers)."""

    def __init__(self, mesh: Mesh):
        self.vertices = mesh.vertices
        self.faces = mesh.faces
        self.tree = cKDTree(self.vertices[self.faces].mean(axis=1))
        self.k = min(_NEIGHBOUR_FACES, len(self.faces))

    def __call__(self, points: np.ndarray, labels: np.ndarray | None = None,
                 face_label: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(Q, 3)`` points -> ``(Q, 3)`` closest surface points and ``(Q,)`` faces; with
        ``labels`` (``(Q,)``) only faces whose ``face_label`` matches count (face ``-1`` where
        none of the nearest faces does)."""
        _, cand = self.tree.query(points, k=self.k)
        cand = cand.reshape(len(points), -1)
        tri = self.vertices[self.faces[cand]]
        q = closest_on_triangles(points[:, None, :], tri[..., 0, :], tri[..., 1, :],
                                 tri[..., 2, :])
        d2 = ((q - points[:, None, :]) ** 2).sum(-1)
        if labels is not None:
            d2 = np.where(face_label[cand] == labels[:, None], d2, np.inf)
        best = np.argmin(d2, axis=1)
        rows = np.arange(len(points))
        face = np.where(np.isfinite(d2[rows, best]), cand[rows, best], -1)
        return q[rows, best], face


def space_colonisation(
    mesh: Mesh,
    seeds: np.ndarray,
    *,
    points: int = 2000,
    influence: float | None = None,
    kill: float | None = None,
    step: float | None = None,
    iterations: int = 400,
    density: np.ndarray | None = None,
    gamma: float = 3.0,
    tip_radius: float | None = None,
    seed: int = 0,
    refill: int = 0,
    birth: float | None = None,
    min_branch: float = 0.0,
    same_piece: bool = False,
) -> VeinGraph:
    """Grow veins from mesh vertices ``seeds`` towards ``points`` attraction points.

    Lengths are in mesh units; by default ``step = 2 e``, ``kill = 3 step`` and
    ``influence = 15 step`` for the mean edge ``e``, and ``tip_radius = e / 4``.

    Args:
        seeds: vertex indices where veins start (the roots).
        density: optional ``(V,)`` acceptance probability of attraction points (§3.4.4), for
            the initial and the refilled points.
        refill: candidate points drawn every iteration (0: none); a candidate is kept if it
            is farther than ``birth`` (default ``kill``) from every node and every point.
        min_branch: terminal branches (from a tip to the first branching node or root)
            shorter than this are removed after growth (0: keep all).
        same_piece: keep every vein on the connected piece of the mesh its root is on (for
            flowers of separate organs that lie close together or overlap); a step that would
            leave the piece is not taken.

    Raises:
        MorphogenError: no seeds, a seed out of range, no points, or lengths out of order
            (``0 < step < kill < influence`` is required).
    """
    seeds, step, kill, influence, tip_radius, birth = check_options(
        mesh, seeds, points=points, iterations=iterations, step=step, kill=kill,
        influence=influence, gamma=gamma, tip_radius=tip_radius, refill=refill,
        birth=birth, min_branch=min_branch)

    project, normals, piece, roots, attract, pool = growth_start(
        mesh, seeds, points=points, density=density, seed=seed, refill=refill,
        iterations=iterations, kill=kill, same_piece=same_piece)
    nodes, face = [roots[0]], [roots[1]]
    parent = [np.full(len(seeds), -1)]
    all_nodes = nodes[0]
    for it in range(iterations):
        if refill:
            attract = _refill(attract, pool[it * refill:(it + 1) * refill], all_nodes,
                              birth, kill)
        if len(attract) == 0:
            break
        tree = cKDTree(all_nodes)
        dist, near = tree.query(attract, distance_upper_bound=influence)
        ok = np.isfinite(dist) & (dist > 0)
        if not ok.any():
            break
        near, unit = near[ok], (attract[ok] - all_nodes[near[ok]]) / dist[ok, None]
        growing, slot = np.unique(near, return_inverse=True)
        direction = np.zeros((len(growing), 3))
        np.add.at(direction, slot, unit)
        n = normals[np.concatenate(face)[growing]]
        direction -= (direction * n).sum(1, keepdims=True) * n
        length = np.linalg.norm(direction, axis=1)
        live = length > 1e-9
        growing, direction = growing[live], direction[live] / length[live, None]
        if piece is None:
            new, new_face = project(all_nodes[growing] + step * direction)
        else:
            label = piece[np.concatenate(face)[growing]]
            new, new_face = project(all_nodes[growing] + step * direction, label, piece)
        # a node whose points pull it back onto existing veins stops (no duplicate nodes)
        keep = (tree.query(new)[0] > 0.25 * step) & (new_face >= 0)
        growing, new, new_face = growing[keep], new[keep], new_face[keep]
        if len(new) == 0:
            break
        nodes.append(new)
        face.append(new_face)
        parent.append(growing)
        all_nodes = np.concatenate([all_nodes, new])
        attract = attract[cKDTree(new).query(attract)[0] > kill]
    parent_arr, face_arr = np.concatenate(parent), np.concatenate(face)
    while min_branch > 0:  # until no short twig is left (a fork of two twigs is one)
        keep = ~_short_branches(all_nodes, parent_arr, min_branch)
        if keep.all():
            break
        index = np.cumsum(keep) - 1
        parent_arr = np.where(parent_arr[keep] >= 0, index[parent_arr[keep]], -1)
        all_nodes, face_arr = all_nodes[keep], face_arr[keep]
    order, thickness = _pipe_model(parent_arr, gamma, tip_radius)
    return VeinGraph(nodes=all_nodes, parent=parent_arr, face=face_arr,
                     order=order, thickness=thickness, seeds=seeds, remaining=attract)


def check_options(mesh: Mesh, seeds: np.ndarray, *, points: int, iterations: int,
                  step: float | None, kill: float | None, influence: float | None,
                  gamma: float, tip_radius: float | None, refill: int,
                  birth: float | None, min_branch: float) -> tuple:
    """The checked ``(seeds, step, kill, influence, tip_radius, birth)`` of a growth, the
    lengths defaulted from the mean edge (see :func:`space_colonisation`)."""
    seeds = np.unique(np.asarray(seeds, np.int64).ravel())
    if seeds.size == 0:
        raise MorphogenError("veins need at least one seed vertex (seeds = a vertex set name)")
    if seeds.min() < 0 or seeds.max() >= mesh.n_vertices:
        raise MorphogenError(f"seed vertices must be in [0, {mesh.n_vertices}), "
                             f"got {seeds.min()}..{seeds.max()}")
    if not (isinstance(points, int | np.integer) and points > 0):
        raise MorphogenError(f"veins need a positive number of attraction points, got {points}")
    if not (isinstance(iterations, int | np.integer) and iterations > 0):
        raise MorphogenError(f"vein iterations must be a positive integer, got {iterations}")
    e = mesh.edge_length
    step = 2.0 * e if step is None else float(step)
    kill = 3.0 * step if kill is None else float(kill)
    influence = 15.0 * step if influence is None else float(influence)
    tip_radius = 0.25 * e if tip_radius is None else float(tip_radius)
    if not (np.isfinite(influence) and 0 < step < kill < influence):
        raise MorphogenError(f"vein lengths must satisfy 0 < step < kill < influence, got step "
                             f"{step:g}, kill {kill:g}, influence {influence:g}")
    if not (gamma > 0 and tip_radius > 0):
        raise MorphogenError(f"gamma and tip_radius must be positive, got {gamma}, {tip_radius}")
    birth = kill if birth is None else float(birth)
    if not (isinstance(refill, int | np.integer) and refill >= 0):
        raise MorphogenError(f"vein refill must be a non-negative integer, got {refill}")
    if not (np.isfinite(birth) and birth > 0 and np.isfinite(min_branch) and min_branch >= 0):
        raise MorphogenError(f"vein birth must be positive and min_branch non-negative, got "
                             f"{birth:g}, {min_branch:g}")
    return seeds, step, kill, influence, tip_radius, birth


def growth_start(mesh: Mesh, seeds: np.ndarray, *, points: int, density: np.ndarray | None,
                 seed: int, refill: int, iterations: int, kill: float, same_piece: bool):
    """What open and closed growth start from: the surface projector, unit face normals, the
    faces' pieces (``same_piece``, else ``None``), the roots projected on the surface
    (positions, faces), the attraction points farther than ``kill`` from every root and the
    refill pool (``refill * iterations`` candidates)."""
    project = SurfaceProjector(mesh)
    normals = face_normals(mesh.vertices, mesh.faces)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    attract = surface_points(mesh, points, density=density, seed=seed)
    roots = project(mesh.vertices[seeds])
    piece = _face_pieces(mesh) if same_piece else None
    attract = attract[cKDTree(roots[0]).query(attract)[0] > kill]
    pool = surface_points(mesh, refill * iterations, density=density, seed=seed + 1) \
        if refill else np.zeros((0, 3))
    return project, normals, piece, roots, attract, pool


def _face_pieces(mesh: Mesh) -> np.ndarray:
    """Connected-piece label of every face (faces sharing a vertex are connected)."""
    from scipy.sparse.csgraph import connected_components

    f = mesh.faces
    n = mesh.n_vertices
    rows = np.concatenate([f[:, 0], f[:, 1]])
    cols = np.concatenate([f[:, 1], f[:, 2]])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    return label[f[:, 0]]


def _refill(attract: np.ndarray, candidates: np.ndarray, nodes: np.ndarray,
            birth: float, kill: float) -> np.ndarray:
    """``attract`` plus the candidates farther than ``birth`` (and ``kill``) from every node,
    and than ``birth`` from every point and every earlier accepted candidate."""
    ok = cKDTree(nodes).query(candidates)[0] > max(birth, kill)
    if len(attract):
        ok &= cKDTree(attract).query(candidates)[0] > birth
    candidates = candidates[ok]
    if len(candidates) > 1:  # among themselves: the earlier of a close pair wins
        drop = {j for i, j in cKDTree(candidates).query_pairs(birth)}
        candidates = candidates[np.setdiff1d(np.arange(len(candidates)), list(drop))]
    return np.concatenate([attract, candidates])


def _terminal_branches(parent: np.ndarray) -> list[np.ndarray]:
    """Each tip's terminal branch: the nodes from the tip up to, not including, the first
    node with two or more children (or a root, included if the whole tree is one chain)."""
    children = np.bincount(parent[parent >= 0], minlength=len(parent))
    out = []
    for tip in np.flatnonzero(children == 0):
        path = [tip]
        v = parent[tip]
        while v >= 0 and children[v] == 1 and parent[v] >= 0:
            path.append(v)
            v = parent[v]
        out.append(np.asarray(path))
    return out


def _short_branches(nodes: np.ndarray, parent: np.ndarray, min_length: float) -> np.ndarray:
    """Mask of the nodes of terminal branches shorter than ``min_length`` (measured from the
    branching node to the tip); roots are never removed."""
    drop = np.zeros(len(parent), bool)
    for path in _terminal_branches(parent):
        if parent[path[-1]] < 0:
            continue  # a tree that never branched
        ends = np.append(path, parent[path[-1]])
        length = np.linalg.norm(np.diff(nodes[ends], axis=0), axis=1).sum()
        if length < min_length:
            drop[path] = True
    return drop


def vein_statistics(graph: VeinGraph, area: float, stub: int = 2) -> dict[str, float]:
    """Measures of a vein forest on a surface of ``area``: ``nodes``; ``tips`` (nodes without
    children or links); ``stub_share``, the share of tips whose terminal branch has at most
    ``stub`` nodes; ``strahler``, the highest Strahler order (of the forest without the
    links); ``order_length``, the vein length of each order from 1 up; ``length`` in all;
    ``spacing = area / length``, the mean distance between neighbouring veins (for parallel
    veins ``s`` apart the length per unit area is ``1/s``); and ``loops = E - V + C``, the
    independent cycles of the graph of ``V`` nodes, ``E`` segments and ``C`` connected pieces
    (0 for a forest)."""
    parent = graph.parent
    edges = graph.edges
    linked = np.zeros(len(parent), bool)
    linked[graph.links.ravel()] = True
    branches = [b for b in _terminal_branches(parent) if not linked[b[0]]]
    tips = len(branches)
    stubs = sum(len(b) <= stub for b in branches)
    top = int(graph.order.max()) if len(graph.order) else 0
    seg = np.linalg.norm(graph.nodes[edges[:, 1]] - graph.nodes[edges[:, 0]], axis=1) \
        if len(edges) else np.zeros(0)
    per_order = [float(seg[graph.order[edges[:, 1]] == k].sum()) for k in range(1, top + 1)]
    length = float(seg.sum())
    return {"nodes": int(len(parent)), "tips": tips, "stubs": int(stubs),
            "stub_share": stubs / tips if tips else 0.0, "strahler": top,
            "order_length": per_order, "length": length,
            "spacing": area / length if length else float("inf"),
            "loops": len(edges) - len(parent) + _pieces(edges, len(parent))}


def _pieces(edges: np.ndarray, n: int) -> int:
    """Connected pieces of the graph of ``n`` nodes and ``(E, 2)`` ``edges``."""
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    return int(connected_components(graph, directed=False)[0])


def _pipe_model(parent: np.ndarray, gamma: float,
                tip_radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Strahler order and pipe-model radius, accumulated from the tips towards the roots
    (every parent precedes its children)."""
    n = len(parent)
    tips = (np.bincount(parent[parent >= 0], minlength=n) == 0).astype(np.float64)
    order = np.ones(n, np.int64)
    best = np.zeros(n, np.int64)
    ties = np.zeros(n, np.int64)
    for v in range(n - 1, -1, -1):
        if best[v]:
            order[v] = best[v] + (ties[v] > 1)
        p = parent[v]
        if p >= 0:
            tips[p] += tips[v]
            if order[v] > best[p]:
                best[p], ties[p] = order[v], 1
            elif order[v] == best[p]:
                ties[p] += 1
    return order, tip_radius * tips ** (1.0 / gamma)


def vein_fields(mesh: Mesh, graph: VeinGraph) -> dict[str, np.ndarray]:
    """Per-vertex ``vein``, ``vein_thickness`` and ``vein_distance`` (see the module
    docstring), each ``(V,)`` float64."""
    e = mesh.edge_length
    edges = graph.edges
    mask = np.zeros(mesh.n_vertices, bool)
    thick = np.zeros(mesh.n_vertices)
    tree = cKDTree(mesh.vertices)
    mask[graph.seeds] = True
    if len(edges):
        a, b = graph.nodes[edges[:, 0]], graph.nodes[edges[:, 1]]
        radius = graph.thickness[edges[:, 1]]
        pieces = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / (0.5 * e)), 1).astype(int)
        seg = np.repeat(np.arange(len(edges)), pieces + 1)
        start = np.repeat(np.cumsum(pieces + 1) - (pieces + 1), pieces + 1)
        frac = (np.arange(len(seg)) - start) / pieces[seg]
        samples = a[seg] + frac[:, None] * (b[seg] - a[seg])
        nearest = tree.query(samples)[1]
        mask[nearest] = True
        np.maximum.at(thick, nearest, radius[seg])
        for r in np.unique(radius):
            sel = radius[seg] == r
            hits = tree.query_ball_point(samples[sel], r, return_sorted=False)
            flat = np.fromiter((v for h in hits for v in h), np.int64)
            mask[flat] = True
            np.maximum.at(thick, flat, r)
    thick[graph.seeds] = np.maximum(thick[graph.seeds], graph.thickness[: len(graph.seeds)])
    return {"vein": mask.astype(np.float64), "vein_thickness": np.where(mask, thick, 0.0),
            "vein_distance": edge_distance(mesh, np.flatnonzero(mask))}


def edge_distance(mesh: Mesh, sources: np.ndarray) -> np.ndarray:
    """``(V,)`` shortest-path length over mesh edges from the nearest of ``sources``
    (Dijkstra; vertices not connected to any source get the largest finite distance)."""
    f = mesh.faces
    pairs = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    i, j = np.unique(np.sort(pairs, axis=1), axis=0).T
    w = np.linalg.norm(mesh.vertices[i] - mesh.vertices[j], axis=1)
    graph = coo_matrix((w, (i, j)), shape=(mesh.n_vertices,) * 2).tocsr()
    dist = dijkstra(graph, directed=False, indices=np.asarray(sources), min_only=True)
    finite = np.isfinite(dist)
    return np.where(finite, dist, dist[finite].max() if finite.any() else 0.0)
