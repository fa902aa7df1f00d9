"""What the schemes that run on meshes gain on Ringham's flower case studies at the same picture.

Each case study is one simulate stage of a shipped pipeline (:data:`CASES`), at its own mesh,
time step, steps and seed; the prepattern stages before it run as the pipeline runs them,
without pictures (earlier simulate stages, which it does not read, are left out). Every scheme
that runs on a mesh advances it to the stage's final time ``T``:

- ``euler`` at the case study's own ``dt`` (the shipped setting, and the reference picture) and
  at its stability limit (:func:`~morphogen.solvers.step.max_stable_dt`, margin included);
- ``rk4`` at its limit;
- ``imex1`` and ``imex`` (conjugate-gradient diffusion solves,
  :mod:`morphogen.solvers.imex_cg`) at the longest step of the ladder ``dt 2^k`` (``k >= 1``,
  at most ``T`` and the scheme's own limit) that keeps the picture: tried from the longest step
  down, the first that passes is timed;
- ``adaptive`` (Tsit5, ``rtol`` :data:`RTOL`) where the run is deterministic (it refuses flux
  noise); ``etdrk4`` and ``etdrk4-adaptive`` refuse meshes (their messages are recorded), and
  ``auto``'s choice is recorded.

*The same picture*: the Pearson correlation of the final picture field (the field the case
study's picture colours: the next ``fields`` stage's ``show``, else the stage's own ``show``)
with the reference's is at least :data:`SAME`; its relative L2 error, and where a ``pigment``
field follows, the mean absolute change of the pigment (for a 0/1 pigment: the share of
vertices that change colour), are reported too. A stochastic case study (``omega``) is measured
twice: as shipped (the reference is euler at ``dt`` with the stage's seed; a second seed gives
the correlation two equally valid pictures reach, ``seed_floor``) and with the noise removed,
where a difference is the scheme's alone. ``noise_ratio``: the rms of a run's stochastic minus
deterministic picture (same scheme and step) over the reference's: the implicit schemes add
each step's flux noise after its solve, so with long steps the noise grows (a little slower
than ``sqrt(dt)``) while the correlation may stay above :data:`SAME`; the ladders therefore
also look for the longest step whose noise is within :data:`NOISE` times the reference's.

Timing: each run once to compile (and for its accuracy), then :data:`ROUNDS` interleaved timed
rounds, the best of each: CPU seconds of this process (``time.process_time``) and wall seconds.
The machine is shared, so the CPU seconds are the fair measure; the one-minute load average
before and after each case is recorded. ``python -m bench.bench_case_schemes NAME ...`` runs
some cases and merges them into ``bench/results/case_schemes.json``; ``--figure`` draws
``docs/images/schemes/primula-noise.png`` (:func:`figure`). All six cases took 34 CPU-minutes
on 2 shared cores (Dianthus 13, Kohleria about 11; docs/schemes-mesh.md).
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bench.timing import interleaved_cpu
from morphogen.domains.ply import apply_fields
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate
from morphogen.errors import MorphogenError
from morphogen.flowers.case_studies import find_flowers
from morphogen.flowers.pipeline import build_mesh, load_pipeline, run_pipeline
from morphogen.flowers.stages import evaluate
from morphogen.models.registry import load_model
from morphogen.solvers.auto import choose_scheme
from morphogen.solvers.imex_cg import CG_MAXITER, CG_RTOL
from morphogen.solvers.step import max_stable_dt

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
CASES = {  # name: (pipeline under examples/, simulate stage)
    "arctostaphylos": ("flowers/arctostaphylos.toml", "morphogen"),
    "primula": ("flowers/primula.toml", "fig9c"),
    "dianthus": ("flowers/dianthus.toml", "morphogen"),
    "digitalis": ("flowers/digitalis.toml", "spots"),
    "kohleria": ("kohleria-mesh-pipeline.toml", "pattern"),
    "phalaenopsis-nankung": ("flowers/phalaenopsis-nankung.toml", "blotches"),
}
SAME, NOISE, ROUNDS, RTOL = 0.99, 1.25, 2, 1e-3
RESULT = Path(__file__).parent / "results" / "case_schemes.json"


@dataclass
class Case:
    """One case study's simulate stage, ready to run."""

    model: Any
    mesh: Any  # with the prepattern fields
    domain: Any  # as shipped (boundary, directions, omega)
    u0: np.ndarray  # (S, V) float32
    params: dict[str, np.ndarray]
    dt: float
    steps: int
    seed: int
    picture: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray | None]]
    show: str
    cmap: str  # the picture's colour map

    @property
    def T(self) -> float:
        return self.dt * self.steps


