"""The no-flux solvers' cosine transform against JAX's own ``jax.scipy.fft.dctn``.

:mod:`morphogen.solvers.cosine` computes the 2D DCT-II of a field with one real FFT of its own
size (Makhoul's 2D form); ``jax.scipy.fft.dctn`` applies Makhoul's 1D form along each axis,
each with a complex FFT of the full length. Both are timed here as the IMEX and ETDRK4 steps
use them: a forward transform, a mode multiplier and the inverse, on two species, in one jitted
program; CPU seconds of this process, interleaved rounds, the best of each. The largest
difference of each from SciPy's float64 ``dctn`` (relative to the largest coefficient) is
recorded too.
"""

from __future__ import annotations

import os

import jax
import jax.numpy as jnp
import numpy as np
import scipy.fft
from jax.scipy.fft import dctn, idctn

from bench.timing import interleaved_cpu
from morphogen.solvers.cosine import dct, idct

SIZES = (64, 256, 512)
REPEATS = 20
ROUNDS = 5


def _error(forward, x: jax.Array) -> float:
    ref = scipy.fft.dctn(np.asarray(x, np.float64), axes=(-2, -1))
    return float(np.abs(np.asarray(forward(x)) - ref).max() / np.abs(ref).max())


def run() -> dict:
    load_before = os.getloadavg()
    sizes = {}
    for n in SIZES:
        x = jnp.asarray(np.random.default_rng(0).standard_normal((2, n, n)), jnp.float32)
        ours = jax.jit(lambda a: idct(0.5 * dct(a, 2), 2))
        library = jax.jit(lambda a: idctn(0.5 * dctn(a, axes=(-2, -1)), axes=(-2, -1)))
        runs = {}
        for name, f in (("morphogen", ours), ("jax_dctn", library)):
            f(x).block_until_ready()
            runs[name] = lambda f=f, x=x: [f(x).block_until_ready() for _ in range(REPEATS)]
        cpu, _ = interleaved_cpu(runs, ROUNDS)
        best = {k: min(v) / REPEATS for k, v in cpu.items()}
        sizes[f"{n}x{n}"] = {
            "cpu_s_per_pair": {k: round(v, 7) for k, v in best.items()},
            "jax_dctn_over_morphogen": round(best["jax_dctn"] / best["morphogen"], 2),
            "error_vs_scipy": {"morphogen": _error(lambda a: dct(a, 2), x),
                               "jax_dctn": _error(lambda a: dctn(a, axes=(-2, -1)), x)},
        }
    return {"benchmark": "2 species, DCT-II, x0.5, inverse; float32; CPU s per pair, best of "
                         f"{ROUNDS} interleaved rounds of {REPEATS}",
            "xla_flags": os.environ.get("XLA_FLAGS", ""), "load_before": load_before,
            "load_after": os.getloadavg(), "sizes": sizes}
