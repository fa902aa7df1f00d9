"""Fused single-thread Numba loops for a population of reaction networks: the reference of
``bench/bench_networks.py`` (needs Numba: ``.venv-bench``, ``make bench-peers``; never imported
by the package).

Both advance every member in turn on its own periodic grid, explicit Euler with the 5-point
Laplacian (``dx = 1``), float32, two buffers, the members' cells in row-major order:

- :func:`generic`: the runtime-structure arithmetic of ``m`` slots per member (``k``, ``M_e``,
  ``M_p``, three species), slots with rate 0 skipped (static ones included), ``s^e`` looked up;
- :func:`table2`: the Table-2 network written out (rates from ``k``, slot layout of
  ``genome.table2_spec``).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=False, fastmath=False)
def _generic(u, k, me, mp, d, steps, dt):
    """Three species (the seed's n); per member its used slots' rates, exponents and net
    stoichiometry in small arrays, ``s^e`` looked up in ``(1, s, s², s³)``."""
    p_, n, h, w = u.shape
    m = k.shape[1]
    dt = np.float32(dt)
    four = np.float32(4.0)
    pa = np.empty(4, np.float32)
    pb = np.empty(4, np.float32)
    pc = np.empty(4, np.float32)
    for b in range(p_):
        used = np.array([j for j in range(m) if k[b, j] != 0.0], dtype=np.int64)
        q = used.size
        kk = np.empty(q, np.float32)
        ee = np.empty((q, 3), np.int64)
        nu = np.empty((q, 3), np.float32)
        for t in range(q):
            kk[t] = k[b, used[t]]
            for i in range(3):
                ee[t, i] = me[b, i, used[t]]
                nu[t, i] = mp[b, i, used[t]] - me[b, i, used[t]]
        cur = u[b].copy()
        nxt = np.empty_like(cur)
        pa[0] = pb[0] = pc[0] = 1.0
        for _ in range(steps):
            for y in range(h):
                yu = y - 1 if y > 0 else h - 1
                yd = y + 1 if y < h - 1 else 0
                for x in range(w):
                    xl = x - 1 if x > 0 else w - 1
                    xr = x + 1 if x < w - 1 else 0
                    a, bb, c = cur[0, y, x], cur[1, y, x], cur[2, y, x]
                    pa[1], pa[2], pa[3] = a, a * a, a * a * a
                    pb[1], pb[2], pb[3] = bb, bb * bb, bb * bb * bb
                    pc[1], pc[2], pc[3] = c, c * c, c * c * c
                    ra = rb = rc = np.float32(0.0)
                    for t in range(q):
                        v = kk[t] * pa[ee[t, 0]] * pb[ee[t, 1]] * pc[ee[t, 2]]
                        ra += nu[t, 0] * v
                        rb += nu[t, 1] * v
                        rc += nu[t, 2] * v
                    la = cur[0, yu, x] + cur[0, yd, x] + cur[0, y, xl] + cur[0, y, xr] - four * a
                    lb = cur[1, yu, x] + cur[1, yd, x] + cur[1, y, xl] + cur[1, y, xr] - four * bb
                    lc = cur[2, yu, x] + cur[2, yd, x] + cur[2, y, xl] + cur[2, y, xr] - four * c
                    nxt[0, y, x] = a + dt * (d[0] * la + ra)
                    nxt[1, y, x] = bb + dt * (d[1] * lb + rb)
                    nxt[2, y, x] = c + dt * (d[2] * lc + rc)
            cur, nxt = nxt, cur
        u[b] = cur
    return u


@numba.njit(cache=False, fastmath=False)
def _table2(u, k, d, steps, dt):
    p_, n, h, w = u.shape
    dt = np.float32(dt)
    four = np.float32(4.0)
    for b in range(p_):
        rho_c, mu_a, mu_b = k[b, 2], k[b, 3], k[b, 4]
        k1, k2, k3 = k[b, 6], k[b, 7], k[b, 8]
        cur = u[b].copy()
        nxt = np.empty_like(cur)
        for _ in range(steps):
            for y in range(h):
                yu = y - 1 if y > 0 else h - 1
                yd = y + 1 if y < h - 1 else 0
                for x in range(w):
                    xl = x - 1 if x > 0 else w - 1
                    xr = x + 1 if x < w - 1 else 0
                    a, bb, c = cur[0, y, x], cur[1, y, x], cur[2, y, x]
                    la = cur[0, yu, x] + cur[0, yd, x] + cur[0, y, xl] + cur[0, y, xr] - four * a
                    lb = cur[1, yu, x] + cur[1, yd, x] + cur[1, y, xl] + cur[1, y, xr] - four * bb
                    nxt[0, y, x] = a + dt * (d[0] * la + k1 * a * a * c - mu_a * a)
                    nxt[1, y, x] = bb + dt * (d[1] * lb + k3 * a * a - mu_b * bb)
                    nxt[2, y, x] = c + dt * (rho_c - k2 * bb * c)
            cur, nxt = nxt, cur
        u[b] = cur
    return u


def generic(u: np.ndarray, k: np.ndarray, me: np.ndarray, mp: np.ndarray, d: np.ndarray,
            steps: int, dt: float) -> np.ndarray:
    """``steps`` steps of every member of ``u`` ``(P, n, H, W)`` (a copy)."""
    return _generic(u.copy(), k, me.astype(np.int64), mp.astype(np.int64), d, steps, dt)


def table2(u: np.ndarray, k: np.ndarray, d: np.ndarray, steps: int, dt: float) -> np.ndarray:
    """The Table-2 network written out; ``k`` in the slot order of ``table2_spec``."""
    return _table2(u.copy(), k, d, steps, dt)
