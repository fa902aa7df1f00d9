"""``morphogen evolve``: search a model's parameters with a GA or CMA-ES, or resume a search."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from morphogen.cli import options
from morphogen.errors import MorphogenError
from morphogen.models.registry import load_model
from morphogen.search.archive import Archive, archive_path
from morphogen.search.evaluate import FITNESS_KINDS, SEARCH_SIZE, Problem, policy_problem
from morphogen.search.executors import EXECUTORS, make_executor, split_notice
from morphogen.search.fitness import ask_selection
from morphogen.search.genes import Gene, check_genes, preset_genes
from morphogen.search.run import (
    STRATEGIES,
    check_resumable,
    evolve,
    make_strategy,
    resolve_run,
    set_generations,
    start,
)
from morphogen.util.guard import LIMITS, check_count, check_numbers, check_steps
from morphogen.util.io import check_image


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
    p.add_argument("--generations", type=options.positive_int,
                   help=f"generations to run (default {GENERATIONS}); with --resume, the run's "
                   "new total: more extends it, and it may not be below the generations done")
    p.add_argument("--elitism", type=int, default=0, help="GA: best individuals kept as is")
    p.add_argument("--tournament", type=int, default=0,
                   help="GA: tournament size (default 0: fitness-proportionate selection)")
    p.add_argument("--sigma-init", type=options.positive_float, default=0.25,
                   help="CMA-ES: initial step as a fraction of each gene's range")
    p.add_argument("--learning-rate", type=options.positive_float, default=0.02,
                   help="gradient: Adam step as a fraction of each gene's range")
    options.add_run_arguments(p, "evolve")
    p.add_argument("--out", help="run directory (default: next to the archive, named by id)")
    p.add_argument("--resume", metavar="RUN", help="continue a run: its directory or id")
    p.add_argument("--archive", help="run archive (default $MORPHOGEN_ARCHIVE or "
                   "runs/index.sqlite)")
    p.add_argument("--executor", choices=EXECUTORS, default="auto",
                   help="auto (default): one Ray worker per core when a generation is large "
                   "and Ray is installed, else this process; local; ray")
    p.add_argument("--address", help="Ray cluster address (default: start a local Ray)")
    p.add_argument("--batches", type=options.positive_int,
                   help="Ray tasks per generation (default: one per CPU)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)
    NEW_RUN_DEFAULTS.update(vars(p.parse_args([])))


NEW_RUN_DEFAULTS: dict = {}
"""Every option's default, recorded when the parser is built: with ``--resume`` an option that
sets up a new run must keep it (the run keeps the settings it was started with)."""
RESUME_OPTIONS = ("generations", "archive", "executor", "address", "batches", "quiet")
"""The options that apply to a resumed run (besides ``--resume`` itself)."""
GENERATIONS = 10
"""Generations of a new run unless ``--generations`` says otherwise."""
DEFAULTS = {"size": list(SEARCH_SIZE), "cmap": "viridis"}
"""``evolve``'s own defaults of run settings (the others are the table's)."""


def problem_from_args(args: argparse.Namespace) -> Problem:
    """The evaluation problem described by the command line (validated)."""
    model = load_model(args.model)
    if args.gene:
        genes = tuple(Gene.parse(g) for g in args.gene)
    else:
        genes = tuple(preset_genes(model.name, list(model.params)))
    check_genes(genes, list(model.params))
    if args.size and "x" not in args.size.lower():
        args.size = f"{args.size}x{args.size}"  # evolve takes N for an N x N grid
    run = options.run_settings(args, "evolve", DEFAULTS)
    problem = Problem(
        model=args.model, genes=genes, model_source=model.source, preset=run["preset"],
        params=run["params"], size=tuple(run["size"]), dx=run["dx"], boundary=run["boundary"],
        stencil=run["stencil"], scheme=run["scheme"],
        clamp=run["clamp"], seed=run["seed"], init=run["init"] or model.init,
        init_options=run["init_options"], fitness=args.fitness,
        target=str(Path(args.target).absolute()) if args.target else None,
    )
    problem = policy_problem(problem, dt=run["dt"], steps=run["steps"], time=run["time"],
                             model=model)
    if args.fitness != "target" and args.target:
        raise MorphogenError("--target is used only with --fitness target")
    if args.target:
        check_image(args.target, "target image")
    population = check_count(args.population, "--population", 1, LIMITS.batch)
    cells = math.prod(problem.size)
    check_numbers(2 * population * len(model.species) * cells,
                  f"a population of {population} on {cells:,} cells",
                  "use a smaller --population or --size")
    check_steps(problem.steps * (args.generations or GENERATIONS), cells, len(model.species),
                batch=population)  # the whole search's cell updates
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
        _refuse_new_run_options(args)
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
        check_resumable(run_id, archive)  # before --generations changes the record
        if args.generations is not None:
            set_generations(run_id, archive, args.generations)
        executor = make_executor(args.executor, problem, gradient=gradient,
                                 population=int(config["strategy"].get("population", 1)),
                                 **options_for)
    else:
        problem = problem_from_args(args)
        if problem.fitness == "user" and not stdin_can_answer():
            raise MorphogenError("--fitness user asks for each generation's favourites on "
                                 "standard input, which is empty or not a terminal that can "
                                 "answer; run it in a terminal, or pipe the selections in")
        strategy = strategy_from_args(args)
        gradient = STRATEGIES[strategy["name"]].needs_gradient
        executor = make_executor(args.executor, problem, gradient=gradient,
                                 population=args.population, **options_for)  # validates first
        make_strategy(strategy)  # checks --population, --elitism, --tournament
        new_archive = [p for p in (archive_path(args.archive), archive_path(args.archive).parent)
                       if not p.exists()]
        new_folder = not (args.out and Path(args.out).exists())
        archive = Archive(args.archive)
        run_id, _ = start(problem, strategy, generations=args.generations or GENERATIONS,
                          seed=problem.seed,
                          out=args.out, archive=archive, cmap=args.cmap or DEFAULTS["cmap"])
    print(f"run {run_id} in {archive.run(run_id)['dir']}", flush=True)
    if args.executor == "auto" and executor.name == "ray":
        print(split_notice(executor.batches), flush=True)
    try:
        result = evolve(run_id, archive, executor, select=ask_selection,
                        progress=options.show_progress(args),
                        log=lambda line: print(line, flush=True))
    except MorphogenError:
        if not args.resume and not archive.generations(run_id):
            _forget(run_id, archive, new_archive, new_folder)  # refused before generation 1
        raise
    genes = gene_summary([g.name for g in problem.genes], result.best_genome)
    print(f"best fitness {result.best_fitness:.4f}: {genes}; see {result.directory}/best/")
    return 0


def stdin_can_answer() -> bool:
    """Whether standard input may still bring a person's answer: ``False`` when it is closed,
    a device that is not a terminal (``/dev/null``), a file read to its end, or a pipe whose
    writer has closed without writing; ``True`` otherwise (a terminal, a pipe still open)."""
    import os
    import select
    import stat
    import sys

    stream = sys.stdin
    if stream is None or stream.closed:
        return False
    try:
        fd = stream.fileno()
    except (OSError, ValueError):
        return True  # not a file descriptor (an embedding's own stream): it may answer
    if os.isatty(fd):
        return True
    info = os.fstat(fd)
    if stat.S_ISCHR(info.st_mode):
        return False
    if stat.S_ISREG(info.st_mode):
        return os.lseek(fd, 0, os.SEEK_CUR) < info.st_size
    if stat.S_ISFIFO(info.st_mode) and select.select([fd], [], [], 0)[0]:
        return bool(stream.buffer.peek(1))  # readable now: data, or the end of input
    return True


def _forget(run_id: str, archive: Archive, new_archive: list[Path], new_folder: bool) -> None:
    """Undo a new run that stopped before its first generation was recorded: its archive row,
    its folder if this command made it, and the archive file (and its folder) if this command
    made them."""
    import shutil

    directory = Path(archive.run(run_id)["dir"])
    archive.delete_run(run_id)
    if new_folder:
        shutil.rmtree(directory, ignore_errors=True)
    if archive.path in new_archive and not archive.runs():
        for suffix in ("", "-wal", "-shm", "-journal"):
            Path(f"{archive.path}{suffix}").unlink(missing_ok=True)
        if archive.path.parent in new_archive:
            shutil.rmtree(archive.path.parent, ignore_errors=True)


def _refuse_new_run_options(args: argparse.Namespace) -> None:
    """With ``--resume``, refuse an option that only a new run can honour, rather than ignore
    it and report success."""
    for name, default in NEW_RUN_DEFAULTS.items():
        if name in (*RESUME_OPTIONS, "resume", "model", "func"):
            continue
        if getattr(args, name, default) != default:
            flag = "--" + name.replace("_", "-")
            raise MorphogenError(
                f"{flag} sets up a new run, and a resumed run keeps the settings it was started "
                f"with; drop {flag} (with --resume only --{', --'.join(RESUME_OPTIONS)} apply)"
            )


def gene_summary(names: list[str], values, limit: int = 8) -> str:
    """``F=0.0272, k=0.0516``; past ``limit`` genes, the count of the others."""
    shown = ", ".join(f"{n}={v:.6g}" for n, v in zip(names[:limit], values[:limit], strict=True))
    return shown + (f", ... ({len(names) - limit} more)" if len(names) > limit else "")
