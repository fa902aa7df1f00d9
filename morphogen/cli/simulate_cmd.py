"""``morphogen simulate``: run one model and write its state, pictures and ``run.json``."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from morphogen.cli import options
from morphogen.errors import MorphogenError

if TYPE_CHECKING:
    from morphogen.runs.config import RunConfig


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "simulate",
        help="simulate a model on a grid or mesh",
        description="Simulate a library model, a model file (.toml) or a mass-action network "
        "(Antimony .ant, SBML .xml; species diffuse with parameters D_<species>, default 0) "
        "and write DIR/state.npz, "
        "DIR/final.png, DIR/run.json (and DIR/animation.gif with --every).",
    )
    p.add_argument("model", nargs="?", metavar="MODEL_OR_FILE",
                   help="library model name (see `morphogen models`) or a model file")
    p.add_argument("--config", metavar="RUN_JSON", help="reproduce the run described by run.json")
    options.add_run_arguments(p, "simulate")
    p.add_argument("--out", default=None,
                   help="output directory (default out/MODEL; neural:NAME gives out/neural-NAME)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def config_from_args(args: argparse.Namespace) -> RunConfig:
    """A :class:`RunConfig` from command-line arguments (or from ``--config``, with flags
    given on the command line taking precedence)."""
    from morphogen.runs.config import RunConfig, load_run_file

    if args.config:
        config = load_run_file(args.config)
    elif args.model:
        config = RunConfig(model=args.model)
        if Path(args.model).suffix.lower() == ".toml":
            from morphogen.util.io import check_input_file

            check_input_file(args.model, "model file")  # missing, or a folder, FIFO, device
    else:
        raise MorphogenError("give a model name or file, or --config run.json")
    given = options.given_settings(args, "simulate")
    for key, value in given.items():
        setattr(config, key, value)
    if "steps" in given:
        config.time = None
    if "time" in given:
        config.steps = None
    return config


def run(args: argparse.Namespace) -> int:
    from morphogen.runs.execute import execute

    config = config_from_args(args)
    out = Path(args.out or Path("out") / Path(config.model).stem.replace(":", "-"))
    solution = execute(config, out, progress=options.show_progress(args))
    rejected = "" if solution.rejected_steps is None else f", {solution.rejected_steps} rejected"
    print(f"wrote {out}/ ({solution.steps} steps{rejected}, t={solution.t:g}, "
          f"{solution.wall_time:.1f} s)")
    return 0
