"""The answer: the best candidates at the picture's scale, replayable, side by side.

A candidate found on the 64² search grid with wavelength ``λ_s`` cells at spacing ``dx_s`` is
rescaled so that its pattern has the picture's wavelength ``λ_p`` (original pixels): one cell of
the answer stands for ``ppc = λ_p / λ_c`` pixels, with ``λ_c = clip(λ_p, 8, 40)`` cells (a
pattern finer than 8 cells per wavelength is not resolved by the stencil, a coarser one only
costs time), and the spacing is

.. math:: dx = dx_s\\,\\lambda_s / \\lambda_c ,

since a reaction-diffusion pattern's wavelength is a physical length (set by the diffusion
lengths, Turing's ``2π/k*``), so its count of cells scales as ``1/dx``. The grid covers the picture
(``H / ppc`` by ``W / ppc`` cells, at most :data:`MAX_SIDE`), ``dt`` is the run policy's (the
model's, reduced to the stability limit at the new ``dx`` when needed), for the same simulated
time. Each candidate is then simulated exactly as its ``run.json`` says (the *verification* run) and
measured; the candidates are ranked by their replay's descriptor distance to the picture (a
sample that scored best on the search grid can form another pattern at the picture's scale),
and for the best one ``dx`` is corrected once by the measured wavelength ratio (discretisation
and the finite domain shift ``λ`` by a few per cent) and verified again.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.match.boxes import Box
from morphogen.match.search import Journal, Samples
from morphogen.match.signature import Signature, distance, normalise, signature

MIN_CELLS, MAX_CELLS = 8.0, 40.0
"""Range of the answer's wavelength in cells."""

MAX_SIDE = 128
"""Largest side of the answer's grid (cells)."""

CORRECT_ABOVE = 0.03
"""Relative wavelength error above which the best candidate's ``dx`` is corrected once."""


@dataclass
class Candidate:
    """One answer: a model, its parameters and scale, and how its replay compares.

    Attributes:
        model, params: the model and its searched parameters.
        dx, size, dt, steps, seed, init: the answer's simulation (its ``run.json``).
        invert: the picture's dark is the species' high (the other polarity).
        family: the replay's family; distance, texture: search scores; replay_distance: the
            replay's descriptor distance to the picture.
        wavelength_px: the replay's wavelength in the picture's pixels; pixels_per_cell: the
            picture's pixels per cell of the answer's grid.
        replay: the replay's display species, ``(H, W)``.
        run: the ``run.json`` object.
    """

    model: str
    params: dict[str, float]
    dx: float
    size: tuple[int, int]
    dt: float
    steps: int
    seed: int
    init: str
    invert: bool
    family: str
    distance: float
    texture: float
    replay_distance: float = float("nan")
    pixels_per_cell: float = 1.0
    wavelength_px: float = float("nan")
    replay: np.ndarray | None = None
    run: dict[str, Any] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        return {"model": self.model, "params": self.params, "dx": self.dx,
                "size": list(self.size), "dt": self.dt, "steps": self.steps, "seed": self.seed,
                "invert": self.invert, "family": self.family,
                "search_distance": round(self.distance, 4), "texture": round(self.texture, 4),
                "replay_distance": round(self.replay_distance, 4),
                "wavelength_px": round(self.wavelength_px, 3),
                "pixels_per_cell": round(self.pixels_per_cell, 4)}


OTHER_MODEL_WITHIN = 0.3
"""A runner-up of another model is listed second if its score is within this of the best."""


def pick(samples: Samples, boxes: Sequence[Box], top: int) -> list[int]:
    """Indices of the ``top`` best samples by score: the best, then the best of each other
    model scoring within :data:`OTHER_MODEL_WITHIN` of it, then the next best, skipping any
    within 10 % of a chosen one's ranges in the same model (near copies of one candidate)."""
    widths = {b.model: np.array([g.width for g in b.genes]) for b in boxes}
    score = samples.score
    order = [int(j) for j in np.argsort(score, kind="stable") if samples.distance[j] < 5.0]
    chosen: list[int] = order[:1]
    for i in order:
        if len(chosen) < top and score[i] <= score[order[0]] + OTHER_MODEL_WITHIN and \
                samples.model[i] not in {samples.model[j] for j in chosen}:
            chosen.append(i)
    for i in order:
        near = any(samples.model[j] == samples.model[i]
                   and np.max(np.abs(samples.genome[j] - samples.genome[i])
                              / widths[samples.model[i]]) < 0.1 for j in chosen)
        if len(chosen) < top and not near:
            chosen.append(i)
    return chosen