def prepare(file: str, name: str) -> Case:
    """The inputs of stage ``name`` as :mod:`morphogen.flowers.pipeline` builds them."""
    spec = load_pipeline(EXAMPLES / file)
    stages = spec["stage"]
    k = [s.get("name", s["kind"]) for s in stages].index(name)
    stage = stages[k]
    before = [s for s in stages[:k] if s["kind"] != "simulate"]
    made: set[str] = set()
    with tempfile.TemporaryDirectory() as tmp:
        if before:
            mesh = run_pipeline({**spec, "stage": before}, tmp, pictures=False)
            for path in Path(tmp).glob("*/fields.npz"):
                with np.load(path) as data:
                    made.update(data.files)
        else:
            mesh = build_mesh(spec["mesh"], spec["base"])
    ref = str(stage["model"])
    model = load_model(str(spec["base"] / ref) if ref.endswith(".toml") else ref)
    domain = mesh.replace(boundary=stage.get("boundary", "neumann"), omega=stage.get("omega"))
    if "directions" in stage:
        domain = domain.replace(
            directions=domain.face_gradient(evaluate(stage["directions"], mesh)))
    values = model.parameters(preset=stage.get("preset"))
    seed = int(stage.get("seed", spec.get("seed", 0)))
    u0 = make_initial(stage.get("init", model.init), model, domain, values, seed=seed,
                      **stage.get("init_options", {}))
    u0, values = apply_fields(model, domain, u0, values, names=made)
    for key, text in stage.get("params", {}).items():
        values[key] = text if isinstance(text, int | float) else evaluate(text, mesh)
    params = {key: np.asarray(v, np.float32) for key, v in values.items()}
    current = mesh.with_fields(**{s: u0[i] for i, s in enumerate(model.species)})
    for key, text in stage.get("initial", {}).items():
        u0[model.species_index(key)] = evaluate(text, current)
    after = stages[k + 1] if k + 1 < len(stages) else {}
    fields = after.get("fields", {}) if after.get("kind") == "fields" else {}
    show = after.get("show") if fields else stage.get("show", model.display_species)

    def picture(state: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """The picture field and the pigment field (``None`` without one) of a final state."""
        cur = mesh.with_fields(**{s: np.asarray(state[i], np.float64)
                                  for i, s in enumerate(model.species)})
        for key, text in fields.items():
            cur = cur.with_fields(**{key: evaluate(text, cur)})
        return evaluate(show, cur), cur.fields.get("pigment") if "pigment" in fields else None

    return Case(model, mesh, domain, np.asarray(u0, np.float32), params, float(stage["dt"]),
                int(stage["steps"]), seed, picture, str(show),
                str((after if fields else stage).get("cmap", spec.get("cmap", "viridis"))))


def _compare(u: np.ndarray, ref: np.ndarray) -> dict:
    """Pearson correlation (``None`` for a uniform field, which has none) and relative L2."""
    a, b = u - u.mean(), ref - ref.mean()
    spread = np.sqrt((a @ a) * (b @ b))
    return {"correlation": float(a @ b / spread) if spread > 0 else None,
            "relative_l2": float(np.linalg.norm(u - ref) / np.linalg.norm(ref))}


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def _limit(value: float) -> float | None:
    return None if math.isinf(value) else value


def _steps(case: Case, dt: float) -> int:
    return max(1, math.ceil(case.T / dt - 1e-6))


class Runner:
    """Runs one case on a domain (as shipped, or without noise), judging each picture against
    that domain's reference; deterministic pictures are kept for the noise ratio."""

    def __init__(self, case: Case, domain, plain: dict[tuple[str, int], np.ndarray]):
        self.case, self.domain, self.plain = case, domain, plain
        self.noisy = domain.omega is not None
        self.ref = self.run("euler", case.steps)
        self.ref_picture, self.ref_pigment = case.picture(self.ref.state)
        if not self.noisy:
            plain[("euler", case.steps)] = self.ref_picture

    def run(self, scheme: str, steps: int, seed: int | None = None, domain=None, **kw):
        c = self.case
        return simulate(c.model, domain or self.domain, c.u0, c.params, steps=steps,
                        dt=c.dt if steps == c.steps else c.T / steps, scheme=scheme,
                        seed=c.seed if seed is None else seed, **kw)

    def _plain(self, scheme: str, steps: int) -> np.ndarray:
        if (scheme, steps) not in self.plain:
            sol = self.run(scheme, steps, domain=self.domain.replace(omega=None))
            self.plain[(scheme, steps)] = self.case.picture(sol.state)[0]
        return self.plain[(scheme, steps)]

    def assess(self, scheme: str, steps: int, **kw) -> dict:
        """Run once (this compiles it) and compare its picture with the reference."""
        try:
            sol = self.run(scheme, steps, **kw)
        except MorphogenError as exc:
            return {"steps": steps, "error": str(exc).splitlines()[0], "same_picture": False}
        pic, pigment = self.case.picture(sol.state)
        out: dict[str, Any] = {"steps": sol.steps, **_compare(pic, self.ref_picture)}
        if sol.rejected_steps is not None:
            out["rejected_steps"] = sol.rejected_steps
        if pigment is not None:
            out["pigment_mean_abs_diff"] = float(np.abs(pigment - self.ref_pigment).mean())
        if self.noisy and "rtol" not in kw:
            base = _rms(self.ref_picture - self._plain("euler", self.case.steps))
            out["noise_ratio"] = _rms(pic - self._plain(scheme, steps)) / base
        elif "rtol" not in kw:
            self.plain[(scheme, steps)] = pic
        out["same_picture"] = (out["correlation"] or 0.0) >= SAME
        if sol.warnings:
            out["warnings"] = sol.warnings
        return out

    def ladder(self, scheme: str) -> tuple[int | None, int | None, list[dict]]:
        """The longest steps ``dt 2^k`` that keep the picture, and (with noise) the picture and
        the noise's size (:data:`NOISE`), tried from the longest down: ``(steps, steps, tried)``."""
        c = self.case
        top = min(c.T, max_stable_dt(c.model, self.domain, c.params, scheme))
        ks = [k for k in range(1, 40) if c.dt * 2**k <= top * (1 + 1e-9)]
        tried, best = [], None
        for k in reversed(ks):
            steps = _steps(c, c.dt * 2**k)
            result = self.assess(scheme, steps)
            tried.append({"dt": c.T / steps, **result})
            if result["same_picture"]:
                best = best or steps
                if result.get("noise_ratio", 1.0) <= NOISE:
                    return best, steps, tried
        return best, None, tried


def _variant(runner: Runner) -> dict:
    """The reference, the ladders and the timed runs on one domain."""
    c, domain = runner.case, runner.domain
    out: dict[str, Any] = {"load_average_1min": [round(os.getloadavg()[0], 2)]}
    if runner.noisy:
        other = runner.case.picture(runner.run("euler", c.steps, seed=c.seed + 1).state)[0]
        out["seed_floor"] = _compare(other, runner.ref_picture)
    candidates: dict[str, tuple[str, int, dict]] = {
        f"euler dt={c.dt:.4g} (shipped)": ("euler", c.steps, {})}
    for scheme in ("euler", "rk4"):
        dt = max_stable_dt(c.model, domain, c.params, scheme)
        candidates[f"{scheme} dt={dt:.4g} (its limit)"] = (scheme, _steps(c, dt), {})
    ladders = {}
    for scheme in ("imex1", "imex"):
        best, quiet, ladders[scheme] = runner.ladder(scheme)
        if best is not None:
            label = f"{scheme} dt={c.T / best:.4g} (longest same picture)"
            candidates[label] = (scheme, best, {})
        if quiet is not None and quiet != best:
            label = f"{scheme} dt={c.T / quiet:.4g} (longest with the noise within {NOISE:g}x)"
            candidates[label] = (scheme, quiet, {})
    if not runner.noisy:
        candidates[f"adaptive rtol={RTOL:g}"] = ("adaptive", c.steps, {"rtol": RTOL})
    results: dict[str, dict] = {}
    for label, (scheme, steps, kw) in candidates.items():
        if scheme in ("imex1", "imex") and scheme in ladders:
            results[label] = next(t for t in ladders[scheme] if t["steps"] == steps)
        elif steps == c.steps and scheme == "euler":
            results[label] = {"steps": steps, "correlation": 1.0, "relative_l2": 0.0,
                              "same_picture": True}
        else:
            results[label] = runner.assess(scheme, steps, **kw)
        results[label] = {"scheme": scheme, "dt": c.T / steps if scheme != "adaptive"
                          else None, **results[label]}
    timed = {label: (lambda s=s, n=n, kw=kw: runner.run(s, n, **kw))
             for label, (s, n, kw) in candidates.items() if "error" not in results[label]}
    cpu, wall = interleaved_cpu(timed, ROUNDS)
    shipped, limit = list(candidates)[:2]
    for label in timed:
        results[label].update(
            cpu_s=round(min(cpu[label]), 3), wall_s=round(min(wall[label]), 3),
            cpu_s_rounds=[round(t, 3) for t in cpu[label]],
            wall_s_rounds=[round(t, 3) for t in wall[label]],
            speedup_vs_shipped=round(min(cpu[shipped]) / min(cpu[label]), 2),
            speedup_vs_euler_limit=round(min(cpu[limit]) / min(cpu[label]), 2)
            if limit in timed else None)
    out["results"] = results
    out["ladders"] = ladders
    for key, noise in (("fastest_same_picture", math.inf), ("fastest_same_noise", NOISE)):
        if noise < math.inf and not runner.noisy:
            continue
        same = [label for label in timed if results[label]["same_picture"]
                and results[label].get("noise_ratio", 1.0) <= noise]
        fastest = min(same, key=lambda label: results[label]["cpu_s"])
        out[key] = {"run": fastest, **{
            k: results[fastest][k] for k in ("speedup_vs_shipped", "speedup_vs_euler_limit")}}
    out["load_average_1min"].append(round(os.getloadavg()[0], 2))
    return out


def _refused(case: Case) -> dict:
    out = {}
    for scheme in ("etdrk4", "etdrk4-adaptive"):
        try:
            simulate(case.model, case.domain.replace(omega=None), case.u0, case.params,
                     steps=1, dt=case.dt, scheme=scheme)
            out[scheme] = "ran"
        except MorphogenError as exc:
            out[scheme] = str(exc).splitlines()[0]
    return out


def run_case(name: str) -> dict:
    file, stage = CASES[name]
    started, load = time.perf_counter(), round(os.getloadavg()[0], 2)
    case = prepare(file, stage)
    prepare_s = time.perf_counter() - started
    mesh, plain = case.mesh, {}
    limits = {s: _limit(max_stable_dt(case.model, case.domain, case.params, s))
              for s in ("euler", "rk4", "imex1", "imex")}
    section = {f.path.name: f.section for f in find_flowers()}.get(Path(file).name)
    out: dict[str, Any] = {
        "pipeline": f"examples/{file}", "stage": stage, "section": section,
        "vertices": mesh.n_vertices, "triangles": mesh.n_faces,
        "mean_edge": round(mesh.edge_length, 5), "picture_field": case.show,
        "shipped": {"scheme": "euler", "dt": case.dt, "steps": case.steps, "T": case.T,
                    "omega": case.domain.omega, "seed": case.seed},
        "limits": limits, "auto_choice": choose_scheme(case.model, case.domain, case.params),
        "refused": _refused(case), "prepare_s": round(prepare_s, 2), "variants": {},
    }
    quiet = case.domain.replace(omega=None)
    out["variants"]["deterministic"] = _variant(Runner(case, quiet, plain))
    if case.domain.omega is not None:
        out["variants"]["shipped"] = _variant(Runner(case, case.domain, plain))
        out["variants"]["deterministic"]["note"] = "the shipped stage with omega removed"
    else:
        out["variants"]["deterministic"]["note"] = "as shipped"
    out["load_average_1min"] = [load, round(os.getloadavg()[0], 2)]
    out["seconds"] = round(time.perf_counter() - started, 1)
    return out


def run(only: list[str] | None = None) -> dict:
    import jax

    cases = {}
    for name in CASES:
        if only and name not in only:
            continue
        print(f"-- {name}", flush=True)
        cases[name] = run_case(name)
        print(json.dumps({name: cases[name]["variants"]}, default=str)[:2000], flush=True)
    return {
        "name": "case_schemes",
        "what": "Ringham's flower case studies to their final time with every scheme that runs "
                "on a mesh: euler at the shipped dt and at its limit, rk4 at its limit, "
                "imex1/imex (CG) at the longest step keeping the picture (Pearson >= "
                f"{SAME} against the shipped setting), adaptive where deterministic; "
                f"best of {ROUNDS} interleaved rounds after a compiling run, float32",
        "cg": {"rtol": CG_RTOL, "maxiter": CG_MAXITER},
        "cases": cases,
        "backend": jax.default_backend(),
    }


FIGURE = Path(__file__).resolve().parents[1] / "docs" / "images" / "schemes" / "primula-noise.png"


def figure(path: Path = FIGURE) -> Path:
    """One Primula petal (fig. 9C, stochastic) as shipped and with ``imex1`` at longer steps:
    the flux noise added after each implicit solve grows with the step."""
    from morphogen.render.colour import colourise
    from morphogen.render.images import write_png
    from morphogen.render.mesh import render_mesh

    case = prepare(*CASES["primula"])
    v, f = case.mesh.vertices, case.mesh.faces
    angle = np.arctan2(v[:, 1], v[:, 0])
    tip = angle[np.argmax(np.hypot(v[:, 0], v[:, 1]))]
    keep = f[np.all(np.abs(np.angle(np.exp(1j * (angle[f] - tip)))) < np.pi / 5, axis=1)]
    used = np.unique(keep)
    index = np.full(len(v), -1)
    index[used] = np.arange(len(used))
    panels = []
    for scheme, steps in (("euler", case.steps), ("imex1", 500), ("imex1", 125), ("imex1", 32)):
        sol = simulate(case.model, case.domain, case.u0, case.params, steps=steps,
                       dt=case.T / steps, scheme=scheme, seed=case.seed)
        colours = colourise(case.picture(sol.state)[0][used], case.cmap)
        panels.append(render_mesh(v[used], index[keep], colours, view="top", size=(360, 360),
                                  shade=0.0))
    return write_png(path, np.concatenate(panels, axis=1))


if __name__ == "__main__":
    import sys

    if sys.argv[1:] == ["--figure"]:
        print(f"wrote {figure()}")
        sys.exit(0)

    from bench.run import machine
    from morphogen.util.io import write_json

    result = run(sys.argv[1:] or None)
    if sys.argv[1:] and RESULT.exists():
        stored = json.loads(RESULT.read_text())
        stored["cases"] = {n: (result["cases"].get(n) or stored["cases"].get(n))
                           for n in CASES if n in result["cases"] or n in stored["cases"]}
        result = {**result, "cases": stored["cases"]}
    result["machine"] = machine()
    write_json(RESULT, result)
    print(f"wrote {RESULT}")
