"""IMEX with conjugate-gradient diffusion solves (morphogen/solvers/imex_cg.py): meshes, and
varying,
anisotropic or Dirichlet diffusion on grids. Small meshes and grids, few compiled programs (each
CG step compiles in 1-4 s, so tests share models, domains and step counts)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg
import trimesh

from morphogen.domains.grid import Grid
from morphogen.domains.mesh import Mesh
from morphogen.engine.simulate import integrate, simulate, simulate_batch
from morphogen.errors import MorphogenError
from morphogen.flowers.planar import lattice_mesh
from morphogen.models.model import Model, Tensor
from morphogen.models.registry import load_model
from morphogen.solvers.auto import choose_scheme, fourier_solves
from morphogen.solvers.base import stepper
from morphogen.solvers.stability import SAFETY_IMPLICIT
from morphogen.solvers.step import batch_params, make_step, max_stable_dt

SCHNAKENBERG = load_model("examples/schnakenberg.toml")


def _coefficient(kind: str, p, c):
    if kind == "tensor":
        return Tensor(p["D"], 0.3 * p["D"] * (1.0 + c["y"]), 2.0 * p["D"])
    if kind == "field":
        return p["D"] * (1.0 + 0.8 * jnp.sin(6.0 * c["x"]) * jnp.cos(4.0 * c["y"]))
    return p["D"]


def linear(*kinds: str) -> Model:
    """``du_i/dt = -k u_i + div(D_i grad u_i)``, one species per kind of ``D_i``: ``scalar``,
    ``field`` (varying in space) or ``tensor`` (anisotropic, varying cross term)."""
    return Model(name="linear", species=tuple(f"{k}{i}" for i, k in enumerate(kinds)),
                 params={"k": 0.0, "D": 0.5},
                 reaction=lambda u, p, c: -p["k"] * u,
                 diffusion=lambda p, c: tuple(_coefficient(k, p, c) for k in kinds),
                 ground=lambda p: tuple(0.0 for _ in kinds))


HEAT = linear("scalar")


@pytest.fixture(scope="module")
def sphere() -> Mesh:
    s = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    return Mesh(s.vertices, s.faces, name="icosphere")


@pytest.fixture(scope="module")
def eigen(sphere):
    """``(mu, phi)``: ``K phi = mu M phi``, i.e. ``L phi = -mu phi``, every eigenpair of the
    cotangent Laplacian (dense, 162 vertices), each vector normalised to max 1."""
    mu, vec = scipy.linalg.eigh(sphere.ops.stiffness.toarray(), np.diag(sphere.areas))
    return mu, vec / np.abs(vec).max(axis=0)


def _runner(step, p):
    """``run(u, dt, n)``: ``n`` steps of ``dt``, both at run time, so one compiled program
    serves every step size of a convergence study."""
    key = jax.random.PRNGKey(0)

    def run(u, dt, n):
        return jax.lax.fori_loop(0, n, lambda i, v: step(v, p, i * dt, dt, key), u)

    return jax.jit(run)


@pytest.mark.slow
def test_eigenvectors_decay_by_the_scheme_factor(sphere, eigen):
    """imex1 on pure diffusion of a smooth (l = 1) plus a rough Laplacian eigenvector at a
    step 30x the explicit limit: each decays by ``1 / (1 + dt D mu)`` per step, to the CG
    tolerance."""
    mu, phi = eigen
    d, dt, steps = 0.5, 1.5, 2
    p = {"k": 0.0, "D": d}
    assert dt > 30 * max_stable_dt(HEAT, sphere, p)
    factors = (1.0 / (1.0 + dt * d * mu[[2, 40]])) ** steps
    np.testing.assert_allclose(factors,
                               stepper("imex1").amplification(-dt * d * mu[[2, 40]]) ** steps)
    assert factors[0] > 0.1 and factors[1] < 0.1 * factors[0]
    u0 = phi[:, 2] + phi[:, 40]
    sol = simulate(HEAT, sphere, u0[None], p, steps=steps, dt=dt, scheme="imex1")
    expected = factors[0] * phi[:, 2] + factors[1] * phi[:, 40]
    np.testing.assert_allclose(sol.state[0], expected, atol=2e-5)


@pytest.mark.slow
def test_mass_is_conserved_with_no_flux_and_flux_noise():
    """Field and tensor coefficients on an open mesh with Ringham eq. 17's flux noise (added
    after the implicit step, as after an explicit one): the solve restores the M-weighted mass
    exactly and the noise moves mass between neighbours only."""
    mesh = lattice_mesh(12, 10, spacing=0.1, omega=1e7)
    model = linear("field", "tensor")
    u0 = 1.0 + np.random.default_rng(1).random((2, mesh.n_vertices)).astype(np.float32)
    runs = [simulate(model, mesh, u0, dict(model.params), steps=5, dt=0.5, scheme="imex1",
                     seed=seed).state for seed in (3, 4)]
    for u in runs:
        np.testing.assert_allclose(mesh.mass(u), mesh.mass(u0), rtol=2e-6)
        assert np.all(np.std(u, axis=1) < 0.5 * np.std(u0, axis=1))
    assert np.abs(runs[0] - runs[1]).max() > 1e-3  # the noise is there


@pytest.mark.slow
def test_grid_tensor_and_dirichlet_field_converge_at_second_order():
    """A no-flux tensor species (BiCGSTAB) and a held varying-coefficient species (CG on
    ``I - c sqrt(D) L sqrt(D)``), at 8x and 4x the explicit limit, against the same scheme at a
    16x smaller step: the error falls 4x when dt halves; held values stay, the tensor species
    keeps its mass up to the reaction's explicit decay."""
    model = linear("tensor", "field")
    grid = Grid((12, 14), boundary={"tensor0": "neumann", "field1": "dirichlet=0.25"})
    p = {"k": 0.2, "D": 0.5}
    u0 = np.random.default_rng(2).random((2, 12, 14)).astype(np.float32)
    dt = 8 * max_stable_dt(model, grid, p)
    run = _runner(make_step(model, grid, scheme="imex"), p)
    sol = [np.asarray(run(jnp.asarray(u0), dt / k, 8 * k)) for k in (1, 2, 16)]
    ref = sol.pop()
    errors = [np.abs(u - ref).max() for u in sol]
    assert errors[0] / errors[1] == pytest.approx(4, abs=0.8), errors
    assert np.abs(u0 - ref).max() > 0.3  # diffusion did change the state
    ring = grid.hold(np.full_like(u0, np.nan), grid.boundaries(model.species))
    assert np.all(sol[0][1][np.isfinite(ring[1])] == np.float32(0.25))
    z = 0.2 * dt  # the uniform mode sees only the explicit part: 1 - z + z^2 / 2 per step
    assert sol[0][0].sum() == pytest.approx((1 - z + z * z / 2) ** 8 * u0[0].sum(), rel=1e-5)


