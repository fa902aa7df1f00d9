"""Train the library of neural RD rules shipped with morphogen (seed 002, fig. 2).

.. code-block:: text

    python -m morphogen.learn.train_library [--only NAME ...] [--runs DIR] [--recipe seed]
        [--base FILE|shipped|none] [--iterations N] [--resume] [--ship DIR] [--features NAME]

trains one rule per target of :data:`TARGETS`, one after the other, on the synthetic textures
of :func:`morphogen.learn.textures.synthetic_texture` (generated here, nothing downloaded), and
writes ``NAME.npz`` (the rule, ~7 kB) and ``NAME.json`` (its training record: iterations, wall
time, final loss, settings, machine load) into :data:`morphogen.models.neural_library.FOLDER`.
Every run uses the same settings (:func:`library_config`) and seed, and iteration ``i`` of a run
draws its randomness from ``fold_in(key, i)`` (:mod:`morphogen.learn.train`), so rerunning the
script on the same platform reproduces the shipped weights.

The settings are the ``cpu`` preset (n = 12, h = 64, pool ageing from the first iteration) on
a 32 x 32 torus, starting from a rule of docs/neural-rd.md (:data:`BASES`: the dots or stripes
rule, 1 000 iterations of the cpu preset without ageing, so already a stable pattern former):
``dots`` for 300 iterations, ``stripes`` for 100 and the others for 60 (:data:`SCHEDULES`),
which is what fitted into about an hour of two shared CPU cores at a load average of 9-14
(1-4.5 s per iteration). From
zero weights 200 iterations at this size left the dots' loss at 0.29 (a blank canvas scores
0.52, the rule it starts from 0.04). Run it from the repository root.

``--recipe seed`` trains to seed 002's schedule instead (:func:`seed_config`: 20 000 iterations,
pool 1 024, batch 4, learning rate 1e-3 multiplied by 0.2 at iterations 1 000 and 10 000, no
ageing) at the library's model size (n = 12, h = 64) on the cpu preset's 64 x 64 torus.
``--iterations N`` stops a run after ``N`` iterations in total without changing its schedule,
and ``--resume`` continues ``RUNS/NAME/checkpoint.npz`` (written every
``checkpoint_every`` iterations and on Ctrl-C) bit for bit, so a 20 000-iteration run can be
done in pieces; every piece is logged in ``RUNS/NAME/library.json`` and the shipped record
sums them. ``--base shipped`` starts from the rule shipped now (continued training).

The shipped ``lizards`` is the 60-iteration rule trained on by 300 more iterations on a
48 x 48 torus (the ``command`` of its record, ``lizards.json``); a plain rerun of this script
reproduces the 60-iteration rule.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.learn.extractors import EXTRACTORS
from morphogen.learn.session import load_checkpoint, new_run, save_model, train
from morphogen.learn.textures import synthetic_texture
from morphogen.learn.train import TrainConfig, TrainState, optimizer, preset
from morphogen.models.neural import read_neural_file
from morphogen.util.io import write_atomic

TARGETS: dict[str, str] = {
    "dots": "red dots on a pale ground",
    "stripes": "oblique dark blue stripes on cream",
    "checker": "a brown and cream checkerboard",
    "lined": "thin undulating grey-blue lines",
    "blotchy": "irregular ochre blotches on sand",
    "lizards": "a tiling of little green lizards",
}
"""Library rule names and what their target shows (the synthetic texture of the same name)."""

TARGET_SIZE = 64
"""Side of the target images the rules are trained on."""

SCHEDULES: dict[str, tuple[int, tuple[int, int]]] = {
    "dots": (300, (200, 270)),
    "stripes": (100, (70, 90)),
}
"""Training iterations and learning-rate drops per rule (:data:`DEFAULT_SCHEDULE` where not
listed): the schedules the shipped rules were trained with."""
DEFAULT_SCHEDULE = (60, (42, 54))


SEED_RECIPE = {"iterations": 20000, "pool_size": 1024, "batch_size": 4, "learning_rate": 1e-3,
               "decay_at": (1000, 10000), "decay": 0.2, "age_every": 0}
"""Seed 002's training schedule (Algorithm 1, "Texture synthesis")."""


def seed_config(name: str) -> TrainConfig:
    """Settings of library rule ``name`` on seed 002's schedule (:data:`SEED_RECIPE`), at the
    library's model size on the cpu preset's 64 x 64 torus; checkpoints every 25 iterations."""
    del name  # one recipe for every rule
    return preset("cpu", size=64, checkpoint_every=25, sample_every=500, sample_steps=500,
                  **SEED_RECIPE)


