"""Mesh diffusion operators against theory (Ringham et al. §3.4.2)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import trimesh

from morphogen.domains.grid import Grid
from morphogen.domains.mesh import Mesh
from morphogen.engine.simulate import integrate, simulate
from morphogen.errors import MorphogenError, UnstableTimeStepError
from morphogen.flowers.planar import grid_mesh, lattice_mesh
from morphogen.models.library import get_model
from morphogen.models.model import Model, Tensor
from morphogen.solvers.step import make_step, max_stable_dt


def heat(tensor: bool = False, field: bool = False) -> Model:
    """Pure diffusion of one species: scalar ``D``, a per-vertex field, or a tensor."""

    def diffusion(p, c):
        if tensor:
            return (Tensor(p["l1"], 0.0 * p["l1"], p["l2"]),)
        if field:
            return (p["D"] * (1.0 + 0.5 * jnp.sin(3.0 * c["x"])),)
        return (p["D"],)

    return Model(name="heat", species=("u",), params={"D": 1.0, "l1": 1.0, "l2": 0.25},
                 reaction=lambda u, p, c: jnp.zeros_like(u), diffusion=diffusion)


@pytest.fixture(scope="module")
def sphere() -> Mesh:
    s = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    return Mesh(s.vertices, s.faces, name="icosphere")


def test_heat_kernel_on_sphere(sphere):
    """u = z is an l = 1 spherical harmonic: u(t) = z exp(-2 D t / R^2)."""
    model = heat()
    params = {**model.params, "D": 0.5}
    z = sphere.coords["z"]
    dt = 0.25 * max_stable_dt(model, sphere, params)
    steps = int(round(1.0 / dt))
    sol = simulate(model, sphere, z[None], params, steps=steps, dt=dt)
    a = sphere.areas
    amplitude = np.sum(a * sol.state[0] * z) / np.sum(a * z * z)
    expected = np.exp(-2.0 * 0.5 * sol.t / 1.0**2)
    assert amplitude == pytest.approx(expected, rel=0.01)
    residual = sol.state[0] - amplitude * z
    assert np.abs(residual).max() < 0.01 * expected


def test_isotropic_paths_agree(sphere):
    """Scalar, per-vertex field and tensor coefficients give the same operator for D = 1."""
    ops = sphere.ops
    u = jnp.asarray(np.random.default_rng(0).random(sphere.n_vertices), jnp.float32)
    a = ops.laplacian(u)
    b = ops.laplacian_field(u, jnp.ones_like(u))
    c = ops.tensor_divergence(u, ops.face_tensor(1.0, 0.0, 1.0, u.dtype))
    scale = float(jnp.abs(a).max())
    assert float(jnp.abs(a - b).max()) < 1e-5 * scale
    assert float(jnp.abs(a - c).max()) < 1e-5 * scale


def test_flux_decomposition_matches_operator(sphere):
    """Summing the per-border, per-corner flux components (eqs. 12, 14) gives the operator."""
    ops = sphere.ops
    u = jnp.asarray(np.random.default_rng(1).random(sphere.n_vertices), jnp.float32)
    tensor = ops.face_tensor(1.0, 0.3, 0.5, u.dtype)
    z = ops.flux_components(tensor, u.dtype)
    flow = (z * u[jnp.asarray(ops.faces)][:, None, :]).sum(axis=2)
    mass = jnp.roll(flow, 1, axis=1) - jnp.roll(flow, -1, axis=1)
    direct = ops.tensor_divergence(u, tensor)
    summed = ops.corners.apply(mass.T.reshape(-1))  # corner-major: entry k F + f
    assert np.allclose(summed, direct, atol=1e-4 * np.abs(direct).max())


def _moments(mesh: Mesh, u: np.ndarray, direction: np.ndarray) -> tuple[float, float]:
    w = mesh.areas * u
    w = w / w.sum()
    p = mesh.vertices[:, :2] - (w[:, None] * mesh.vertices[:, :2]).sum(axis=0)
    along = p @ direction
    across = p @ np.array([-direction[1], direction[0]])
    return float(np.sum(w * along**2)), float(np.sum(w * across**2))


def test_anisotropic_point_source_variances():
    """Variances along and across the direction field grow as 2 l1 t and 2 l2 t (eqs. 8, 18)."""
    angle = 0.5
    d = np.array([np.cos(angle), np.sin(angle)])
    base = lattice_mesh(61, 71)
    mesh = base.replace(directions=np.tile([d[0], d[1], 0.0], (base.n_faces, 1)))
    model = heat(tensor=True)
    params = {**model.params, "l1": 1.0, "l2": 0.25}
    centre = int(np.argmin(np.linalg.norm(mesh.vertices, axis=1)))
    u0 = np.zeros((1, mesh.n_vertices), np.float32)
    u0[0, centre] = 1.0 / mesh.areas[centre]
    v0 = _moments(mesh, u0[0], d)
    dt = 0.5 * max_stable_dt(model, mesh, params)
    sol = simulate(model, mesh, u0, params, steps=int(12.0 / dt), dt=dt)
    v1 = _moments(mesh, sol.state[0], d)
    grow_along, grow_across = v1[0] - v0[0], v1[1] - v0[1]
    assert grow_along == pytest.approx(2 * 1.0 * sol.t, rel=0.05)
    assert grow_across == pytest.approx(2 * 0.25 * sol.t, rel=0.05)
    assert grow_along / grow_across == pytest.approx(4.0, rel=0.05)


@pytest.mark.parametrize("kind", ["scalar", "field", "tensor"])
def test_mass_conservation_closed_and_open(sphere, kind):
    model = heat(tensor=kind == "tensor", field=kind == "field")
    params = {**model.params, "D": 0.5}
    rng = np.random.default_rng(2)
    for mesh in (sphere, lattice_mesh(20, 20, spacing=0.1)):
        u0 = rng.random((1, mesh.n_vertices)).astype(np.float32)
        dt = 0.5 * max_stable_dt(model, mesh, params)
        sol = simulate(model, mesh, u0, params, steps=200, dt=dt)
        before, after = float(mesh.mass(u0)[0]), float(mesh.mass(sol.state)[0])
        assert after == pytest.approx(before, rel=2e-5)
        assert np.std(sol.state) < 0.8 * np.std(u0)  # something actually diffused


@pytest.mark.slow
def test_grid_and_flat_mesh_agree():
    """Gray-Scott with Dirichlet edges: the mesh's interior operator is the 5-point stencil."""
    model = get_model("gray-scott")
    params = model.parameters()
    n = 24
    bc = {"u": "dirichlet=1", "v": "dirichlet=0"}
    grid = Grid((n, n), dx=1.0, boundary=bc)
    mesh = grid_mesh(n, n, boundary=bc)
    u0 = np.stack([np.ones((n, n)), np.zeros((n, n))]).astype(np.float32)
    u0[:, 9:15, 9:15] = [[[0.5]], [[0.25]]]
    run = dict(steps=400, dt=1.0, clamp=None)
    on_grid = simulate(model, grid, u0, params, **run).state
    on_mesh = simulate(model, mesh, u0.reshape(2, -1), params, **run).state.reshape(2, n, n)
    assert np.abs(on_grid - u0).max() > 0.05  # the pattern moved
    assert np.abs(on_grid - on_mesh).max() < 1e-4


