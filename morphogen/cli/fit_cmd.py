"""``morphogen fit``: fit a model's parameters to a target image by gradient descent through the
simulator (the gradient strategy beside GA and CMA-ES)."""

from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

import numpy as np

from morphogen.cli import options
from morphogen.errors import MorphogenError
from morphogen.learn.extractors import EXTRACTORS
from morphogen.models.registry import load_model
from morphogen.search.evaluate import Problem, policy_problem
from morphogen.search.genes import Gene, check_genes
from morphogen.search.gradient import (
    GradientAscent,
    GradientEvaluator,
    field_image,
    fit,
    target_field_image,
)
from morphogen.util.io import (
    check_input_file,
    check_writable_dir,
    ensure_writable_dir,
    write_atomic,
    write_json,
)
from morphogen.util.progress import ProgressBar


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "fit",
        help="fit model parameters to a target image by gradient descent",
        description="Fit the parameters (genes) of a library model or model file so that its "
        "pattern matches the texture of IMAGE, by gradient descent through the simulator on a "
        "rotation-invariant texture loss. Each population member is an independent start "
        "point. Writes DIR/fit.json, DIR/loss.png and DIR/best.png.",
    )
    p.add_argument("model", metavar="MODEL_OR_FILE", help="library model name or model file")
    p.add_argument("--target", required=True, metavar="IMAGE", help="target pattern image")
    p.add_argument("--gene", action="append", required=True, metavar="NAME=LOW:HIGH[:SIGMA]",
                   help="fitted parameter and its bounds (repeatable)")
    p.add_argument("--population", type=options.positive_int, default=2,
                   help="number of start points (at least 2)")
    p.add_argument("--iterations", type=options.positive_int, default=40)
    p.add_argument("--learning-rate", type=options.positive_float, default=0.03,
                   help="Adam step as a fraction of each gene's range")
    p.add_argument("--start", choices=("centre", "uniform"), default="centre",
                   help="start at the centre of the bounds (spread by sigma) or uniformly")
    options.add_run_arguments(p, "fit")
    p.add_argument("--features", choices=EXTRACTORS, default="random", help="texture descriptors")
    p.add_argument("--n-rot", type=options.positive_int, default=8,
                   help="target orientations of the rotation-invariant loss")
    p.add_argument("--out", help="output directory (default out/fit/MODEL)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


DEFAULTS = {"size": [64, 64], "steps": 400}
"""``fit``'s own defaults of run settings (400 steps: short-ish keeps the loss landscape
smooth)."""


def problem_from_args(args: argparse.Namespace) -> Problem:
    """The fitting problem described by the command line (validated)."""
    model = load_model(args.model)
    genes = tuple(Gene.parse(g) for g in args.gene)
    check_genes(genes, list(model.params))
    check_input_file(args.target, "target image", limit=float("inf"))  # a FIFO named, too
    run = options.run_settings(args, "fit", DEFAULTS)
    problem = Problem(
        model=args.model, genes=genes, model_source=model.source, preset=run["preset"],
        params=run["params"], size=tuple(run["size"]), stencil=run["stencil"],
        scheme=run["scheme"], seed=run["seed"],
        init=run["init"] or model.init, init_options=run["init_options"], fitness="target",
        target=str(Path(args.target).absolute()),
    )
    return policy_problem(problem, dt=run["dt"], steps=run["steps"], time=run.get("time"),
                          model=model)


def run(args: argparse.Namespace) -> int:
    if args.population < 2:
        raise MorphogenError("--population must be at least 2")
    problem = problem_from_args(args)
    out = check_writable_dir(args.out or Path("out") / "fit" / Path(args.model).stem)
    strategy = GradientAscent(population_size=args.population,
                              learning_rate=args.learning_rate, start=args.start)
    evaluate = GradientEvaluator(problem, features=args.features, n_rot=args.n_rot)
    bar = ProgressBar(args.iterations, enabled=options.show_progress(args), unit="it",
                      desc="fit")

    def report(i: int, genomes: np.ndarray, fitness: np.ndarray) -> None:
        bar.update(1)
        if args.quiet or options.show_progress(args):
            return
        best = int(np.nanargmax(fitness)) if np.isfinite(fitness).any() else 0
        genes = ", ".join(f"{g.name}={v:.5g}" for g, v in zip(problem.genes, genomes[best],
                                                               strict=True))
        sys.stderr.write(f"iteration {i + 1}: loss {-fitness[best]:.4g} at {genes}\n")

    try:
        result = fit(evaluate, strategy, problem.genes, iterations=args.iterations,
                     seed=problem.seed, callback=report)
    finally:
        bar.close()
    if not np.isfinite(result.best_fitness):
        raise MorphogenError("every iteration of the fit gave a NaN or infinite loss; try a "
                             "smaller --learning-rate, another --start or fewer --steps")
    best = {g.name: float(v) for g, v in zip(problem.genes, result.best_genome, strict=True)}
    ensure_writable_dir(out)  # only once the fit has passed its checks and finished
    write_json(out / "fit.json", {
        "best": best,
        "best_loss": -result.best_fitness,
        "problem": problem.to_dict(),
        "strategy": {"name": "gradient", "population": args.population,
                     "learning_rate": args.learning_rate, "start": args.start},
        "features": args.features,
        "n_rot": args.n_rot,
        "history": {"genomes": result.genomes, "loss": -result.fitness},
    })
    write_loss_plot(out / "loss.png", -result.fitness)
    write_best_image(out / "best.png", evaluate, result.best_genome)
    summary = ", ".join(f"{k}={v:.6g}" for k, v in best.items())
    print(f"best loss {-result.best_fitness:.4g}: {summary}; wrote {out}/")
    return 0


def write_loss_plot(path: Path, loss: np.ndarray) -> None:
    """Loss of every start point per iteration (log scale)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.5), dpi=100)
    its = np.arange(1, loss.shape[0] + 1)
    for j in range(loss.shape[1]):
        ax.semilogy(its, loss[:, j], lw=1.2, label=f"start {j}")
    ax.set_xlabel("iteration")
    ax.set_ylabel("texture loss")
    ax.legend(loc="upper right", fontsize="small")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    write_atomic(path, lambda fh: fh.write(buf.getvalue()))


def write_best_image(path: Path, evaluate: GradientEvaluator, genome: np.ndarray) -> None:
    """Target (standardised grey) beside the best genome's pattern, shown the same way."""
    import jax

    from morphogen.learn.textures import to_uint8
    from morphogen.render import write_png

    genomes = np.stack([genome, genome]).astype(np.float32)
    _, metrics = evaluate(genomes, jax.random.PRNGKey(0))
    fitted = to_uint8(np.asarray(field_image(metrics["fields"][0])))
    target = to_uint8(target_field_image(evaluate.problem.target))
    h = max(fitted.shape[0], target.shape[0])
    tiles = [np.pad(t, ((0, h - t.shape[0]), (0, 4), (0, 0)), constant_values=255)
             for t in (target, fitted)]
    image = np.concatenate(tiles, axis=1)
    write_png(path, np.repeat(np.repeat(image, 3, axis=0), 3, axis=1))