def library_config(name: str) -> TrainConfig:
    """Training settings of library rule ``name``."""
    iterations, decay_at = SCHEDULES.get(name, DEFAULT_SCHEDULE)
    return preset("cpu", size=32, iterations=iterations, decay_at=decay_at, age_start=0,
                  checkpoint_every=25, sample_every=iterations, sample_steps=500)


BASES: dict[str, Path] = {
    "stripes": Path("docs/images/neural/stripes.npz"),
    "lined": Path("docs/images/neural/stripes.npz"),
}
"""The rule each library rule starts from (relative to the repository root), :data:`BASE`
where not listed."""
BASE = Path("docs/images/neural/dots.npz")


def train_rule(name: str, runs: Path | None, config: TrainConfig, ship: Path | None = None,
               base: Path | None = BASE, *, iterations: int | None = None,
               resume: bool = False, recipe: str = "library", command: str | None = None
               ) -> dict:
    """Train the rule ``name`` (from the weights of ``base``, or from scratch when ``None``)
    and write ``ship/NAME.npz`` and ``ship/NAME.json``.

    ``iterations`` stops after that many iterations in total (default: the settings');
    ``resume`` continues ``runs/NAME/checkpoint.npz`` (its own settings) instead of starting.

    Returns the training record.
    """
    from morphogen.models.neural_library import FOLDER

    ship = FOLDER if ship is None else Path(ship)
    try:  # before training, so that a folder that cannot be made fails in a second, not hours
        ship.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MorphogenError(f"cannot write rules to {ship}: {exc.strerror}") from None
    target = synthetic_texture(name, TARGET_SIZE)
    directory = None if runs is None else Path(runs) / name
    load_before = os.getloadavg()[0]
    start = time.perf_counter()
    pieces: list[dict] = []
    if resume:
        if directory is None:
            raise MorphogenError("--resume needs --runs (the folder holding NAME/checkpoint.npz)")
        run = load_checkpoint(directory)
        if run.target_name != f"synthetic:{name}":
            raise MorphogenError(f"{directory} trains {run.target_name!r}, not synthetic:{name}")
        config, pieces = run.config, _pieces(directory)
    else:
        run = new_run(config, target, f"synthetic:{name}")
        if base is not None:
            run.state = start_from(run.state, config, base)
    first, origin = run.iteration, "checkpoint" if resume else _origin(base)

    def log_piece() -> list[float]:
        load = [round(load_before, 2), round(os.getloadavg()[0], 2)]
        pieces.append({"from": first, "to": run.iteration,
                       "seconds": round(time.perf_counter() - start, 1),
                       "load_average": load, "initial_weights": origin})
        if directory is not None:
            text = json.dumps(pieces, indent=2) + "\n"
            write_atomic(directory / "library.json", lambda fh: fh.write(text.encode()))
        return load

    try:
        run = train(run, directory, iterations=iterations, log=print)
    except KeyboardInterrupt:  # the checkpoint is written; so is the piece's log
        log_piece()
        raise
    load = log_piece()
    record = {
        "name": name,
        "description": TARGETS.get(name, ""),
        "target": f"synthetic:{name} ({TARGET_SIZE}x{TARGET_SIZE})",
        "preset": "cpu",
        "recipe": recipe,
        "iterations": run.iteration,
        "scheduled_iterations": config.iterations,
        "seconds": round(sum(p["seconds"] for p in pieces), 1),
        "final_loss": float(np.median(run.losses[-20:])),
        "load_average": load,
        "cpu_count": os.cpu_count(),
        "initial_weights": pieces[0]["initial_weights"] if pieces else origin,
        "pieces": pieces,
        "settings": {k: v for k, v in config.to_dict().items() if k != "vgg_weights"},
        "loss_log": _loss_log(run.losses),
        "command": command or f"python -m morphogen.learn.train_library --only {name}"
        + ("" if recipe == "library" else f" --recipe {recipe}"),
    }
    save_model(ship / f"{name}.npz", run)
    text = json.dumps(record, indent=2) + "\n"
    write_atomic(ship / f"{name}.json", lambda fh: fh.write(text.encode()))
    return record


