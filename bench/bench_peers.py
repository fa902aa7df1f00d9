"""Time to reach t = T against Exponax and py-pde, on the same PDEs from the same initial state.

Two problems on a periodic 256² grid with ``dx = 1`` (domain length 256):

- Schnakenberg (``examples/schnakenberg.toml``, Murray II eq. 2.8, ``Dv/Du = 40``), noise start;
- Gray-Scott at the library model's defaults (Skaggs eqs. 2.3-2.4), blobs start.

The initial state is made once by :func:`morphogen.engine.initial.make_initial` (seed 0) and the
same NumPy array is handed to every solver. The peers are given the same domain length, grid
spacing, diffusion coefficients and reaction terms as the morphogen model:

- Exponax 0.2.0 (Koehler et al., pseudo-spectral ETDRK): its ``GrayScott`` stepper at order 4,
  and for Schnakenberg, which it has no stepper for, a :class:`exponax.BaseStepper` subclass with
  the diagonal operator ``diag(Du, Dv) (-|k|²)`` and the reaction evaluated pointwise in real
  space. Exponax has no stability check; besides the steps morphogen's ``etdrk4`` runs, it is
  timed at a longer one (``exponax_large_dt``) to meet the error of morphogen's ``imex``.
  morphogen's spectral Laplacian does not dealias, so neither does the custom nonlinearity;
  the Gray-Scott stepper cannot switch it off and is given ``dealiasing_fraction = 1``, which
  drops only the Nyquist modes (one more Gray-Scott row runs the custom nonlinearity). The
  steps run in Fourier space inside one ``lax.scan``.
- py-pde 0.59.0 (Zwicker 2020): ``PDE`` from expression strings on a periodic
  ``CartesianGrid`` (its ``laplace`` is the 5-point stencil), explicit Euler, with the numba
  backend (float64, the default) and with the JAX backend (float32: JAX's default precision),
  advanced by the solver's stepper function (``make_stepper``), compiled before timing. Its
  numba code runs single-threaded (``backend.numba.multithreading = "never"``): with its
  default, threads from 256² up, one run of this benchmark on the shared 2 cores spread from
  6.5 to 83 s per round, against 0.09 s for 300 Gray-Scott steps either way when run alone.
  Explicit Euler is taken as its fastest solver here (the others were not timed): the rest are
  explicit too (Runge-Kutta, Adams-Bashforth), or implicit Euler / Crank-Nicolson solved by
  fixed-point iteration, which converges only for steps near the explicit limit.

Exponax is pseudo-spectral, py-pde finite-difference, so the rows fall into two groups, each
against its own reference: 5-point rows (morphogen's default stencil, py-pde) against morphogen
``etdrk4`` on the 5-point stencil in float64 at a small step, spectral rows (morphogen
``stencil="spectral"``, Exponax) against the same on the spectral Laplacian. ``etdrk4``
integrates the (diagonal) diffusion exactly, so the reference's time error is the reaction's
alone; halving its step again changes it by ``reference_self_change`` (recorded).

Every run is compiled once, then all runs of a problem are timed interleaved (``ROUNDS``
rounds, :func:`bench.timing.interleaved`) and the median is reported with the load average
before and after. Error: relative L2 of the displayed species (``u`` for Schnakenberg, ``v``
for Gray-Scott) against the reference, and the Pearson correlation of the two patterns.

``make bench-peers`` creates ``.venv-bench`` (the project's lock plus ``bench/peers.txt``) and
runs this module there. ``make bench`` in the project's own environment, where the peers are
not installed, prints one line and keeps the stored ``bench/results/peers.json`` as it is.
"""

from __future__ import annotations

import importlib.util
import json
import math
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from bench.timing import interleaved
from morphogen.domains.grid import Grid
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate
from morphogen.models.library import get_model
from morphogen.models.registry import load_model
from morphogen.solvers.step import max_stable_dt

SIZE, ROUNDS = 256, 3
RESULT = Path(__file__).parent / "results" / "peers.json"
PEERS = {"exponax": "exponax", "pde": "py-pde"}  # module: distribution

