"""The Mesh builders: a rectangle, a disc and an icosphere, checked by their geometry and by the
heat kernel on the sphere."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

import morphogen as mg
from morphogen.domains import mesh_builders
from morphogen.domains.mesh_geometry import boundary_vertices


def _euler_characteristic(faces: np.ndarray, n_vertices: int) -> int:
    edges = np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]],
                                              faces[:, [2, 0]]]), axis=1), axis=0)
    return n_vertices - len(edges) + len(faces)


@pytest.mark.parametrize("subdivisions", [0, 1, 3])
def test_icosphere_is_a_closed_sphere(subdivisions):
    mesh = mg.Mesh.sphere(2.0, subdivisions=subdivisions)
    assert mesh.n_vertices == 10 * 4**subdivisions + 2
    assert mesh.n_faces == 20 * 4**subdivisions
    np.testing.assert_allclose(np.linalg.norm(mesh.vertices, axis=1), 2.0, rtol=1e-12)
    assert _euler_characteristic(mesh.faces, mesh.n_vertices) == 2
    assert mesh.boundary_vertices.size == 0
    centroids = mesh.vertices[mesh.faces].mean(axis=1)
    normals = np.cross(*(mesh.vertices[mesh.faces[:, k]] - mesh.vertices[mesh.faces[:, 0]]
                         for k in (1, 2)))
    assert np.all(np.sum(normals * centroids, axis=1) > 0)  # counter-clockwise from outside


def test_icosphere_area_approaches_the_sphere():
    errors = [abs(mg.Mesh.sphere(1.0, subdivisions=s).areas.sum() / (4 * np.pi) - 1)
              for s in (2, 3, 4)]
    assert errors[0] < 0.03 and errors[2] < 0.003
    assert errors[0] > errors[1] > errors[2]  # inscribed: each subdivision gets closer


def test_heat_kernel_on_the_built_sphere():
    """u = z is an l = 1 spherical harmonic: u(t) = z exp(-2 D t / R^2), D = 1, R = 1."""
    sphere = mg.Mesh.sphere(1.0, subdivisions=3)
    model = mg.Model(name="heat", species=("u",), params={"D": 1.0},
                     reaction=lambda u, p, c: jnp.zeros_like(u),
                     diffusion=lambda p, c: (p["D"],))
    z = sphere.coords["z"]
    dt = 0.25 * mg.max_stable_dt(model, sphere, model.params)
    sol = mg.simulate(model, sphere, z[None], model.params, steps=round(0.5 / dt), dt=dt)
    a = sphere.areas
    amplitude = np.sum(a * sol.state[0] * z) / np.sum(a * z * z)
    assert amplitude == pytest.approx(np.exp(-2.0 * sol.t), rel=0.02)


def test_plane_covers_its_rectangle_exactly():
    mesh = mg.Mesh.plane(3.0, 2.0, edge=0.25)
    assert mesh.n_vertices == 13 * 9
    assert mesh.areas.sum() == pytest.approx(6.0, rel=1e-12)
    assert np.ptp(mesh.vertices, axis=0) == pytest.approx([3.0, 2.0, 0.0])
    assert _euler_characteristic(mesh.faces, mesh.n_vertices) == 1


def test_disc_is_round_with_edges_near_the_asked_length():
    mesh = mg.Mesh.disc(1.5, edge=0.1)
    n = len(boundary_vertices(mesh.faces))
    ring = np.linalg.norm(mesh.vertices[boundary_vertices(mesh.faces), :2], axis=1)
    np.testing.assert_allclose(ring, 1.5, rtol=1e-12)
    polygon = 0.5 * n * 1.5**2 * np.sin(2 * np.pi / n)
    assert mesh.areas.sum() == pytest.approx(polygon, rel=1e-9)
    assert _euler_characteristic(mesh.faces, mesh.n_vertices) == 1
    assert 0.07 < mesh.edge_length < 0.12
    assert np.all(mesh.vertices[:, 2] == 0)


@pytest.mark.parametrize("build, message", [
    (lambda: mg.Mesh.sphere(-1.0), "radius must be a positive number"),
    (lambda: mg.Mesh.sphere(1.0, subdivisions=1.5), "whole number"),
    (lambda: mg.Mesh.sphere(1.0, subdivisions=12), "more than 2,000,000"),
    (lambda: mg.Mesh.disc(1.0, edge=float("nan")), "edge must be a positive number"),
    (lambda: mg.Mesh.plane(1.0, 1.0, edge=1e-5), "choose a larger edge"),
])
def test_bad_builder_settings_are_one_line(build, message):
    with pytest.raises(mg.MorphogenError, match=message):
        build()


def test_builders_return_plain_arrays():
    vertices, faces = mesh_builders.sphere(1.0, 1)
    assert vertices.shape == (42, 3) and faces.shape == (80, 3)
    assert faces.dtype == np.int64