def test_second_order_on_a_mesh(sphere, eigen):
    """``du/dt = -k u + D L u`` from an eigenvector is exactly ``exp(-(k + D mu) t) phi``:
    the imex error falls as dt^2."""
    mu, phi = eigen[0][2], eigen[1][:, 2]
    p = {"k": 1.0, "D": 0.05}
    exact = np.exp(-(1.0 + 0.05 * mu)) * phi
    dts = np.array([0.2, 0.1, 0.05])
    with jax.enable_x64(True):
        run = _runner(make_step(HEAT, sphere, scheme="imex"), p)
        errors = [np.abs(np.asarray(run(jnp.asarray(phi[None]), dt, round(1 / dt)))[0]
                         - exact).max() for dt in dts]
    slope = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    assert slope == pytest.approx(2, abs=0.1)


@pytest.mark.parametrize("domain", ["mesh", "grid"])
@pytest.mark.slow
def test_gradient_matches_finite_differences(sphere, domain):
    """Through the CG solve (mesh, varying coefficient) and the BiCGSTAB one (grid tensor),
    in float64 so the solver tolerance does not blur the finite difference."""
    space, model = ((sphere, linear("field")) if domain == "mesh"
                    else (Grid((8, 8), boundary="neumann"), linear("tensor")))
    n = space.spatial_shape
    with jax.enable_x64(True):
        step = make_step(model, space, scheme="imex1")
        u0 = jnp.asarray(np.random.default_rng(5).random((1, *n)))
        target = jnp.asarray(np.random.default_rng(6).random((1, *n)))

        def loss(d):
            u, _, _ = integrate(step, u0, {"k": 0.3, "D": d}, steps=2, dt=0.5,
                                key=jax.random.PRNGKey(0))
            return jnp.mean((u - target) ** 2)

        loss_and_grad = jax.jit(jax.value_and_grad(loss))
        g = float(loss_and_grad(0.2)[1])
        fd = (float(loss_and_grad(0.2 + 1e-4)[0]) - float(loss_and_grad(0.2 - 1e-4)[0])) / 2e-4
    assert g == pytest.approx(fd, rel=1e-5)
    assert abs(g) > 1e-4


