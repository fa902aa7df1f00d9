"""``morphogen networks``: evolve mass-action reaction networks or their rates toward the
cluster-head task (Yamamoto et al. §4)."""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import numpy as np

from morphogen.cli import networks_export_cmd, options
from morphogen.errors import MorphogenError
from morphogen.search.executors import EXECUTORS, auto_executor, split_notice
from morphogen.util.guard import WORKING_COPIES, check_count, check_numbers, check_steps
from morphogen.util.io import check_out_name, ensure_writable_dir, write_atomic, write_json
from morphogen.util.progress import ProgressBar

DEFAULTS = {"mode": "rates", "population": 150, "generations": 100, "seed": 0, "size": 32,
            "dt": 0.1, "t_start": 2000.0, "interval": 200.0, "rounds": 10, "m_max": 12,
            "tournament": 2, "init": "fixed", "init_noise": 0.1, "stage2": "stationary",
            "checkerboards": "invalid", "draw": "decade"}
"""Settings of a new run (Table 1); ``--resume`` takes the run's own instead."""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "networks",
        help="evolve reaction networks (or their rates) for the cluster-head task",
        description="Genetic evolution of mass-action reaction-diffusion networks (Yamamoto et "
        "al. §4). --mode rates searches the rate constants of the hand-made activator-"
        "inhibitor-catalyst network (Table 2, §4.1); --mode network evolves the reactions "
        "themselves for 3 species with static inflow/decay and up to --m-max reactions "
        "(§4.2). Defaults are Table 1. Writes DIR/state.npz (resumable), DIR/history.csv "
        "(fitness per generation and individual), DIR/best.json (best reaction table) and "
        "DIR/best/best_1.json (replay with `morphogen simulate --config`); the run is recorded "
        "in the run archive (`morphogen runs`, `morphogen runs show DIR`). "
        "`morphogen networks export DIR|table2 --out FILE` writes a network as a model file, "
        "Antimony, SBML, PNG or SVG (see `morphogen networks export --help`). "
        "`--out DIR --resume` continues a run with its own settings (add --generations N to "
        "extend it); settings below default to Table 1 for a new run.",
    )
    p.add_argument("--mode", choices=("rates", "network"), help="default: rates")
    p.add_argument("--out", metavar="DIR", help="run folder (required)")
    p.add_argument("--resume", action="store_true", help="continue the run saved in DIR")
    p.add_argument("--population", type=int, help="default: 150")
    p.add_argument("--generations", type=int, help="default: 100 (on --resume, the run's)")
    p.add_argument("--seed", type=options.seed, help="default: 0 (0 to 2**32 - 1)")
    p.add_argument("--size", type=int, help="grid side in cells (default: 32)")
    p.add_argument("--dt", type=float, help="default: 0.1")
    p.add_argument("--t-start", type=float, help="first evaluation time (default: 2000)")
    p.add_argument("--interval", type=float, help="time between evaluations (default: 200)")
    p.add_argument("--rounds", type=int, help="evaluation rounds (default: 10)")
    p.add_argument("--init", choices=("fixed", "steady", "uniform"),
                   help="initial condition of each evaluation: 'fixed' starts every individual "
                   "at its own homogeneous fixed point (Newton) times 1 + noise, 'steady' at "
                   "its well-mixed state after t = 5000 from 1, times 1 + noise, 'uniform' "
                   "all from one state uniform in [0, 2) (also 'fixed' without a valid fixed "
                   "point); default: fixed")
    p.add_argument("--init-noise", type=float,
                   help="relative noise of --init fixed and steady (default: 0.1, i.e. ±10 %%)")
    p.add_argument("--stage2", choices=("stationary", "graded", "activator", "literal"),
                   help="stage two of the fitness, 'presence of any non-homogeneous pattern': "
                   "'stationary' (default) tests the activator and ranks a state without a peak "
                   "by how close it is to one and how settled it is since the previous round, "
                   "'graded' by the first alone, 'activator' only tests the activator, "
                   "'literal' every species (the seed's words)")
    p.add_argument("--checkerboards", choices=("invalid", "scored"),
                   help="grid-scale checkerboards (a numerical artefact of the step): "
                   "'invalid' (default) or 'scored' as patterns (the seed's words)")
    p.add_argument("--draw", choices=("log-uniform", "decade"),
                   help="initial rates: 'decade' (default) within one decade of the "
                   "template's (Table 2 in --mode rates; network mode's evolvable slots have "
                   "none, so there it is log-uniform), 'log-uniform' over every exponent")
    p.add_argument("--m-max", type=int, help="reaction slots, network mode (default: 12)")
    p.add_argument("--tournament", type=int, help="default: 2")
    p.add_argument("--archive", help="run archive (default $MORPHOGEN_ARCHIVE or "
                   "runs/index.sqlite); `morphogen runs` lists the run")
    p.add_argument("--executor", choices=EXECUTORS, default="auto",
                   help="auto (default): one Ray worker per core when a generation is large "
                   "and Ray is installed, else this process; local; ray")
    p.add_argument("--address", help="Ray cluster address (default: start a local Ray)")
    p.add_argument("--batches", type=int, help="Ray tasks per generation (default: one per "
                   "CPU)")
    p.add_argument("--quiet", action="store_true", help="no progress bar or log")
    p.set_defaults(func=run)
    actions = p.add_subparsers(dest="action", metavar="{export}", parser_class=type(p))
    networks_export_cmd.register(actions)


