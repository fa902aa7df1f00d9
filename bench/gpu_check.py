"""``make gpu-check``: the GPU-relevant checks and benchmarks in one script, on whatever JAX
backend is present, written to ``bench/results/gpu.json``.

Run it whenever a GPU is available (``.venv/bin/python -m bench.gpu_check``, at most
:data:`BUDGET_S` seconds on one GPU); on a CPU it runs everything at tiny sizes (``--small``,
automatic when the backend is ``cpu``), which is what ``tests/project/test_gpu_check.py`` does
so that the script cannot rot. Sections, each timed after its compiling call:

- ``device``: backend, device name, the memory bandwidth from :data:`BANDWIDTH_GBS` (a table of
  known devices, vendors' figures) and a measured device-to-device copy (a jitted ``2 x`` of a
  large float32 array: one read and one write per element);
- ``checks``: numbers against theory on this device, float32: a Fourier mode of
  ``du/dt = -k u + D L u`` under ``euler`` decays by exactly ``(1 + dt(-k + D lambda))^N`` and
  under ``etdrk4`` by ``exp(N dt (-k + D lambda))`` (``lambda`` the 5-point symbol); Gray-Scott
  in float32 on the device stays within float32 rounding of a NumPy float64 run of the same
  steps;
- ``gray_scott``: Gray-Scott Euler steps per second at 256² and 1024² (Skaggs eqs. 2.3-2.4,
  library defaults, periodic 5-point, ``dt`` = the Euler limit) next to the memory-bandwidth
  bound: a step must read both species and write both, 16 bytes per cell, so at bandwidth
  ``B`` it cannot exceed ``B / (16 n²)`` steps per second;
- ``networks``: one full Table-1 generation of Yamamoto's network evolution (150 individuals,
  32², ``dt = 0.1``, 10 rounds from ``t = 2000``: evaluation and breeding, rates mode around
  the Table-2 network, :mod:`morphogen.search.networks.evolve`);
- ``skaggs``: Skaggs' Table-5.1 generation (20 Gray-Scott individuals, 256², 4000 steps; seed
  000 §5: 39.72 s on one CPU thread, 27.03 s on 16, 6.39 s on his GPU), the GA's ask,
  evaluation and tell as ``bench/bench_search.py`` times it;
- ``neural``: one neural-RD training iteration (seed 002, Algorithm 1: rollout, texture loss,
  backward pass, Adam, pool update) of the ``paper`` preset on a GPU, the ``cpu`` preset
  shrunk on a CPU;
- ``mesh``: a deterministic and a stochastic (Ringham eq. 17, ``omega`` set) explicit step of
  Ringham's *Mimulus* model (eq. 19) on the ~88 000-vertex tube of ``bench/bench_mesh.py``;
- ``tests`` (full size only, last, within what is left of the budget): the suite's files whose
  numbers depend on the backend (:data:`GPU_TESTS`: convergence orders, the steppers, batched
  ETDRK4, the spectral Laplacian, stochastic mesh diffusion, the network lanes kernel), run by
  pytest on this backend, tests marked ``slow`` left out.

A section that fails is recorded with its one-line error and the script exits 1 after writing
the file; a section that would start after the budget is spent is recorded as skipped. The JSON
is written atomically (:func:`morphogen.util.io.write_json`); a small run writes
``bench/results/gpu_small.json`` unless ``--out`` says otherwise, never a GPU's ``gpu.json``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

HERE = Path(__file__).parent
RESULT = HERE / "results" / "gpu.json"
RESULT_SMALL = HERE / "results" / "gpu_small.json"
"""Where a small run writes unless told otherwise, so that it never replaces a GPU's figures."""
BUDGET_S = 480.0
ROUNDS = 3
GPU_TESTS = ("tests/solvers/test_convergence.py", "tests/solvers/test_steppers.py",
             "tests/solvers/test_etd_batched.py", "tests/domains/test_spectral.py",
             "tests/domains/test_mesh_stochastic.py",
             "tests/search/networks/test_networks_lanes.py")