Run = Callable[[], tuple[np.ndarray, int]]  # final state and steps taken (rejected included)


def _schnakenberg(u: Any, p: dict) -> tuple[Any, Any]:
    """Murray II eq. 2.8: ``a - u + u²v``, ``b - u²v``."""
    u2v = u[0] * u[0] * u[1]
    return p["a"] - u[0] + u2v, p["b"] - u2v


def _gray_scott(u: Any, p: dict) -> tuple[Any, Any]:
    """Skaggs eqs. 2.3-2.4: ``-uv² + F(1 - u)``, ``uv² - (F + k)v``."""
    uvv = u[0] * u[1] * u[1]
    return -uvv + p["F"] * (1.0 - u[0]), uvv - (p["F"] + p["k"]) * u[1]


PROBLEMS: dict[str, dict[str, Any]] = {
    "schnakenberg": {
        "model": lambda: load_model("examples/schnakenberg.toml"),
        "T": 30.0, "reference_dt": 0.005, "display": 0, "reaction": _schnakenberg,
        "pde": {"u": "a - u + u**2*v + Du*laplace(u)", "v": "b - u**2*v + Dv*laplace(v)"},
        "etdrk4_dts": (0.05,), "exponax_large_dt": 0.4,
    },
    "gray-scott": {
        "model": lambda: get_model("gray-scott"),
        "T": 1000.0, "reference_dt": 0.25, "display": 1, "reaction": _gray_scott,
        "pde": {"u": "-u*v**2 + F*(1 - u) + Du*laplace(u)",
                "v": "u*v**2 - (F + k)*v + Dv*laplace(v)"},
        "etdrk4_dts": (1.0,), "exponax_large_dt": 20.0,
    },
}


def _steps(T: float, dt: float) -> tuple[int, float]:
    """Whole steps to ``T`` and the step (at most ``dt``) that lands on it exactly."""
    n = max(1, math.ceil(T / dt - 1e-9))
    return n, T / n


def _morphogen(model, grid: Grid, u0: np.ndarray, p: dict, T: float, scheme: str, dt: float,
               rtol: float | None = None) -> Run:
    n, dt = _steps(T, dt)
    atol = None if rtol is None else rtol * 1e-2

    def go() -> tuple[np.ndarray, int]:
        sol = simulate(model, grid, u0, p, steps=n, dt=dt, scheme=scheme, rtol=rtol, atol=atol)
        return np.asarray(jax.block_until_ready(sol.state)), sol.steps + (sol.rejected_steps or 0)
    return go


def _exponax(problem: dict, p: dict, u0: np.ndarray, T: float, dt: float,
             custom: bool = False) -> Run:
    """Exponax ETDRK4 to ``T``; the steps run in Fourier space inside one ``lax.scan``.

    ``custom``: the reaction as a pointwise nonlinearity even where Exponax has a stepper."""
    import exponax as ex
    from exponax._spectral import build_laplace_operator, fft, ifft
    from exponax.nonlin_fun import BaseNonlinearFun

    n, dt = _steps(T, dt)
    length = float(SIZE)  # dx = 1
    if problem["reaction"] is _gray_scott and not custom:
        stepper = ex.stepper.reaction.GrayScott(
            2, length, SIZE, dt, diffusivity_1=p["Du"], diffusivity_2=p["Dv"],
            feed_rate=p["F"], kill_rate=p["k"], order=4, dealiasing_fraction=1.0)
    else:
        reaction, params = problem["reaction"], dict(p)

        class Pointwise(BaseNonlinearFun):
            """The reaction evaluated at the grid points, no dealiasing."""

            def __call__(self, u_hat):
                return self.fft(jnp.stack(reaction(self.ifft(u_hat), params)))

        class Custom(ex.BaseStepper):
            def _build_linear_operator(self, derivative_operator):
                lap = build_laplace_operator(derivative_operator, order=2)
                return jnp.concatenate([params["Du"] * lap, params["Dv"] * lap])

            def _build_nonlinear_fun(self, derivative_operator):
                return Pointwise(2, SIZE)

        stepper = Custom(2, length, SIZE, dt, num_channels=2, order=4)

    @jax.jit
    def advance(u):
        u_hat = fft(u, num_spatial_dims=2)
        u_hat, _ = jax.lax.scan(lambda c, _: (stepper.step_fourier(c), None), u_hat, None,
                                length=n)
        return ifft(u_hat, num_spatial_dims=2, num_points=SIZE)

    u = jnp.asarray(u0, jnp.float32)
    return lambda: (np.asarray(jax.block_until_ready(advance(u))), n)


