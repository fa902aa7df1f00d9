"""ETDRK4's own stability region (morphogen.solvers.etd_stability): the step matrix reduces to
the exact exponential and to RK4 at its two edges, and on linear problems, where the analysis
is exact, the marginal step runs bounded while 1.5 times it grows."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.simulate import integrate
from morphogen.models.model import Model
from morphogen.solvers.etd_stability import amplification, marginal_dt
from morphogen.solvers.step import make_step


def test_edges_are_the_exponential_and_rk4() -> None:
    z = np.array([-50.0, -3.0, -0.5, -1e-4, 0.0])
    assert np.allclose(amplification(z, 0.0), np.exp(z), rtol=1e-6, atol=1e-12)
    w = np.array([-2.7, -1.0, 0.3j - 0.1, 2.5j, -1e-4])
    rk4 = 1 + w + w**2 / 2 + w**3 / 6 + w**4 / 24
    assert np.allclose(amplification(0.0, w), rk4, rtol=1e-9)


def test_stiff_diffusion_widens_the_region() -> None:
    """Du & Zhu: the stable interval in z_N grows as z_L goes to -inf (RK4's is 2.785)."""
    assert abs(amplification(0.0, -3.0)) > 1
    assert abs(amplification(-20.0, -3.0)) < 1


def _linear(jac: np.ndarray, d: tuple[float, ...]) -> Model:
    j = jnp.asarray(jac, jnp.float32)
    return Model(name="linear", species=tuple("uvw"[: len(d)]), params={},
                 reaction=lambda u, p, c: jnp.tensordot(j, u, axes=1),
                 diffusion=lambda p, c: d, ground=lambda p: (0.0,) * len(d))


CASES = {
    "decay": (np.array([[-0.5]]), (0.2,)),
    "coupled": (np.array([[-0.4, 1.0], [-2.0, -0.6]]), (0.1, 2.0)),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_marginal_step_is_exact_on_linear_problems(case: str) -> None:
    jac, d = CASES[case]
    grid = Grid((16, 16))
    k = 2 * np.pi * np.fft.fftfreq(16)
    sym = (2 * np.cos(k)[:, None] - 2 + 2 * np.cos(k)[None] - 2).ravel()
    h = marginal_dt(jac, np.array(d), np.unique(np.round(-sym, 12)))
    model = _linear(jac, d)
    step = make_step(model, grid, scheme="etdrk4")
    u0 = jax.random.normal(jax.random.key(1), (len(d), 16, 16), jnp.float32)

    def growth(dt: float, steps: int) -> float:
        u, _, _ = integrate(step, u0, {}, steps=steps, dt=dt, key=jax.random.key(0))
        ratio = float(jnp.max(jnp.abs(u)) / jnp.max(jnp.abs(u0)))
        return ratio if np.isfinite(ratio) else float("inf")  # overflowed

    assert growth(0.98 * h, 200) <= 1.0
    assert growth(1.5 * h, 200) > 1e3
