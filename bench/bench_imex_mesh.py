"""Time to reach t = T on a stiff mesh model: explicit Euler at its limit against IMEX with
conjugate-gradient diffusion solves (:mod:`morphogen.solvers.imex_cg`) at the reaction's limit.

Ringham's Mimulus (``examples/mimulus-mesh-pipeline.toml``: activator-inhibitor, eq. 19,
``D_h / D_a = 40``, spots on a painted prepattern of a two-lipped tube) at a modest size
(mean edge :data:`EDGE` instead of the example's 0.031), float32, ``T`` = the example's
17 500 steps of 0.06, from the pipeline's initial state (noise, seed 1).

As shipped (``kappa = 0``) the reaction ``rho_a a^2 / h`` is singular where ``h`` decays
towards 0, outside the painted region; the run records how IMEX fares there. The timed
comparison uses ``kappa = 0.001`` (the value of Ringham's Digitalis preset), which bounds it.
Each candidate runs once to compile and for its accuracy, then the candidates are timed
interleaved for :data:`ROUNDS` rounds (median reported, load average recorded). Accuracy:
relative L2 error of the activator ``a`` against RK4 at half the Euler limit in float64, and
the Pearson correlation of the patterns. On the example's own mesh (edge 0.031) only the
speed of Euler and imex at their limits is timed (``example_size``).
"""

from __future__ import annotations

import math
import statistics
import tempfile
import time
from functools import partial
from pathlib import Path

import jax
import numpy as np

from bench.timing import interleaved
from morphogen.domains.ply import apply_fields
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate
from morphogen.errors import MorphogenError
from morphogen.flowers.pipeline import load_pipeline, run_pipeline
from morphogen.flowers.stages import evaluate
from morphogen.models.registry import load_model
from morphogen.solvers.auto import choose_scheme, stiffness_ratio
from morphogen.solvers.imex_cg import CG_MAXITER, CG_RTOL
from morphogen.solvers.step import max_stable_dt

PIPELINE = Path(__file__).parent.parent / "examples" / "mimulus-mesh-pipeline.toml"
EDGE, T, ROUNDS = 0.06, 17500 * 0.06, 3
KAPPA = 0.001


def setup(edge: float | None = EDGE) -> tuple:
    """``(model, mesh, u0, params)`` of the pipeline's simulate stage on a mesh of mean edge
    ``edge`` (``None``: the example's own), with the shipped parameters (``kappa = 0``)."""
    spec = load_pipeline(PIPELINE)
    if edge is not None:
        spec["mesh"] = {**spec["mesh"], "edge": edge}
    stage = spec["stage"][1]
    with tempfile.TemporaryDirectory() as tmp:
        mesh = run_pipeline({**spec, "stage": spec["stage"][:1]}, tmp, pictures=False)
    model = load_model(stage["model"])
    domain = mesh.replace(boundary="neumann")
    values = model.parameters(preset=stage["preset"])
    u0 = make_initial(stage["init"], model, domain, values, seed=spec["seed"])
    u0, values = apply_fields(model, domain, u0, values)
    current = mesh.with_fields(**{s: u0[i] for i, s in enumerate(model.species)})
    for key, text in stage["initial"].items():
        u0[model.species_index(key)] = evaluate(text, current)
    params = {k: np.asarray(v, np.float32) for k, v in values.items()}
    return model, domain, np.asarray(u0, np.float32), params


def _metrics(u: np.ndarray, ref: np.ndarray) -> dict:
    u, ref = np.asarray(u, np.float64), np.asarray(ref, np.float64)
    a, b = u - u.mean(), ref - ref.mean()
    return {"relative_l2_error_a": float(np.linalg.norm(u - ref) / np.linalg.norm(ref)),
            "correlation": float(a @ b / np.sqrt((a @ a) * (b @ b)))}


def _shipped(model, mesh, u0, p) -> dict:
    """IMEX on the shipped, singular parameters: where it stops, at two steps."""
    out = {}
    for dt in (max_stable_dt(model, mesh, p, "imex"), 0.5):
        steps = math.ceil(T / dt)
        try:
            sol = simulate(model, mesh, u0, p, steps=steps, dt=T / steps, scheme="imex")
            out[f"imex dt={dt:.4g}"] = f"reached T, min h {float(sol.state[1].min()):.3g}"
        except MorphogenError as exc:
            out[f"imex dt={dt:.4g}"] = str(exc)
    return out