def _pypde(problem: dict, p: dict, u0: np.ndarray, T: float, dt: float, backend: str
           ) -> Run:
    """py-pde's explicit Euler stepper to ``T`` (compiled on construction and one call)."""
    import pde

    pde.config["backend.numba.multithreading"] = "never"
    grid = pde.CartesianGrid([[0.0, float(SIZE)]] * 2, [SIZE, SIZE], periodic=True)
    n, dt = _steps(T, dt)
    eq = pde.PDE(problem["pde"], consts={k: float(v) for k, v in p.items()})
    fields = [pde.ScalarField(grid, np.asarray(u0[i], np.float64)) for i in range(2)]
    state = pde.FieldCollection(fields, labels=["u", "v"])
    solver = pde.solvers.EulerSolver(eq, backend=backend)
    stepper = solver.make_stepper(state, dt=dt)

    def go() -> tuple[np.ndarray, int]:
        s, before = state.copy(), solver.info["steps"]
        stepper(s, 0.0, T)  # round(T / dt) = n steps
        return np.asarray(s.data), solver.info["steps"] - before
    return go


def _metrics(u: np.ndarray, ref: np.ndarray) -> dict[str, float]:
    u, ref = np.asarray(u, np.float64), np.asarray(ref, np.float64)
    a, b = u.ravel() - u.mean(), ref.ravel() - ref.mean()
    return {"relative_l2_error": float(np.linalg.norm(u - ref) / np.linalg.norm(ref)),
            "correlation": float(a @ b / np.sqrt((a @ a) * (b @ b)))}


def _reference(model, grid: Grid, u0: np.ndarray, p: dict, T: float, dt: float
               ) -> tuple[np.ndarray, float, float]:
    """float64 ``etdrk4`` at ``dt`` and the change from halving it; and its wall time."""
    start = time.perf_counter()
    with jax.enable_x64(True):
        u64 = np.asarray(u0, np.float64)
        runs = [np.asarray(simulate(model, grid, u64, p, steps=round(T / h), dt=h,
                                    scheme="etdrk4").state) for h in (2 * dt, dt)]
    change = float(np.linalg.norm(runs[0] - runs[1]) / np.linalg.norm(runs[1]))
    return runs[1], change, time.perf_counter() - start


