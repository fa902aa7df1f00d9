"""Stochastic diffusion on meshes (Ringham et al. eqs. 14-17)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.engine.simulate import simulate
from morphogen.flowers.planar import grid_mesh, lattice_mesh
from morphogen.models.model import Model

D = 0.5
DT = 0.05


def heat() -> Model:
    return Model(name="heat", species=("u",), params={"D": D},
                 reaction=lambda u, p, c: jnp.zeros_like(u), diffusion=lambda p, c: (p["D"],))


def _samples(mesh, u, n=2000):
    bcs = mesh.boundaries(("u",))
    keys = jax.random.split(jax.random.PRNGKey(3), n)
    draw = jax.jit(jax.vmap(lambda k: mesh.diffusion_noise(u, (D,), bcs, DT, k)[0]))
    return np.asarray(draw(keys), np.float64)


def _predicted_variance(mesh, u, omega):
    """Per-vertex variance of eq. 17: every border's variance reaches both its vertices."""
    ops = mesh.ops
    tensor = ops.face_tensor(D, 0.0, D, jnp.float32)
    z = np.asarray(ops.flux_components(tensor, jnp.float32), np.float64)
    uf = np.asarray(u)[0][ops.faces]
    var = (np.abs(z) * uf[:, None, :]).sum(axis=2) * DT / omega
    corner = np.roll(var, 1, axis=1) + np.roll(var, -1, axis=1)
    out = np.zeros(mesh.n_vertices)
    np.add.at(out, ops.faces.ravel(), corner.ravel())
    return out / mesh.areas**2


@pytest.mark.slow
def test_noise_variance_matches_eq17_and_scales_as_one_over_omega():
    u = jnp.full((1, 144), 2.0, jnp.float32)
    variances = []
    for omega in (1e2, 1e4):
        mesh = lattice_mesh(12, 12, spacing=0.1, omega=omega)
        samples = _samples(mesh, u)
        predicted = _predicted_variance(mesh, u, omega)
        measured = samples.var(axis=0)
        assert np.mean(measured) == pytest.approx(np.mean(predicted), rel=0.05)
        assert np.allclose(measured, predicted, rtol=0.25)
        # each draw moves mass between neighbours only
        masses = samples @ mesh.areas
        assert np.abs(masses).max() < 1e-4 * np.abs(samples * mesh.areas).sum(axis=1).max()
        variances.append(measured.mean())
    assert variances[0] / variances[1] == pytest.approx(100.0, rel=0.1)


def test_negative_concentrations_add_no_noise():
    mesh = lattice_mesh(8, 8, spacing=0.1, omega=10.0)
    u = jnp.full((1, mesh.n_vertices), -1.0, jnp.float32)
    assert np.abs(_samples(mesh, u, n=4)).max() == 0.0


@pytest.mark.slow
def test_deterministic_limit_and_seeding():
    model = heat()
    base = lattice_mesh(16, 16, spacing=0.1)
    u0 = np.random.default_rng(0).random((1, base.n_vertices)).astype(np.float32) + 1.0
    run = dict(steps=100, dt=DT * 0.02)
    exact = simulate(model, base, u0, model.params, **run).state
    meshes = {omega: base.replace(omega=omega) for omega in (1e4, 1e6, 1e12)}
    rms = {}
    for omega, mesh in meshes.items():
        noisy = simulate(model, mesh, u0, model.params, seed=1, **run).state
        rms[omega] = float(np.sqrt(np.mean((noisy - exact) ** 2)))
    assert rms[1e4] / rms[1e6] == pytest.approx(10.0, rel=0.3)
    assert rms[1e12] < 1e-4
    first = simulate(model, meshes[1e4], u0, model.params, seed=1, **run).state
    again = simulate(model, meshes[1e4], u0, model.params, seed=1, **run).state
    other = simulate(model, meshes[1e4], u0, model.params, seed=2, **run).state
    assert np.array_equal(first, again)
    assert not np.allclose(first, other)


def _noise_draws(mesh, c, d, dt, n, seed=5):
    """``n`` draws of eq. 17's increment (concentration change) at the uniform state ``c``."""
    u = jnp.full((1, mesh.n_vertices), c, jnp.float32)
    bcs = mesh.boundaries(("u",))
    keys = jax.random.split(jax.random.PRNGKey(seed), n)
    draw = jax.jit(jax.vmap(lambda k: mesh.diffusion_noise(u, (d,), bcs, dt, k)[0]))
    return np.asarray(draw(keys), np.float64)


def _stationary_covariance(mesh, omega, c=1.0, d=1.0, n=16000):
    """Stationary covariance of the explicit stochastic scheme ``u' = (I + dt D L) u + xi`` about
    the uniform state ``c``: ``Sigma = sum_k M^k Q M^kT`` with ``Q`` the covariance of eq. 17's
    increment (measured from draws), summed by doubling."""
    ops = mesh.ops
    n_v = mesh.n_vertices
    lap = np.asarray(ops.laplacian(jnp.eye(n_v, dtype=jnp.float32)), np.float64).T
    dt = 0.05 * 2.0 / (d * ops.spectral_radius())  # small: Euler's inflation stays < 3 %
    xi = _noise_draws(mesh.replace(omega=omega), c, d, dt, n)
    q = xi.T @ xi / n
    m = np.eye(n_v) + dt * d * lap
    sigma = q
    for _ in range(17):  # 2**17 steps: t = 2**17 dt, several times the slowest decay time
        sigma = sigma + m @ sigma @ m.T
        m = m @ m
    return sigma


