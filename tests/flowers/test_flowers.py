"""Procedural flower meshes, positional information and random points."""

from __future__ import annotations

import numpy as np
import pytest

from morphogen.domains import mesh_geometry as geo
from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError
from morphogen.flowers import (
    corolla,
    direction_field,
    petal,
    positional_information,
    random_vertices,
    seed_field,
    tube,
)
from morphogen.flowers.meshing import triangulate


def _quality(mesh: Mesh) -> tuple[float, float, float, float]:
    lengths = np.linalg.norm(geo.edge_vectors(mesh.vertices, mesh.faces), axis=2).ravel()
    angles = np.degrees(np.arctan2(1.0, geo.cotangents(mesh.vertices, mesh.faces)))
    small = angles.min(axis=1) < 20  # only where the outline itself has a sharp corner
    return (lengths.mean(), lengths.std() / lengths.mean(), float(small.mean()),
            float((angles.max(axis=1) > 90).mean()))


@pytest.mark.parametrize("make", [
    lambda: petal(edge=0.03),
    lambda: corolla(petals=5, edge=0.04, eye=0.1, teeth=4, fringe=0.1),
    lambda: tube(lobes=5, edge=0.04, lobe_scales=[0.7, 0.7, 1.1, 1.3, 1.1]),
], ids=["petal", "corolla", "tube"])
def test_generated_shapes_are_near_equilateral_with_named_sets(make):
    mesh = make()
    edge = 0.03 if mesh.name == "petal" else 0.04
    mean, cv, sharp, obtuse = _quality(mesh)
    assert mean == pytest.approx(edge, rel=0.15)
    assert cv < 0.25 and sharp < 0.002 and obtuse < 0.05
    boundary = set(mesh.boundary_vertices.tolist())
    margin = set(mesh.vertex_set("margin").tolist())
    inner = "base" if "base" in mesh.fields else "throat"
    assert margin and margin <= boundary
    assert len(mesh.vertex_set("midline")) > 5
    if mesh.name != "corolla-5":  # the corolla's hole is its throat; otherwise base edge
        assert boundary == margin | set(mesh.vertex_set(inner).tolist())


def test_tube_is_closed_around_and_follows_its_profile():
    mesh = tube(lobes=4, length=1.0, radius=0.2, mouth=0.2, edge=0.04)
    s = mesh.fields["s"]
    in_tube = s < 0.9
    radius = np.linalg.norm(mesh.vertices[in_tube, :2], axis=1)
    assert np.allclose(radius, 0.2, rtol=1e-6)  # a cylinder, no seam
    assert np.allclose(mesh.vertices[in_tube, 2], s[in_tube], atol=1e-3)
    base = mesh.vertex_set("base")
    assert np.allclose(mesh.vertices[base, 2], 0.0, atol=1e-9)


def _annulus(r1=0.3, r2=1.0, edge=0.03) -> Mesh:
    t = np.linspace(0, 2 * np.pi, 300, endpoint=False)
    circle = np.stack([np.cos(t), np.sin(t)], 1)
    pts, tri, _ = triangulate([r2 * circle, r1 * circle], lambda p: np.full(len(p), edge),
                              holes=[[0.0, 0.0]])
    r = np.linalg.norm(pts, axis=1)
    fields = {"outer": (r > 0.5 * (r1 + r2)).astype(float)}
    mesh = Mesh(np.c_[pts, np.zeros(len(pts))], tri, fields=fields)
    outer = np.zeros(len(pts))
    outer[np.intersect1d(mesh.boundary_vertices, np.flatnonzero(r > 0.5))] = 1
    inner = np.zeros(len(pts))
    inner[np.intersect1d(mesh.boundary_vertices, np.flatnonzero(r < 0.5))] = 1
    return mesh.with_fields(outer=outer, inner=inner)


def test_positional_information_is_harmonic():
    """Between two circles the steady state is g = ln(r/r1) / ln(r2/r1)."""
    mesh = _annulus()
    g = positional_information(mesh, "outer", "inner")
    r = np.linalg.norm(mesh.vertices[:, :2], axis=1)
    exact = np.log(r / 0.3) / np.log(1.0 / 0.3)
    assert np.abs(g - exact).max() < 0.01
    # eq. 18 direction: the gradient points outwards, radially
    d = direction_field(mesh, g)
    centres = mesh.vertices[mesh.faces].mean(axis=1)
    cosine = np.einsum("fi,fi->f", d, centres) / (np.linalg.norm(d, axis=1)
                                                  * np.linalg.norm(centres, axis=1))
    assert np.percentile(cosine, 5) > 0.99
    with pytest.raises(MorphogenError, match="overlap"):
        positional_information(mesh, "outer", "outer")
    decayed = positional_information(mesh, "outer", "inner", decay=50.0)
    assert np.all(decayed <= g + 1e-9)


def test_random_points_uniform_and_rejection():
    n = 8000
    pts = random_vertices(n, 300, seed=4)
    assert len(np.unique(pts)) == 300 and np.array_equal(pts, random_vertices(n, 300, seed=4))
    density = np.where(np.arange(n) < n // 2, 1.0, 0.25)
    chosen = random_vertices(n, 400, density=density, seed=5)
    high = int((chosen < n // 2).sum())
    assert high / (400 - high) == pytest.approx(4.0, rel=0.3)
    zero = np.zeros(n)
    zero[:10] = 1.0
    assert set(random_vertices(n, 10, density=zero, seed=0)) == set(range(10))
    with pytest.raises(MorphogenError):
        random_vertices(n, 11, density=zero)
    with pytest.raises(MorphogenError):
        random_vertices(10, 11)
    field = seed_field(n, 50, seed=1)
    assert (field > 0).sum() == 50 and field.max() <= 1.0


def test_bad_shape_arguments():
    with pytest.raises(MorphogenError):
        petal(edge=0.0)
    with pytest.raises(MorphogenError):
        corolla(petals=1)
    with pytest.raises(MorphogenError):
        tube(lobes=5, lobe_scales=[1.0, 1.0])