def _candidates(name: str, problem: dict, model, p: dict, u0: np.ndarray
                ) -> dict[str, dict[str, Any]]:
    """Every timed run: its solver, stencil group, step and the function that runs it."""
    T = problem["T"]
    grids = {"5-point": Grid((SIZE, SIZE)), "spectral": Grid((SIZE, SIZE), stencil="spectral")}
    rows: dict[str, dict[str, Any]] = {}

    def add(label: str, group: str, dt: float, fn: Run, **info: Any):
        rows[label] = {"group": group, "dt": _steps(T, dt)[1], "fn": fn, **info}

    for group, grid in grids.items():
        schemes = ("euler", "rk4", "imex", "etdrk4") if group == "5-point" else ("imex", "etdrk4")
        limits = {s: max_stable_dt(model, grid, p, s) for s in schemes}
        for scheme, dt in limits.items():
            add(f"morphogen {scheme} {group} dt={dt:.4g} (its limit)", group, dt,
                _morphogen(model, grid, u0, p, T, scheme, dt), solver="morphogen",
                scheme=scheme, precision="float32")
        for dt in problem["etdrk4_dts"]:
            add(f"morphogen etdrk4 {group} dt={dt:g}", group, dt,
                _morphogen(model, grid, u0, p, T, "etdrk4", dt), solver="morphogen",
                scheme="etdrk4", precision="float32")
        if group == "5-point":
            add(f"morphogen adaptive {group} rtol=1e-3", group, limits["euler"],
                _morphogen(model, grid, u0, p, T, "adaptive", limits["euler"], rtol=1e-3),
                solver="morphogen", scheme="adaptive", precision="float32")
            for backend, precision in (("numba", "float64"), ("jax", "float32")):
                add(f"py-pde euler ({backend}) dt={limits['euler']:.4g}", group,
                    limits["euler"], _pypde(problem, p, u0, T, limits["euler"], backend),
                    solver=f"py-pde {backend}", scheme="euler", precision=precision)
            continue
        for dt in (problem["exponax_large_dt"], limits["etdrk4"], *problem["etdrk4_dts"]):
            add(f"exponax etdrk4 dt={dt:.4g}", group, dt, _exponax(problem, p, u0, T, dt),
                solver="exponax", scheme="etdrk4", precision="float32")
        if problem["reaction"] is _gray_scott:
            dt = problem["etdrk4_dts"][0]
            add(f"exponax etdrk4 dt={dt:g}, custom nonlinearity", group, dt,
                _exponax(problem, p, u0, T, dt, custom=True), solver="exponax",
                scheme="etdrk4", precision="float32")
    return rows


def _run_problem(name: str, problem: dict) -> dict:
    model = problem["model"]()
    p = {k: float(v) for k, v in model.parameters().items()}
    grid5 = Grid((SIZE, SIZE))
    u0 = make_initial(model.init, model, grid5, p, seed=0)
    T, shown = problem["T"], problem["display"]
    references = {}
    for group, stencil in (("5-point", None), ("spectral", "spectral")):
        ref, change, wall = _reference(model, Grid((SIZE, SIZE), stencil=stencil), u0, p, T,
                                       problem["reference_dt"])
        references[group] = {"state": ref, "reference_self_change": change, "wall_s": wall}
    ref5, refs = (references[g]["state"][shown] for g in ("5-point", "spectral"))
    stencils_differ = _metrics(ref5, refs)
    rows = _candidates(name, problem, model, p, u0)
    finals = {label: row["fn"]() for label, row in rows.items()}  # compile; (state, steps)
    times, load_before, load_after = interleaved({k: r["fn"] for k, r in rows.items()}, ROUNDS)
    table = {}
    for label, row in rows.items():
        wall = statistics.median(times[label])
        ref = references[row["group"]]["state"][shown]
        state, steps = finals[label]
        table[label] = {
            **{k: v for k, v in row.items() if k != "fn"},
            "steps": steps,
            "wall_s_median": round(wall, 3),
            "wall_s_rounds": [round(t, 3) for t in times[label]],
            "cell_steps_per_s": float(f"{SIZE * SIZE * steps / wall:.3g}"),
            **_metrics(state[shown], ref),
        }
    return {
        "problem": f"{name}, {SIZE}x{SIZE}, dx=1, periodic, T={T:g}, "
                   f"{model.init} init seed 0, parameters {p}",
        "displayed_species": model.species[shown],
        "references": {
            g: {"scheme": f"morphogen etdrk4 {g} float64 dt={problem['reference_dt']:g}",
                "reference_self_change": r["reference_self_change"],
                "wall_s": round(r["wall_s"], 1)}
            for g, r in references.items()},
        "five_point_reference_against_spectral": stencils_differ,
        "rounds": ROUNDS,
        "load_average_before": load_before,
        "load_average_after": load_after,
        "results": table,
    }


def versions() -> dict[str, str]:
    from importlib.metadata import version

    return {name: version(name) for name in ("exponax", "py-pde", "numba", "jax", "numpy")}


def run() -> dict:
    missing = [dist for module, dist in PEERS.items() if importlib.util.find_spec(module) is None]
    if missing:
        print(f"peers: skipped, {' and '.join(missing)} not installed here; `make bench-peers` "
              "runs it in .venv-bench (keeping the stored result)", flush=True)
        stored = json.loads(RESULT.read_text()) if RESULT.exists() else {}
        return stored
    return {"versions": versions(),
            **{name: _run_problem(name, problem) for name, problem in PROBLEMS.items()}}