"""Test files run on the device in full mode (module docstring)."""
BYTES_PER_CELL_STEP = 16
"""Gray-Scott Euler: read ``u`` and ``v`` and write them, float32."""

BANDWIDTH_GBS: dict[str, float] = {
    "GH200": 4000.0, "H200": 4800.0, "H100 PCIe": 2000.0, "H100 NVL": 3900.0, "H100": 3350.0,
    "A100-SXM4-80GB": 2039.0, "A100 80GB PCIe": 1935.0, "A100": 1555.0,
    "L40S": 864.0, "L40": 864.0, "L4": 300.0, "A10G": 600.0, "A10": 600.0, "T4": 320.0,
    "V100": 900.0, "P100": 732.0, "RTX 4090": 1008.0, "RTX 3090": 936.0,
    "RTX 2070 SUPER": 448.0, "RTX 2070": 448.0,
}
"""Peak memory bandwidth (GB/s, vendors' data sheets) by a substring of the device name;
the first match in this order wins (more specific names first)."""


# --- helpers -------------------------------------------------------------------------------

def _timed(fn: Callable[[], Any], rounds: int = ROUNDS) -> dict[str, float]:
    """Compile (one call), then the median and best wall seconds of ``rounds`` calls, each
    blocked until its result is ready."""
    t0 = time.perf_counter()
    jax.block_until_ready(fn())
    first = time.perf_counter() - t0
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        jax.block_until_ready(fn())
        times.append(time.perf_counter() - t0)
    return {"first_call_s": first, "median_s": statistics.median(times), "best_s": min(times)}


def known_bandwidth(name: str) -> float | None:
    """The data-sheet bandwidth (GB/s) of a device named ``name``, or ``None``."""
    for key, gbs in BANDWIDTH_GBS.items():
        if key.lower() in name.lower():
            return gbs
    return None


def measured_bandwidth(mib: int) -> float:
    """GB/s of a jitted ``2 x`` over a float32 array of ``mib`` MiB (one read, one write per
    element), best of five."""
    x = jnp.ones((mib * 2**18,), jnp.float32)
    double = jax.jit(lambda a: 2.0 * a)
    t = _timed(lambda: double(x), rounds=5)["best_s"]
    return 2 * x.nbytes / t / 1e9


# --- sections ------------------------------------------------------------------------------

def device(small: bool) -> dict:
    dev = jax.devices()[0]
    name = getattr(dev, "device_kind", str(dev))
    table = known_bandwidth(name) if dev.platform == "gpu" else None
    copy = measured_bandwidth(16 if small else 1024)
    return {"backend": jax.default_backend(), "device": str(dev), "device_kind": name,
            "device_count": jax.device_count(), "bandwidth_table_gbs": table,
            "bandwidth_copy_gbs": copy,
            "bandwidth_used_gbs": table if table is not None else copy,
            "bandwidth_source": "table" if table is not None else "measured copy"}


