"""``morphogen gallery flowers [--out DIR] [--only NAME...]``: every flower case study, one page;
``morphogen gallery neural``: every shipped neural RD rule (:mod:`morphogen.cli.gallery_neural`).

Each flower pipeline (Ringham et al. 2021, §4) under ``examples/flowers/*.toml``, plus the two
older mesh pipelines ``examples/mimulus-mesh-pipeline.toml`` (§4.5) and
``examples/kohleria-mesh-pipeline.toml`` (§4.7), is run into ``DIR/NAME/`` with
:func:`morphogen.flowers.pipeline.run_pipeline`; ``DIR/index.html`` shows the last stage's picture
of each with its name and section. A file that is not a pipeline (a model file such as
``dianthus-diffusion.toml``, which has no ``[mesh]`` table) is not a flower and is skipped.
Every selected pipeline is loaded and checked before anything is made: a broken one is one
line, exit status 2, and nothing is written. A flower that fails while it runs is reported in
one line and left off the page; the others still run, and the command exits with status 2.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Iterator
from pathlib import Path

from morphogen.errors import MorphogenError
from morphogen.flowers.case_studies import EXAMPLES, Flower, find_flowers


def _select(flowers: list[Flower], only: list[str] | None) -> list[Flower]:
    if not only:
        return flowers
    names = {f.name for f in flowers}
    unknown = [n for n in only if n not in names]
    if unknown:
        raise MorphogenError(f"unknown flower {', '.join(unknown)}; choose from "
                             f"{', '.join(f.name for f in flowers)}")
    return [f for f in flowers if f.name in only]


def _picture(flower_dir: Path) -> Path:
    """The last stage's ``out.png`` of a finished pipeline directory."""
    import json

    record = json.loads((flower_dir / "pipeline.json").read_text())
    for stage in reversed(record["stages"]):
        png = flower_dir / stage["dir"] / "out.png"
        if png.is_file():
            return png
    raise MorphogenError(f"{flower_dir} has no stage picture (out.png)")


def _run_flower(pipeline: dict, out_dir: Path, resume: bool) -> tuple[str | None, str, float]:
    """One flower's loaded pipeline into ``out_dir``: its picture's path relative to the gallery
    (or ``None`` and the one-line error), and the seconds it took. Runs in a worker process
    too."""
    from morphogen.flowers.pipeline import run_pipeline

    started = time.perf_counter()
    try:
        run_pipeline(pipeline, out_dir, resume=resume)
        png = _picture(out_dir)
    except MorphogenError as exc:
        return None, str(exc), time.perf_counter() - started
    return f"{out_dir.name}/{png.relative_to(out_dir).as_posix()}", "", \
        time.perf_counter() - started


def default_workers(flowers: int) -> int:
    """Flowers run side by side: one process per core on a CPU backend (each with one XLA
    thread), one at a time on an accelerator (they would share it)."""
    import jax

    if jax.default_backend() != "cpu":
        return 1
    return max(1, min(flowers, os.cpu_count() or 1))


def run_gallery(out: str | Path, *, only: list[str] | None = None, examples: Path = EXAMPLES,
                resume: bool = False, workers: int | None = None) -> tuple[Path, list[str]]:
    """Run the selected flowers into ``out/NAME/`` and write ``out/index.html``.

    ``workers`` flowers run at a time, each in its own process (default
    :func:`default_workers`; 1: one after the other in this process). Returns the page and the
    one-line errors of the flowers that failed.
    """
    from morphogen.flowers.pipeline import load_pipeline
    from morphogen.render.gallery import write_gallery
    from morphogen.util.io import check_writable_dir, ensure_writable_dir

    flowers = _select(find_flowers(Path(examples)), only)
    if not flowers:
        raise MorphogenError(f"no flower pipelines in {Path(examples) / 'flowers'}")
    pipelines = {}
    for flower in flowers:  # every file checked before anything is made
        try:
            pipelines[flower.name] = load_pipeline(flower.path)
        except MorphogenError as exc:
            raise MorphogenError(f"{flower.name} ({flower.path}): {exc}") from None
    check_writable_dir(out)
    out_dir = ensure_writable_dir(out)
    workers = default_workers(len(flowers)) if workers is None else workers
    results: dict[str, tuple[str | None, str, float]] = {}
    for k, (flower, result) in enumerate(_run_all(flowers, pipelines, out_dir, resume, workers),
                                         1):
        png, error, seconds = results[flower.name] = result
        head = f"[{k}/{len(flowers)}] {flower.caption}: {flower.path.name}"
        if png is None:
            print(f"{head}: failed: {error}", flush=True)
        else:
            print(f"{head}: done in {seconds:.1f} s: {png}", flush=True)
    items = [(results[f.name][0], f.caption) for f in flowers if results[f.name][0] is not None]
    errors = [f"{f.name}: {results[f.name][1]}" for f in flowers if results[f.name][0] is None]
    page = write_gallery(out_dir, "Flowers: Ringham et al. (2021) case studies", items,
                         intro=f"{len(items)} of {len(flowers)} flower pipelines from "
                         f"{Path(examples)}; each picture is its pipeline's last stage.",
                         smooth=True)
    return page, errors


