"""The dispersion relation on a grid's modes and the class of a fixed point (models/linear.py)
against Murray's closed forms for two species (Mathematical Biology II, ch. 2.3)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.domains.grid import Grid
from morphogen.models.linear import CLASSES, lattice_modes, stability, turing_batch
from morphogen.models.registry import load_model


def _schnakenberg(a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """Fixed point ``(a + b, b / (a + b)²)`` and its Jacobian ``[[-1 + 2uv, u²], [-2uv, -u²]]``."""
    u, v = a + b, b / (a + b) ** 2
    return np.array([u, v]), np.array([[-1 + 2 * u * v, u * u], [-2 * u * v, -u * u]])


def _sigma(jac: np.ndarray, d: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Largest real part of the roots of ``λ² - tr λ + det`` for ``J - q² D`` (2 x 2)."""
    tr = jac[0, 0] + jac[1, 1] - q2 * d.sum()
    det = (jac[0, 0] - q2 * d[0]) * (jac[1, 1] - q2 * d[1]) - jac[0, 1] * jac[1, 0]
    root = np.sqrt((tr * tr - 4 * det).astype(complex))
    return np.real((tr + root) / 2)


def _band(jac: np.ndarray, d: np.ndarray) -> tuple[float, float]:
    """The roots ``q²₋ < q²₊`` of ``det(J - q² D) = d_u d_v q⁴ - (d_v f_u + d_u g_v) q² + det J``:
    the unstable band when ``tr J < 0 < det J`` (Murray II, eq. 2.27)."""
    b = d[1] * jac[0, 0] + d[0] * jac[1, 1]
    disc = np.sqrt(b * b - 4 * d[0] * d[1] * np.linalg.det(jac))
    return (b - disc) / (2 * d[0] * d[1]), (b + disc) / (2 * d[0] * d[1])


def test_lattice_modes_of_the_5_point_laplacian():
    grid = Grid((32, 32))
    modes = lattice_modes(grid.shape, grid.symbol)
    assert len(modes.kappa2) == 153  # 0 <= m <= n <= 16
    m, n = modes.index.T
    np.testing.assert_allclose(
        modes.kappa2, 4 - 2 * np.cos(2 * np.pi * m / 32) - 2 * np.cos(2 * np.pi * n / 32),
        atol=1e-14)
    np.testing.assert_allclose(modes.wavelength[1:], 32 / np.hypot(m, n)[1:])
    fine = Grid((32, 32), dx=0.5)  # the symbol is in 1/length², the wavelength in cells
    np.testing.assert_allclose(lattice_modes(fine.shape, fine.symbol).kappa2, 4 * modes.kappa2)
    walls = lattice_modes((4, 6), Grid((4, 6)).symbol, periodic=False)
    assert len(walls.kappa2) == 24 and walls.wavelength[1] == 12.0  # cos(π x / 6): 2·6 cells


def test_schnakenberg_dispersion_band_and_class_are_murrays():
    a, b, d = 0.1, 0.9, np.array([1.0, 40.0])
    u, jac = _schnakenberg(a, b)
    grid = Grid((64, 64), dx=0.5)
    modes = lattice_modes(grid.shape, grid.symbol)
    with jax.enable_x64(True):
        st = stability(jnp.asarray(jac), jnp.asarray(u), jnp.asarray(d),
                       jnp.asarray(modes.kappa2))
    sigma = np.asarray(st.sigma)
    np.testing.assert_allclose(sigma, _sigma(jac, d, modes.kappa2), rtol=1e-12, atol=1e-12)
    assert CLASSES[int(st.cls)] == "turing"
    low, high = _band(jac, d)
    inside = (modes.kappa2 > low) & (modes.kappa2 < high)
    assert inside.sum() >= 10
    np.testing.assert_array_equal(np.asarray(st.unstable), inside)
    q2 = modes.kappa2[int(st.fastest)]
    assert sigma[int(st.fastest)] == sigma[1:].max() > 0
    assert low < q2 < high


def test_equal_diffusion_is_stable_with_no_band():
    """``tr J < 0 < det J`` and ``D_u = D_v``: ``σ(q²) = σ(0) - D q² < 0`` for every mode."""
    u, jac = _schnakenberg(0.1, 0.9)
    grid = Grid((32, 32))
    kappa2 = lattice_modes(grid.shape, grid.symbol).kappa2
    with jax.enable_x64(True):
        st = stability(jnp.asarray(jac), jnp.asarray(u), jnp.asarray([1.0, 1.0]),
                       jnp.asarray(kappa2))
    assert CLASSES[int(st.cls)] == "stable" and not np.asarray(st.unstable).any()
    np.testing.assert_allclose(np.asarray(st.sigma), float(st.sigma[0]) - kappa2, atol=1e-12)


def test_hopf_side_and_a_lost_fixed_point():
    """Schnakenberg with ``tr J > 0`` (``b - a > (a + b)³``) is unstable at ``k = 0`` with
    complex eigenvalues; no fixed point is class ``no_fixed_point`` whatever ``J`` says."""
    u, jac = _schnakenberg(0.05, 0.3)
    assert np.trace(jac) > 0 and np.trace(jac) ** 2 < 4 * np.linalg.det(jac)
    kappa2 = jnp.asarray([0.0, 0.5, 1.0])
    with jax.enable_x64(True):
        st = stability(jnp.asarray(jac), jnp.asarray(u), jnp.asarray([1.0, 40.0]), kappa2)
        lost = stability(jnp.asarray(jac), jnp.asarray(u), jnp.asarray([1.0, 40.0]), kappa2,
                         found=False)
    assert CLASSES[int(st.cls)] == "unstable_k0" and bool(st.oscillatory)
    assert CLASSES[int(lost.cls)] == "no_fixed_point"


def test_table2_is_turing_unstable_on_the_evaluation_grid_and_batches():
    """Table 2 at its fixed point (1, 1, 1) on the evaluation's 32² grid: Turing-unstable,
    fastest mode as in docs/networks.md (κ² = 0.489, λ = 32/√13 = 8.88 cells); a population whose
    second member has ``D_A = D_B`` (no inhibitor advantage) is classified ``stable`` in the
    same program."""
    model = load_model("examples/networks/table2.ant")
    grid = Grid((32, 32))
    modes = lattice_modes(grid.shape, grid.symbol)
    base = model.parameters()
    with jax.enable_x64(True):
        params = {k: jnp.asarray([v, v], jnp.float64) for k, v in base.items()}
        params["D_B"] = jnp.asarray([base["D_B"], base["D_A"]], jnp.float64)
        u, found, st = turing_batch(model, params, jnp.ones((1, 3), jnp.float64),
                                    modes.kappa2)
    np.testing.assert_allclose(np.asarray(u), 1.0, rtol=1e-10)
    assert np.asarray(found).all()
    assert [CLASSES[int(c)] for c in st.cls] == ["turing", "stable"]
    fastest = int(st.fastest[0])
    assert np.isclose(modes.wavelength[fastest], 32 / np.sqrt(13), rtol=1e-12)
    assert abs(modes.kappa2[fastest] - 0.4893) < 1e-4
