"""Closed (reticulate) venation by space colonisation on a triangle-mesh surface.

Runions, Fuhrer, Lane, Federl, Rolland-Lagan and Prusinkiewicz, "Modeling and visualization of
leaf venation patterns", ACM SIGGRAPH 2005, 702-711, obtain closed venation from the open
algorithm (:mod:`morphogen.flowers.veins`, where each auxin source pulls only its nearest vein
node) by two changes:

1. a source ``s`` influences every vein node ``v`` of its *relative neighbourhood*,
   ``v in V(s)`` iff no other node ``u`` lies in the lune of ``v`` and ``s``,
   ``max(|v - u|, |s - u|) < |v - s|`` (here also ``|v - s| <= d_i``, the influence radius);
2. a source is removed only when *every* node of ``V(s)`` is closer than the kill distance
   ``d_k``, so all the veins growing towards one source reach it: they meet there, and a loop
   closes.

Ringham et al. (2021, §6) name reticulate vascular patterns in petals an open problem; this is
one attempt on their curved surfaces, with the same surface handling as the open veins (a node
grows ``v' = P(v + D t / |t|)``, ``t = sum_{s: v in V(s), |s - v| >= d_k} (s - v)/|s - v|``
in the tangent plane of the face under ``v``, ``P`` the closest point on the mesh; nodes
closer than ``d_k`` to a source wait for the others instead of overshooting it). One
iteration, with sources ``S`` (refilled as in the open veins):

1. ``V(s)`` for every ``s`` (:func:`relative_neighbourhood`);
2. every ``s`` whose non-empty ``V(s)`` lies within ``d_k`` is removed (:func:`reached`);
   where two or more of its nodes belong to different veins (taken by distance, a node is
   dropped within ``h = ceil(2 d_k / D)`` segments of a nearer one: the same vein passing by,
   which would close a loop smaller than the kill zone), a *junction* node is placed at ``s``
   (or the nearest node, if it is within ``D / 4`` of ``s``), joined to each of them (with
   ``same_piece``, to those on the nearest one's piece of the mesh);
3. the other pairs pull their nodes as above; a step ending within ``D / 4`` of a node is
   not taken.

Growth stops when no source is left, nothing grows and no source is removed, or after
``iterations``. The graph is the growth forest (each node's parent is the node it grew from,
a junction's its nearest node) plus ``links``, the other segments to junctions, which close the
loops. Thickness follows the pipe model over the forest, and a link takes its junction's
radius (the tip radius unless the junction grew on); the Strahler order is not defined on
loops (``order`` is the forest's). ``min_branch`` prunes
terminal branches: from a node of degree one up through nodes of degree two.

Areoles (:func:`areoles`) are the regions the veins enclose: connected pieces of the mesh's
off-vein vertices (the ``vein`` field below 0.5, joined by mesh edges) that touch no boundary
vertex. On a planar network without crossings their number is ``loops = E - V + C``; fewer
means loops too small for the mesh to resolve, veins that cross, or two areoles joined through
a gap in the rasterised vein.
"""

from __future__ import annotations

from collections.abc import Callable
from itertools import chain

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError
from morphogen.flowers.veins import (
    SurfaceProjector,
    VeinGraph,
    _pipe_model,
    _refill,
    check_options,
    growth_start,
    space_colonisation,
)

_QUICK = 8
"""Nearest nodes of each source tried first as blockers of its candidate nodes."""
_CHUNK = 65536
"""Pairs per block of the quick test (bounds its ``(P, 8, 3)`` temporary)."""


