"""Train the library of neural RD rules shipped with morphogen (seed 002, fig. 2).

.. code-block:: text

    python -m morphogen.learn.train_library [--only NAME ...] [--runs DIR]

trains one rule per target of :data:`TARGETS`, one after the other, on the synthetic textures
of :func:`morphogen.learn.textures.synthetic_texture` (generated here, nothing downloaded), and
writes ``NAME.npz`` (the rule, ~7 kB) and ``NAME.json`` (its training record: iterations, wall
time, final loss, settings, machine load) into :data:`morphogen.models.neural_library.FOLDER`.
Every run uses the same settings (:data:`LIBRARY_CONFIG`) and seed, and iteration ``i`` of a run
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
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.learn.session import new_run, save_model, train
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


def library_config(name: str) -> TrainConfig:
    """Training settings of library rule ``name``."""
    iterations, decay_at = SCHEDULES.get(name, DEFAULT_SCHEDULE)
    return preset("cpu", size=32, iterations=iterations, decay_at=decay_at, age_start=0,
                  checkpoint_every=50, sample_every=iterations, sample_steps=500)


BASES: dict[str, Path] = {
    "stripes": Path("docs/images/neural/stripes.npz"),
    "lined": Path("docs/images/neural/stripes.npz"),
}
"""The rule each library rule starts from (relative to the repository root), :data:`BASE`
where not listed."""
BASE = Path("docs/images/neural/dots.npz")


def train_rule(name: str, runs: Path | None, config: TrainConfig, ship: Path | None = None,
               base: Path | None = BASE) -> dict:
    """Train the rule ``name`` (from the weights of ``base``, or from scratch when ``None``)
    and write ``ship/NAME.npz`` and ``ship/NAME.json``.

    Returns the training record.
    """
    from morphogen.models.neural_library import FOLDER

    ship = FOLDER if ship is None else Path(ship)
    try:  # before training, so that a folder that cannot be made fails in a second, not hours
        ship.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MorphogenError(f"cannot write rules to {ship}: {exc.strerror}") from None
    target = synthetic_texture(name, TARGET_SIZE)
    load_before = os.getloadavg()[0]
    start = time.perf_counter()
    run = new_run(config, target, f"synthetic:{name}")
    if base is not None:
        run.state = start_from(run.state, config, base)
    run = train(run, None if runs is None else runs / name, log=print)
    seconds = time.perf_counter() - start
    record = {
        "name": name,
        "description": TARGETS.get(name, ""),
        "target": f"synthetic:{name} ({TARGET_SIZE}x{TARGET_SIZE})",
        "preset": "cpu",
        "iterations": run.iteration,
        "seconds": round(seconds, 1),
        "final_loss": float(np.median(run.losses[-20:])),
        "load_average": [round(load_before, 2), round(os.getloadavg()[0], 2)],
        "cpu_count": os.cpu_count(),
        "initial_weights": str(base) if base is not None else "zero W1 (from scratch)",
        "settings": {k: v for k, v in config.to_dict().items() if k != "vgg_weights"},
        "command": f"python -m morphogen.learn.train_library --only {name}",
    }
    save_model(ship / f"{name}.npz", run)
    text = json.dumps(record, indent=2) + "\n"
    write_atomic(ship / f"{name}.json", lambda fh: fh.write(text.encode()))
    return record


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
    parser.add_argument("--base", type=Path, help="rule to start from (default: BASES)")
    parser.add_argument("--no-ageing", action="store_true",
                        help="train without pool ageing (the control of docs/neural-rd.md)")
    args = parser.parse_args(argv)
    for name in args.only or TARGETS:
        config = library_config(name)
        config = replace(config, age_every=0) if args.no_ageing else config
        base = args.base or BASES.get(name, BASE)
        record = train_rule(name, args.runs, config, args.ship, base)
        print(f"{name}: {record['iterations']} iterations, {record['seconds']} s, "
              f"loss {record['final_loss']:.4g}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
