"""Every fixed-step scheme of the registry converges at its declared order.

``du/dt = -k u + D L u`` started from an eigenvector ``phi`` of the domain's own discrete
Laplacian (``L phi = lambda phi``) stays on it: ``u(t) = exp((-k + D lambda) t) phi`` exactly,
so the error of a scheme at ``t = T`` is its time-stepping error alone, and falls as
``dt^order`` (:attr:`morphogen.solvers.registry.SchemeInfo.order`). The eigenvectors: a Fourier
mode on a periodic grid, a sine mode on a grid whose outer ring is held at 0 (Dirichlet), and
an ``l = 1`` eigenvector of the cotangent Laplacian on a small icosphere. In float64, one
compiled program per scheme and domain (``dt`` and the step count are run-time values).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg
import trimesh

from morphogen.domains.grid import Grid
from morphogen.domains.mesh import Mesh
from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.solvers.base import stepper
from morphogen.solvers.registry import FIXED_STEP
from morphogen.solvers.step import make_step

LINEAR = Model(
    name="linear", species=("u",), params={"k": 0.5, "D": 0.2},
    reaction=lambda u, p, c: -p["k"] * u, diffusion=lambda p, c: (p["D"],),
    ground=lambda p: (0.0,),
)

FOURIER_ONLY = {"etdrk4"}
"""Schemes that solve diffusion in Fourier space: periodic and no-flux grids only."""

T_END = 2.0
DTS = np.array([0.2, 0.1, 0.05])


def _periodic() -> tuple[Grid, np.ndarray, float]:
    n = 16
    y, x = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    ky, kx = 2 * np.pi * 2 / n, 2 * np.pi * 1 / n
    lam = 2 * np.cos(ky) - 2 + 2 * np.cos(kx) - 2
    return Grid((n, n)), np.cos(ky * y) * np.cos(kx * x), lam


def _dirichlet() -> tuple[Grid, np.ndarray, float]:
    """Cells ``0`` and ``n - 1`` are held at 0; ``sin(pi m i / (n - 1))`` vanishes on both and
    is an eigenvector of the 5-point stencil on the cells between."""
    n = 17
    y, x = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    ky, kx = np.pi * 2 / (n - 1), np.pi * 1 / (n - 1)
    lam = 2 * np.cos(ky) - 2 + 2 * np.cos(kx) - 2
    return Grid((n, n), boundary="dirichlet"), np.sin(ky * y) * np.sin(kx * x), lam


def _mesh() -> tuple[Mesh, np.ndarray, float]:
    """``K phi = mu M phi`` (lumped masses): ``L = -M^{-1} K`` has ``phi`` with ``-mu``."""
    s = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    mesh = Mesh(s.vertices, s.faces, name="icosphere")
    mu, vec = scipy.linalg.eigh(mesh.ops.stiffness.toarray(), np.diag(mesh.areas))
    phi = vec[:, 2] / np.abs(vec[:, 2]).max()
    return mesh, phi, -mu[2]


DOMAINS = {"periodic": _periodic, "dirichlet": _dirichlet, "mesh": _mesh}


def _errors(scheme: str, domain, phi: np.ndarray, lam: float) -> np.ndarray:
    """Max error at ``T_END`` for each of :data:`DTS`, through the step's explicit interface:
    its invariants computed once per ``dt``, then passed to every step."""
    p = {k: jnp.float64(v) for k, v in LINEAR.params.items()}
    step = make_step(LINEAR, domain, scheme=scheme)
    key = jax.random.PRNGKey(0)

    @jax.jit
    def run(u, dt, n):
        aux = step.invariants(p, jnp.zeros((), u.dtype), dt)
        return jax.lax.fori_loop(0, n, lambda i, v: step(v, p, i * dt, dt, key, aux), u)

    exact = np.exp((-p["k"] + p["D"] * lam) * T_END) * phi
    return np.array([
        np.abs(np.asarray(run(jnp.asarray(phi[None]), dt, round(T_END / dt)))[0] - exact).max()
        for dt in DTS
    ])


@pytest.mark.parametrize("where", list(DOMAINS))
@pytest.mark.parametrize("scheme", FIXED_STEP)
def test_every_scheme_converges_at_its_order(scheme, where):
    domain, phi, lam = DOMAINS[where]()
    with jax.enable_x64(True):
        if scheme in FOURIER_ONLY and where != "periodic":
            with pytest.raises(MorphogenError, match="periodic and neumann|on grids"):
                make_step(LINEAR, domain, scheme=scheme)
            return
        errors = _errors(scheme, domain, phi, lam)
    slope = np.polyfit(np.log(DTS), np.log(errors), 1)[0]
    assert slope == pytest.approx(stepper(scheme).order, abs=0.25), errors
