"""Stochastic diffusion on meshes (Ringham et al. eqs. 14-17)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.engine.simulate import simulate
from morphogen.flowers.planar import lattice_mesh
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
