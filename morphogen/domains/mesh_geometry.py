"""Triangle-mesh geometry in NumPy (float64): validation, areas, angles, gradients, frames.

Everything here runs once per mesh, outside ``jit``; :mod:`morphogen.domains.mesh_operators`
turns the results into the arrays the JAX operators use. Conventions: ``vertices`` has shape
``(V, 3)``, ``faces`` ``(F, 3)`` (vertex indices, counter-clockwise seen from the normal);
inside a face, corner ``k`` is opposite the edge from corner ``k+1`` to corner ``k+2``
(indices mod 3).
"""

from __future__ import annotations

import numpy as np

from morphogen.errors import MorphogenError

DEGENERATE_AREA = 1e-12
"""A face whose area is below this fraction of the mean face area counts as degenerate."""


def validate(vertices: np.ndarray, faces: np.ndarray, *, source: str = "mesh") -> None:
    """Reject meshes the operators cannot handle, with a one-line reason.

    Checks: shapes, finite coordinates, indices in range, no face repeating a vertex, no
    zero-area face, every vertex used by some face, and every edge shared by at most two faces
    (edge-manifold). Open boundaries are allowed (they are no-flux by default).

    Raises:
        MorphogenError: naming the first problem and its index.
    """
    if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) < 3:
        raise MorphogenError(f"{source}: vertices must have shape (V, 3) with V >= 3, got "
                             f"{vertices.shape}")
    if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) < 1:
        raise MorphogenError(f"{source}: needs triangle faces of shape (F, 3), got {faces.shape}")
    if not np.all(np.isfinite(vertices)):
        bad = int(np.flatnonzero(~np.isfinite(vertices).all(axis=1))[0])
        raise MorphogenError(f"{source}: vertex {bad} has a non-finite coordinate")
    if faces.min() < 0 or faces.max() >= len(vertices):
        bad = int(np.flatnonzero((faces < 0).any(1) | (faces >= len(vertices)).any(1))[0])
        raise MorphogenError(
            f"{source}: face {bad} refers to a vertex outside 0..{len(vertices) - 1}"
        )
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (
        faces[:, 0] == faces[:, 2]
    )
    if repeated.any():
        bad = int(np.flatnonzero(repeated)[0])
        raise MorphogenError(f"{source}: face {bad} repeats a vertex (degenerate triangle)")
    with np.errstate(over="ignore", invalid="ignore"):
        area = face_areas(vertices, faces)
    if not np.all(np.isfinite(area)):
        bad = int(np.flatnonzero(~np.isfinite(area))[0])
        raise MorphogenError(f"{source}: face {bad} has an infinite area (coordinates too "
                             "large); rescale the mesh")
    small = area <= DEGENERATE_AREA * max(float(area.mean()), np.finfo(float).tiny)
    if small.any():
        bad = int(np.flatnonzero(small)[0])
        raise MorphogenError(
            f"{source}: face {bad} has zero area (degenerate triangle); remove or repair it"
        )
    used = np.zeros(len(vertices), bool)
    used[faces.ravel()] = True
    if not used.all():
        bad = int(np.flatnonzero(~used)[0])
        raise MorphogenError(
            f"{source}: vertex {bad} belongs to no face ({int((~used).sum())} unused); "
            "remove unused vertices before simulating"
        )
    _, counts = _unique_edges(faces)
    if counts.max() > 2:
        raise MorphogenError(
            f"{source}: non-manifold: {int((counts > 2).sum())} edge(s) shared by more than "
            "two faces; repair the mesh (e.g. split the edges) first"
        )


def _unique_edges(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Undirected edges ``(E, 2)`` (sorted pairs, in lexicographic order) and how many faces use
    each. Each pair ``(a, b)`` is sorted as the one number ``a·V + b`` (``V`` past the largest
    index), an order-preserving code: a sort of numbers is about ten times faster than
    ``np.unique(axis=0)`` on pairs, which a mesh pays every time it is built."""
    edges = np.sort(np.concatenate([faces[:, [1, 2]], faces[:, [2, 0]], faces[:, [0, 1]]]), axis=1)
    n = np.int64(edges.max()) + 1 if edges.size else np.int64(1)
    codes, counts = np.unique(edges[:, 0].astype(np.int64) * n + edges[:, 1], return_counts=True)
    return np.stack([codes // n, codes % n], axis=1).astype(edges.dtype), counts


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unnormalised normals ``N = AB x AC`` with ``|N| = 2 area``, shape ``(F, 3)``."""
    p = vertices[faces]
    return np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])


def face_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Triangle areas, shape ``(F,)``."""
    return 0.5 * np.linalg.norm(face_normals(vertices, faces), axis=1)


def edge_vectors(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``e[:, k] = p[k+2] - p[k+1]``, the edge opposite corner ``k``, shape ``(F, 3, 3)``."""
    p = vertices[faces]
    return np.stack([p[:, (k + 2) % 3] - p[:, (k + 1) % 3] for k in range(3)], axis=1)