def checks(small: bool) -> dict:
    from morphogen.domains.grid import Grid
    from morphogen.engine.initial import make_initial
    from morphogen.engine.simulate import integrate
    from morphogen.models.library import get_model
    from morphogen.models.model import Model
    from morphogen.solvers.step import make_step

    linear = Model(name="linear", species=("u",), params={"k": 0.5, "D": 0.2},
                   reaction=lambda u, p, c: -p["k"] * u, diffusion=lambda p, c: (p["D"],),
                   ground=lambda p: (0.0,))
    n, steps, dt = 32, 50, 0.1
    y, x = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    ky, kx = 2 * np.pi * 2 / n, 2 * np.pi / n
    mode = (np.cos(ky * y) * np.cos(kx * x))[None].astype(np.float32)
    rate = -0.5 + 0.2 * (2 * np.cos(ky) - 2 + 2 * np.cos(kx) - 2)
    exact = {"euler": (1 + dt * rate) ** steps, "etdrk4": np.exp(steps * dt * rate)}
    p = {k: jnp.float32(v) for k, v in linear.params.items()}
    out: dict[str, Any] = {}
    for scheme, factor in exact.items():
        step = make_step(linear, Grid((n, n)), scheme=scheme)
        u = np.asarray(integrate(step, jnp.asarray(mode), p, steps=steps, dt=dt,
                                 key=jax.random.key(0))[0], np.float64)
        err = float(np.max(np.abs(u - factor * mode)) / factor)
        out[f"mode_decay_{scheme}"] = {"relative_error": err, "ok": err < 1e-4}

    model, size = get_model("gray-scott"), 64
    grid = Grid((size, size))
    params = model.parameters()
    u0 = make_initial("blobs", model, grid, params, seed=0)
    gs_steps, gs_dt = 200, 1.0
    step = make_step(model, grid)
    pj = {k: jnp.float32(v) for k, v in params.items()}
    u32 = np.asarray(integrate(step, jnp.asarray(u0), pj, steps=gs_steps, dt=gs_dt,
                               key=jax.random.key(0))[0], np.float64)
    u, v = (np.asarray(a, np.float64) for a in u0)
    pn = {k: float(np.asarray(val)) for k, val in params.items()}
    for _ in range(gs_steps):
        lap = [np.roll(a, 1, 0) + np.roll(a, -1, 0) + np.roll(a, 1, 1) + np.roll(a, -1, 1)
               - 4 * a for a in (u, v)]
        uvv = u * v * v
        u, v = (u + gs_dt * (pn["Du"] * lap[0] - uvv + pn["F"] * (1 - u)),
                v + gs_dt * (pn["Dv"] * lap[1] + uvv - (pn["F"] + pn["k"]) * v))
    diff = float(np.max(np.abs(u32 - np.stack([u, v]))))
    out["gray_scott_float32_vs_float64"] = {"steps": gs_steps, "max_abs_difference": diff,
                                            "ok": diff < 1e-3}
    out["ok"] = all(c["ok"] for c in out.values() if isinstance(c, dict))
    return out


def gray_scott(small: bool, bandwidth_gbs: float) -> dict:
    from morphogen.domains.grid import Grid
    from morphogen.engine.initial import make_initial
    from morphogen.engine.simulate import integrate
    from morphogen.models.library import get_model
    from morphogen.solvers.step import make_step, max_stable_dt

    model = get_model("gray-scott")
    sizes = ((32, 200), (64, 100)) if small else ((256, 20000), (1024, 4000))
    rows = {}
    for size, steps in sizes:
        grid = Grid((size, size))
        params = model.parameters()
        u0 = jnp.asarray(make_initial("blobs", model, grid, params, seed=0))
        p = {k: jnp.float32(v) for k, v in params.items()}
        dt = max_stable_dt(model, grid, params)
        step = make_step(model, grid)
        run = jax.jit(lambda u, p=p, dt=dt, step=step, steps=steps: integrate(
            step, u, p, steps=steps, dt=dt, key=jax.random.key(0))[0])
        t = _timed(lambda run=run, u0=u0: run(u0))
        rate = steps / t["median_s"]
        bound = bandwidth_gbs * 1e9 / (BYTES_PER_CELL_STEP * size * size)
        rows[f"{size}x{size}"] = {"steps": steps, "dt": dt, **t, "steps_per_s": rate,
                                  "cell_steps_per_s": rate * size * size,
                                  "bandwidth_bound_steps_per_s": bound,
                                  "share_of_bound": rate / bound}
    return rows


def networks(small: bool) -> dict:
    from morphogen.search.networks import evolve
    from morphogen.search.networks.genome import table2_genome, table2_spec
    from morphogen.search.networks.operators import Operators, random_population

    spec, ops = table2_spec(), Operators(mode="rates")
    pop_size = 8 if small else 150
    ev = (evolve.Evaluation(size=8, t_start=20.0, interval=10.0, rounds=2) if small
          else evolve.Evaluation())
    root = jax.random.key(0)
    pop = random_population(jax.random.fold_in(root, 0), table2_genome(spec), spec, pop_size,
                            ops)
    breed = evolve._breeder(spec, ops)

    def generation(gen: int) -> np.ndarray:
        u0 = evolve.initial_state(jax.random.fold_in(root, 2 * gen + 2), spec, ev)
        fitness, _ = evolve.evaluate(pop, u0, spec, ev)
        jax.block_until_ready(breed(jax.random.fold_in(root, 2 * gen + 1), pop,
                                    jnp.asarray(fitness)))
        return fitness

    t0 = time.perf_counter()
    generation(0)
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    fitness = generation(1)
    second = time.perf_counter() - t0
    return {"population": pop_size, "size": ev.size, "dt": ev.dt, "steps": ev.steps,
            "first_generation_s": first, "generation_s": second,
            "valid": int((fitness > evolve.INVALID).sum()),
            "cell_steps_per_s_upper_bound": pop_size * ev.size**2 * ev.steps / second}