def _full_size() -> dict:
    """Speed only, on the example's own mesh (``kappa = KAPPA``): Euler and imex at their
    limits, once to compile, then 2 interleaved timed rounds; the imex result's relative L2
    difference from Euler's."""
    model, mesh, u0, p = setup(None)
    p = {**p, "kappa": np.float32(KAPPA)}
    runs = {"euler": max_stable_dt(model, mesh, p, "euler"),
            "imex": max_stable_dt(model, mesh, p, "imex")}

    def go(scheme: str):
        steps = math.ceil(T / runs[scheme])
        return simulate(model, mesh, u0, p, steps=steps, dt=T / steps, scheme=scheme)

    states = {name: go(name).state[0] for name in runs}
    wall, _, load_after = interleaved({name: partial(go, name) for name in runs}, 2)
    times = {name: [round(t, 3) for t in rounds] for name, rounds in wall.items()}
    diff = np.linalg.norm(states["imex"] - states["euler"]) / np.linalg.norm(states["euler"])
    return {"vertices": mesh.n_vertices, "mean_edge": round(mesh.edge_length, 4),
            "dt": {k: round(v, 4) for k, v in runs.items()}, "wall_s_rounds": times,
            "speedup_imex_vs_euler": round(min(times["euler"]) / min(times["imex"]), 2),
            "relative_l2_difference_a_imex_vs_euler": float(diff),
            "load_average_after": load_after}


def run() -> dict:
    model, mesh, u0, p = setup()
    shipped = _shipped(model, mesh, u0, p)
    p = {**p, "kappa": np.float32(KAPPA)}
    euler_dt = max_stable_dt(model, mesh, p, "euler")
    imex_dt = max_stable_dt(model, mesh, p, "imex")
    runs = {f"euler dt={euler_dt:.4g} (its limit)": ("euler", euler_dt),
            f"imex dt={imex_dt:.4g} (its limit)": ("imex", imex_dt),
            f"imex dt={imex_dt / 2:.4g}": ("imex", imex_dt / 2),
            f"imex dt={imex_dt / 4:.4g}": ("imex", imex_dt / 4)}

    def go(scheme: str, dt: float, u=u0, params=p):
        steps = math.ceil(T / dt)
        return simulate(model, mesh, u, params, steps=steps, dt=T / steps, scheme=scheme)

    start = time.perf_counter()
    with jax.enable_x64(True):
        ref = go("rk4", 0.5 * euler_dt, np.asarray(u0, np.float64),
                 {k: np.asarray(v, np.float64) for k, v in p.items()}).state[0]
    ref_wall = time.perf_counter() - start
    results = {name: go(*c) for name, c in runs.items()}
    times, load_before, load_after = interleaved(
        {name: partial(go, *c) for name, c in runs.items()}, ROUNDS)
    euler_name = next(iter(runs))
    euler_time = statistics.median(times[euler_name])
    table = {}
    for name, sol in results.items():
        wall = statistics.median(times[name])
        table[name] = {"wall_s_median": round(wall, 3),
                       "wall_s_rounds": [round(t, 3) for t in times[name]],
                       "speedup_vs_euler": round(euler_time / wall, 2), "steps": sol.steps,
                       **_metrics(sol.state[0], ref)}
    return {
        "problem": f"{PIPELINE.name}: activator-inhibitor (mimulus preset, kappa={KAPPA}), "
                   f"{mesh.n_vertices} vertices (mean edge {mesh.edge_length:.4f}), no-flux, "
                   f"float32, T={T:g}",
        "shipped_kappa_0": shipped,
        "reference": f"rk4 dt={0.5 * euler_dt:.4g} float64 ({ref_wall:.1f} s)",
        "cg": {"rtol": CG_RTOL, "maxiter": CG_MAXITER},
        "stiffness_ratio": round(stiffness_ratio(model, mesh, p), 2),
        "auto_choice": choose_scheme(model, mesh, p),
        "rounds": ROUNDS,
        "load_average_before": load_before,
        "load_average_after": load_after,
        "results": table,
        "example_size": _full_size(),
    }