CURVES_DTS = (0.1, 0.2, 0.4, 0.8)
CURVES_RTOLS = (1e-3, 1e-4, 1e-5)


def _cpu_rounds(runs: dict[str, Run], rounds: dict[str, int]) -> tuple[dict[str, list[float]],
                                                                      tuple, tuple]:
    """CPU seconds (``time.process_time``) of each run, interleaved round by round; a run
    with fewer ``rounds`` sits out the later ones. The load averages before and after."""
    import os

    load_before = os.getloadavg()
    times: dict[str, list[float]] = {k: [] for k in runs}
    for r in range(max(rounds.values())):
        for k, fn in runs.items():
            if r < rounds[k]:
                c = time.process_time()
                fn()
                times[k].append(time.process_time() - c)
    return times, load_before, os.getloadavg()


def curves() -> dict:
    """Schnakenberg (Du = 1, Dv = 40, a = 0.1, b = 0.9), 256², T = 30: every scheme and
    Exponax's ETDRK4 over a range of steps (and tolerances), CPU seconds per run (XLA on one
    thread: run with ``XLA_FLAGS=--xla_cpu_multi_thread_eigen=false``,
    :data:`morphogen.util.cluster.SINGLE_THREAD`), error against float64 ``etdrk4`` at
    ``dt = 0.01`` on the same discretisation (5-point rows against the 5-point one, spectral
    rows against the spectral one)."""
    problem = PROBLEMS["schnakenberg"]
    model = problem["model"]()
    p = {k: float(v) for k, v in model.parameters().items()}
    grids = {"5-point": Grid((SIZE, SIZE)), "spectral": Grid((SIZE, SIZE), stencil="spectral")}
    u0 = make_initial(model.init, model, grids["5-point"], p, seed=0)
    T = problem["T"]
    refs = {}
    for group, grid in grids.items():
        with jax.enable_x64(True):
            refs[group] = np.asarray(simulate(model, grid, np.asarray(u0, np.float64), p,
                                              steps=round(T / 0.01), dt=0.01,
                                              scheme="etdrk4").state)[0]
    rows: dict[str, dict[str, Any]] = {}

    def add(label, group, fn, rounds=3, **info):
        rows[label] = {"group": group, "fn": fn, "rounds": rounds, **info}

    five, spec = grids["5-point"], grids["spectral"]
    for scheme, rounds in (("euler", 3), ("rk4", 1), ("imex", 3)):
        dt = max_stable_dt(model, five, p, scheme)
        add(f"morphogen {scheme} 5-point dt={dt:.4g} (its limit)", "5-point",
            _morphogen(model, five, u0, p, T, scheme, dt), rounds, scheme=scheme, dt=dt)
    add("morphogen adaptive (Tsit5) 5-point rtol=1e-3", "5-point",
        _morphogen(model, five, u0, p, T, "adaptive", max_stable_dt(model, five, p, "euler"),
                   rtol=1e-3), 1, scheme="adaptive", rtol=1e-3)
    add("morphogen imex spectral dt=0.1 (its limit)", "spectral",
        _morphogen(model, spec, u0, p, T, "imex", 0.1), scheme="imex", dt=0.1)
    for dt in CURVES_DTS:
        unsafe = dt > max_stable_dt(model, spec, p, "etdrk4") * (1 + 1e-9)
        n, h = _steps(T, dt)

        def go(h=h, n=n, unsafe=unsafe):
            sol = simulate(model, spec, u0, p, steps=n, dt=h, scheme="etdrk4", unsafe=unsafe)
            return np.asarray(sol.state), n
        add(f"morphogen etdrk4 spectral dt={dt:g}" + (" --unsafe" if unsafe else ""),
            "spectral", go, scheme="etdrk4", dt=dt)
        add(f"exponax etdrk4 dt={dt:g}", "spectral", _exponax(problem, p, u0, T, dt),
            solver="exponax", scheme="etdrk4", dt=dt)
    for rtol in CURVES_RTOLS:
        add(f"morphogen etdrk4-adaptive spectral rtol={rtol:g}", "spectral",
            _morphogen(model, spec, u0, p, T, "etdrk4-adaptive", 0.1, rtol=rtol),
            scheme="etdrk4-adaptive", rtol=rtol)
    finals = {k: r["fn"]() for k, r in rows.items()}  # compile, and the accuracy runs
    times, load_before, load_after = _cpu_rounds({k: r["fn"] for k, r in rows.items()},
                                                 {k: r["rounds"] for k, r in rows.items()})
    euler = next(k for k in rows if "euler" in k)
    euler_cpu = statistics.median(times[euler])
    table = {}
    for k, r in rows.items():
        cpu = statistics.median(times[k])
        state, steps = finals[k]
        table[k] = {**{a: b for a, b in r.items() if a != "fn"}, "steps": steps,
                    "cpu_s_median": round(cpu, 3), "cpu_s_rounds": [round(t, 3) for t in times[k]],
                    "speedup_vs_euler_cpu": round(euler_cpu / cpu, 2),
                    **_metrics(state[0], refs[r["group"]])}
    return {"problem": f"schnakenberg {p}, {SIZE}x{SIZE}, dx=1, periodic, T={T:g}, float32, "
                       "noise init seed 0",
            "reference": "morphogen etdrk4 float64 dt=0.01 on the row's discretisation",
            "timing": "CPU seconds (time.process_time), XLA single-threaded, interleaved rounds",
            "load_average_before": load_before, "load_average_after": load_after,
            "results": table}