def skaggs(small: bool) -> dict:
    from bench.bench_search import SKAGGS_TABLE_5_1, _generation
    from morphogen.search.evaluate import Evaluator, Problem
    from morphogen.search.ga import GeneticAlgorithm
    from morphogen.search.genes import SKAGGS_SCHEDULE, preset_genes

    dt, t_end = SKAGGS_SCHEDULE["gray-scott"]
    size, population, steps = (32, 4, 100) if small else (256, 20, int(t_end / dt))
    problem = Problem(model="gray-scott", genes=tuple(preset_genes("gray-scott")),
                      preset="skaggs-table-3.1", size=(size, size), dt=dt, steps=steps,
                      init="skaggs")
    ga, evaluator = GeneticAlgorithm(population), Evaluator(problem)
    state = ga.init(jax.random.PRNGKey(0), tuple(preset_genes("gray-scott")))
    t0 = time.perf_counter()
    state, _ = _generation(ga, evaluator, state, 1)
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    state, fitness = _generation(ga, evaluator, state, 2)
    second = time.perf_counter() - t0
    return {"population": population, "size": size, "steps": steps,
            "first_generation_s": first, "generation_s": second,
            "valid": int(np.sum(np.asarray(fitness) > -1)),
            "cell_steps_per_s": population * size * size * steps / second,
            "skaggs_table_5_1_s": SKAGGS_TABLE_5_1}


def neural(small: bool) -> dict:
    from morphogen.learn.extractors import make_extractor
    from morphogen.learn.loss import texture_loss
    from morphogen.learn.textures import synthetic_texture
    from morphogen.learn.train import init_state, make_train_step, preset

    config = (preset("cpu", size=16, hidden=16, pool_size=8, batch_size=2, min_steps=4,
                     max_steps=8, n_rot=4) if small else preset("paper", features="random"))
    loss = texture_loss(synthetic_texture("dots", config.size), make_extractor("random"),
                        config.n_rot)
    step = make_train_step(config)
    box = {"state": init_state(config)}

    def once():
        box["state"], metrics = step(box["state"], loss)
        return box["state"].weights, metrics

    t = _timed(once)
    return {"preset": "cpu (shrunk)" if small else "paper", "size": config.size,
            "channels": config.channels, "hidden": config.hidden,
            "batch_size": config.batch_size, "steps": [config.min_steps, config.max_steps],
            **t, "iterations_per_s": 1.0 / t["median_s"]}


def mesh(small: bool) -> dict:
    from bench.bench_mesh import DT, mimulus_mesh, prepattern
    from morphogen.engine.initial import make_initial
    from morphogen.engine.simulate import integrate
    from morphogen.models.library import get_model
    from morphogen.solvers.step import make_step

    surface = mimulus_mesh(edge=0.2 if small else 0.031)
    model = get_model("activator-inhibitor")
    params = model.parameters(preset="mimulus")
    params["rho_a0"] = prepattern(surface).astype(np.float32)
    u0 = jnp.asarray(make_initial("noise", model, surface, params, seed=0))
    p = {k: jnp.asarray(v, jnp.float32) for k, v in params.items()}
    steps = 50 if small else 2000
    out: dict[str, Any] = {"vertices": surface.n_vertices, "triangles": surface.n_faces,
                           "steps": steps, "dt": DT}
    for kind, domain in (("deterministic", surface),
                         ("stochastic", surface.replace(omega=1e4))):
        step = make_step(model, domain)
        run = jax.jit(lambda u, step=step: integrate(step, u, p, steps=steps, dt=DT,
                                                     key=jax.random.key(0))[0])
        t = _timed(lambda run=run: run(u0))
        out[kind] = {**t, "steps_per_s": steps / t["median_s"],
                     "vertex_steps_per_s": steps * surface.n_vertices / t["median_s"]}
    out["stochastic_over_deterministic"] = (out["stochastic"]["median_s"]
                                            / out["deterministic"]["median_s"])
    return out