def test_dirichlet_on_vertex_set_and_errors():
    mesh = lattice_mesh(12, 12)
    left = (mesh.vertices[:, 0] < mesh.vertices[:, 0].min() + 0.1).astype(float)
    mesh = mesh.with_fields(left=left, source=2.0 * left)
    model = heat()
    bcs = mesh.replace(boundary=["dirichlet=0", "dirichlet=source@left"]).boundaries(("u",))
    u = mesh.hold(jnp.full((1, mesh.n_vertices), 5.0), bcs)
    assert np.allclose(np.asarray(u)[0, mesh.vertex_set("left")], 2.0)
    others = np.setdiff1d(mesh.boundary_vertices, mesh.vertex_set("left"))
    assert np.allclose(np.asarray(u)[0, others], 0.0)
    interior = np.setdiff1d(np.arange(mesh.n_vertices), mesh.boundary_vertices)
    assert np.allclose(np.asarray(u)[0, interior], 5.0)
    for bad in ("periodic", "dirichlet=1@nowhere", "dirichlet=@left", "sticky"):
        with pytest.raises(MorphogenError):
            mesh.replace(boundary=bad).boundaries(("u",))
    with pytest.raises(MorphogenError, match="closed"):
        s = trimesh.creation.icosphere(subdivisions=1)
        Mesh(s.vertices, s.faces, boundary="dirichlet=1").boundaries(model.species)


