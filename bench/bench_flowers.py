"""Benchmark: the ten flower case studies of Ringham et al. (2021) next to their Table 1.

Table 1 times the final patterning (the diffusion or reaction-diffusion simulation) of nine
case studies on an AMD Ryzen 7 5800X with 1 and 16 threads and on an RTX 2070 SUPER; Platycodon
(§4.1) has no simulation and no row. Each shipped pipeline (``examples/flowers/*.toml`` and the
two older mesh pipelines) is run here at its shipped size, without pictures
(:func:`morphogen.flowers.pipeline.run_pipeline` with ``pictures=False``): the mesh is built, the
prepattern stages (veins, positional information, fields, points) run and are timed, vein
growth separately, and each simulation stage's wall time (compilation included) is recorded.

Each case runs twice: with its steps and with a tenth of them (same mesh). A stage's wall time
is fitted as ``W(n) = c + r n``: ``c`` is the fixed cost of a simulation (the stability check,
tracing and XLA compilation, moving the arrays), ``r`` the cost per step. A case whose
simulations would take more than about three minutes on this machine (Trichoglottis: 64 500
anisotropic steps, run at 1/20 and 1/200 of each stage's steps; Kohleria: 5 697 anisotropic
steps on 98 000 triangles, at 1/4 and 1/40) runs at full mesh size and its time ``c + r N`` is
extrapolated (``"extrapolated": true``).

For the comparison with Table 1 each simulation time is also scaled to Table 1's steps and
triangles (linearly, as the cost of an explicit step is proportional to both), where the
shipped file differs (Dianthus runs 6 000 of the 20 000 steps, Arctostaphylos uses 28 000 of
53 626 triangles). Targets of the issue: each case faster than Ringham's 16 threads, and the
sum of all simulations under 60 s. The one-minute load average before and after each case is
recorded, as the machine is shared.
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

# name: (file, Table 1 row: triangles, steps, 1 thread, 16 threads, GPU in seconds)
CASES = {
    "platycodon": ("flowers/platycodon.toml", None),
    "arctostaphylos": ("flowers/arctostaphylos.toml", (53_626, 1_500, 50, 7, 1)),
    "primula": ("flowers/primula.toml", (40_023, 2_000, 37, 5, 1)),
    "dianthus": ("flowers/dianthus.toml", (9_163, 20_000, 70, 11, 7)),
    "mimulus": ("mimulus-mesh-pipeline.toml", (175_968, 17_500, 1424, 191, 124)),
    "digitalis": ("flowers/digitalis.toml", (27_814, 19_000, 82, 11, 23)),
    "kohleria": ("kohleria-mesh-pipeline.toml", (98_250, 5_697, 254, 30, 19)),
    "trichoglottis": ("flowers/trichoglottis.toml", (21_147, 64_500, 141, 26, 33)),
    "phalaenopsis-nankung": ("flowers/phalaenopsis-nankung.toml", (64_191, 175, 3, 1, 1)),
    "phalaenopsis-leopard": ("flowers/phalaenopsis-leopard.toml", (168_394, 6_900, 610, 69, 48)),
}
SAMPLED = {"trichoglottis": 20, "kohleria": 4}
"""Cases run with 1/N of each simulation stage's steps and extrapolated."""

TARGET_TOTAL_S = 60.0


def _load() -> float:
    return round(os.getloadavg()[0], 2)


def _fit(full: list[dict], small: list[dict]) -> list[dict]:
    """Per stage: ``W = c + r n`` through the two runs; the time at the shipped steps."""
    out = []
    for a, b in zip(full, small, strict=True):
        span = a["steps_run"] - b["steps_run"]
        rate = max((a["wall_s"] - b["wall_s"]) / span, 0.0) if span > 0 else 0.0
        fixed = max(a["wall_s"] - rate * a["steps_run"], 0.0)
        out.append({**a, "fixed_s": round(fixed, 2), "per_step_ms": round(1e3 * rate, 4),
                    "time_s": round(fixed + rate * a["steps"], 2) if span > 0
                    else a["time_s"], "stepping_s": round(rate * a["steps"], 2),
                    "small_run": {"steps_run": b["steps_run"], "wall_s": b["wall_s"]}})
    return out


