"""The pseudo-spectral Laplacian: exact Fourier decay, its gap to the 5-point stencil, limits."""

from __future__ import annotations

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.domains import spectral
from morphogen.domains.grid import Boundary, Grid
from morphogen.engine.simulate import simulate
from morphogen.errors import MorphogenError
from morphogen.runs.config import RunConfig
from morphogen.runs.execute import run_prepared
from morphogen.runs.prepare import prepare
from morphogen.solvers.base import stepper
from morphogen.solvers.stability import SAFETY
from morphogen.solvers.step import max_stable_dt
from tests.core_models import pure_diffusion

D = 0.7


def _mode(shape, m, dx):
    """``prod_a cos(k_a x_a)`` on the grid and ``|k|^2`` with ``k_a = 2 pi m_a / (n_a dx)``."""
    axes = np.meshgrid(*[np.arange(n) * dx for n in shape], indexing="ij")
    ks = [2 * np.pi * mi / (n * dx) for mi, n in zip(m, shape, strict=True)]
    f = np.prod([np.cos(k * x) for k, x in zip(ks, axes, strict=True)], axis=0)
    return f.astype(np.float32), sum(k * k for k in ks), ks


PLANE, CUBE = ((16, 24), (3, 5)), ((8, 10, 12), (2, 3, 4))


@pytest.mark.parametrize(("shape", "m", "scheme"), [
    (*PLANE, "euler"), (*PLANE, "imex"), (*CUBE, "rk4"), (*CUBE, "etdrk4")])
def test_fourier_mode_decays_as_the_continuum(shape, m, scheme):
    grid = Grid(shape, dx=0.5, stencil="spectral")
    f, k2, _ = _mode(shape, m, 0.5)
    model = pure_diffusion(d=D)
    steps = 20
    dt = 0.5 * max_stable_dt(model, grid, {"D": D}, scheme) if scheme in ("euler", "rk4") \
        else 0.05
    sol = simulate(model, grid, f[None], {"D": D}, steps=steps, dt=dt, scheme=scheme)
    if scheme == "euler":
        expected = (1 - dt * D * k2) ** steps * f
    elif scheme == "imex":
        expected = stepper("imex").amplification(-dt * D * k2) ** steps * f
    else:  # rk4 (time error ~(dt D k2)^5 / 120 per step) and etdrk4 (exact): the continuum
        expected = np.exp(-D * k2 * steps * dt) * f
    np.testing.assert_allclose(sol.state[0], expected, atol=3e-6)


def test_five_point_and_spectral_differ_as_their_symbols():
    """On a smooth mode the 5-point operator gives ``-sum 4 sin^2(k dx / 2) / dx^2``, which is
    ``-|k|^2 (1 - sum k^4 dx^2 / (12 |k|^2))``; the spectral one ``-|k|^2`` exactly."""
    shape, dx = (32, 32), 1.0
    f, k2, ks = _mode(shape, (3, 2), dx)
    five = sum(4 * np.sin(k * dx / 2) ** 2 for k in ks) / dx**2
    assert five == pytest.approx(k2 * (1 - sum(k**4 for k in ks) * dx**2 / (12 * k2)), rel=1e-3)
    periodic = Boundary("periodic")
    lap = {s: np.asarray(Grid(shape, dx=dx, stencil=s).laplacian(f, periodic))
           for s in (5, "spectral")}
    np.testing.assert_allclose(lap["spectral"], -k2 * f, atol=2e-5)
    np.testing.assert_allclose(lap[5] - lap["spectral"], (k2 - five) * f, atol=2e-5)
    assert (k2 - five) > 0.01  # far more than the tolerance


def test_explicit_limit_follows_the_largest_wavenumber():
    # even axes: max |k|^2 = d pi^2 / dx^2; an odd axis stops at 2 pi ((n - 1) / 2) / (n dx)
    assert spectral.spectral_radius((16, 24), 0.5) == pytest.approx(2 * np.pi**2 / 0.25)
    assert spectral.spectral_radius((5, 4, 4), 1.0) == pytest.approx(
        (4 * np.pi / 5) ** 2 + 2 * np.pi**2)
    grid = Grid((16, 24), dx=0.5, stencil="spectral")
    marginal = 2.0 / (D * 2 * np.pi**2 / 0.25)
    assert max_stable_dt(pure_diffusion(d=D), grid, {"D": D}, "euler") == pytest.approx(
        SAFETY * marginal, rel=1e-6)


def test_spectral_laplacian_of_a_smooth_function_is_exact():
    n, dx = 32, 2 * np.pi / 32
    x = np.arange(n) * dx
    f = np.exp(np.sin(x))[None, :] * np.ones((n, 1))  # analytic: resolved to round-off
    exact = (np.cos(x) ** 2 - np.sin(x)) * np.exp(np.sin(x))
    lap = np.asarray(spectral.laplacian(f.astype(np.float32), dx))
    np.testing.assert_allclose(lap, np.broadcast_to(exact, (n, n)), atol=1e-4)  # float32
    five = np.asarray(Grid((n, n), dx=dx).laplacian(f.astype(np.float32), Boundary()))
    assert np.abs(five - exact).max() > 1e-2  # second order: (dx^2 / 12) u ~ 0.01


@pytest.mark.parametrize("boundary", ["neumann", {"v": "dirichlet=1"}])
def test_non_periodic_boundaries_are_refused(boundary):
    with pytest.raises(MorphogenError, match="spectral stencil needs periodic"):
        Grid((8, 8), boundary=boundary, stencil="spectral")


def test_cli_and_run_file_accept_it(capsys):
    assert main(["simulate", "gray-scott", "--size", "8x8", "--stencil", "spectral",
                 "--boundary", "neumann", "--steps", "2", "--quiet"]) == 2
    assert "spectral stencil needs periodic boundaries" in capsys.readouterr().err
    config = RunConfig.from_dict({"model": "gray-scott", "size": [12, 12],
                                  "stencil": "spectral", "steps": 3, "scheme": "rk4"})
    prep = prepare(config)
    assert prep.domain.is_spectral
    assert np.isfinite(run_prepared(prep).state).all()
