"""Pictures and files of a run directory: contact sheets, fitness plot, best individuals.

Every file is written atomically and can be rewritten at any time from the archive (a resumed
run rewrites the files of the generation that was interrupted).
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.search.evaluate import Problem
from morphogen.util.io import write_atomic, write_json

SHEET_TILE = 128
"""Contact-sheet tiles are shrunk to at most this many pixels a side."""


def sheet_path(directory: Path, gen: int) -> Path:
    return Path(directory) / "generations" / f"gen_{gen:03d}.png"


def individual_path(directory: Path, gen: int, idx: int) -> Path:
    return Path(directory) / "generations" / f"gen_{gen:03d}" / f"ind_{idx:02d}.png"


def tiles(fields: np.ndarray, cmap: str = "viridis", flat_tol: float = 1e-3) -> np.ndarray:
    """Each final display field ``(P, *spatial)`` as an RGB tile ``(P, H, W, 3)`` uint8; 3D
    fields show their mid-plane.

    Each tile has its own colour scale (its min to max), widened to at least the flatness
    tolerance of the staged fitness (``flat_tol * max(1, max |u|)``) around its middle, so a
    state that scores as uniform also looks uniform instead of showing stretched round-off.
    """
    from morphogen.render import state_image

    out = []
    for f in np.asarray(fields, np.float64):
        finite = f[np.isfinite(f)]
        if finite.size == 0:
            out.append(state_image(f, cmap))
            continue
        lo, hi = float(finite.min()), float(finite.max())
        span = flat_tol * max(1.0, float(np.abs(finite).max()))
        if hi - lo < span:
            mid = 0.5 * (lo + hi)
            lo, hi = mid - span / 2, mid + span / 2
        out.append(state_image(f, cmap, lo, hi))
    return np.stack(out)


def write_individuals(directory: Path, gen: int, rgb: np.ndarray) -> list[str]:
    """Write one PNG per individual; returns paths relative to the run directory."""
    from morphogen.render import write_png

    out = []
    for i, tile in enumerate(rgb):
        path = individual_path(directory, gen, i)
        write_png(path, tile)
        out.append(str(path.relative_to(directory)))
    return out


def write_sheet(
    directory: Path, gen: int, rgb: np.ndarray, fitness: Sequence[float] | None, title: str
) -> str:
    """The contact sheet of a generation: tiles labelled ``#i f=0.512`` (index only when
    ``fitness`` is ``None``, before a person has chosen). Returns its relative path."""
    from morphogen.render import write_png
    from morphogen.render.mosaic import mosaic

    small = _shrink(rgb, SHEET_TILE)
    if fitness is None:
        labels = [f"#{i}" for i in range(len(rgb))]
    else:
        labels = [f"#{i} f={_fmt(f)}" for i, f in enumerate(fitness)]
    ncols = math.ceil(math.sqrt(len(rgb) * 1.5))
    path = sheet_path(directory, gen)
    write_png(path, mosaic(small, ncols, labels=labels, title=title))
    return str(path.relative_to(directory))


def write_fitness_plot(directory: Path, generations: Sequence[dict[str, Any]], title: str) -> Path:
    """``fitness.png``: best, mean and best-so-far fitness per generation."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    gens = [g["gen"] for g in generations]
    fig = Figure(figsize=(5.0, 3.2), dpi=120)
    ax = fig.add_subplot()
    for key, label, style in (("best", "generation best", "o-"), ("mean", "generation mean", "s--"),
                              ("best_so_far", "best so far", "-")):
        ys = [np.nan if g[key] is None else g[key] for g in generations]
        ax.plot(gens, ys, style, label=label, markersize=3)
    ax.set_xlabel("generation")
    ax.set_ylabel("fitness")
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    if gens:
        ax.set_xticks(gens if len(gens) <= 20 else gens[:: math.ceil(len(gens) / 20)])
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return write_atomic(Path(directory) / "fitness.png", lambda fh: fh.write(buf.getvalue()))


def write_best(
    directory: Path, problem: Problem, best: Sequence[dict[str, Any]], run_id: str
) -> list[Path]:
    """``best/best_K.png`` and ``best/best_K.json`` for the fittest individuals so far.

    The JSON is a ``run.json`` (:mod:`morphogen.runs.config`) that ``morphogen simulate --config``
    runs to reproduce the individual, plus an ``evolved`` record of where it came from.
    """
    out_dir = Path(directory) / "best"
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for rank, item in enumerate(best, start=1):
        png = out_dir / f"best_{rank}.png"
        data = Path(directory) / item["image"]
        write_atomic(png, lambda fh, src=data: fh.write(src.read_bytes()))
        record = individual_run_file(problem, item["genome"])
        record["evolved"] = {"run": run_id, "generation": item["gen"], "index": item["idx"],
                             "fitness": item["fitness"], "fitness_kind": problem.fitness}
        written.append(write_json(out_dir / f"best_{rank}.json", record))
        written.append(png)
    return written


def individual_run_file(problem: Problem, genome: Sequence[float]) -> dict[str, Any]:
    """A ``run.json`` object for one individual: the problem's settings with its genes set."""
    from morphogen.runs.config import FORMAT, RunConfig

    params = dict(problem.params)
    params.update({g.name: float(v) for g, v in zip(problem.genes, genome, strict=True)})
    clamp = list(problem.clamp) if isinstance(problem.clamp, list | tuple) else problem.clamp
    config = RunConfig(
        model=problem.model, model_source=problem.model_source, preset=problem.preset,
        params=params, size=list(problem.size), dx=problem.dx, boundary=problem.boundary,
        stencil=problem.stencil, dt=problem.dt, steps=problem.steps, scheme=problem.scheme,
        seed=problem.seed, init=problem.init, init_options=dict(problem.init_options),
        clamp=clamp,
    )
    return {"format": FORMAT, "config": asdict(config)}


def _shrink(rgb: np.ndarray, limit: int) -> np.ndarray:
    """Subsample tiles ``(P, H, W, 3)`` by a whole factor so each side is at most ``limit``."""
    factor = max(1, math.ceil(max(rgb.shape[1:3]) / limit))
    return rgb[:, ::factor, ::factor]


def _fmt(value: float) -> str:
    if value is None or not np.isfinite(value):
        return "nan"
    return f"{value:.3f}" if abs(value) >= 1e-3 or value == 0 else f"{value:.1e}"