def run_case(name: str, path: Path, fraction: int = 1) -> dict:
    """Run one pipeline without pictures; per-stage times from its ``pipeline.json``."""
    from morphogen.flowers.pipeline import build_mesh, load_pipeline, run_pipeline

    spec = load_pipeline(path)
    started = time.perf_counter()
    mesh = build_mesh(spec["mesh"], spec["base"])
    mesh_s = time.perf_counter() - started
    shipped = {}
    for i, stage in enumerate(spec["stage"]):
        if stage["kind"] == "simulate" and fraction > 1:
            shipped[i] = int(stage["steps"])
            stage["steps"] = max(1, shipped[i] // fraction)
    load_before = _load()
    with tempfile.TemporaryDirectory() as out:
        started = time.perf_counter()
        run_pipeline(spec, out, pictures=False)
        total_s = time.perf_counter() - started
        record = json.loads((Path(out) / "pipeline.json").read_text())
    simulations, veins_s, other_s = [], 0.0, 0.0
    for i, info in enumerate(record["stages"]):
        if info["kind"] == "simulate":
            wall = float(info["wall_time"])
            full = shipped.get(i, info["steps"])
            simulations.append({"stage": info["name"], "steps_run": info["steps"],
                                "steps": full, "wall_s": round(wall, 2),
                                "time_s": round(wall * full / info["steps"], 2)})
        elif info["kind"] == "veins":
            veins_s += info["seconds"]
        else:
            other_s += info["seconds"]
    return {
        "vertices": mesh.n_vertices, "triangles": mesh.n_faces,
        "mesh_build_s": round(mesh_s, 2), "veins_s": round(veins_s, 2) if veins_s else None,
        "other_prepattern_s": round(other_s, 2),
        "simulations": simulations,
        "steps": sum(s["steps"] for s in simulations),
        "simulation_s": round(sum(s["time_s"] for s in simulations), 2),
        "extrapolated": fraction > 1,
        "pipeline_without_pictures_s": round(total_s, 2),
        "load_average_1min": [load_before, _load()],
    }


def run(only: list[str] | None = None) -> dict:
    import jax

    cases = {}
    for name, (file, row) in CASES.items():
        if only and name not in only:
            continue
        print(f"-- {name}", flush=True)
        fraction = SAMPLED.get(name, 1)
        case = run_case(name, EXAMPLES / file, fraction)
        if case["simulations"]:
            small = run_case(name, EXAMPLES / file, 10 * fraction)
            case["simulations"] = _fit(case["simulations"], small["simulations"])
            case["simulation_s"] = round(sum(s["time_s"] for s in case["simulations"]), 2)
            case["stepping_s"] = round(sum(s["stepping_s"] for s in case["simulations"]), 2)
            case["load_average_1min"] += small["load_average_1min"]
        if row is not None:
            triangles, steps, one, sixteen, gpu = row
            scale = (triangles / case["triangles"]) * (steps / case["steps"])
            ours = case["simulation_s"] * scale
            case["stepping_at_table_1_size_s"] = round(case["stepping_s"] * scale, 2)
            case["ringham_table_1"] = {"triangles": triangles, "steps": steps,
                                       "cpu_1_thread_s": one, "cpu_16_threads_s": sixteen,
                                       "gpu_s": gpu}
            case["at_table_1_size_s"] = round(ours, 2)
            case["faster_than_16_threads"] = bool(ours < sixteen)
            case["stepping_faster_than_16_threads"] = bool(
                case["stepping_at_table_1_size_s"] < sixteen)
        cases[name] = case
        print(json.dumps({name: case}), flush=True)
    timed = [c for c in cases.values() if "ringham_table_1" in c]
    total = sum(c["at_table_1_size_s"] for c in timed)
    stepping = sum(c["stepping_at_table_1_size_s"] for c in timed)
    return {
        "name": "flowers",
        "what": "Ringham et al. 2021 Table 1 next to the shipped flower pipelines on this "
                "machine: simulation wall time (compilation included), veins and other "
                "prepatterns timed separately, pictures not rendered",
        "cases": cases,
        "total_at_table_1_size_s": round(total, 2),
        "total_stepping_at_table_1_size_s": round(stepping, 2),
        "ringham_total_s": {k: sum(c["ringham_table_1"][k] for c in timed)
                            for k in ("cpu_1_thread_s", "cpu_16_threads_s", "gpu_s")},
        "targets": {
            "each_faster_than_16_threads": {n: c["faster_than_16_threads"]
                                            for n, c in cases.items() if "ringham_table_1" in c},
            "all_under_60_s": bool(total < TARGET_TOTAL_S),
            "each_stepping_faster_than_16_threads": {
                n: c["stepping_faster_than_16_threads"] for n, c in cases.items()
                if "ringham_table_1" in c},
            "all_stepping_under_60_s": bool(stepping < TARGET_TOTAL_S),
        },
        "sampled": {n: f"each simulation stage run for 1/{k} and 1/{10 * k} of its steps at "
                       "full mesh size, time extrapolated as c + r N"
                    for n, k in SAMPLED.items() if n in cases},
        "backend": jax.default_backend(),
    }


if __name__ == "__main__":
    import sys

    from morphogen.util.io import write_json

    result = run(sys.argv[1:] or None)
    print(json.dumps(result, indent=2))
    if not sys.argv[1:]:
        write_json(Path(__file__).parent / "results" / "flowers.json", result)
