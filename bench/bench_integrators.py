"""Time to reach t = T on a stiff model: every scheme, in one run.

Schnakenberg (``examples/schnakenberg.toml``, ``Dv/Du = 40``), 256², ``dx = 1``, periodic,
5-point stencil, float32, ``T = 30`` from the model's noise initial state (seed 0). Each
candidate runs once to compile, then the candidates are timed interleaved for ``ROUNDS``
rounds; the median wall time is reported with the load average around the run. Accuracy is
measured against an RK4 run at ``dt = 0.0025`` in float64 (fourth order, far below its
stability limit): the relative L2 error of ``u`` and the Pearson correlation of the patterns.
``python -m bench.bench_integrators`` draws ``docs/images/schemes/accuracy_vs_time.png`` from
the stored result.
"""

from __future__ import annotations

import json
import statistics
import time
from functools import partial
from pathlib import Path

import jax
import numpy as np

from bench.timing import interleaved
from morphogen.domains.grid import Grid
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate
from morphogen.models.registry import load_model
from morphogen.solvers.auto import choose_scheme, stiffness_ratio
from morphogen.solvers.step import max_stable_dt

SIZE, T, ROUNDS = 256, 30.0, 3
MODEL = "examples/schnakenberg.toml"
REFERENCE_DT = 0.0025


def _candidates(limits: dict[str, float]) -> dict[str, dict]:
    """Each fixed-step scheme at its reported limit, IMEX also at half of it, and the two
    error-controlled schemes."""
    out = {f"{scheme} dt={dt:.4g} (its limit)": {"scheme": scheme, "dt": dt}
           for scheme, dt in limits.items()}
    out[f"imex dt={limits['imex'] / 2:.3g}"] = {"scheme": "imex", "dt": limits["imex"] / 2}
    out["adaptive rtol=1e-3"] = {"scheme": "adaptive", "dt": 0.005, "rtol": 1e-3, "atol": 1e-6}
    out["etdrk4-adaptive rtol=1e-4"] = {"scheme": "etdrk4-adaptive", "dt": 0.1, "rtol": 1e-4,
                                        "atol": 1e-6}
    return out


def _metrics(u: np.ndarray, ref: np.ndarray) -> dict:
    u, ref = np.asarray(u, np.float64), np.asarray(ref, np.float64)
    error = float(np.linalg.norm(u - ref) / np.linalg.norm(ref))
    a, b = u.ravel() - u.mean(), ref.ravel() - ref.mean()
    correlation = float(a @ b / np.sqrt((a @ a) * (b @ b)))
    return {"relative_l2_error_u": error, "correlation": correlation}


def run() -> dict:
    model, grid = load_model(MODEL), Grid((SIZE, SIZE))
    p = model.parameters()
    u0 = make_initial(model.init, model, grid, p, seed=0)
    runs = _candidates({scheme: max_stable_dt(model, grid, p, scheme)
                        for scheme in ("euler", "rk4", "imex1", "imex", "etdrk4")})

    def go(c: dict):
        steps = round(T / c["dt"])
        return simulate(model, grid, u0, p, steps=steps, dt=T / steps, scheme=c["scheme"],
                        rtol=c.get("rtol"), atol=c.get("atol"))

    start = time.perf_counter()
    with jax.enable_x64(True):
        ref_model = load_model(MODEL)
        reference = simulate(ref_model, grid, np.asarray(u0, np.float64), p,
                             steps=round(T / REFERENCE_DT), dt=REFERENCE_DT, scheme="rk4")
    ref_u, ref_wall = reference.state[0], time.perf_counter() - start

    results = {name: go(c) for name, c in runs.items()}  # compile (and the accuracy runs)
    times, load_before, load_after = interleaved(
        {name: partial(go, c) for name, c in runs.items()}, ROUNDS)
    euler_name = next(iter(runs))
    euler_time = statistics.median(times[euler_name])
    table = {}
    for name, sol in results.items():
        wall = statistics.median(times[name])
        table[name] = {
            "wall_s_median": round(wall, 3),
            "wall_s_rounds": [round(t, 3) for t in times[name]],
            "speedup_vs_euler": round(euler_time / wall, 2),
            "cost_per_step_vs_euler": round(wall / sol.steps * results[euler_name].steps
                                            / euler_time, 2),
            "steps": sol.steps,
            "rejected_steps": sol.rejected_steps,
            **_metrics(sol.state[0], ref_u),
        }
    return {
        "problem": f"{MODEL} (Dv/Du = 40), {SIZE}x{SIZE}, dx=1, periodic, 5-point, float32, "
                   f"T={T:g}, noise init seed 0",
        "reference": f"rk4 dt={REFERENCE_DT} float64 ({ref_wall:.1f} s)",
        "stiffness_ratio": round(stiffness_ratio(model, grid, p), 2),
        "auto_choice": choose_scheme(model, grid, p),
        "rounds": ROUNDS,
        "load_average_before": load_before,
        "load_average_after": load_after,
        "results": table,
    }


def plot(result: dict, path: Path) -> None:
    """Error against wall time, one point per candidate, log-log."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=120)
    for i, (name, r) in enumerate(result["results"].items()):
        ax.loglog(r["wall_s_median"], r["relative_l2_error_u"], "o")
        ax.annotate(name, (r["wall_s_median"], r["relative_l2_error_u"]), fontsize=8,
                    xytext=(5, -11 if i % 2 else 4), textcoords="offset points")
    ax.set_xlabel("wall time to t = 30 (s, median of 3)")
    ax.set_ylabel("relative L2 error of u")
    ax.set_title(f"Schnakenberg Dv/Du = 40, {SIZE}², float32", fontsize=10)
    ax.set_xlim(right=ax.get_xlim()[1] * 3)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


if __name__ == "__main__":
    here = Path(__file__).parent
    plot(json.loads((here / "results" / "integrators.json").read_text()),
         here.parent / "docs" / "images" / "schemes" / "accuracy_vs_time.png")