def cotangents(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Cotangent of the angle at each corner, shape ``(F, 3)`` (Ringham et al. eq. 11).

    .. math:: \\cot\\alpha = \\frac{\\vec{AB}\\cdot\\vec{AC}}{\\|\\vec{AB}\\times\\vec{AC}\\|}
    """
    p = vertices[faces]
    twice_area = np.linalg.norm(face_normals(vertices, faces), axis=1)
    out = np.empty((len(faces), 3))
    for k in range(3):
        a = p[:, (k + 1) % 3] - p[:, k]
        b = p[:, (k + 2) % 3] - p[:, k]
        out[:, k] = np.einsum("fi,fi->f", a, b) / twice_area
    return out


def hat_gradients(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Gradient of each corner's linear hat function, shape ``(F, 3, 3)`` (corner, xyz).

    Ringham et al. eq. 7: :math:`\\nabla c = -(c_A\\vec{BC} + c_B\\vec{CA} + c_C\\vec{AB})\\times
    \\mathbf N / (\\mathbf N\\cdot\\mathbf N)`, so corner ``k`` contributes
    :math:`\\mathbf N\\times e_k / (\\mathbf N\\cdot\\mathbf N)` with ``e_k`` its opposite edge.
    """
    n = face_normals(vertices, faces)
    nn = np.einsum("fi,fi->f", n, n)[:, None]
    e = edge_vectors(vertices, faces)
    return np.stack([np.cross(n, e[:, k]) / nn for k in range(3)], axis=1)


def mixed_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Mixed Voronoi area of each vertex, shape ``(V,)`` (Meyer et al. 2003).

    A non-obtuse triangle gives corner ``B`` its Voronoi part, Ringham et al. eq. 13:
    :math:`\\tfrac18(|BC|^2\\cot\\alpha + |AB|^2\\cot\\gamma)`. An obtuse triangle, whose
    circumcentre lies outside it (where eq. 13 turns negative), gives half its area to the obtuse
    corner and a quarter to each other corner. The areas are positive and sum to the mesh area.
    """
    cot = cotangents(vertices, faces)
    e = edge_vectors(vertices, faces)
    sq = np.einsum("fki,fki->fk", e, e)
    area = face_areas(vertices, faces)
    part = np.empty((len(faces), 3))
    for k in range(3):
        # edges at corner k: opposite corners k+1 (edge k..k+2) and k+2 (edge k..k+1)
        part[:, k] = (sq[:, (k + 1) % 3] * cot[:, (k + 1) % 3]
                      + sq[:, (k + 2) % 3] * cot[:, (k + 2) % 3]) / 8.0
    obtuse = cot < 0.0
    any_obtuse = obtuse.any(axis=1)
    part[any_obtuse] = np.where(obtuse[any_obtuse], 0.5, 0.25) * area[any_obtuse, None]
    out = np.zeros(len(vertices))
    np.add.at(out, faces.ravel(), part.ravel())
    return out


def boundary_edges(faces: np.ndarray) -> np.ndarray:
    """Edges used by exactly one face, shape ``(B, 2)`` (sorted pairs)."""
    edges, counts = _unique_edges(faces)
    return edges[counts == 1]


def boundary_vertices(faces: np.ndarray) -> np.ndarray:
    """Sorted indices of vertices on an open boundary (empty for a closed mesh)."""
    return np.unique(boundary_edges(faces))


def tangent_frames(
    vertices: np.ndarray, faces: np.ndarray, directions: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An orthonormal tangent frame per face: ``(e1, e2, defined)``, shapes ``(F,3), (F,3), (F,)``.

    ``e1`` is ``directions`` (one vector per face) projected onto the face plane and normalised,
    ``e2 = n x e1``. Without ``directions`` the frame is the global x axis projected (the y axis
    where x is nearly normal to the face), so a flat mesh in the xy plane has the frame (x, y),
    the one a grid uses. ``defined`` is False where a given direction vanishes on the face
    (Ringham et al. eq. 18 is undefined where the gradient is zero).
    """
    n = face_normals(vertices, faces)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    if directions is None:
        d = np.broadcast_to(np.array([1.0, 0.0, 0.0]), n.shape).copy()
        weak = np.abs(n[:, 0]) > 0.95
        d[weak] = np.array([0.0, 1.0, 0.0])
    else:
        d = np.asarray(directions, np.float64)
    t = d - np.einsum("fi,fi->f", d, n)[:, None] * n
    length = np.linalg.norm(t, axis=1)
    scale = np.linalg.norm(d, axis=1)
    defined = length > 1e-9 * np.maximum(scale, np.finfo(float).tiny)
    defined &= scale > 0
    e1 = np.where(defined[:, None], t / np.where(defined, length, 1.0)[:, None], 0.0)
    fallback = np.cross(n, np.array([0.0, 0.0, 1.0]))
    e1[~defined] = fallback[~defined]
    lost = np.linalg.norm(e1, axis=1) < 0.5
    e1[lost] = np.array([1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(n, e1)
    return e1, e2, defined


def face_gradient(vertices: np.ndarray, faces: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Per-face gradient of a per-vertex field (Ringham et al. eq. 7), shape ``(F, 3)``."""
    grads = hat_gradients(vertices, faces)
    return np.einsum("fk,fki->fi", np.asarray(values, np.float64)[faces], grads)
