"""No-flux species are transformed on the grid's own size (a DCT-II by one FFT), not mirrored.

The cosine coefficients used to come from an FFT of the field mirrored along every axis: four
times the data on a 2D grid, and no-flux ETDRK4 and IMEX frames in the live view 3-6 times slower
than periodic ones (docs/web.md). These tests check the transform against SciPy's DCT-II, that
it inverts exactly, and that no program of the live view transforms a grid larger than its own.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.fft

from morphogen.domains.grid import Grid
from morphogen.models.library import get_model
from morphogen.solvers.cosine import dct, idct
from morphogen.solvers.fourier import SpectralDiffusion
from morphogen.web.limits import Limits
from morphogen.web.live import LiveSim


@pytest.mark.parametrize("shape", [(9,), (8,), (6, 9), (7, 8), (5, 6, 7), (4, 4, 6)])
def test_dct_is_scipys_dct_ii_and_idct_inverts_it(shape):
    x = np.random.default_rng(1).normal(size=(2, *shape)).astype(np.float32)
    axes = tuple(range(1, 1 + len(shape)))
    got = np.asarray(jax.jit(lambda a: dct(a, len(shape)))(jnp.asarray(x)))
    ref = scipy.fft.dctn(x.astype(np.float64), type=2, axes=axes)
    assert got.shape == x.shape and got.dtype == np.float32
    np.testing.assert_allclose(got, ref, rtol=0, atol=2e-6 * np.abs(ref).max())
    back = np.asarray(jax.jit(lambda a: idct(a, len(shape)))(jnp.asarray(got)))
    np.testing.assert_allclose(back, x, rtol=0, atol=2e-6)


def test_no_flux_coefficients_live_on_the_grid():
    grid = Grid((12, 10), boundary="neumann")
    spec = SpectralDiffusion(grid, ("u", "v"))
    u = jnp.ones((2, 12, 10), jnp.float32)
    assert spec.forward_stack(u, True).shape == (2, 12, 10)
    assert spec.forward(u[0], True).dtype == jnp.float32
    assert spec.symbols[True].shape == (12, 10)


def _fft_lengths(jaxpr) -> set[tuple[int, ...]]:
    """Every FFT length in a jaxpr and the jaxprs inside it (scan bodies, jitted calls)."""
    found = set()
    for eqn in jaxpr.eqns:
        if eqn.primitive.name == "fft":
            found.add(tuple(eqn.params["fft_lengths"]))
        for value in eqn.params.values():
            for sub in value if isinstance(value, tuple | list) else (value,):
                inner = getattr(sub, "jaxpr", sub)
                if hasattr(inner, "eqns"):
                    found |= _fft_lengths(inner)
    return found


@pytest.mark.parametrize("scheme", ["etdrk4", "imex", "imex1"])
def test_a_no_flux_frame_transforms_nothing_larger_than_the_grid(scheme):
    sim = LiveSim(Limits())
    sim.configure({"library": "gray-scott"}, size=24, height=20, boundary="neumann",
                  scheme=scheme)
    run = sim.engine.program(sim.steps_per_frame)
    p = {k: jnp.asarray(v, jnp.float32) for k, v in sim.values.items()}
    jaxpr = jax.make_jaxpr(run)(sim.u, p, sim.t, jnp.float32(sim.dt), sim.key, sim.show,
                                jnp.float32(0), jnp.float32(1)).jaxpr
    lengths = _fft_lengths(jaxpr)
    assert lengths and all(n in (20, 24) for size in lengths for n in size), lengths


def test_a_no_flux_etdrk4_step_diffuses_a_cosine_mode_exactly():
    """Pure diffusion of one cosine mode: ETDRK4 multiplies it by ``e^{dt D lambda}``."""
    model = get_model("gray-scott")
    grid = Grid((16, 12), boundary="neumann")
    spec = SpectralDiffusion(grid, model.species)
    i, j = np.meshgrid(np.arange(16) + 0.5, np.arange(12) + 0.5, indexing="ij")
    mode = np.cos(np.pi * 3 * i / 16) * np.cos(np.pi * 2 * j / 12)
    lam = (2 * np.cos(np.pi * 3 / 16) - 2) + (2 * np.cos(np.pi * 2 / 12) - 2)
    assert spec.symbols[True][3, 2] == pytest.approx(lam)
    coef = spec.forward(jnp.asarray(mode, jnp.float32), True)
    out = spec.inverse(coef * jnp.exp(0.7 * jnp.asarray(spec.symbols[True], jnp.float32)),
                       True, jnp.float32)
    np.testing.assert_allclose(np.asarray(out), np.exp(0.7 * lam) * mode, atol=2e-6)
