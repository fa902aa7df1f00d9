"""``morphogen match`` on pictures of known origin, against random search in the same run.

Targets are simulated from known models and parameters (not presets) on a 128² torus from
another initial condition than the search's, then degraded as a photograph would be: every
target is recoloured through a colour map and turned, and gets one more degradation in turn
(rescaled x0.6 or x1.8, blurred, noisy, JPEG-compressed, cropped). Per target:

- **match**: :func:`morphogen.match.match` with the default models and ``BUDGET`` simulations;
- **baseline**: random search of the same models with the same number of simulations (split
  evenly, uniform in the same boxes, through the same batched evaluator), the best chosen by
  today's target fitness (:func:`morphogen.search.fitness.target_fitness`: spectrum and
  histogram earth mover's distances to the picture resized to the grid, Skaggs §6.4), at the
  scale that fitness implies (the picture is stretched over the 64² grid).

Reported: whether the model and the family (of the clean target, by the same descriptors) are
found, the family the degraded picture itself reads as, the relative wavelength error in the
picture's pixels, for the right model the mean parameter error in units of the box's ranges,
and the wall time (2 shared CPU cores). Writes
``bench/results/match.json``; ``--quick`` runs the first targets only; ``--markdown`` prints
docs/match.md's tables from the results. Each finished target is
also appended to ``match.json.partial``, so an interrupted run resumes where it stopped.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import time
from pathlib import Path

import numpy as np

BUDGET = 64
TARGETS = [  # model, genes, expected regime (the measured family is what counts): the five
    # default models, five regimes each, chosen from a 5 x 5 survey of each box at these settings
    ("gray-scott", {"F": 0.035, "k": 0.064}, "spots"),
    ("gray-scott", {"F": 0.032, "k": 0.058}, "stripes"),
    ("gray-scott", {"F": 0.042, "k": 0.059}, "holes"),
    ("gray-scott", {"F": 0.045, "k": 0.0625}, "stripes"),
    ("gray-scott", {"F": 0.029, "k": 0.055}, "holes"),
    ("fitzhugh-nagumo", {"alpha": 0.0, "epsilon": 2.5}, "stripes"),
    ("fitzhugh-nagumo", {"alpha": -0.15, "epsilon": 4.5}, "spots"),
    ("fitzhugh-nagumo", {"alpha": 0.15, "epsilon": 4.5}, "holes"),
    ("fitzhugh-nagumo", {"alpha": -0.27, "epsilon": 2.3}, "spots"),
    ("fitzhugh-nagumo", {"alpha": -0.27, "epsilon": 7.7}, "stripes"),
    ("schnakenberg", {"a": 0.1, "b": 0.9}, "spots"),
    ("schnakenberg", {"a": 0.034, "b": 1.54}, "spots"),
    ("schnakenberg", {"a": 0.223, "b": 1.54}, "mixed"),
    ("schnakenberg", {"a": 0.286, "b": 0.46}, "stripes"),
    ("schnakenberg", {"a": 0.286, "b": 1.54}, "stripes"),
    ("turing", {"alpha": 16.0, "beta": 13.8}, "stripes"),
    ("turing", {"alpha": 14.2, "beta": 11.1}, "holes"),
    ("turing", {"alpha": 16.0, "beta": 12.9}, "mixed"),
    ("turing", {"alpha": 14.2, "beta": 12.9}, "spots"),
    ("turing", {"alpha": 19.6, "beta": 11.1}, "stripes"),
    ("brusselator", {"a": 2.2, "b": 4.4}, "spots"),
    ("brusselator", {"a": 4.0, "b": 6.2}, "holes"),
    ("brusselator", {"a": 4.0, "b": 8.0}, "mixed"),
    ("brusselator", {"a": 3.1, "b": 11.6}, "spots"),
    ("brusselator", {"a": 4.9, "b": 4.4}, "stripes"),
]
EXTRA = ["rescale x0.6", "rescale x1.8", "blur", "noise", "jpeg", "crop"]
CMAPS = ["viridis", "magma", "cividis", "copper", "bone", "plasma"]


def simulate_target(model: str, genes: dict, size: int = 128, seed: int = 11):
    """The clean target: the display species ``(size, size)`` and its signature."""
    import jax

    from morphogen.match.boxes import BOXES
    from morphogen.match.signature import signature
    from morphogen.models.registry import load_model
    from morphogen.search.evaluate import Evaluator, Problem

    box = BOXES[model]
    m = load_model(model)
    problem = Problem(model=model, genes=box.genes, size=(size, size), dx=box.dx,
                      dt=float(m.dt), steps=round((box.time or m.t_end) / m.dt), seed=seed,
                      init=m.init)
    genome = np.array([[genes[g.name] for g in box.genes]], np.float32)
    _, metrics = Evaluator(problem)(genome, jax.random.PRNGKey(seed))
    f = metrics["fields"][0]
    return f, signature(f, periodic=True)


def degrade(f: np.ndarray, k: int) -> tuple[np.ndarray, float, str]:
    """Picture RGB ``(H, W, 3)`` uint8, its scale (picture pixels per cell) and a label."""
    from matplotlib import colormaps
    from PIL import Image
    from scipy import ndimage

    rng = np.random.default_rng(k)
    big = np.tile(f, (3, 3))
    angle = 15.0 + 25.0 * (k % 3)
    g = ndimage.rotate(big, angle, reshape=False, order=1)
    c = big.shape[0] // 4
    g = g[c:-c, c:-c]
    extra = EXTRA[k % len(EXTRA)]
    scale = 1.0
    if extra.startswith("rescale"):
        scale = float(extra.split("x")[1])
        g = ndimage.zoom(g, scale, order=1)
    g = (g - g.min()) / np.ptp(g)
    if extra == "blur":
        g = ndimage.gaussian_filter(g, 1.5)
    if extra == "noise":
        g = np.clip(g + rng.normal(0, 0.12, g.shape), 0, 1)
    if extra == "crop":
        g = g[10:10 + 96, 30:30 + 140]
    rgb = (colormaps[CMAPS[k % len(CMAPS)]](g)[..., :3] * 255).astype(np.uint8)
    if extra == "jpeg":
        buf = io.BytesIO()
        Image.fromarray(rgb).save(buf, format="JPEG", quality=35)
        rgb = np.asarray(Image.open(io.BytesIO(buf.getvalue())).convert("RGB"))
    return rgb, scale, f"{CMAPS[k % len(CMAPS)]}, turned {angle:.0f}°, {extra}"


def baseline(rgb: np.ndarray, models, budget: int, seed: int = 0) -> dict:
    """Random search at the same budget, best by today's target fitness (module docstring)."""
    import jax
    import jax.numpy as jnp

    from morphogen.match.boxes import BOXES, SEARCH_SIZE
    from morphogen.match.picture import load_picture
    from morphogen.match.search import Scorer
    from morphogen.match.signature import signature
    from morphogen.search import fitness as fit

    picture = load_picture(rgb.astype(np.float32) / 255.0)
    from PIL import Image

    grey = Image.fromarray((picture.field * 255).astype(np.uint8)).resize(
        (SEARCH_SIZE, SEARCH_SIZE), Image.BILINEAR)
    target = np.asarray(grey, np.float32) / 255.0
    each = max(2, budget // len(models))
    best = (-np.inf, None)
    for m, name in enumerate(models):
        box = BOXES[name]
        scorer = Scorer(box, None, picture.field, "auto", seed)  # the cached evaluator only
        low = np.array([g.low for g in box.genes])
        high = np.array([g.high for g in box.genes])
        genomes = np.random.default_rng([seed, 9, m]).uniform(low, high, (each, len(low)))
        _, metrics = scorer.evaluator(genomes.astype(np.float32), jax.random.PRNGKey(seed))
        score = jax.jit(fit.target_fitness(target, 0))(
            jnp.asarray(metrics["fields"])[:, None])
        score = np.where(metrics["valid"], np.asarray(score), -1.0)
        i = int(np.argmax(score))
        if score[i] > best[0]:
            best = (float(score[i]), (name, genomes[i], metrics["fields"][i]))
    name, genome, field = best[1]
    sig = signature(field, periodic=True)
    px_per_cell = min(picture.field.shape) * picture.scale / SEARCH_SIZE
    return {"model": name, "genome": genome, "family": sig.family,
            "wavelength_px": sig.wavelength * px_per_cell}


def _genes_text(genes: dict) -> str:
    return ", ".join(f"{k}={v:g}" for k, v in genes.items())


def markdown(record: dict) -> str:
    """docs/match.md's per-target table and summary from a results record."""
    pct = lambda x: f"{100 * x:.1f} %" if x < 0.1 else f"{100 * x:.0f} %"  # noqa: E731
    lines = ["| # | truth | family | picture | read as | λ px | match: model, family | λ err "
             "| param err | s | baseline: model, family | λ err |", "|" + "---|" * 12]
    for r in record["targets"]:
        m, b = r["match"], r["baseline"]
        err = "–" if m["param_error"] is None else f"{m['param_error']:.2f}"
        lines.append(f"| {r['target']} | {r['model']} {_genes_text(r['genes'])} | {r['family']} "
                     f"| {r['degraded']} | {r.get('picture_family', '?')} "
                     f"| {r['wavelength_px']:.1f} | {m['model']}, {m['family']} "
                     f"| {pct(m['wavelength_error'])} | {err} | {m['seconds']:.0f} "
                     f"| {b['model']}, {b['family']} | {pct(b['wavelength_error'])} |")
    n = len(record["targets"])
    lines += ["", "| | right family | right model | wavelength within 10 % | median wavelength "
              "error | median time per picture |", "|---|---|---|---|---|---|"]
    for who, label in (("match", "`match`"), ("baseline", "random search, target fitness")):
        x = record["summary"][who]
        lines.append(f"| {label} | {pct(x['right_family'])} ({round(x['right_family'] * n)}/{n}) "
                     f"| {pct(x['right_model'])} ({round(x['right_model'] * n)}/{n}) "
                     f"| {pct(x['wavelength_within_10pct'])} "
                     f"| {pct(x['median_wavelength_error'])} | {x['median_seconds']:.0f} s |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--markdown", action="store_true",
                        help="print docs/match.md's tables from --out and stop")
    parser.add_argument("--quick", type=int, default=0, help="only the first N targets")
    parser.add_argument("--budget", type=int, default=BUDGET)
    parser.add_argument("--out", default="bench/results/match.json")
    parser.add_argument("--sheets", default=None, help="write each answer's sheet here")
    args = parser.parse_args()
    if args.markdown:
        print(markdown(json.loads(Path(args.out).read_text())))
        return
    from morphogen.match import DEFAULT_MODELS, match
    from morphogen.match.boxes import BOXES

    targets = TARGETS[: args.quick] if args.quick else TARGETS
    # finished targets are kept in OUT.partial (a JSON line each): an interrupted run resumes
    partial = Path(args.out + ".partial")
    done = {}
    if partial.is_file():
        for line in partial.read_text().splitlines():
            row = json.loads(line)
            if row.get("budget") == args.budget:
                done[row["target"]] = row
    rows = []
    for k, (model, genes, regime) in enumerate(targets):
        if k in done and done[k]["model"] == model and done[k]["genes"] == genes:
            rows.append(done[k])
            continue
        field, truth = simulate_target(model, genes)
        rgb, scale, label = degrade(field, k)
        lam_true = truth.wavelength * scale
        out = Path(args.sheets) / f"target_{k}" if args.sheets else None
        t0 = time.perf_counter()
        result = match(rgb.astype(np.float32) / 255.0, budget=args.budget, out=out)
        t_match = time.perf_counter() - t0
        t0 = time.perf_counter()
        base = baseline(rgb, DEFAULT_MODELS, args.budget)
        t_base = time.perf_counter() - t0
        best = result.best
        widths = np.array([g.width for g in BOXES[model].genes])
        names = [g.name for g in BOXES[model].genes]
        truth_g = np.array([genes[n] for n in names])
        param_err = (float(np.mean(np.abs(np.array([best.params[n] for n in names]) - truth_g)
                                   / widths)) if best.model == model else None)
        base_err = (float(np.mean(np.abs(base["genome"] - truth_g) / widths))
                    if base["model"] == model else None)
        row = {
            "target": k, "model": model, "genes": genes, "regime": regime,
            "family": truth.family, "degraded": label, "wavelength_px": round(lam_true, 2),
            "picture_family": result.target.family,
            "match": {"model": best.model, "family": best.family, "invert": best.invert,
                      "params": best.params, "wavelength_px": round(best.wavelength_px, 2),
                      "wavelength_error": round(abs(best.wavelength_px / lam_true - 1), 4),
                      "param_error": param_err, "seconds": round(t_match, 1)},
            "baseline": {"model": base["model"], "family": base["family"],
                         "wavelength_px": round(base["wavelength_px"], 2),
                         "wavelength_error": round(abs(base["wavelength_px"] / lam_true - 1), 4),
                         "param_error": base_err, "seconds": round(t_base, 1)},
        }
        rows.append(row)
        print(json.dumps(row), flush=True)
        partial.parent.mkdir(parents=True, exist_ok=True)
        with partial.open("a") as f:
            f.write(json.dumps({**row, "budget": args.budget}) + "\n")
    summary = {}
    for who in ("match", "baseline"):
        r = [row[who] for row in rows]
        summary[who] = {
            "right_family": float(np.mean([x["family"] == row["family"]
                                           for x, row in zip(r, rows, strict=True)])),
            "right_model": float(np.mean([x["model"] == row["model"]
                                          for x, row in zip(r, rows, strict=True)])),
            "wavelength_within_10pct": float(np.mean([x["wavelength_error"] <= 0.1 for x in r])),
            "median_wavelength_error": float(np.median([x["wavelength_error"] for x in r])),
            "median_seconds": float(np.median([x["seconds"] for x in r])),
        }
    record = {"budget": args.budget, "targets": rows, "summary": summary,
              "load_average": os.getloadavg(), "cpus": os.cpu_count()}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(args.out + ".tmp")
    tmp.write_text(json.dumps(record, indent=1) + "\n")
    tmp.replace(args.out)
    partial.unlink(missing_ok=True)
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