def answer(samples: Samples, boxes: Sequence[Box], target: Signature, shape: tuple[int, int],
           scale: float, *, top: int, seed: int, journal: Journal,
           progress: Callable[[int], None]) -> list[Candidate]:
    """The ``top`` candidates at the picture's scale, each verified (module docstring).

    Args:
        shape: the picture's field shape ``(H, W)``; ``scale`` its original pixels per pixel.
    """
    by_name = {b.model: b for b in boxes}
    lam_px = target.wavelength * scale
    cells = float(np.clip(lam_px, MIN_CELLS, MAX_CELLS))
    ppc = lam_px / cells
    side = np.array(shape, float) * scale / ppc
    side = side * min(1.0, MAX_SIDE / side.max())
    size = tuple(int(max(32, round(s))) for s in side)
    picks = pick(samples, boxes, top)
    verified = [_verify(by_name[samples.model[i]], samples, i,
                        by_name[samples.model[i]].dx * samples.wavelength[i] / cells, size, seed,
                        target, journal, f"verify-{rank}", progress)
                for rank, i in enumerate(picks)]
    # the replays at the answer's spacing rank the candidates: one that scored best on the
    # search grid can form another pattern (or none) at the picture's scale
    order = sorted(range(len(picks)), key=lambda r: (_finite(verified[r].replay_distance), r))
    out = []
    for r in order:
        cand = verified[r]
        lam = cand.wavelength_px
        if not out and abs(lam / cells - 1.0) > CORRECT_ABOVE:
            i = picks[r]
            cand = _verify(by_name[samples.model[i]], samples, i, cand.dx * lam / cells, size,
                           seed, target, journal, f"verify-{r}-corrected", progress)
        cand.wavelength_px *= ppc
        cand.pixels_per_cell = ppc
        cand.run["matched"] = cand.summary()
        out.append(cand)
    return out


def _finite(x: float) -> float:
    return x if np.isfinite(x) else np.inf


def _verify(box: Box, samples: Samples, i: int, dx: float, size: tuple[int, int], seed: int,
            target: Signature, journal: Journal, key: str,
            progress: Callable[[int], None]) -> Candidate:
    """Simulate one candidate as its ``run.json`` says and measure it (wavelength in cells)."""
    import jax

    from morphogen.models.registry import load_model
    from morphogen.search.evaluate import Evaluator, Problem, policy_problem
    from morphogen.search.genes import genome_params
    from morphogen.search.report import individual_run_file

    model = load_model(box.model)
    params = genome_params(box.genes, samples.genome[i])
    problem = Problem(model=box.model, genes=box.genes, model_source=model.source,
                      params=params, size=size, dx=float(dx), seed=seed, init=model.init)
    problem = policy_problem(problem, time=box.time, model=model)  # the run policy's dt
    genome = np.asarray([samples.genome[i]], np.float32)
    rec = journal.get(key)
    if rec is None or not np.isclose(float(rec["dx"]), dx):
        _, metrics = Evaluator(problem)(genome, jax.random.PRNGKey(seed))
        rec = {"field": metrics["fields"][0], "dx": np.asarray(dx)}
        journal.put(key, rec)
    progress(1)
    f = np.asarray(rec["field"], np.float32)
    invert = samples.invert[i]
    sig = signature(f, periodic=True, invert=invert)
    run = individual_run_file(problem, samples.genome[i])
    run["config"]["cmap"] = "gray_r" if invert else "gray"
    cand = Candidate(model=box.model, params=params, dx=float(dx), size=size, dt=problem.dt,
                     steps=problem.steps, seed=seed, init=model.init, invert=invert,
                     family=sig.family,
                     distance=samples.distance[i], texture=samples.texture[i],
                     replay_distance=distance(sig, target), wavelength_px=sig.wavelength,
                     replay=f, run=run)
    return cand


def grey_tile(f: np.ndarray, invert: bool, side: int, crop: int | None = None) -> np.ndarray:
    """A field as a grey ``(side, side, 3)`` uint8 tile (its centre square, or its centre
    ``crop`` square, resized)."""
    g = normalise(f)
    g = 1.0 - g if invert else g
    return rgb_tile(np.repeat(g[..., None], 3, axis=-1), side, crop)


