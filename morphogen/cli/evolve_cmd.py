"""``morphogen evolve``: search a model's parameters with a GA or CMA-ES, or resume a search."""

from __future__ import annotations

import argparse
from pathlib import Path

from morphogen.cli import options
from morphogen.errors import MorphogenError
from morphogen.models.registry import load_model
from morphogen.search.archive import Archive
from morphogen.search.evaluate import FITNESS_KINDS, Problem
from morphogen.search.executors import EXECUTORS, make_executor
from morphogen.search.fitness import ask_selection
from morphogen.search.genes import Gene, check_genes, preset_genes
from morphogen.search.run import STRATEGIES, evolve, resolve_run, start


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "evolve",
        help="search model parameters with a genetic algorithm, CMA-ES or gradient ascent",
        description="Evolve the parameters (genes) of a model toward a fitness: modified "
        "Dirichlet energy, a person's choice, or a target image (the gradient strategy fits a "
        "target image by gradient descent through the simulator). Writes a run directory "
        "(contact sheets, fitness plot, best individuals) and indexes it in the run archive.",
    )
    p.add_argument("model", nargs="?", metavar="MODEL_OR_FILE",
                   help="library model name or model file (not with --resume)")
    p.add_argument("--gene", action="append", metavar="NAME=LOW:HIGH[:SIGMA]",
                   help="searched parameter and its range (repeatable; default: Skaggs's "
                   "genes for gray-scott, gierer-meinhardt, genrd)")
    p.add_argument("--strategy", choices=tuple(STRATEGIES), default="ga")
    p.add_argument("--fitness", choices=FITNESS_KINDS, default="dirichlet")
    p.add_argument("--target", metavar="IMAGE", help="target image for --fitness target")
    p.add_argument("--population", type=options.positive_int, default=30)
    p.add_argument("--generations", type=options.positive_int, default=10)
    p.add_argument("--elitism", type=int, default=0, help="GA: best individuals kept as is")
    p.add_argument("--tournament", type=int, default=0,
                   help="GA: tournament size (default 0: fitness-proportionate selection)")
    p.add_argument("--sigma-init", type=options.positive_float, default=0.25,
                   help="CMA-ES: initial step as a fraction of each gene's range")
    p.add_argument("--learning-rate", type=options.positive_float, default=0.02,
                   help="gradient: Adam step as a fraction of each gene's range")
    p.add_argument("--size", default="128x128", help="grid size: N, NxM or NxMxK")
    p.add_argument("--dx", type=options.positive_float, default=1.0, help="cell spacing")
    p.add_argument("--dt", type=options.positive_float, help="time step (default: the model's)")
    length = p.add_mutually_exclusive_group()
    length.add_argument("--steps", type=options.positive_int, help="steps per individual")
    length.add_argument("--time", type=options.positive_float, help="simulated time T")
    p.add_argument("--boundary", action="append", metavar="SPEC",
                   help="periodic | neumann | dirichlet=VALUE, or SPECIES=SPEC")
    p.add_argument("--stencil", choices=options.STENCILS,
                   help="Laplacian: stencil points, or spectral (periodic grids)")
    p.add_argument("--scheme", choices=options.POPULATION_SCHEMES, default="euler",
                   help="time stepper (imex, imex1, etdrk4: stiff diffusion on grids; auto: imex "
                   "when stiff, else euler; see docs/schemes.md)")
    p.add_argument("--init", metavar="KIND|FILE",
                   help="initial condition (default: the model's; Skaggs used 'skaggs')")
    p.add_argument("--init-opt", action="append", metavar="NAME=VALUE")
    p.add_argument("-p", "--param", action="append", metavar="NAME=VALUE",
                   help="fixed parameter value (repeatable)")
    p.add_argument("--preset", help="named parameter preset of the model")
    p.add_argument("--clamp", metavar="LO:HI|none", help="bound values after each step")
    p.add_argument("--seed", type=options.seed, default=0)
    p.add_argument("--cmap", default="viridis", help="colour map of the pictures")
    p.add_argument("--out", help="run directory (default: next to the archive, named by id)")
    p.add_argument("--resume", metavar="RUN", help="continue a run: its directory or id")
    p.add_argument("--archive", help="run archive (default $MORPHOGEN_ARCHIVE or "
                   "runs/index.sqlite)")
    p.add_argument("--executor", choices=EXECUTORS, default="local")
    p.add_argument("--address", help="Ray cluster address (default: start a local Ray)")
    p.add_argument("--batches", type=options.positive_int,
                   help="Ray tasks per generation (default: one per CPU)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def problem_from_args(args: argparse.Namespace) -> Problem:
    """The evaluation problem described by the command line (validated)."""
    model = load_model(args.model)
    if args.gene:
        genes = tuple(Gene.parse(g) for g in args.gene)
    else:
        genes = tuple(preset_genes(model.name, list(model.params)))
    check_genes(genes, list(model.params))
    dt = float(args.dt if args.dt is not None else model.dt)
    steps = args.steps if args.steps is not None else round((args.time or model.t_end) / dt)
    size = args.size if "x" in args.size.lower() else f"{args.size}x{args.size}"
    problem = Problem(
        model=args.model, genes=genes, model_source=model.source, preset=args.preset,
        params=options.assignments(args.param), size=tuple(options.size(size)), dx=args.dx,
        boundary=options.boundary(args.boundary), stencil=options.stencil(args.stencil), dt=dt,
        steps=max(1, int(steps)), scheme=args.scheme, clamp=options.clamp(args.clamp),
        seed=args.seed, init=args.init or model.init,
        init_options=options.assignments(args.init_opt, "--init-opt"), fitness=args.fitness,
        target=str(Path(args.target).absolute()) if args.target else None,
    )
    if args.fitness != "target" and args.target:
        raise MorphogenError("--target is used only with --fitness target")
    return problem


def strategy_from_args(args: argparse.Namespace) -> dict:
    spec = {"name": args.strategy, "population": args.population}
    if args.strategy == "ga":
        spec.update(elitism=args.elitism, tournament=args.tournament)
    elif args.strategy == "cmaes":
        spec["sigma_init"] = args.sigma_init
    elif args.strategy == "gradient":
        spec["learning_rate"] = args.learning_rate
    return spec


def run(args: argparse.Namespace) -> int:
    if args.resume and args.model:
        raise MorphogenError("give either MODEL_OR_FILE for a new run or --resume RUN, not both")
    if not args.resume and not args.model:
        raise MorphogenError("give a model name or file, or --resume RUN")
    if args.executor != "ray" and (args.address or args.batches):
        raise MorphogenError("--address and --batches need --executor ray")
    ray_options = {"address": args.address, "batches": args.batches}
    options_for = ray_options if args.executor == "ray" else {}
    if args.resume:
        run_id, archive = resolve_run(args.resume, args.archive)
        stored = archive.run(run_id)
        config = stored["config"]
        if isinstance(config, dict) and config.get("kind") == "networks":
            from morphogen.search.networks.record import resume_hint

            raise MorphogenError(resume_hint(run_id, stored["dir"]))
        try:
            problem = Problem.from_dict(config["problem"])
            gradient = STRATEGIES[config["strategy"]["name"]].needs_gradient
        except MorphogenError:
            raise
        except (KeyError, TypeError, ValueError, AttributeError):
            raise MorphogenError(
                f"run {run_id} has a damaged stored configuration; it cannot be resumed"
            ) from None
        executor = make_executor(args.executor, problem, gradient=gradient, **options_for)
    else:
        problem = problem_from_args(args)
        strategy = strategy_from_args(args)
        gradient = STRATEGIES[strategy["name"]].needs_gradient
        executor = make_executor(args.executor, problem, gradient=gradient,
                                 **options_for)  # validates first
        archive = Archive(args.archive)
        run_id, _ = start(problem, strategy, generations=args.generations, seed=args.seed,
                          out=args.out, archive=archive, cmap=args.cmap)
    print(f"run {run_id} in {archive.run(run_id)['dir']}", flush=True)
    result = evolve(run_id, archive, executor, select=ask_selection,
                    progress=options.show_progress(args), log=lambda line: print(line, flush=True))
    genes = gene_summary([g.name for g in problem.genes], result.best_genome)
    print(f"best fitness {result.best_fitness:.4f}: {genes}; see {result.directory}/best/")
    return 0


def gene_summary(names: list[str], values, limit: int = 8) -> str:
    """``F=0.0272, k=0.0516``; past ``limit`` genes, the count of the others."""
    shown = ", ".join(f"{n}={v:.6g}" for n, v in zip(names[:limit], values[:limit], strict=True))
    return shown + (f", ... ({len(names) - limit} more)" if len(names) > limit else "")