def _origin(base: Path | None) -> str:
    if base is None:
        return "zero W1 (from scratch)"
    base = Path(base)
    info = base.with_suffix(".json")
    if base.is_absolute() and base.is_relative_to(Path.cwd()):
        base = base.relative_to(Path.cwd())
    if info.is_file():  # a shipped rule: say what it was
        try:
            prior = json.loads(info.read_text(encoding="utf-8"))
            return (f"{base} ({prior.get('iterations', '?')} iterations from "
                    f"{prior.get('initial_weights', '?')})")
        except (OSError, ValueError):
            pass
    return str(base)


def _pieces(directory: Path) -> list[dict]:
    """The pieces of a run logged in ``directory/library.json`` (``[]`` when absent)."""
    try:
        data = json.loads((directory / "library.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return []
    return data if isinstance(data, list) else []


def _loss_log(losses: list[float], every: int = 10) -> list[list[float]]:
    """``[iteration, mean loss of the last `every` iterations]`` every ``every`` iterations
    (and at the last), the training log kept with a shipped rule."""
    out = []
    for i in range(every, len(losses) + every, every):
        i = min(i, len(losses))
        out.append([i, round(float(np.mean(losses[max(0, i - every):i])), 5)])
        if i == len(losses):
            break
    return out


def start_from(state: TrainState, config: TrainConfig, path: Path) -> TrainState:
    """``state`` with the weights of the rule in ``path`` and a fresh optimiser state.

    Raises:
        MorphogenError: the file's rule has another shape than ``config``.
    """
    shape, weights, _ = read_neural_file(path)
    if shape != config.neural:
        raise MorphogenError(f"{path} holds a {shape} rule; the library trains {config.neural}")
    weights = {k: jnp.asarray(v) for k, v in weights.items()}
    return state._replace(weights=weights, opt_state=optimizer(config).init(weights))


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", nargs="+", choices=tuple(TARGETS), help="rules to train")
    parser.add_argument("--runs", type=Path, help="also keep each run directory here")
    parser.add_argument("--ship", type=Path, help="write the rules here instead of the package")
    parser.add_argument("--base", help="rule file to start from, 'shipped' (the rule shipped "
                        "now) or 'none' (from scratch); default: BASES")
    parser.add_argument("--no-ageing", action="store_true",
                        help="train without pool ageing (the control of docs/neural-rd.md)")
    parser.add_argument("--recipe", choices=("library", "seed"), default="library",
                        help="library: the shipped schedules; seed: seed 002's (20 000 "
                        "iterations, pool 1 024, lr 1e-3 x0.2 at 1 000 and 10 000)")
    parser.add_argument("--iterations", type=int, help="stop after N iterations in total "
                        "(the schedule is unchanged; continue later with --resume)")
    parser.add_argument("--resume", action="store_true",
                        help="continue RUNS/NAME/checkpoint.npz (needs --runs)")
    parser.add_argument("--learning-rate", type=float, help="replace the recipe's")
    parser.add_argument("--size", type=int, help="replace the recipe's training torus side")
    parser.add_argument("--features", choices=EXTRACTORS,
                        help="replace the recipe's texture descriptors (docs/neural-rd.md)")
    parser.add_argument("--schedule", type=int, nargs="+", metavar="N",
                        help="replace the recipe's iterations and learning-rate drops: "
                        "ITERATIONS [DROP ...]")
    args = parser.parse_args(argv)
    argv = sys.argv[1:] if argv is None else list(argv)
    for name in args.only or TARGETS:
        config = seed_config(name) if args.recipe == "seed" else library_config(name)
        config = replace(config, age_every=0) if args.no_ageing else config
        if args.learning_rate:
            config = replace(config, learning_rate=args.learning_rate)
        if args.size:
            config = replace(config, size=args.size)
        if args.features:
            config = replace(config, features=args.features)
        if args.schedule:
            config = replace(config, iterations=args.schedule[0],
                             decay_at=tuple(args.schedule[1:]))
        base = _base(name, args.base)
        record = train_rule(name, args.runs, config, args.ship, base,
                            iterations=args.iterations, resume=args.resume, recipe=args.recipe,
                            command=" ".join(["python -m morphogen.learn.train_library", *argv]))
        print(f"{name}: {record['iterations']} iterations, {record['seconds']} s, "
              f"loss {record['final_loss']:.4g}", flush=True)
    return 0


def _base(name: str, choice: str | None) -> Path | None:
    from morphogen.models.neural_library import FOLDER

    if choice is None:
        return BASES.get(name, BASE)
    if choice == "none":
        return None
    return FOLDER / f"{name}.npz" if choice == "shipped" else Path(choice)


if __name__ == "__main__":
    raise SystemExit(main())
