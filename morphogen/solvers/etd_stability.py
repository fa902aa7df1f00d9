"""ETDRK4's own stability region on the linearised system (Cox & Matthews 2002; Du & Zhu 2005).

Linearise ``∂t u = L u + N(u)`` on one Fourier mode: the linear part (diffusion) is diagonal,
``L = diag(c_s)`` with ``c_s = -D_s σ`` (``σ`` the stencil's symbol, ``0 <= σ <= ρ(L)``), and
the reaction ``N(u) ≈ J u`` (``J`` the reaction Jacobian). One Cox-Matthews step
(:mod:`morphogen.solvers.etd`, with ``h = dt``, ``E = e^{hL}``, ``E₂ = e^{hL/2}`` and the
diagonal ``Q, f₁, f₂, f₃`` of :func:`morphogen.solvers.etd.phi_coefficients`) is then a
matrix ``M(h)``:

.. math::
    A = E_2 + Q J,\\quad B = E_2 + Q J A,\\quad C = E_2 A + Q J (2B - I),

    M = E + f_1 J + 2 f_2 J (A + B) + f_3 J C .

For one species (or ``L`` and ``J`` commuting) it is the scalar stability function
``R(z_L, z_N)`` of ETDRK4 with ``z_L = c h`` and ``z_N = λ h`` (:func:`amplification`):
``R(z_L, 0) = e^{z_L}`` (diffusion exact) and ``R(0, z_N)`` is RK4's degree-4 Taylor
polynomial of ``e^{z_N}`` (with no diffusion ETDRK4 is RK4); with ``z_L → -∞`` the region in
``z_N`` grows (Du & Zhu's regions). A mode whose exact linear flow decays (every eigenvalue of
``J - σ diag(D)`` with negative real part) is stable when the spectral radius ``ρ(M(h)) <= 1``;
growing modes (a Turing band, a Hopf-unstable ground state) are the physics and are left out.
:func:`marginal_dt` is the largest ``h`` with ``ρ(M(h')) <= 1`` for every decaying mode and
every ``0 < h' <= h`` (a geometric scan of ``h``, refined by bisection); for a linear problem
it is exact (``tests/solvers/test_etd_stability.py``: the marginal step runs, 1.5× it grows).

For a nonlinear model the Jacobian is taken at the ground state while the pattern moves away
from it, and there the marginal step of the ground state is no safe guide: measured on the
library models (docs/schemes.md, "ETDRK4's own stability region"), the largest step that
runs is 0.7-1.0× it for most, 0.30-0.33× for Schnakenberg and 0.14-0.17× for Turing's model.
"""

from __future__ import annotations

import numpy as np

SCAN = np.geomspace(1e-2, 1e3, 300)
"""Steps scanned, in units of ``1 / max |λ(J)|``, before bisection."""

BISECTIONS = 50


def _phis(z: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, ...]:
    """``E, E₂, Q, f₁, f₂, f₃`` of ETDRK4 for complex ``z = c h`` (series near 0)."""
    z = np.asarray(z, np.complex128)
    small = np.abs(z) < 1e-3
    w = np.where(small, 1.0, z)
    e = np.exp(w)
    q = np.where(small, 0.5 + z / 8, np.expm1(w / 2) / w)
    f1 = np.where(small, 1 / 6 + z / 6, (-4 - w + e * (4 - 3 * w + w * w)) / w**3)
    f2 = np.where(small, 1 / 6 + z / 12, (2 + w + e * (w - 2)) / w**3)
    f3 = np.where(small, 1 / 6 - 0 * z, (-4 - 3 * w - w * w + e * (4 - w)) / w**3)
    return np.exp(z), np.exp(z / 2), h * q, h * f1, h * f2, h * f3


def step_matrix(c: np.ndarray, jac: np.ndarray, h: np.ndarray | float) -> np.ndarray:
    """ETDRK4's one-step matrix ``M(h)`` on linearised modes (module docstring).

    Args:
        c: diffusion eigenvalues per mode and species, ``(..., S)`` (``-D_s σ``, ``<= 0``).
        jac: the reaction Jacobian, ``(S, S)`` or broadcastable ``(..., S, S)``.
        h: the step, a number or broadcastable to ``c``'s leading axes.
    Returns:
        ``(..., S, S)`` complex.
    """
    c = np.asarray(c, np.complex128)
    h = np.asarray(h, np.float64)[..., None]
    eye = np.eye(c.shape[-1])
    e, e2, q, f1, f2, f3 = (x[..., :, None] * eye for x in _phis(c * h, h))
    jq = q @ jac
    a = e2 + jq
    b = e2 + jq @ a
    cc = e2 @ a + jq @ (2 * b - eye)
    return e + f1 @ jac + 2 * f2 @ jac @ (a + b) + f3 @ jac @ cc


def amplification(z_l: np.ndarray, z_n: np.ndarray) -> np.ndarray:
    """ETDRK4's scalar stability function ``R(z_L, z_N)`` (one species, ``h = 1``)."""
    z_l, z_n = np.broadcast_arrays(np.asarray(z_l, np.complex128),
                                   np.asarray(z_n, np.complex128))
    return step_matrix(z_l[..., None], z_n[..., None, None], 1.0)[..., 0, 0]


def marginal_dt(jac: np.ndarray, d: np.ndarray, sigma: np.ndarray) -> float:
    """Largest ``h`` at which every decaying linear mode stays bounded (module docstring).

    Args:
        jac: reaction Jacobian ``(S, S)``.
        d: diffusion coefficient per species ``(S,)``.
        sigma: the domain's Laplacian eigenvalues to check (``-σ``), ``(K,)``.
    Returns:
        The marginal step, ``inf`` when no decaying mode limits it.
    """
    jac = np.asarray(jac, np.float64)
    d = np.asarray(d, np.float64)
    sigma = np.asarray(sigma, np.float64)
    c = -sigma[:, None] * d[None]
    growth = np.linalg.eigvals(jac[None] - sigma[:, None, None] * np.diag(d)[None]).real.max(1)
    decaying = growth < 0
    scale = np.abs(np.linalg.eigvals(jac)).max()
    if not decaying.any() or scale < 1e-12:
        return float("inf")

    def bad(h: float) -> bool:
        rho = np.abs(np.linalg.eigvals(step_matrix(c[decaying], jac, h))).max(axis=1)
        return bool((rho > 1.0 + 1e-9).any())

    hs = SCAN / scale
    first = next((i for i, h in enumerate(hs) if bad(h)), None)
    if first is None:
        return float("inf")
    lo, hi = (hs[first - 1] if first else 0.0), hs[first]
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if bad(mid) else (mid, hi)
    return float(lo)
