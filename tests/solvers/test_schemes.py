"""Implicit-explicit schemes: exact Fourier decay with the stencil symbol, order, gradients."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.simulate import integrate, simulate
from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.models.registry import load_model
from morphogen.solvers.base import stepper
from morphogen.solvers.etd import phi_coefficients
from morphogen.solvers.stability import SAFETY_IMPLICIT
from morphogen.solvers.step import make_step, max_stable_dt
from tests.core_models import pure_diffusion


def _mode(shape, m, mirror):
    """A single Fourier (periodic) or cosine (no-flux) mode and its 5/7-point symbol."""
    grids = np.meshgrid(*[np.arange(n) for n in shape], indexing="ij")
    if mirror:
        ks = [np.pi * mi / n for mi, n in zip(m, shape, strict=True)]
        f = np.prod([np.cos(k * (g + 0.5)) for k, g in zip(ks, grids, strict=True)], axis=0)
    else:
        ks = [2 * np.pi * mi / n for mi, n in zip(m, shape, strict=True)]
        f = np.prod([np.cos(k * g) for k, g in zip(ks, grids, strict=True)], axis=0)
    return f, ks


@pytest.mark.parametrize("scheme", ["imex1", "imex"])
@pytest.mark.parametrize(("shape", "boundary", "stencil"), [
    ((24, 32), "periodic", 5), ((24, 32), "neumann", 5), ((24, 32), "periodic", 9),
    ((8, 12, 10), "neumann", 7),
])
def test_pure_diffusion_mode_decays_by_the_scheme_factor(scheme, shape, boundary, stencil):
    grid = Grid(shape, dx=0.5, boundary=boundary, stencil=stencil)
    mirror = boundary == "neumann"
    f, ks = _mode(shape, (3, 5, 2)[: len(shape)], mirror)
    if stencil == 9:
        ky, kx = ks
        lam = (2 / 3 * (2 * np.cos(kx) + 2 * np.cos(ky)) + 4 / 6 * np.cos(kx) * np.cos(ky)
               - 10 / 3) / 0.25
    else:
        lam = sum(2 * np.cos(k) - 2 for k in ks) / 0.25
    d, dt, steps = 0.7, 2.0, 5  # dt D rho(L) = 45: far beyond any explicit limit
    sol = simulate(pure_diffusion(d=d), grid, f[None], {"D": d}, steps=steps, dt=dt,
                   scheme=scheme)
    expected = stepper(scheme).amplification(dt * d * lam) ** steps * f
    np.testing.assert_allclose(sol.state[0], expected, atol=2e-6)


@pytest.mark.parametrize("boundary", ["periodic", "neumann"])
def test_mass_is_conserved(boundary):
    grid = Grid((20, 16), boundary=boundary)
    u0 = np.random.default_rng(0).random((1, 20, 16)).astype(np.float32)
    sol = simulate(pure_diffusion(d=3.0), grid, u0, {"D": 3.0}, steps=10, dt=1.0, scheme="imex")
    assert sol.state.sum() == pytest.approx(u0.sum(), rel=1e-5)


def _linear() -> Model:
    """``du/dt = -k u + D lap(u)``: a mode decays exactly at ``exp(t (-k + D lambda))``."""
    return Model(
        name="linear", species=("u",), params={"k": 1.5, "D": 0.8},
        reaction=lambda u, p, c: -p["k"] * u, diffusion=lambda p, c: (p["D"],),
        ground=lambda p: (0.0,),
    )


@pytest.mark.parametrize(("scheme", "order"), [("imex1", 1), ("imex", 2)])
def test_convergence_order(scheme, order):
    grid = Grid((16, 16))
    f, ks = _mode((16, 16), (2, 1), False)
    lam = sum(2 * np.cos(k) - 2 for k in ks)
    t_end = 1.0
    exact = np.exp(t_end * (-1.5 + 0.8 * lam)) * f
    errors = []
    dts = [0.1, 0.05, 0.025]
    for dt in dts:
        sol = simulate(_linear(), grid, f[None], dict(_linear().params),
                       steps=round(t_end / dt), dt=dt, scheme=scheme)
        errors.append(np.abs(sol.state[0] - exact).max())
    slope = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    assert slope == pytest.approx(order, abs=0.15)


@pytest.mark.parametrize(("scheme", "boundary", "steps", "dt", "seed"),
                         [("imex", "neumann", 20, 0.05, 2), ("etdrk4", "periodic", 10, 0.1, 3)])
@pytest.mark.slow
def test_gradient_matches_finite_differences(scheme, boundary, steps, dt, seed):
    grid = Grid((12, 12), boundary=boundary)
    model = load_model("schnakenberg")
    step = make_step(model, grid, scheme=scheme)
    u0 = jnp.asarray(np.array([1.0, 0.9])[:, None, None]
                     + 0.05 * np.random.default_rng(seed).standard_normal((2, 12, 12)),
                     jnp.float32)

    def loss(a):
        p = {**{k: jnp.float32(v) for k, v in model.params.items()}, "a": a}
        u, _, _ = integrate(step, u0, p, steps=steps, dt=dt, key=jax.random.PRNGKey(0))
        return jnp.mean(u[0] ** 2)

    g = jax.grad(loss)(jnp.float32(0.1))
    h = 1e-2
    fd = (loss(jnp.float32(0.1 + h)) - loss(jnp.float32(0.1 - h))) / (2 * h)
    assert float(g) == pytest.approx(float(fd), rel=0.02)


def test_imex_limit_is_set_by_the_reaction():
    model, grid = load_model("examples/schnakenberg.toml"), Grid((128, 128))
    p = dict(model.params)
    # J at u* has eigenvalues -0.1 +- 0.995i: the Euler disc needs dt <= -2 Re / |lambda|^2
    lam = np.linalg.eigvals(np.array([[0.8, 1.0], [-1.8, -1.0]]))
    marginal = float(np.min(-2 * lam.real / np.abs(lam) ** 2))
    assert max_stable_dt(model, grid, p, "imex") == pytest.approx(
        SAFETY_IMPLICIT * marginal, rel=1e-4)
    assert max_stable_dt(model, grid, p, "imex") > 10 * max_stable_dt(model, grid, p)


def test_schemes_that_cannot_carry_a_term_say_so():
    """ETDRK4 needs the Fourier solve; IMEX takes these cases by conjugate gradients
    (tests/solvers/test_imex_cg.py)."""
    model = pure_diffusion()
    with pytest.raises(MorphogenError, match="periodic and neumann boundaries; use imex"):
        make_step(model, Grid((8, 8), boundary="dirichlet"), scheme="etdrk4")
    field = Model(
        name="field", species=("u",), params={},
        reaction=lambda u, p, c: jnp.zeros_like(u),
        diffusion=lambda p, c: (0.5 + c["x"],), ground=lambda p: (0.0,),
    )
    with pytest.raises(MorphogenError, match="needs constant isotropic diffusion; use imex"):
        simulate(field, Grid((8, 8)), np.zeros((1, 8, 8)), {}, steps=1, dt=0.1,
                 scheme="etdrk4", unsafe=True)


@pytest.mark.parametrize("boundary", ["periodic", "neumann"])
def test_etdrk4_integrates_pure_diffusion_exactly(boundary):
    grid = Grid((24, 32), dx=0.5, boundary=boundary)
    f, ks = _mode((24, 32), (3, 5), boundary == "neumann")
    lam = sum(2 * np.cos(k) - 2 for k in ks) / 0.25
    sol = simulate(pure_diffusion(d=0.7), grid, f[None], {"D": 0.7}, steps=4, dt=0.3,
                   scheme="etdrk4")
    np.testing.assert_allclose(sol.state[0], np.exp(4 * 0.3 * 0.7 * lam) * f, atol=2e-6)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_etdrk4_coefficients_match_their_closed_forms_and_limits(dtype):
    """Cox-Matthews' ``Q, f1, f2, f3`` by the contour mean against the closed forms in float64
    where they do not cancel (``|z| >= 0.5``), and against their limits ``h/2, h/6, h/6, h/6``
    at ``z -> 0``, where the closed forms lose every digit."""
    z = np.array([-1e-12, -0.5, -3.0, -40.0])
    h = 0.3
    with jax.enable_x64(dtype == np.float64):
        got = [np.asarray(c, np.float64)
               for c in phi_coefficients(jnp.asarray(z, dtype), jnp.asarray(h, dtype))]
    e = np.exp(z[1:])
    zz = z[1:]
    closed = [(np.exp(zz / 2) - 1) / zz, (-4 - zz + e * (4 - 3 * zz + zz**2)) / zz**3,
              (2 + zz + e * (zz - 2)) / zz**3, (-4 - 3 * zz - zz**2 + e * (4 - zz)) / zz**3]
    rtol = 2e-6 if dtype == np.float32 else 1e-12
    for c, want, limit in zip(got, closed, (0.5, 1 / 6, 1 / 6, 1 / 6), strict=True):
        np.testing.assert_allclose(c[1:], h * want, rtol=rtol)
        assert c[0] == pytest.approx(h * limit, rel=rtol)


def test_etdrk4_is_fourth_order():
    """``du/dt = -k u + D lap(u)`` on one mode, in float64; the reaction is the explicit part."""
    grid = Grid((16, 16))
    f, ks = _mode((16, 16), (2, 1), False)
    lam = sum(2 * np.cos(k) - 2 for k in ks)
    model = _linear()
    p = {"k": 2.0, "D": 0.8}
    exact = np.exp(2.0 * (0.8 * lam - 2.0)) * f
    dts = [0.2, 0.1, 0.05]
    errors = []
    with jax.enable_x64(True):
        for dt in dts:
            sol = simulate(model, grid, f[None], p, steps=round(2.0 / dt), dt=dt,
                           scheme="etdrk4", unsafe=True)
            assert sol.state.dtype == np.float64
            errors.append(np.abs(sol.state[0] - exact).max())
    slope = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    assert slope == pytest.approx(4, abs=0.4)


def test_etdrk4_coefficients_computed_once_per_run_give_the_same_steps():
    """``integrate`` computes ETDRK4's exponentials and φ-coefficients once, before its loop
    (``step.invariants``); the steps equal those of a step that computes them itself."""
    model, grid = load_model("examples/schnakenberg.toml"), Grid((24, 24))
    p = {k: jnp.float32(v) for k, v in model.parameters().items()}
    u0 = jnp.asarray(1.0 + 0.1 * np.random.default_rng(3).standard_normal((2, 24, 24)),
                     jnp.float32)
    step = make_step(model, grid, scheme="etdrk4")
    assert hasattr(step, "invariants")
    key = jax.random.PRNGKey(0)
    hoisted = integrate(step, u0, p, steps=30, dt=0.05, key=key)[0]
    inline = integrate(lambda u, q, t, dt, k: step(u, q, t, dt, k), u0, p, steps=30, dt=0.05,
                       key=key)[0]
    np.testing.assert_allclose(np.asarray(hoisted), np.asarray(inline), rtol=1e-5, atol=1e-6)


def test_etdrk4_refuses_diffusion_that_changes_with_time():
    model = Model(
        name="warming", species=("u",), params={"D": 0.5},
        reaction=lambda u, p, c: -u, diffusion=lambda p, c: (p["D"] * (1.0 + 0.01 * c["t"]),),
        ground=lambda p: (0.0,),
    )
    with pytest.raises(MorphogenError, match="diffusion of u changes with t; use imex"):
        make_step(model, Grid((8, 8)), scheme="etdrk4")
    make_step(model, Grid((8, 8)), scheme="imex")