def plot_curves(result: dict, path: Path) -> None:
    """Error against CPU time of every row of :func:`curves`, one curve per scheme."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.2, 4.8), dpi=120)
    series: dict[str, list[tuple[float, float, str]]] = {}
    for label, r in result["results"].items():
        key = label.split(" dt=")[0].split(" rtol=")[0]
        tag = label.split("=")[-1].replace(" (its limit)", "").replace(" --unsafe", "*")
        tag = f"{float(tag[:-1]):.2g}*" if tag.endswith("*") else f"{float(tag):.2g}"
        series.setdefault(key, []).append((r["cpu_s_median"], r["relative_l2_error"], tag))
    for key, pts in series.items():
        pts.sort()
        style = "s--" if key.startswith("exponax") else "o-"
        ax.loglog([x for x, _, _ in pts], [y for _, y, _ in pts], style, label=key)
        for x, y, tag in pts:
            ax.annotate(tag, (x, y), fontsize=6, xytext=(3, 3), textcoords="offset points")
    ax.set_xlabel("CPU seconds to t = 30 (one thread, median of interleaved rounds); "
                  "labels: dt or rtol, * = --unsafe", fontsize=8)
    ax.set_ylabel("relative L2 error of u (vs float64, same discretisation)")
    ax.set_title(f"Schnakenberg Dv/Du = 40, {SIZE}², float32", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def run_curves() -> None:
    """Measure :func:`curves`, store it in ``peers.json`` under ``schnakenberg_curves`` and
    draw ``docs/images/schemes/stiff_vs_exponax.png``."""
    result = curves()
    stored = json.loads(RESULT.read_text()) if RESULT.exists() else {}
    stored["schnakenberg_curves"] = result
    RESULT.write_text(json.dumps(stored, indent=2) + "\n")
    plot_curves(result, Path(__file__).parent.parent / "docs" / "images" / "schemes"
                / "stiff_vs_exponax.png")


if __name__ == "__main__":
    if sys.argv[1:] == ["curves"]:
        run_curves()
        sys.exit(0)
    if sys.argv[1:] == ["plot-curves"]:
        plot_curves(json.loads(RESULT.read_text())["schnakenberg_curves"],
                    Path(__file__).parent.parent / "docs" / "images" / "schemes"
                    / "stiff_vs_exponax.png")
        sys.exit(0)
    from bench.run import main

    sys.exit(main(["peers"]))