MAX_M = 1024
"""Most reaction slots (``--m-max``) of an evolved network."""


def check_counts(args: argparse.Namespace) -> None:
    """Refuse a count option out of range (a population of 0 or 1 cannot be selected from)."""
    check_count(args.population, "--population", 2, 100_000)
    check_count(args.generations, "--generations", 1, 10**6)
    check_count(args.m_max, "--m-max", 1, MAX_M)
    check_count(args.tournament, "--tournament", 1, args.population)
    check_count(args.size, "--size", 3, 1 << 16)


def check_cost(args: argparse.Namespace, species: int, steps_per_generation: int) -> None:
    """Refuse counts out of range and a run whose memory or work exceeds the guard's limits
    (:mod:`morphogen.util.guard`), before anything is created: the population's states and
    per-slot reaction rates on every cell, and ``generations`` x steps of every individual."""
    pop = args.population
    cells = args.size * args.size
    check_numbers(pop * cells * (species * (WORKING_COPIES + 1) + args.m_max),
                  f"a population of {pop} on {args.size}x{args.size} cells",
                  "use a smaller --size, --population or --m-max")
    check_steps(steps_per_generation * args.generations, cells, species, batch=pop)


def run(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from morphogen.search.archive import Archive
    from morphogen.search.networks import record
    from morphogen.search.networks.evolve import Evaluation, completed
    from morphogen.search.networks.evolve import run as evolve
    from morphogen.search.networks.genome import (
        NetworkSpec,
        describe,
        make_genome,
        table2_genome,
        table2_spec,
    )
    from morphogen.search.networks.operators import Operators

    if args.out is None:
        raise MorphogenError("morphogen networks needs --out DIR (the run folder)")
    if args.executor != "ray" and (args.address or args.batches):
        raise MorphogenError("--address and --batches need --executor ray")
    out = check_out_name(args.out)
    settings = record.saved_settings(out) if args.resume else DEFAULTS
    for key, value in settings.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    check_counts(args)
    if args.mode == "rates":
        spec = table2_spec()
        template = table2_genome(spec)
    else:
        spec = NetworkSpec(("A", "B", "C"), args.m_max, (0.005, 0.2, 0.0), fixed=(0, 1),
                           fixed_rates=(0.0, 0.0))
        template = make_genome(spec, [0.0] * spec.m_max)
    ops = Operators(mode=args.mode, tournament=args.tournament, draw=args.draw)
    ev = Evaluation(size=args.size, dt=args.dt, t_start=args.t_start, interval=args.interval,
                    rounds=args.rounds, init=args.init, init_noise=args.init_noise,
                    stage2=args.stage2, reject_checkerboards=args.checkerboards == "invalid")
    check_cost(args, len(spec.species), ev.steps)
    done = 0
    if args.resume:
        # the saved state is read and checked whole before the record changes
        if not (out / "state.npz").exists():
            raise MorphogenError(f"nothing to resume in {out}: no state.npz")
        done = completed(out, args.population)
        run_id, archive = record.resume(out, args.archive, args.generations)
    elif (out / "state.npz").exists() or (out / "config.json").exists():
        raise MorphogenError(f"{out} already holds a run; use --resume or another --out")
    else:
        out = ensure_writable_dir(out)  # only once every setting is checked
        archive = Archive(args.archive)
        run_id = record.start(out, archive, {
            "mode": args.mode, "generations": args.generations, "population": args.population,
            "seed": args.seed, "spec": asdict(spec), "ops": asdict(ops), "ev": asdict(ev)})
    per_gen = ev.steps
    evaluator = None
    executor = args.executor
    if executor == "auto":
        executor = auto_executor(args.population * args.size ** 2 * per_gen)
    if executor == "ray":
        from morphogen.search.networks.ray_workers import RayNetworkEvaluator

        evaluator = RayNetworkEvaluator(address=args.address, batches=args.batches)
        if args.executor == "auto" and not args.quiet:
            print(split_notice(evaluator.batches), flush=True)
    recorder = record.Recorder(archive, run_id, Path(out), spec, asdict(ev))
    bar = ProgressBar(max(args.generations - done, 0) * per_gen, enabled=not args.quiet,
                      unit="step", desc=args.mode)
    try:
        pop, fitness, history = evolve(
            spec, template, out, ops=ops, ev=ev, population=args.population,
            generations=args.generations, seed=args.seed, resume=args.resume,
            log=(lambda s: None) if args.quiet else print,
            progress=bar.update, evaluator=evaluator, on_generation=recorder)
    finally:
        bar.close()
    archive.set_status(run_id, "done")
    buf = io.StringIO()
    np.savetxt(buf, history, delimiter=",", fmt="%.4f")
    write_atomic(Path(out) / "history.csv", lambda fh: fh.write(buf.getvalue().encode()))
    best = int(np.argmax(fitness))
    genome = type(pop)(*(x[best] for x in pop))
    if not np.isfinite(fitness[best]):  # never a NaN in best.json
        raise MorphogenError(f"the run's best fitness is {fitness[best]}; best.json is not "
                             "written")
    write_json(Path(out) / "best.json", {"mode": args.mode, "fitness": float(fitness[best]),
                                         "reactions": describe(genome, spec)})
    if not args.quiet:
        print(f"best fitness {fitness[best]:.2f}; reactions in {Path(out) / 'best.json'}; "
              f"run {run_id} (morphogen runs show {out})")
    return 0