def tests(small: bool, seconds: float) -> dict:
    """The :data:`GPU_TESTS` on this backend (a pytest subprocess, at most ``seconds``)."""
    if small:
        return {"skipped": "small mode: the suite runs these files on the CPU"}
    cmd = [sys.executable, "-m", "pytest", "-q", "-m", "not slow", "-p", "no:cacheprovider",
           *GPU_TESTS]
    env = {k: v for k, v in os.environ.items() if k != "JAX_PLATFORMS"}
    try:
        done = subprocess.run(cmd, cwd=HERE.parent, env=env, capture_output=True, text=True,
                              timeout=max(seconds, 30.0))
    except subprocess.TimeoutExpired:
        return {"files": list(GPU_TESTS), "error": f"pytest ran past {seconds:.0f} s",
                "ok": False}
    lines = done.stdout.strip().splitlines()
    return {"files": list(GPU_TESTS), "returncode": done.returncode,
            "summary": lines[-1] if lines else "", "ok": done.returncode == 0}


# --- driver --------------------------------------------------------------------------------

def run(small: bool, budget_s: float = BUDGET_S) -> tuple[dict, bool]:
    """Every section within ``budget_s``; returns the result and whether all sections ran
    and passed."""
    start = time.perf_counter()
    result: dict[str, Any] = {"small": small, "budget_s": budget_s,
                              "load_average": list(os.getloadavg()),
                              "cpu_count": os.cpu_count(), "jax": jax.__version__}
    ok = True
    dev = device(small)
    result["device"] = dev
    sections: dict[str, Callable[[], dict]] = {
        "checks": lambda: checks(small),
        "gray_scott": lambda: gray_scott(small, dev["bandwidth_used_gbs"]),
        "mesh": lambda: mesh(small),
        "neural": lambda: neural(small),
        "skaggs": lambda: skaggs(small),
        "networks": lambda: networks(small),
        "tests": lambda: tests(small, budget_s - (time.perf_counter() - start)),
    }
    for name, section in sections.items():
        if time.perf_counter() - start > budget_s:
            result[name] = {"skipped": f"budget of {budget_s:.0f} s spent"}
            ok = False
            continue
        t0 = time.perf_counter()
        try:
            result[name] = section()
        except Exception as exc:  # a failing section is recorded, the others still run
            result[name] = {"error": f"{type(exc).__name__}: {exc}".splitlines()[0]}
            ok = False
        else:
            ok = ok and result[name].get("ok", True)
        result[name]["section_s"] = time.perf_counter() - t0
        print(f"{name}: {time.perf_counter() - t0:.1f} s", flush=True)
    result["total_s"] = time.perf_counter() - start
    result["load_average_after"] = list(os.getloadavg())
    return result, ok


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true",
                        help="tiny sizes (automatic when JAX's backend is the CPU)")
    parser.add_argument("--out", type=Path, default=None,
                        help=f"the JSON file to write (default {RESULT.name}, small runs "
                             f"{RESULT_SMALL.name}, in bench/results)")
    parser.add_argument("--budget", type=float, default=BUDGET_S,
                        help="seconds after which no further section starts")
    args = parser.parse_args(argv)
    from bench.run import machine
    from morphogen.util.io import write_json

    small = args.small or jax.default_backend() == "cpu"
    result, ok = run(small, args.budget)
    result["machine"] = machine()
    out = args.out or (RESULT_SMALL if small else RESULT)
    write_json(out, result)
    print(f"wrote {out} ({'all sections passed' if ok else 'SOME SECTIONS FAILED'})")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
