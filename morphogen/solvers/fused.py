"""The fused CPU step: explicit Euler on a 2D grid as one loop over cells, compiled by Numba.

XLA on CPU compiles an explicit step of a big grid (stencil, reaction and update in one fusion)
to about half the speed of a hand-fused single-thread loop (Gray-Scott 256², one core:
``bench/results/gs_single.json``, docs/schemes.md). This module writes that loop for any model:
the model's own ``reaction`` and ``diffusion`` are traced on one cell into the jaxpr the engine
compiles (:func:`morphogen.models.cell_code.cell_jaxpr`), each operation becomes one line of
Python (:data:`NUMBA`), and the lines sit in a loop that computes, per cell and species,

.. math::
    u' = u + dt\\,(R(u, p, c) + D\\,\\Delta u),

with the 5- or 9-point Laplacian of :mod:`morphogen.domains.stencils` term for term (the same
order of additions, the same division by ``dx^2``), the ghost cells of
:mod:`morphogen.domains.grid` (wrap for periodic, the edge value for no flux), the model's
clamp as ``jnp.clip`` takes it, and the clock ``t += dt`` in float32; two buffers, swapped every
step. XLA's floating-point mode is reproduced (:mod:`morphogen.solvers.fused_jit`: fused
multiply-adds, flush-to-zero), so the two agree to float32 rounding; functions such as ``exp``
come from different libraries and may differ in the last bit.

:func:`fused_step` gives the step only where it computes what the JAX step computes and the
processor is an x86-64 CPU with Numba installed (the ``fast`` extra); ``None`` otherwise, and
the caller keeps the JAX path (:func:`morphogen.engine.simulate.simulate`). ``MORPHOGEN_FUSED=off``
(:data:`ENV`) turns it off.

The generated source holds only generated names (``s0``, ``q3``, ``t17``, ``k2``, …) and
Python's operators: no model, species or parameter name and no text from a model file reaches
``compile``; constants are float32 globals ``k0``, ``k1``, … bound beside it.
"""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.domains.grid import Grid
from morphogen.errors import MorphogenError
from morphogen.models.cell_code import Dialect, Emitter, cell_jaxpr
from morphogen.models.model import Model

ENV = "MORPHOGEN_FUSED"
"""``off``: every run takes the JAX path; ``on``: the fused step wherever it applies, however
short the run; unset (or anything else): where it applies and the run has at least
:data:`MIN_WORK` cell-steps."""

MIN_WORK = 2**32
"""Cell-steps (cells × steps) from which a run takes the fused step by default (256² × 65 536
steps). The fused step saves about 0.5 ns a cell-step on one core (Gray-Scott 256²: 2.2e9
cell-steps per CPU-second through ``simulate`` against 1.05e9 on the JAX step,
``bench/results/gs_single.json``), but a process pays for Numba's start (about 0.65
CPU-seconds measured through ``morphogen simulate``, the kernel loaded from disk) and once per
kernel for its compile (about 0.8 s, 1.5 s for GenRD's 110 parameters; kept on disk when the
compile cache is on, :mod:`morphogen.util.compile_cache`): from 2³² cell-steps a run gains
about 0.7 s even when it starts Numba and compiles its kernel."""

MIN_MEMBER_WORK = 2**26
"""Cell-steps a member (cells × steps) from which a population takes the fused step by default
(128² × 4 096 steps). A search evaluates generation after generation in one process, so Numba's
start and the compile are paid once against about 0.5 ns a cell-step saved in every member of
every generation (30 ms a member a generation from here)."""

_BINARY = {"add": "({} + {})", "sub": "({} - {})", "mul": "({} * {})", "div": "({} / {})",
           "max": "np.maximum({}, {})", "min": "np.minimum({}, {})", "pow": "np.power({}, {})",
           "atan2": "np.arctan2({}, {})", "rem": "np.fmod({}, {})",
           "lt": "({} < {})", "le": "({} <= {})", "gt": "({} > {})", "ge": "({} >= {})",
           "eq": "({} == {})", "ne": "({} != {})", "and": "({} & {})", "or": "({} | {})"}
