"""A population of reaction networks on the SIMD lanes: the evaluation kernel of network evolution.

The padded runtime-structure term (:mod:`morphogen.search.networks.reaction`) under ``vmap``
lays a population out as ``(P, n, H, W)``: every operation of a step runs once per member over
a small 32 × 32 grid, and the reaction evaluates every slot, used or not. Here the member axis
is innermost, ``(n, H, W, B)``, so every stencil and reaction operation is one contiguous
vector operation over the members, and the reaction does only the work a network needs:

- the static slots are written out (``ds_i += ρ_i - μ_i s_i``), since their structure is fixed
  by the :class:`~morphogen.search.networks.genome.NetworkSpec`;
- the evolvable slots of each member are compacted on the host to the front (active slots with
  a non-zero rate, in slot order), and only the batch's largest count ``E`` of them is
  evaluated (one compiled program per ``E``, at most ``m_max - 2n + 1``);
- ``s², s³`` are formed once per cell and species, and ``s^e = w_0 + w_1 s + w_2 s² + w_3 s³``
  with one-hot weights ``w`` per member built once per chunk: exact for ``e ∈ {0, 1, 2, 3}``
  while ``s³`` is finite (``|s| < 7e12``, far beyond ``s_max``; past it ``0 · inf`` gives NaN
  where selects give ``inf``: invalid either way). It measured faster than nested selects.
- the fluxes of the evolvable slots are formed once per step into one array behind an
  optimisation barrier: XLA on CPU otherwise fused them into the update of every species,
  computing each flux ``n`` times (3x the reaction's work; the barrier measured 1.5-2x faster).

One step is explicit Euler with the periodic 5-point Laplacian (``dx = 1``): the step of
:func:`morphogen.solvers.step.make_step` for
:func:`~morphogen.search.networks.reaction.padded_model` on a periodic
:class:`~morphogen.domains.grid.Grid`; the sums are formed in another order, so the states agree
to float32 rounding (tested), not bit for bit. A slot left out contributes an exact 0 in the
padded term unless its powers overflow, where both states are invalid.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.search.networks.genome import NetworkSpec

Array = Any
LANES = 8
"""Batches are padded to a multiple of this (by repeating a member): the culled batches are
powers of two from 8, so only the full population is padded (150 -> 152)."""


def compact(params: dict[str, Any], spec: NetworkSpec) -> tuple[dict[str, np.ndarray], int]:
    """The kernel's arrays for a batch of :func:`~morphogen.search.networks.reaction.genome_params`
    (leading axis ``B``) and the number ``E`` of evolvable slots it needs.

    Returns ``rho, mu`` ``(n, B)``, ``k`` ``(E, B)``, ``e`` ``(E, n, B)`` int32 and ``nu``
    ``(E, n, B)`` float32 (``M_p - M_e``), the active non-zero-rate evolvable slots of each
    member first, in slot order, the rest zero.
    """
    n = spec.n
    k = np.asarray(params["k"], np.float32)
    me = np.asarray(params["Me"], np.int32)
    mp = np.asarray(params["Mp"], np.int32)
    b = k.shape[0]
    evo_k, evo_e, evo_p = k[:, 2 * n:], me[:, :, 2 * n:], mp[:, :, 2 * n:]
    used = evo_k != 0
    count = used.sum(1)
    e_max = int(count.max(initial=0))
    order = np.argsort(~used, axis=1, kind="stable")[:, :e_max]  # used slots first, in order
    rows = np.arange(b)[:, None]
    keep = np.arange(e_max)[None, :] < count[:, None]
    ck = np.where(keep, evo_k[rows, order], 0.0).astype(np.float32)
    ce = np.where(keep[:, None], np.take_along_axis(evo_e, order[:, None, :], 2), 0)
    cp = np.where(keep[:, None], np.take_along_axis(evo_p, order[:, None, :], 2), 0)
    out = {"rho": np.ascontiguousarray(k[:, :n].T), "mu": np.ascontiguousarray(k[:, n:2 * n].T),
           "k": np.ascontiguousarray(ck.T),
           "e": np.ascontiguousarray(ce.transpose(2, 1, 0)).astype(np.int32),
           "nu": np.ascontiguousarray((cp - ce).transpose(2, 1, 0)).astype(np.float32)}
    return out, e_max


def _laplacian(f: Array) -> Array:
    """Periodic 5-point Laplacian (``dx = 1``) of ``(H, W, B)`` over the first two axes.

    The wrapped neighbours come from two ghost-padded copies, ``(H + 2, W, B)`` and ``(H, W +
    2, B)``, written by ``dynamic_update_slice``; the stencil then reads them at fixed offsets.
    With ``jnp.roll`` (a slice and a concatenation per neighbour, fused into the step) XLA on
    CPU chose per element which piece to read and the step ran 2x slower (measured, 150 × 32²).
    """
    h, w, b = f.shape
    dus = jax.lax.dynamic_update_slice
    rows = jnp.zeros((h + 2, w, b), f.dtype)
    rows = dus(dus(dus(rows, f, (1, 0, 0)), f[-1:], (0, 0, 0)), f[:1], (h + 1, 0, 0))
    cols = jnp.zeros((h, w + 2, b), f.dtype)
    cols = dus(dus(dus(cols, f, (0, 1, 0)), f[:, -1:], (0, 0, 0)), f[:, :1], (0, w + 1, 0))
    return rows[:-2] + rows[2:] + cols[:, :-2] + cols[:, 2:] - 4.0 * f


@lru_cache(maxsize=64)
def lanes_advance(spec: NetworkSpec, e_max: int, steps: int, dt: float) -> Callable:
    """``advance(u, arrays) -> u``: ``steps`` Euler steps of states ``(n, H, W, B)`` with the
    arrays of :func:`compact` (``E = e_max``)."""
    n = spec.n
    diffusion = tuple(float(d) for d in spec.diffusion)

    def advance(u, a):
        rho, mu, k, e, nu = a["rho"], a["mu"], a["k"], a["e"], a["nu"]
        ks = [k[j] for j in range(e_max)]
        nus = [[nu[j, i] for i in range(n)] for j in range(e_max)]
        # one-hot weights of 1, s, s², s³ per slot, species and member (B,)
        wts = [[tuple((e[j, i] == q).astype(u.dtype) for q in range(4)) for i in range(n)]
               for j in range(e_max)]

        def step(s, _):
            powers = [(x, x * x, x * x * x) for x in s]
            fluxes = []
            for j in range(e_max):
                flux = ks[j]
                for i in range(n):
                    x, x2, x3 = powers[i]
                    w0, w1, w2, w3 = wts[j][i]
                    flux = flux * (w0 + w1 * x + w2 * x2 + w3 * x3)
                fluxes.append(flux)
            if fluxes:  # computed once, not once per species (see the module docstring)
                fluxes = jax.lax.optimization_barrier(jnp.stack(fluxes))
            rate = [rho[i] - mu[i] * s[i] for i in range(n)]
            for j in range(e_max):
                rate = [rate[i] + nus[j][i] * fluxes[j] for i in range(n)]
            out = tuple(s[i] + dt * (diffusion[i] * _laplacian(s[i]) + rate[i])
                        if diffusion[i] else s[i] + dt * rate[i] for i in range(n))
            return out, None

        s, _ = jax.lax.scan(step, tuple(u[i] for i in range(n)), None, length=steps)
        return jnp.stack(s)

    return jax.jit(advance)


def advance_population(u: Array, params: dict[str, Any], spec: NetworkSpec, steps: int,
                       dt: float) -> Array:
    """``steps`` Euler steps of a batch ``(B, n, H, W)`` of states with the genomes' runtime
    parameters ``params`` (leading axis ``B``); returns ``(B, n, H, W)``."""
    arrays, e_max = compact(params, spec)
    b = u.shape[0]
    pad = -b % LANES
    if pad:
        arrays = {k: np.concatenate([v, np.repeat(v[..., :1], pad, -1)], -1)
                  for k, v in arrays.items()}
        u = jnp.concatenate([u, jnp.repeat(u[:1], pad, 0)])
    run = lanes_advance(spec, e_max, int(steps), float(dt))
    out = run(jnp.transpose(u, (1, 2, 3, 0)), {k: jnp.asarray(v) for k, v in arrays.items()})
    return jnp.transpose(out[..., :b], (3, 0, 1, 2))