@pytest.mark.slow
def test_stationary_noise_is_a_poisson_count_independent_of_triangle_size():
    """Eq. 17 converts masses to molecule numbers with Omega "independently of the size of
    triangles": at equilibrium a region of area a of a closed domain of area A at concentration c
    holds Omega c a molecules with the multinomial variance Omega c a (1 - a/A), so the mass in
    a fixed region has variance c a (1 - a/A) / Omega on any mesh, and each vertex region
    A_i a concentration variance c / (Omega A_i). The unit square on a coarse grid (spacing
    1/7) and one about twice as fine (1/15); the region x < 1/2 has the same area on both."""
    c, omega = 1.0, 1e4
    predicted = c * 0.5 * (1 - 0.5) / omega
    region_var = {}
    for n in (8, 16):
        mesh = grid_mesh(n, n, dx=1.0 / (n - 1))
        sigma = _stationary_covariance(mesh, omega, c)
        areas = mesh.areas
        w = np.where(mesh.vertices[:, 0] < 0.5, areas, 0.0)
        assert w.sum() == pytest.approx(0.5, rel=1e-9)
        region_var[n] = float(w @ sigma @ w)
        assert region_var[n] == pytest.approx(predicted, rel=0.06)
        per_vertex = omega * areas * np.diag(sigma) / c  # molecules' relative variance x N
        assert np.mean(per_vertex) == pytest.approx(1.0, abs=0.06)
        assert np.all(np.abs(per_vertex - 1.0) < 0.1)
    assert region_var[16] / region_var[8] == pytest.approx(1.0, abs=0.06)


@pytest.mark.slow
def test_flux_noise_amplitude_scales_as_omega_to_the_minus_half():
    """The mass carried across a fixed line in one step (the stochastic flux of eq. 17) has a
    standard deviation proportional to Omega^(-1/2)."""
    mesh = grid_mesh(8, 8, dx=1.0 / 7)
    w = np.where(mesh.vertices[:, 0] < 0.5, mesh.areas, 0.0)
    omegas = np.array([1e2, 1e4, 1e6])
    sd = [np.std(_noise_draws(mesh.replace(omega=om), 2.0, 0.5, 1e-3, 3000) @ w)
          for om in omegas]
    slope = np.polyfit(np.log(omegas), np.log(sd), 1)[0]
    assert slope == pytest.approx(-0.5, abs=0.02)
    assert sd[0] > 0


def test_increment_is_eq17_with_its_own_normals_and_its_mean_is_zero():
    """One draw equals eq. 17 written out in NumPy (float64) with the same normals, row ``k`` of
    ``normal(key, (3, F))`` on border ``k``: border ``k`` moves ``sqrt(sum_c |Z_kc| c_c dt /
    Omega) N_k`` from corner ``k+2`` to corner ``k+1``; and over many draws the mean increment
    is zero within its standard error while the variance is eq. 17's."""
    mesh = lattice_mesh(10, 10, spacing=0.1, omega=1e3)
    ops = mesh.ops
    rng = np.random.default_rng(4)
    u = jnp.asarray(rng.uniform(0.5, 2.0, (1, mesh.n_vertices)), jnp.float32)
    bcs = mesh.boundaries(("u",))
    key = jax.random.PRNGKey(11)
    got = np.asarray(mesh.diffusion_noise(u, (D,), bcs, DT, key)[0], np.float64)
    normal = np.asarray(jax.random.normal(jax.random.split(key, 1)[0], (3, len(ops.faces))),
                        np.float64)
    z = np.asarray(ops.flux_components(ops.face_tensor(D, 0.0, D, jnp.float32), jnp.float32),
                   np.float64)
    uf = np.maximum(np.asarray(u, np.float64)[0][ops.faces], 0.0)
    eta = np.sqrt((np.abs(z) * uf[:, None, :]).sum(axis=2) * DT / 1e3) * normal.T  # (F, 3)
    mass = np.zeros(mesh.n_vertices)
    for k in range(3):
        np.add.at(mass, ops.faces[:, (k + 1) % 3], eta[:, k])
        np.add.at(mass, ops.faces[:, (k + 2) % 3], -eta[:, k])
    expected = mass / mesh.areas
    assert np.allclose(got, expected, rtol=1e-5, atol=1e-6 * np.abs(expected).max())

    samples = _samples(mesh, u, n=4000)
    predicted = _predicted_variance(mesh, u, 1e3)
    standard_error = np.sqrt(predicted / len(samples))
    assert np.all(np.abs(samples.mean(axis=0)) < 5 * standard_error)
    assert np.mean(samples.var(axis=0)) == pytest.approx(np.mean(predicted), rel=0.05)