_UNARY = {"neg": "(-{})", "exp": "np.exp({})", "log": "np.log({})", "sqrt": "np.sqrt({})",
          "tanh": "np.tanh({})", "sin": "np.sin({})", "cos": "np.cos({})", "tan": "np.tan({})",
          "abs": "np.abs({})", "sign": "np.sign({})", "floor": "np.floor({})",
          "ceil": "np.ceil({})", "exp2": "np.exp2({})", "log1p": "np.log1p({})",
          "expm1": "np.expm1({})", "square": "({0} * {0})", "not": "(not {})",
          "asin": "np.arcsin({})", "acos": "np.arccos({})", "atan": "np.arctan({})",
          "sinh": "np.sinh({})", "cosh": "np.cosh({})"}


def _declare(kind: str, name: str, expr: str) -> str:
    return f"    {name} = {expr}"


NUMBA = Dialect(
    binary=_BINARY, unary=_UNARY, zero="k0", one="k1", literal=repr, true="True",
    false="False", declare=_declare, select="({1} if {0} else {2})",
    clamp="np.minimum(np.maximum({1}, {0}), {2})", to_float="(k1 if {} else k0)",
    to_bool="({} != k0)")
"""How Python for Numba writes each operation on float32 scalars (each constant a float32
global ``k…``, bound by :class:`_Constants`)."""


class _Constants:
    """Float32 constants as the globals ``k0``, ``k1``, … (``k0 = 0``, ``k1 = 1``)."""

    def __init__(self) -> None:
        self.values: list[float] = []
        self.add(0.0)
        self.add(1.0)

    def add(self, value: Any) -> str:
        v = float(np.float32(value))
        for i, old in enumerate(self.values):
            if np.float32(old).tobytes() == np.float32(v).tobytes():
                return f"k{i}"
        self.values.append(v)
        return f"k{len(self.values) - 1}"


class _Float32Emitter(Emitter):
    """An :class:`~morphogen.models.cell_code.Emitter` that refuses values other than float32
    and booleans (integer arithmetic would change meaning as float32)."""

    def equation(self, eqn: Any, ins: list[np.ndarray]) -> list[np.ndarray]:
        for var in eqn.outvars:
            if str(var.aval.dtype) not in ("float32", "bool"):
                raise self.refuse(f"{eqn.primitive.name} on {var.aval.dtype}")
        return super().equation(eqn, ins)


@dataclass(frozen=True)
class KernelSource:
    """A generated kernel: Python source defining ``advance`` and its float32 constants."""

    source: str
    constants: tuple[float, ...]


