"""Benchmark: Ringham et al.'s *Mimulus* model (eq. 19) on an ~88 000-vertex flower mesh.

Table 1 of Ringham et al. (2021) times 17 500 steps of the *Mimulus* pattern on 175 968
triangles: 23:44 on one CPU thread, 3:11 on 16 threads, 2:04 on an RTX 2070 SUPER. This runs
the same number of steps of the same model (fig. 13 parameters, ``dt = 0.06``, ``rho_a0``
painted on the lower throat) on a generated Mimulus-like tube of about 88 000 vertices, and,
in the same run, a plain NumPy + ``scipy.sparse`` implementation of the identical explicit
step as the reference. ``run()`` returns the figures; ``python bench/bench_mesh.py`` also
writes ``bench/results/mesh.json``.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

STEPS = 17_500
DT = 0.06
REFERENCE_STEPS = 300
RINGHAM_TABLE_1 = {"cpu_1_thread_s": 23 * 60 + 44, "cpu_16_threads_s": 3 * 60 + 11,
                   "gpu_rtx_2070_s": 2 * 60 + 4, "triangles": 175_968}


def mimulus_mesh(edge: float = 0.031, scale: float = 4.6):
    """A five-lobed, bilateral tube scaled so that Ringham's ``dt = 0.06`` is stable."""
    from morphogen.flowers import tube

    m = tube(lobes=5, length=1.0, radius=0.22, lobe_scales=[0.75, 0.75, 1.1, 1.3, 1.1],
             edge=edge / scale)
    return m.replace(vertices=m.vertices * scale, name="mimulus-like tube")


def prepattern(mesh) -> np.ndarray:
    """``rho_a0`` = 0.0125 on the lower throat and lower lobes, 0 elsewhere (fig. 13)."""
    s, side = mesh.fields["s"], mesh.fields["side"]
    return np.where((s > 0.55) & (s < 1.6) & (side < -0.2), 0.0125, 0.0)


def _reference_rate(mesh, params, u0, steps: int) -> float:
    """Vertex-steps per second of the same Euler step in NumPy with a scipy CSR Laplacian."""
    import scipy.sparse as sp

    lap = (sp.diags(1.0 / mesh.areas) @ (-mesh.ops.stiffness)).tocsr().astype(np.float32)
    a, h = (u0[0].astype(np.float32), u0[1].astype(np.float32))
    p = {k: np.asarray(v, np.float32) for k, v in params.items()}
    start = time.perf_counter()
    for _ in range(steps):
        da = (p["rho_a"] * a * a / (h + p["kappa"]) + p["rho_a0"] - p["mu_a"] * a
              + p["Da"] * (lap @ a))
        dh = p["rho_h"] * a * a + p["rho_h0"] - p["mu_h"] * h + p["Dh"] * (lap @ h)
        a, h = a + DT * da, h + DT * dh
    return mesh.n_vertices * steps / (time.perf_counter() - start)


def run(steps: int = STEPS) -> dict:
    import jax

    from morphogen.engine.initial import make_initial
    from morphogen.engine.simulate import simulate
    from morphogen.models.library import get_model

    t0 = time.perf_counter()
    mesh = mimulus_mesh()
    build_s = time.perf_counter() - t0
    model = get_model("activator-inhibitor")
    params = model.parameters(preset="mimulus")
    params["rho_a0"] = prepattern(mesh).astype(np.float32)
    u0 = make_initial("noise", model, mesh, params, seed=0)
    t0 = time.perf_counter()
    mesh.spectral_radius()
    assemble_s = time.perf_counter() - t0
    warm = simulate(model, mesh, u0, params, steps=10, dt=DT)  # compile
    t0 = time.perf_counter()
    sol = simulate(model, mesh, u0, params, steps=steps, dt=DT)
    run_s = time.perf_counter() - t0 + warm.wall_time
    rate = mesh.n_vertices * steps / (run_s - warm.wall_time)
    reference = _reference_rate(mesh, params, u0, REFERENCE_STEPS)
    a = sol.state[0]
    return {
        "name": "mesh",
        "model": "activator-inhibitor (Ringham eq. 19), preset mimulus, rho_a0 prepattern",
        "vertices": mesh.n_vertices,
        "triangles": mesh.n_faces,
        "steps": steps,
        "dt": DT,
        "mesh_build_s": round(build_s, 2),
        "operator_assembly_s": round(assemble_s, 2),
        "compile_and_first_steps_s": round(warm.wall_time, 2),
        "full_run_s": round(run_s, 2),
        "vertex_steps_per_s": rate,
        "projected_17500_steps_s": round(mesh.n_vertices * STEPS / rate, 2),
        "reference": "NumPy + scipy.sparse CSR matvec, same explicit step, float32",
        "reference_vertex_steps_per_s": reference,
        "ratio_vs_reference": rate / reference,
        "ringham_table_1": RINGHAM_TABLE_1,
        "speedup_vs_ringham": {k: round(v / run_s, 2) for k, v in RINGHAM_TABLE_1.items()
                               if k.endswith("_s")},
        "pattern_check": {"activator_min": float(a.min()), "activator_max": float(a.max()),
                          "finite": bool(np.all(np.isfinite(sol.state)))},
        "backend": jax.default_backend(),
        "device": str(jax.devices()[0]),
        "target_full_run_s": 191,
    }


if __name__ == "__main__":
    import json

    from morphogen.util.io import write_json

    result = run()
    print(json.dumps(result, indent=2))
    write_json(Path(__file__).parent / "results" / "mesh.json", result)