def _run_all(flowers: list[Flower], pipelines: dict[str, dict], out_dir: Path, resume: bool,
             workers: int) -> Iterator[tuple[Flower, tuple[str | None, str, float]]]:
    """Each flower with its result (:func:`_run_flower` of its loaded pipeline), as it
    finishes."""
    if workers <= 1:
        for flower in flowers:
            print(f"{flower.caption}: {flower.path.name} ...", flush=True)
            yield flower, _run_flower(pipelines[flower.name], out_dir / flower.name, resume)
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    from morphogen.util.cluster import SINGLE_THREAD

    # the workers start with one XLA thread each (they read XLA_FLAGS as they import JAX)
    saved = os.environ.get("XLA_FLAGS")
    os.environ["XLA_FLAGS"] = f"{saved or ''} {SINGLE_THREAD}".strip()
    pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"))
    try:
        running = {pool.submit(_run_flower, pipelines[f.name], out_dir / f.name, resume): f
                   for f in flowers}
        print(f"{len(flowers)} flowers, {workers} at a time", flush=True)
        for future in as_completed(running):
            yield running[future], future.result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
        if saved is None:
            os.environ.pop("XLA_FLAGS", None)
        else:
            os.environ["XLA_FLAGS"] = saved


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("gallery", help="regenerate a gallery of example case studies",
                       description="Run example pipelines and write an index.html of their "
                       "pictures (see docs/flowers.md).")
    kinds = p.add_subparsers(dest="gallery", metavar="KIND")
    kinds.required = True
    fl = kinds.add_parser("flowers", help="every flower case study (Ringham et al. §4) into "
                          "DIR/NAME/ and DIR/index.html")
    fl.add_argument("--out", default="out/flowers", metavar="DIR",
                    help="output directory (default out/flowers)")
    fl.add_argument("--only", nargs="+", metavar="NAME",
                    help="run only these flowers (names as in the file names, e.g. dianthus)")
    fl.add_argument("--examples", type=Path, default=EXAMPLES, metavar="DIR",
                    help="where flowers/*.toml are (default: the repository's examples/)")
    fl.add_argument("--resume", action="store_true",
                    help="reuse stages already finished in DIR/NAME with the same settings")
    fl.add_argument("--workers", type=int, metavar="N",
                    help="flowers run at a time, each in its own process (default: one per "
                    "core on a CPU, 1 on a GPU)")
    fl.add_argument("--list", action="store_true", help="list the flowers and exit")
    fl.set_defaults(func=run_gallery_cmd)
    nr = kinds.add_parser("neural", help="every shipped neural RD rule: its target, runs from "
                          "three seeds, a mesh and a volume, and the confusion table, into DIR")
    nr.add_argument("--out", default="out/neural", metavar="DIR",
                    help="output directory (default out/neural)")
    nr.add_argument("--only", nargs="+", metavar="NAME", help="show only these rules")
    nr.add_argument("--rule", action="append", default=[], metavar="NAME=FILE",
                    help="show this model file in place of the shipped rule NAME")
    nr.add_argument("--size", type=int, default=64, help="side of the plane runs (64)")
    nr.add_argument("--steps", type=int, default=5000, help="steps of the plane runs (5000)")
    nr.add_argument("--seeds", type=int, default=3, help="plane runs per rule (3)")
    nr.add_argument("--mesh-edge", type=float, default=0.02, metavar="H",
                    help="corolla edge before scaling to unit edges (0.02: ~7 000 vertices)")
    nr.add_argument("--mesh-time", type=float, default=2000.0, metavar="T",
                    help="time units on the mesh (2000)")
    nr.add_argument("--volume", default="16x48x48", metavar="DxHxW",
                    help="3D grid (16x48x48)")
    nr.add_argument("--volume-steps", type=int, default=3000, help="3D steps of 0.5 (3000)")
    nr.set_defaults(func=run_neural_cmd)


def run_neural_cmd(args: argparse.Namespace) -> int:
    from morphogen.cli.gallery_neural import NeuralGallery, run_neural_gallery

    try:
        volume = tuple(int(v) for v in args.volume.lower().split("x"))
    except ValueError:
        volume = ()
    if len(volume) != 3 or min(volume) < 4:
        raise MorphogenError(f"--volume takes DxHxW with sides >= 4, got {args.volume!r}")
    if min(args.size, args.steps, args.seeds) < 1 or args.size < 8:
        raise MorphogenError("--size >= 8, --steps and --seeds >= 1")
    if not (0 < args.mesh_edge <= 0.5) or args.mesh_time <= 0 or args.volume_steps < 1:
        raise MorphogenError("--mesh-edge in (0, 0.5], --mesh-time and --volume-steps > 0")
    rules = {}
    for item in args.rule:
        name, sep, path = item.partition("=")
        if not sep or not name or not path:
            raise MorphogenError(f"--rule takes NAME=FILE, got {item!r}")
        rules[name] = path
    cfg = NeuralGallery(size=args.size, steps=args.steps, seeds=args.seeds,
                        mesh_edge=args.mesh_edge, mesh_time=args.mesh_time, volume=volume,
                        volume_steps=args.volume_steps)
    page = run_neural_gallery(args.out, cfg, only=args.only, rules=rules)
    print(f"wrote {page}")
    return 0


def run_gallery_cmd(args: argparse.Namespace) -> int:
    if args.list:
        for flower in _select(find_flowers(args.examples), args.only):
            print(f"{flower.name:<20} {('§' + flower.section) if flower.section else '-':<6} "
                  f"{flower.path}")
        return 0
    if args.workers is not None and args.workers < 1:
        raise MorphogenError(f"--workers takes a number >= 1, got {args.workers}")
    page, errors = run_gallery(args.out, only=args.only, examples=args.examples,
                               resume=args.resume, workers=args.workers)
    print(f"wrote {page}")
    for line in errors:
        sys.stderr.write(f"morphogen: error: {line}\n")
    return 2 if errors else 0