def kernel_source(model: Model, names: Sequence[str], *, boundary: str, stencil: int,
                  dx: float, clamp: tuple[float, float] | None) -> KernelSource:
    """The source of ``advance(cur, nxt, steps, t, dt, xs, ys, qs) -> (u, t)``, which runs
    under flush-to-zero and denormals-are-zero (:mod:`morphogen.solvers.fused_jit`), and of
    ``advance_all(cur, nxt, steps, t, dt, xs, ys, qs) -> t``, the same for a population: ``cur``
    and ``nxt`` ``(P, S, H, W + 2)``, ``qs`` ``(P, K)``, each member advanced all ``steps`` in
    turn (its state stays in the cache) and left in ``cur``.

    ``cur`` (the state, float32 ``(S, H, W + 2)``: each row between a ghost column on either
    side) and ``nxt`` (as large) are the two buffers; ``xs`` (``(W + 2,)``, the ghosts' entries
    unused) and ``ys`` (``(H,)``) the cell-centre coordinates; ``qs`` the parameters of
    ``names``, in order (float32 ``(P,)``). Each step first fills the ghost columns (the
    opposite border column when periodic, the border's own value for no flux), so that every
    row is one loop over its cells that LLVM vectorises, with the model's cell code written
    once, inside the loop over rows (a function called per row cost a quarter of the time). A
    model operation the kernel cannot write is a :class:`~morphogen.errors.MorphogenError`.
    """
    if boundary not in ("periodic", "neumann") or stencil not in (5, 9):
        raise MorphogenError(f"the fused step takes periodic or no-flux boundaries and 5- or "
                             f"9-point stencils, not {boundary} with {stencil} points")
    who, target = "fused step", "the fused CPU step"
    closed = cell_jaxpr(model, names, who=who, target=target)
    consts = _Constants()
    em = _Float32Emitter(replace(NUMBA, literal=consts.add), who=who, target=target,
                         model=model.name)
    s = len(model.species)
    cell = np.array([[f"s{i}"] for i in range(s)], dtype=object)
    params = [np.array(f"q{i}", dtype=object) for i in range(len(names))]
    coords = [np.array(["xc"], dtype=object), np.array(["yc"], dtype=object),
              np.array(["tc"], dtype=object)]
    outs = em.run(closed.jaxpr, closed.consts, [cell, *params, *coords])
    reaction = np.broadcast_to(outs[0], (s, 1))
    diffusion = [np.broadcast_to(d, (1,)).ravel()[0] for d in outs[1:1 + s]]
    h2 = consts.add(dx * dx)
    laps = []
    for i in range(s):
        c, n, so = f"rc{i}", f"rn{i}", f"rs{i}"
        edges = f"((({n}[x] + {so}[x]) + {c}[xl]) + {c}[xr])"
        if stencil == 5:
            laps.append(f"l{i} = ({edges} - {consts.add(4.0)} * s{i}) / {h2}")
        else:
            corners = f"((({n}[xl] + {n}[xr]) + {so}[xl]) + {so}[xr])"
            laps.append(f"l{i} = (({edges} * {consts.add(2 / 3)} + {corners} * "
                        f"{consts.add(1 / 6)}) - s{i} * {consts.add(10 / 3)}) / {h2}")
    update = []
    for i in range(s):
        update.append(f"v{i} = s{i} + dt * ({reaction[i, 0]} + {diffusion[i]} * l{i})")
        if clamp is not None:
            lo, hi = consts.add(clamp[0]), consts.add(clamp[1])
            update.append(f"v{i} = np.minimum(np.maximum(v{i}, {lo}), {hi})")
        update.append(f"ro{i}[x] = v{i}")
    periodic = boundary == "periodic"
    west, east = ("w", "1") if periodic else ("1", "w")
    north, south = ("h - 1", "0") if periodic else ("0", "h - 1")
    lines = [
        "@njit",
        "def advance(cur, nxt, steps, tc, dt, xs, ys, qs):",
        "    mode = stmxcsr()",
        "    ldmxcsr(np.uint32(mode | FTZ_DAZ))",
        "    h = cur.shape[1]",
        "    w = cur.shape[2] - 2",
        *(f"    q{i} = qs[{i}]" for i in range(len(names))),
        "    for _ in range(steps):",
        "        for y in range(h):",
        *(f"            cur[{i}, y, 0] = cur[{i}, y, {west}]" for i in range(s)),
        *(f"            cur[{i}, y, w + 1] = cur[{i}, y, {east}]" for i in range(s)),
        "        for y in range(h):",
        f"            yn = y - 1 if y > 0 else {north}",
        f"            ys_ = y + 1 if y < h - 1 else {south}",
        "            yc = ys[y]",
        *(f"            {line}" for i in range(s) for line in (
            f"rc{i} = cur[{i}, y]", f"rn{i} = cur[{i}, yn]", f"rs{i} = cur[{i}, ys_]",
            f"ro{i} = nxt[{i}, y]")),
        "            for x in range(1, w + 1):",
        "                xl = x - 1",
        "                xr = x + 1",
        "                xc = xs[x]",
        *(f"                s{i} = rc{i}[x]" for i in range(s)),
        *("                " + line.strip() for line in [*laps, *em.lines, *update]),
        "        cur, nxt = nxt, cur",
        "        tc = tc + dt",
        "    ldmxcsr(mode)",
        "    return cur, tc",
        "",
        "",
        "@njit",
        "def advance_all(cur, nxt, steps, tc, dt, xs, ys, qs):",
        "    clock = tc",
        "    for m in range(cur.shape[0]):",
        "        out, clock = advance(cur[m], nxt[m], steps, tc, dt, xs, ys, qs[m])",
        "        if steps % 2 == 1:",
        "            cur[m] = out",
        "    return clock",
        "",
    ]
    return KernelSource("\n".join(lines), tuple(consts.values))