def rgb_tile(rgb: np.ndarray, side: int, crop: int | None = None,
             centre: tuple[int, int] | None = None) -> np.ndarray:
    """The centre square (side ``crop``, default the shorter side) of RGB ``(H, W, 3)`` in
    ``[0, 1]``, resized to ``(side, side, 3)`` uint8; ``centre`` (row, column) centres it
    there instead, as near as the picture's edges allow."""
    from PIL import Image

    h, w = rgb.shape[:2]
    s = min(h, w, crop or h, crop or w)
    row, col = centre if centre is not None else (h // 2, w // 2)
    top = int(np.clip(row - s // 2, 0, h - s))
    left = int(np.clip(col - s // 2, 0, w - s))
    img = Image.fromarray((np.clip(rgb[top:top + s, left:left + s], 0, 1) * 255).astype(np.uint8))
    return np.asarray(img.resize((side, side), Image.BILINEAR))


def sheet(picture_rgb: np.ndarray, target: Signature, scale: float,
          candidates: Sequence[Candidate], title: str, side: int = 192,
          centre: tuple[int, int] | None = None) -> np.ndarray:
    """Target | best | next best ...: uint8 RGB, every tile showing the same extent of the
    picture's pixels, captioned with its family, wavelength and descriptor distance; the
    target's tile is centred on ``centre`` (row, column) when given (a mesh's picture: a
    point well inside the mesh)."""
    from morphogen.render.mosaic import mosaic

    extent = min(picture_rgb.shape[:2]) * scale
    for c in candidates:
        extent = min(extent, min(c.replay.shape) * c.pixels_per_cell)
    tiles = [rgb_tile(picture_rgb, side, max(1, round(extent / scale)), centre)]
    labels = [f"target: {target.family}, λ {target.wavelength * scale:.1f} px"]
    for k, c in enumerate(candidates, start=1):
        cells = max(1, round(extent / c.pixels_per_cell))
        tiles.append(grey_tile(c.replay, c.invert, side, cells))
        labels.append(f"#{k} {c.model} {c.family}, λ {c.wavelength_px:.1f} px, "
                      f"d {c.replay_distance:.2f}")
    return mosaic(np.stack(tiles), len(tiles), labels=labels, title=title)


def report_text(source: str, target: Signature, scale: float, candidates: Sequence[Candidate],
                samples: Samples, seconds: float, *, pixel_size: float | None = None) -> str:
    """The short text report; with ``pixel_size`` (a mesh target's mesh units per pixel) the
    wavelengths and the answer's cells are quoted in mesh units too."""

    def mesh(px: float) -> str:
        return "" if pixel_size is None else f" ({px * pixel_size:.4g} mesh units)"

    lines = [f"match of {source}",
             f"target: {target.family}, wavelength {target.wavelength * scale:.2f} px"
             f"{mesh(target.wavelength * scale)}, "
             f"spot index {target.spot_index:.2f}, coherence {target.coherence:.2f}, "
             f"covered {target.covered:.2f}",
             f"{len(samples)} candidates simulated in {seconds:.0f} s", ""]
    for k, c in enumerate(candidates, start=1):
        params = ", ".join(f"{n}={v:.5g}" for n, v in c.params.items())
        polarity = " (picture inverted)" if c.invert else ""
        lines.append(f"#{k} {c.model}: {params}; dx={c.dx:.4g}, grid {c.size[0]}x{c.size[1]}, "
                     f"dt={c.dt:g}, {c.steps} steps, seed {c.seed}{polarity}")
        cell = "" if pixel_size is None else \
            f"; a cell is {c.pixels_per_cell * pixel_size:.4g} mesh units"
        lines.append(f"    {c.family}, wavelength {c.wavelength_px:.2f} px{mesh(c.wavelength_px)}"
                     f"{cell}, descriptor distance "
                     f"{c.replay_distance:.3f} (search {c.distance:.3f}, texture {c.texture:.3f});"
                     f" replay: morphogen simulate --config candidate_{k}.json")
    return "\n".join(lines) + "\n"


def write_answer(stage: Path, picture_rgb: np.ndarray, target: Signature, scale: float,
                 candidates: Sequence[Candidate], summary: dict, report: str,
                 centre: tuple[int, int] | None = None) -> None:
    """Write the answer's files into the staging directory ``stage`` (``centre``: see
    :func:`sheet`)."""
    from morphogen.render.images import write_png
    from morphogen.util.io import write_atomic, write_json

    for k, c in enumerate(candidates, start=1):
        write_json(stage / f"candidate_{k}.json", c.run)
        write_png(stage / f"candidate_{k}.png",
                  grey_tile(c.replay, c.invert, max(256, *c.size)))
    if candidates:
        write_json(stage / "run.json", candidates[0].run)
    name = Path(summary["picture"]).name
    title = "match" if summary["picture"] == "array" else f"match: {name}"
    write_png(stage / "sheet.png", sheet(picture_rgb, target, scale, candidates, title,
                                         centre=centre))
    write_json(stage / "match.json", summary)
    write_atomic(stage / "report.txt", lambda fh: fh.write(report.encode()))