def test_spectral_radius_and_stability_check(sphere):
    scale = 1.0 / np.sqrt(sphere.areas)
    dense = sphere.ops.stiffness.toarray() * scale[:, None] * scale[None, :]
    exact = np.linalg.eigvalsh(dense).max()  # same spectrum as M^-1 C
    assert sphere.spectral_radius() == pytest.approx(exact, rel=2e-3)
    assert sphere.spectral_radius() >= exact
    model = heat()
    with pytest.raises(UnstableTimeStepError):
        simulate(model, sphere, sphere.coords["z"][None], model.params, steps=1,
                 dt=2.5 / exact)


def test_invalid_meshes_are_rejected():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1]], float)
    with pytest.raises(MorphogenError, match="repeats a vertex"):
        Mesh(v[:4], [[0, 1, 2], [0, 1, 0]])
    with pytest.raises(MorphogenError, match="non-manifold"):
        Mesh(v, [[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    with pytest.raises(MorphogenError, match="belongs to no face"):
        Mesh(v, [[0, 1, 2], [1, 3, 2]])
    with pytest.raises(MorphogenError, match="outside"):
        Mesh(v[:3], [[0, 1, 3]])
    collinear = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]], float)
    with pytest.raises(MorphogenError, match="zero area"):
        Mesh(collinear, [[0, 1, 2], [0, 1, 3]])


@pytest.mark.slow
def test_grad_through_mesh_simulation_matches_finite_differences(sphere):
    model = heat()
    step = make_step(model, sphere)
    z = jnp.asarray(sphere.coords["z"])[None]
    weight = jnp.asarray(sphere.areas, jnp.float32) * z[0]

    def loss(d):
        u, _, _ = integrate(step, z, {"D": d, "l1": 1.0, "l2": 1.0}, steps=20, dt=0.002,
                            key=jax.random.PRNGKey(0))
        return jnp.sum(weight * u[0])

    g = float(jax.grad(loss)(0.5))
    h = 1e-2
    fd = (float(loss(0.5 + h)) - float(loss(0.5 - h))) / (2 * h)
    assert g == pytest.approx(fd, rel=1e-2)
    assert g < 0  # faster diffusion decays the mode faster


def test_padded_table_with_tail_matches_sparse_product(monkeypatch):
    import scipy.sparse as sp

    from morphogen.domains import mesh_operators

    monkeypatch.setattr(mesh_operators, "MAX_WIDTH", 3)
    rng = np.random.default_rng(5)
    n = 50
    a = sp.random(n, n, density=0.15, random_state=6, format="coo")
    table = mesh_operators.Table.from_coo(a.row, a.col, a.data, n)
    assert len(table.tail_rows) > 0 and table.index.shape[0] <= 3
    x = rng.random((2, n)).astype(np.float32)
    assert np.allclose(table.apply(jnp.asarray(x)), (a @ x.T).T, atol=1e-5)
    d = rng.random(n).astype(np.float32)
    sym = (a + a.T).tocoo()
    table = mesh_operators.Table.from_coo(sym.row, sym.col, sym.data, n)
    dense = sym.toarray() * 0.5 * (d[:, None] + d[None, :])
    expected = dense @ x[0] - dense.sum(axis=1) * x[0]
    got = table.apply_differences(jnp.asarray(x[0]), jnp.asarray(d))
    assert np.allclose(got, expected, atol=1e-4)


@pytest.mark.slow
def test_batch_on_a_mesh_equals_a_loop():
    from morphogen.engine.simulate import simulate_batch
    from morphogen.solvers.step import batch_params

    mesh = lattice_mesh(6, 6, spacing=0.5, omega=1e4)
    model = heat()
    u0 = np.random.default_rng(3).random((2, 1, mesh.n_vertices)).astype(np.float32) + 1.0
    params = batch_params({**model.params, "D": np.array([0.1, 0.3], np.float32)}, 2, ["D"])
    run = dict(steps=20, dt=0.05, seed=7)
    batch = simulate_batch(model, mesh, u0, params, **run)
    keys = jax.random.split(jax.random.PRNGKey(7), 2)
    step = make_step(model, mesh)
    for b in range(2):
        one = {k: v[b] for k, v in params.items()}
        u, _, _ = integrate(step, jnp.asarray(u0[b]), one, steps=20, dt=0.05, key=keys[b])
        assert np.allclose(batch.state[b], np.asarray(u), atol=1e-6)
    assert batch.valid.all()