class FusedStep:
    """``step(u, t, dt, n) -> (u, t)``: ``n`` fused Euler steps from ``(u, t)``; ``u`` is a new
    float32 array ``(S, H, W)`` (the input is not written), ``t`` a float32."""

    def __init__(self, kernel: Any, params: np.ndarray, xs: np.ndarray, ys: np.ndarray):
        self.kernel, self.params, self.xs, self.ys = kernel, params, xs, ys

    def __call__(self, u: Any, t: Any, dt: float, n: int) -> tuple[Any, Any]:
        cur = _padded(u)
        out, t = self.kernel.advance(cur, np.empty_like(cur), n, np.float32(t), np.float32(dt),
                                     self.xs, self.ys, self.params)
        return np.ascontiguousarray(out[..., 1:-1]), np.float32(t)


class FusedPopulation:
    """``step(u, params, t, dt, n) -> (u, t)``: ``n`` fused Euler steps of each member of a
    population, ``u`` float32 ``(P, S, H, W)`` (a new array is returned), ``params`` float32
    ``(P, K)`` in the order the kernel was made for, one clock ``t`` for all."""

    def __init__(self, kernel: Any, xs: np.ndarray, ys: np.ndarray):
        self.kernel, self.xs, self.ys = kernel, xs, ys

    def __call__(self, u: Any, params: np.ndarray, t: Any, dt: float, n: int
                 ) -> tuple[np.ndarray, Any]:
        cur = _padded(u)
        t = self.kernel.advance_all(cur, np.empty_like(cur), n, np.float32(t), np.float32(dt),
                                    self.xs, self.ys,
                                    np.ascontiguousarray(params, np.float32))
        return np.ascontiguousarray(cur[..., 1:-1]), np.float32(t)


def _padded(u: Any) -> np.ndarray:
    """``u`` as float32 with a ghost column on either side of each row (the kernel fills them)."""
    u = np.asarray(u, np.float32)
    cur = np.zeros((*u.shape[:-1], u.shape[-1] + 2), np.float32)
    cur[..., 1:-1] = u
    return cur


def fused_step(model: Model, domain: Any, params: Mapping[str, Any], *, scheme: Any,
               noise: Any, clamp: tuple[float, float] | None, dtype: Any, steps: int
               ) -> FusedStep | None:
    """The fused step of one state of ``model`` on ``domain`` for a run of ``steps`` steps, or
    ``None`` where the JAX step runs.

    It runs where it computes what the JAX step does (:func:`_kernel`), every parameter one
    number, when :data:`ENV` allows (by default from :data:`MIN_WORK` cell-steps).
    """
    if not _wanted(domain, steps, MIN_WORK):
        return None
    values = [np.asarray(v) for v in params.values()]
    if any(v.ndim != 0 for v in values):
        return None
    made = _kernel(model, domain, tuple(params), scheme=scheme, noise=noise, clamp=clamp,
                   dtype=dtype)
    if made is None:
        return None
    kernel, xs, ys = made
    step = FusedStep(kernel, np.array(values, np.float32).reshape(-1), xs, ys)
    try:  # Numba compiles at the first call: a kernel it cannot compile leaves the JAX path
        step(np.zeros((len(model.species), *domain.shape), np.float32), 0.0, 1.0, 0)
    except Exception:  # noqa: BLE001 (any failure of Numba's compiler)
        return None
    return step