def relative_neighbourhood(sources: np.ndarray, nodes: np.ndarray, radius: float,
                           tree: cKDTree | None = None
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pairs ``(s, v)`` with node ``v`` in the relative neighbourhood of source ``s`` and
    ``|v - s| <= radius``: no node ``u != v`` has ``max(|v - u|, |s - u|) < |v - s|``.

    Args:
        sources: ``(S, 3)`` positions.
        nodes: ``(N, 3)`` positions.
        radius: the largest ``|v - s|`` considered (a blocker is always closer to ``s``).
        tree: optional ``cKDTree`` of ``nodes``.

    Returns:
        ``(P,)`` source indices, ``(P,)`` node indices and ``(P,)`` distances ``|v - s|``,
        sorted by source, then distance.
    """
    tree = cKDTree(nodes) if tree is None else tree
    empty = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))
    if len(sources) == 0 or len(nodes) == 0:
        return empty
    hits = tree.query_ball_point(sources, radius)
    count = np.fromiter(map(len, hits), np.int64, len(hits))
    src = np.repeat(np.arange(len(sources)), count)
    node = np.fromiter(chain.from_iterable(hits), np.int64, int(count.sum()))
    dist = np.linalg.norm(sources[src] - nodes[node], axis=1)
    # most candidates are blocked by one of the source's nearest nodes: test those first
    near_d, near = tree.query(sources, k=min(_QUICK, len(nodes)))
    near_d, near = near_d.reshape(len(sources), -1), near.reshape(len(sources), -1)
    blocked = np.zeros(len(src), bool)
    for lo in range(0, len(src), _CHUNK):
        sl = slice(lo, lo + _CHUNK)
        u, r = near[src[sl]], dist[sl, None]
        uv = np.linalg.norm(nodes[u] - nodes[node[sl], None], axis=2)
        blocked[sl] = ((u != node[sl, None]) & (near_d[src[sl]] < r) & (uv < r)).any(axis=1)
    # the rest against every node closer to the source than the candidate
    rest = np.flatnonzero(~blocked)
    balls = tree.query_ball_point(sources[src[rest]], dist[rest])
    size = np.fromiter(map(len, balls), np.int64, len(balls))
    pair = np.repeat(np.arange(len(rest)), size)
    u = np.fromiter(chain.from_iterable(balls), np.int64, int(size.sum()))
    r = dist[rest][pair]
    lune = (u != node[rest][pair]) \
        & (np.linalg.norm(nodes[u] - sources[src[rest]][pair], axis=1) < r) \
        & (np.linalg.norm(nodes[u] - nodes[node[rest]][pair], axis=1) < r)
    blocked[rest] = np.bincount(pair[lune], minlength=len(rest)) > 0
    keep = np.flatnonzero(~blocked)
    keep = keep[np.lexsort((dist[keep], src[keep]))]
    return src[keep], node[keep], dist[keep]


def reached(source: np.ndarray, dist: np.ndarray, n_sources: int, kill: float) -> np.ndarray:
    """``(S,)`` mask of the sources to remove: those with at least one pair and every pair's
    node closer than ``kill`` (``source``, ``dist``: ``(P,)`` pairs as from
    :func:`relative_neighbourhood`)."""
    pairs = np.bincount(source, minlength=n_sources)
    far = np.bincount(source, weights=dist >= kill, minlength=n_sources)
    return (pairs > 0) & (far == 0)


def _near_along_veins(adjacency: list[list[int]], start: int, hops: int) -> set[int]:
    """The nodes at most ``hops`` segments from ``start`` (breadth first)."""
    seen, frontier = {start}, [start]
    for _ in range(hops):
        frontier = [w for v in frontier for w in adjacency[v] if w not in seen]
        seen.update(frontier)
    return seen


def _meeting(members: np.ndarray, adjacency: list[list[int]], hops: int) -> list[int]:
    """The members (nearest first) on different veins: each farther than ``hops`` segments
    from every nearer one kept."""
    kept: list[int] = []
    for m in members:
        near = _near_along_veins(adjacency, int(m), hops)
        if not any(k in near for k in kept):
            kept.append(int(m))
    return kept


def closed_colonisation(
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
    """Grow closed venation from mesh vertices ``seeds`` (see the module docstring); the
    arguments, defaults and errors are those of :func:`morphogen.flowers.space_colonisation`.

    Returns:
        a :class:`VeinGraph` whose ``links`` close the loops.
    """
    seeds, step, kill, influence, tip_radius, birth = check_options(
        mesh, seeds, points=points, iterations=iterations, step=step, kill=kill,
        influence=influence, gamma=gamma, tip_radius=tip_radius, refill=refill,
        birth=birth, min_branch=min_branch)
    project, normals, piece, roots, attract, pool = growth_start(
        mesh, seeds, points=points, density=density, seed=seed, refill=refill,
        iterations=iterations, kill=kill, same_piece=same_piece)
    net = _Network(*roots)
    hops = int(np.ceil(2.0 * kill / step))
    for it in range(iterations):
        if refill:
            attract = _refill(attract, pool[it * refill:(it + 1) * refill], net.nodes, birth,
                              kill)
        if len(attract) == 0:
            break
        nodes, face = net.nodes, net.face
        tree = cKDTree(nodes)
        src, near, dist = relative_neighbourhood(attract, nodes, influence, tree)
        done = reached(src, dist, len(attract), kill)
        pull = ~done[src] & (dist >= kill)
        unit = (attract[src[pull]] - nodes[near[pull]]) / dist[pull, None]
        growing, slot = np.unique(near[pull], return_inverse=True)
        direction = np.zeros((len(growing), 3))
        np.add.at(direction, slot, unit)
        n = normals[face[growing]]
        direction -= (direction * n).sum(1, keepdims=True) * n
        length = np.linalg.norm(direction, axis=1)
        live = length > 1e-9
        growing, direction = growing[live], direction[live] / length[live, None]
        new, new_face, keep = np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros(0, bool)
        if len(growing):
            label = None if piece is None else piece[face[growing]]
            new, new_face = project(nodes[growing] + step * direction, label, piece)
            keep = (tree.query(new)[0] > 0.25 * step) & (new_face >= 0)
        for s in np.flatnonzero(done):  # the veins that reached s meet there
            lo, hi = np.searchsorted(src, [s, s + 1])
            meet = _meeting(near[lo:hi], net.adjacency, hops)
            if len(meet) > 1:
                net.join(meet, attract[s], project, piece, step)
        net.add(new[keep], new_face[keep], growing[keep])
        attract = attract[~done]
        if not (keep.any() or done.any()):
            break
    nodes, face, parent = net.nodes, net.face, net.parent
    links = np.asarray(net.links, np.int64).reshape(-1, 2)
    while min_branch > 0:  # until no short twig is left
        drop = _short_twigs(nodes, parent, links, min_branch)
        if not drop.any():
            break
        keep_node = ~drop
        index = np.cumsum(keep_node) - 1
        parent = np.where(parent[keep_node] >= 0, index[parent[keep_node]], -1)
        nodes, face, links = nodes[keep_node], face[keep_node], index[links]
    order, thickness = _pipe_model(parent, gamma, tip_radius)
    return VeinGraph(nodes=nodes, parent=parent, face=face, order=order, thickness=thickness,
                     seeds=seeds, remaining=attract, links=links)


class _Network:
    """A growing vein network: the forest (``nodes``, ``face``, ``parent``), the ``links`` and
    the adjacency of both (for the distance along veins)."""

    def __init__(self, roots: np.ndarray, face: np.ndarray):
        self.nodes, self.face = roots, face
        self.parent = np.full(len(roots), -1)
        self.adjacency: list[list[int]] = [[] for _ in range(len(roots))]
        self.links: list[tuple[int, int]] = []

    def add(self, new: np.ndarray, face: np.ndarray, parent: np.ndarray) -> None:
        """Append ``(K, 3)`` nodes on faces ``(K,)``, grown from nodes ``parent`` ``(K,)``."""
        first = len(self.nodes)
        self.nodes = np.concatenate([self.nodes, new])
        self.face = np.concatenate([self.face, face])
        self.parent = np.concatenate([self.parent, parent])
        for k, p in enumerate(parent):
            self.adjacency.append([int(p)])
            self.adjacency[p].append(first + k)

    def join(self, meet: list[int], at: np.ndarray, project: SurfaceProjector,
             piece: np.ndarray | None, step: float) -> None:
        """Join the nodes ``meet`` (nearest first) at the source ``at``: through a new
        junction node there, or through the nearest node if it is within ``step / 4``; with
        face ``piece`` labels, only the nodes on the nearest one's piece."""
        if piece is not None:
            meet = [m for m in meet if piece[self.face[m]] == piece[self.face[meet[0]]]]
            if len(meet) < 2:
                return
        hub = meet[0]
        if np.linalg.norm(self.nodes[hub] - at) > 0.25 * step:
            label = None if piece is None else piece[self.face[[hub]]]
            point, face = project(at[None], label, piece)
            if face[0] < 0:
                return
            self.add(point, face, np.array([hub]))
            hub = len(self.nodes) - 1
        for m in meet[1:]:
            self.links.append((m, hub))
            self.adjacency[m].append(hub)
            self.adjacency[hub].append(m)


def _short_twigs(nodes: np.ndarray, parent: np.ndarray, links: np.ndarray,
                 min_length: float) -> np.ndarray:
    """Mask of the nodes of terminal branches (from a node of degree one up through nodes of
    degree two) shorter than ``min_length``; roots and linked nodes are never removed."""
    child = np.flatnonzero(parent >= 0)
    ends = np.concatenate([parent[child], child, links.ravel()])
    degree = np.bincount(ends, minlength=len(parent))
    drop = np.zeros(len(parent), bool)
    for tip in np.flatnonzero((degree == 1) & (parent >= 0)):
        path = [tip]
        v = parent[tip]
        while degree[v] == 2 and parent[v] >= 0:
            path.append(v)
            v = parent[v]
        ends = np.append(path, v)
        if np.linalg.norm(np.diff(nodes[ends], axis=0), axis=1).sum() < min_length:
            drop[path] = True
    return drop


def areoles(mesh: Mesh, vein: np.ndarray) -> np.ndarray:
    """``(A,)`` vertex counts of the areoles: connected pieces of the vertices with
    ``vein < 0.5`` (joined by mesh edges) that touch no boundary vertex, largest first."""
    f = mesh.faces
    pairs = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    off = np.asarray(vein) < 0.5
    pairs = pairs[off[pairs].all(axis=1)]
    n = mesh.n_vertices
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    open_ = np.zeros(label.max() + 1, bool)
    open_[label[mesh.boundary_vertices]] = True
    size = np.bincount(label[off], minlength=len(open_))
    return np.sort(size[~open_ & (size > 0)])[::-1]


VENATIONS: dict[str, Callable[..., VeinGraph]] = {
    "open": space_colonisation,
    "closed": closed_colonisation,
}
"""Growth by venation: ``open`` (a forest, :func:`space_colonisation`) and ``closed``
(with loops, :func:`closed_colonisation`)."""


def colonisation(venation: str) -> Callable[..., VeinGraph]:
    """The growth function of ``venation`` (a key of :data:`VENATIONS`)."""
    if not isinstance(venation, str) or venation not in VENATIONS:
        raise MorphogenError(f"veins: venation must be one of {', '.join(VENATIONS)}, "
                             f"got {venation!r}")
    return VENATIONS[venation]
