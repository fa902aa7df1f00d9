"""A fused single-thread Numba loop for Gray-Scott on a periodic 2D grid: the reference of
``bench/bench_gs_single.py`` (needs Numba, the ``fast`` extra; never imported by the package).

One explicit Euler step of the library model ``gray-scott`` (Skaggs eqs. 2.3-2.4) with the
5-point Laplacian, ``dx = 1``, float32, state ``(2, H, W)`` (``u``, ``v``) in row-major order:

.. math::
    u' = u + dt\\,[(-uv^2 + F(1-u)) + D_u \\Delta u],\\qquad
    v' = v + dt\\,[(uv^2 - (F+k)v) + D_v \\Delta v],

    \\Delta f = ((f_N + f_S) + f_W) + f_E - 4 f

in the order of operations of morphogen's step (``domains/stencils.py``,
``models/library.py``, ``solvers/explicit.py``). Two buffers, swapped every step; each row is one
loop over the interior columns with the neighbour rows and columns taken directly (no modulo; the
wrapped row indices are chosen once per row and the two border columns are done apart), so LLVM
vectorises the interior (16 floats a vector on AVX-512). The rows are loops in the step's own
loop over rows: a function called per row (this loop's earlier form) ran at 1.7e9 cell-steps per
CPU-second against 2.3e9.

Same arithmetic as XLA on CPU, which contracts ``a * b + c`` into fused multiply-adds and runs
with flush-to-zero and denormals-are-zero (a denormal result or input reads as 0):

- ``fastmath={"contract"}`` (:data:`FASTMATH`, with the MXCSR helpers shared with the
  package's fused step, :mod:`morphogen.solvers.fused_jit`) and nothing else: contraction only, no
  reassociation. LLVM does not always pick the same pairs to fuse as XLA (one step from a random
  state: u bit-identical, 5 % of v one rounding apart), so the two agree to float32 rounding,
  not bit for bit; without contraction, 27 % of cells differ after one step.
- :func:`advance` sets both MXCSR bits (``0x8040``) of the calling thread for the duration of
  the loop and restores the previous value after (Gray-Scott's ``v`` decays through the
  denormal range far from the spots).
"""

from __future__ import annotations

import numba
import numpy as np

from morphogen.solvers.fused_jit import FASTMATH, FTZ_DAZ, ldmxcsr, stmxcsr

__all__ = ["FASTMATH", "FTZ_DAZ", "advance", "get_mxcsr", "set_mxcsr"]


@numba.njit(cache=True)
def get_mxcsr():
    """MXCSR of the calling thread."""
    return stmxcsr()


@numba.njit(cache=True)
def set_mxcsr(value):
    """Set MXCSR of the calling thread to ``value`` (``np.uint32``)."""
    ldmxcsr(value)


@numba.njit(inline="always")
def _cell(a, an, as_, b, bn, bs, ao, bo, x, xl, xr, du, dv, f, fk, dt):
    one, four = np.float32(1.0), np.float32(4.0)
    ac, bc = a[x], b[x]
    la = an[x] + as_[x] + a[xl] + a[xr] - four * ac
    lb = bn[x] + bs[x] + b[xl] + b[xr] - four * bc
    r = ac * bc * bc
    ao[x] = ac + dt * ((-r + f * (one - ac)) + du * la)
    bo[x] = bc + dt * ((r - fk * bc) + dv * lb)


@numba.njit(cache=False, fastmath=FASTMATH, error_model="numpy", boundscheck=False)
def _advance(cur, nxt, steps, du, dv, f, k, dt):
    h, w = cur.shape[1], cur.shape[2]
    fk = f + k
    for _ in range(steps):
        for y in range(h):
            yn = y - 1 if y > 0 else h - 1
            ys = y + 1 if y < h - 1 else 0
            a, an, as_ = cur[0, y], cur[0, yn], cur[0, ys]
            b, bn, bs = cur[1, y], cur[1, yn], cur[1, ys]
            ao, bo = nxt[0, y], nxt[1, y]
            _cell(a, an, as_, b, bn, bs, ao, bo, 0, w - 1, 1, du, dv, f, fk, dt)
            for x in range(1, w - 1):
                _cell(a, an, as_, b, bn, bs, ao, bo, x, x - 1, x + 1, du, dv, f, fk, dt)
            _cell(a, an, as_, b, bn, bs, ao, bo, w - 1, w - 2, 0, du, dv, f, fk, dt)
        cur, nxt = nxt, cur
    return cur


def advance(u: np.ndarray, params: dict, steps: int, dt: float, *, ftz: bool = True
            ) -> np.ndarray:
    """``steps`` Euler steps of ``u`` (float32, shape ``(2, H, W)``, a copy is advanced) with
    the parameters ``F``, ``k``, ``Du``, ``Dv``; with ``ftz`` under flush-to-zero and
    denormals-are-zero, as XLA computes."""
    f, k, du, dv = (np.float32(params[n]) for n in ("F", "k", "Du", "Dv"))
    cur = np.ascontiguousarray(u, np.float32).copy()
    nxt = np.empty_like(cur)
    old = get_mxcsr()
    if ftz:
        set_mxcsr(np.uint32(old | FTZ_DAZ))
    try:
        return _advance(cur, nxt, steps, du, dv, f, k, np.float32(dt))
    finally:
        set_mxcsr(old)
