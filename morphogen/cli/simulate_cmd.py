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
    p.add_argument("--size", type=str, default=None, help="grid size, e.g. 256x256 or 64x64x64")
    p.add_argument("--mesh", metavar="FILE.ply", help="simulate on a triangle mesh instead")
    p.add_argument("--dx", type=options.positive_float, default=None, help="cell spacing")
    p.add_argument("--dt", type=options.positive_float, default=None,
                   help="time step (default: the model's suggestion)")
    run_length = p.add_mutually_exclusive_group()
    run_length.add_argument("--steps", type=options.positive_int, help="number of steps")
    run_length.add_argument("--time", type=options.positive_float, help="simulated time")
    p.add_argument("--boundary", action="append", metavar="SPEC",
                   help="periodic | neumann | dirichlet=VALUE, or SPECIES=SPEC (repeatable)")
    p.add_argument("--stencil", choices=options.STENCILS,
                   help="Laplacian: stencil points, or spectral (periodic grids)")
    p.add_argument("--scheme", choices=options.SCHEMES, default=None,
                   help="time stepper (imex, imex1, etdrk4: stiff diffusion on grids; adaptive: "
                   "error-controlled steps; auto: imex when stiff, else euler; see "
                   "docs/schemes.md)")
    p.add_argument("--rtol", type=options.positive_float, default=None,
                   help="relative error tolerance of --scheme adaptive (default 1e-3)")
    p.add_argument("--atol", type=options.positive_float, default=None,
                   help="absolute error tolerance of --scheme adaptive (default 1e-6)")
    p.add_argument("--init", metavar="KIND|FILE",
                   help="uniform, noise, square, blobs, skaggs, seeds, random "
                   "(U[low, high], --init-opt high=2), or a .npz/image file")
    p.add_argument("--init-opt", action="append", metavar="NAME=VALUE",
                   help="option of the initial condition, e.g. count=20, or for blobs "
                   "spacing=16 sigma=2 (cells per blob, width in cells) (repeatable)")
    p.add_argument("--seed", type=options.seed, default=None, help="random seed")
    p.add_argument("-p", "--param", action="append", metavar="NAME=VALUE",
                   help="parameter: a number, an expression of x, y, z, or a .npy field "
                   "(repeatable)")
    p.add_argument("--preset", help="named parameter preset of the model")
    p.add_argument("--noise", metavar="AMP[:KIND[:SPECIES]]",
                   help="additive or multiplicative noise, e.g. 0.01:multiplicative:u")
    p.add_argument("--clamp", metavar="LO:HI|none", help="bound values after each step")
    p.add_argument("--every", type=options.positive_int, help="snapshot every N steps")
    p.add_argument("--species", help="species to draw (default: the model's display species)")
    p.add_argument("--cmap", default=None,
                   help="matplotlib colormap, ramp '#000,#f80,#fff', or transfer function "
                   "'step: #fff < 0.5 < #a00', 'ramp: 0 #fff, 0.3 #f80, 1 #000'")
    p.add_argument("--vmin", type=float, help="colour scale minimum")
    p.add_argument("--vmax", type=float, help="colour scale maximum")
    p.add_argument("--threshold", type=float, help="two-colour map split at this value")
    p.add_argument("--animation", choices=("gif", "mp4"), default=None, help="animation format")
    p.add_argument("--unsafe", action="store_true", help="skip the stability check on dt")
    p.add_argument("--x64", action="store_true", help="compute in float64 (default float32)")
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
        if Path(args.model).suffix.lower() == ".toml" and not Path(args.model).is_file():
            raise MorphogenError(f"model file {args.model} not found")
    else:
        raise MorphogenError("give a model name or file, or --config run.json")
    overrides = {
        "size": options.size(args.size) if args.size else None,
        "mesh": args.mesh,
        "dx": args.dx,
        "dt": args.dt,
        "steps": args.steps,
        "time": args.time,
        "boundary": options.boundary(args.boundary) if args.boundary else None,
        "stencil": options.stencil(args.stencil),
        "scheme": args.scheme,
        "rtol": args.rtol,
        "atol": args.atol,
        "init": args.init,
        "init_options": options.assignments(args.init_opt, "--init-opt") or None,
        "seed": args.seed,
        "params": options.assignments(args.param) or None,
        "preset": args.preset,
        "noise": options.noise(args.noise),
        "every": args.every,
        "species": args.species,
        "cmap": args.cmap,
        "vmin": args.vmin,
        "vmax": args.vmax,
        "threshold": args.threshold,
        "animation": args.animation,
    }
    for key, value in overrides.items():
        if value is not None:
            setattr(config, key, value)
    if args.steps is not None:
        config.time = None
    if args.time is not None:
        config.steps = None
    if args.clamp is not None:
        config.clamp = options.clamp(args.clamp)
    if args.unsafe:
        config.unsafe = True
    if args.x64:
        config.precision = "float64"
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