def _schnakenberg_sphere(sphere):
    """Schnakenberg (Dv/Du = 40) on a sphere of radius 6 (642 vertices): Turing-unstable and
    stiff."""
    fine = trimesh.creation.icosphere(subdivisions=3, radius=6.0)
    mesh = Mesh(fine.vertices, fine.faces, name="sphere r6")
    p = dict(SCHNAKENBERG.params)
    ground = np.asarray(SCHNAKENBERG.ground_state(p))
    noise = 0.05 * np.random.default_rng(7).standard_normal((2, mesh.n_vertices))
    return mesh, p, (ground[:, None] + noise).astype(np.float32)


@pytest.mark.slow
def test_stiff_mesh_model_takes_reaction_limited_steps(sphere):
    """At its reaction limit, 18x the explicit one, imex stays bounded and matches Euler at a
    quarter of the explicit limit to 3 % (relative L2); Euler at that step is refused."""
    mesh, p, u0 = _schnakenberg_sphere(sphere)
    dt_e = max_stable_dt(SCHNAKENBERG, mesh, p)
    dt_r = max_stable_dt(SCHNAKENBERG, mesh, p, "imex")
    lam = np.linalg.eigvals(np.array([[0.8, 1.0], [-1.8, -1.0]]))  # J at u*, as on grids
    assert dt_r == pytest.approx(SAFETY_IMPLICIT * np.min(-2 * lam.real / np.abs(lam) ** 2),
                                 rel=1e-4)
    assert dt_r > 15 * dt_e
    t_end = 20.0
    n, m = round(t_end / dt_r), round(t_end / (0.25 * dt_e))
    imex = simulate(SCHNAKENBERG, mesh, u0, p, steps=n, dt=t_end / n, scheme="imex").state
    ref = simulate(SCHNAKENBERG, mesh, u0, p, steps=m, dt=t_end / m).state
    assert np.all(np.isfinite(imex)) and np.abs(imex).max() < 10
    assert np.linalg.norm(imex - ref) / np.linalg.norm(ref) < 0.03
    assert np.std(ref[0]) > 2 * np.std(u0[0])  # the pattern grew: not a trivial comparison
    with pytest.raises(MorphogenError):
        simulate(SCHNAKENBERG, mesh, u0, p, steps=n, dt=t_end / n)


@pytest.mark.slow
def test_vmap_and_batch_equal_single_runs(sphere, eigen):
    """``jax.vmap`` over ``integrate`` and ``simulate_batch`` (a population with one ``D`` per
    member) give each member's single run."""
    u0 = np.repeat(eigen[1][None, None, :, 2] + eigen[1][None, None, :, 40], 3, axis=0)
    params = batch_params({"k": 0.0, "D": np.array([0.2, 0.5, 1.0])}, 3, ["D"])
    batch = simulate_batch(HEAT, sphere, u0, params, steps=2, dt=1.5, scheme="imex1").state
    step = make_step(HEAT, sphere, scheme="imex1")
    keys = jax.random.split(jax.random.PRNGKey(0), 3)
    mapped = jax.jit(jax.vmap(lambda u, q, k: integrate(step, u, q, steps=2, dt=1.5,
                                                        key=k)[0]))(u0, params, keys)
    for b in range(3):
        one = simulate(HEAT, sphere, u0[b], {k: v[b] for k, v in params.items()}, steps=2,
                       dt=1.5, scheme="imex1").state
        np.testing.assert_allclose(batch[b], one, atol=1e-6)
        np.testing.assert_allclose(np.asarray(mapped[b]), one, atol=1e-6)
    assert np.abs(batch[0] - batch[2]).max() > 0.1


def test_routing_auto_and_errors(sphere):
    mesh, p, _ = _schnakenberg_sphere(sphere)
    assert not fourier_solves(SCHNAKENBERG, mesh, p)
    assert fourier_solves(SCHNAKENBERG, Grid((16, 16)), p)
    assert not fourier_solves(SCHNAKENBERG, Grid((16, 16), boundary="dirichlet"), p)
    assert not fourier_solves(linear("scalar", "field"), Grid((16, 16)), {"k": 0.0, "D": 0.5})
    # stiffness ratio ~18 here: below the conjugate-gradient threshold, explicit; with a
    # ten times larger Dv, imex
    assert choose_scheme(SCHNAKENBERG, mesh, p) == "euler"
    assert choose_scheme(SCHNAKENBERG, mesh, {**p, "Dv": 400.0}) == "imex"
    with pytest.raises(MorphogenError, match="use imex, euler or rk4 on meshes"):
        make_step(SCHNAKENBERG, mesh, scheme="etdrk4")