def fused_population(model: Model, domain: Any, names: Sequence[str], *, scheme: Any,
                     clamp: tuple[float, float] | None, steps: int) -> FusedPopulation | None:
    """The fused step of a population of ``model`` on ``domain`` whose members differ only in
    the numbers of the parameters ``names`` (each member one number each), for ``steps`` steps
    a member, or ``None`` where the JAX step runs (:func:`_kernel`, float32, no noise).

    By default (:data:`ENV` unset) from :data:`MIN_MEMBER_WORK` cell-steps a member: the
    choice depends on the problem, not on how many members one call gets, so a population split
    into batches (Ray's workers) runs the same program as the whole.
    """
    if not _wanted(domain, steps, MIN_MEMBER_WORK):
        return None
    made = _kernel(model, domain, tuple(names), scheme=scheme, noise=None, clamp=clamp,
                   dtype=np.float32)
    if made is None:
        return None
    step = FusedPopulation(*made)
    try:
        step(np.zeros((1, len(model.species), *domain.shape), np.float32),
             np.zeros((1, len(names)), np.float32), 0.0, 1.0, 0)
    except Exception:  # noqa: BLE001 (any failure of Numba's compiler)
        return None
    return step


def _wanted(domain: Any, steps: int, work: int) -> bool:
    """Whether :data:`ENV` lets a run of ``steps`` steps on ``domain`` take the fused step
    (by default: from ``work`` cell-steps)."""
    mode = os.environ.get(ENV, "").strip().lower()
    size = domain.size if isinstance(domain, Grid) else 0
    return mode != "off" and (mode == "on" or size * steps >= work)


def _kernel(model: Model, domain: Any, names: tuple[str, ...], *, scheme: Any, noise: Any,
            clamp: tuple[float, float] | None, dtype: Any
            ) -> tuple[Any, np.ndarray, np.ndarray] | None:
    """The compiled kernel module and its padded ``xs`` and ``ys``, or ``None`` where it would
    not compute what the JAX step does: JAX's backend must be the CPU, an x86-64 one, with
    Numba installed; the scheme ``euler`` (by name); no noise; a 2D
    :class:`~morphogen.domains.grid.Grid` (not a subclass) with the 5- or 9-point stencil and
    the same periodic or no-flux boundary for every species (nothing held); float32;
    isotropic diffusion and a reaction of operations the kernel writes (:func:`kernel_source`).
    """
    if type(domain) is not Grid or domain.ndim != 2 or domain.is_spectral:
        return None
    if not (isinstance(scheme, str) and scheme == "euler") or (
            noise is not None and noise.amplitude > 0):
        return None
    if np.dtype(dtype) != np.float32:
        return None
    kinds = {b.kind for b in domain.boundaries(model.species)}
    if len(kinds) != 1 or kinds & {"dirichlet"}:
        return None
    if importlib.util.find_spec("numba") is None:
        return None
    import jax

    if jax.default_backend() != "cpu":
        return None
    try:
        from morphogen.solvers import fused_jit
    except ImportError:  # a Numba that does not import (one built for another NumPy)
        return None
    if not fused_jit.SUPPORTED:
        return None
    stencil = 5 if domain._points.name == "5-point" else 9
    try:
        code = _source(model, names, kinds.pop(), stencil, float(domain.dx),
                       tuple(float(c) for c in clamp) if clamp is not None else None)
    except MorphogenError:
        return None
    coords = domain.coords
    kernel = fused_jit.compile_kernel(code.source, code.constants, _cache_directory())
    return (kernel, np.pad(np.asarray(coords["x"], np.float32).ravel(), 1),
            np.ascontiguousarray(coords["y"].ravel(), np.float32))


def _cache_directory() -> Path | None:
    """Where compiled kernels are kept: beside JAX's persistent cache when it is on
    (``<its folder>-fused``), else nowhere."""
    import jax

    folder = jax.config.jax_compilation_cache_dir
    return Path(f"{folder}-fused") if folder else None


@lru_cache(maxsize=32)
def _source(model: Model, names: tuple[str, ...], boundary: str, stencil: int, dx: float,
            clamp: tuple[float, float] | None) -> KernelSource:
    return kernel_source(model, names, boundary=boundary, stencil=stencil, dx=dx, clamp=clamp)
