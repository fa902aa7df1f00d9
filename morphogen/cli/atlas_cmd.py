"""``morphogen atlas``: a labelled mosaic of a two-parameter grid, in one batched run."""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path
from typing import Any

from morphogen.cli import options
from morphogen.errors import MorphogenError, MorphogenWarning


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "atlas",
        help="map a pattern over two parameters in one batched run",
        description="Simulate a grid of parameter pairs (e.g. Gray-Scott F and k) as one "
        "batched program and write DIR/atlas.png (labelled mosaic), DIR/atlas.npz, "
        "DIR/atlas.json; with --classify also DIR/families.csv (the pattern family of each "
        "tile, drawn on the mosaic).",
    )
    p.add_argument("model", metavar="MODEL_OR_FILE")
    p.add_argument("--x", required=True, metavar="NAME=START:STOP:N", help="horizontal axis")
    p.add_argument("--y", required=True, metavar="NAME=START:STOP:N", help="vertical axis")
    options.add_run_arguments(p, "atlas")
    p.add_argument("--classify", action="store_true",
                   help="name each tile's pattern family (spots, stripes, ...) on the mosaic "
                   "and in DIR/families.csv")
    p.add_argument("--watch", default="4x50", metavar="COUNTxGAP",
                   help="with --classify: states kept at the end for the temporal descriptors "
                   "(default 4x50: 5 states 50 steps apart)")
    p.add_argument("--analysis", action="store_true",
                   help="also draw the linear analysis' saddle-node, Hopf and Turing boundaries "
                   "over the tiles, DIR/analysis.png (docs/analysis.md)")
    p.add_argument("--out", default=None, help="output directory (default out/atlas-MODEL)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


DEFAULTS = {"size": [64, 64], "cmap": "viridis"}
"""``atlas``'s own defaults of run settings (the others are the table's)."""


def run(args: argparse.Namespace) -> int:
    from morphogen.models.registry import load_model
    from morphogen.runs.atlas import Axis
    from morphogen.runs.prepare import precision

    model = load_model(args.model)
    x, y = Axis.parse(args.x), Axis.parse(args.y)
    model.parameters({x.name: 0.0, y.name: 0.0})
    run = options.run_settings(args, "atlas", DEFAULTS)
    with precision(run["precision"]):  # float64 for this atlas only
        return _atlas(args, model, x, y, run)


def _atlas(args: argparse.Namespace, model: Any, x: Any, y: Any, run: dict[str, Any]) -> int:
    """Compute the atlas of ``run``'s settings and write its files (``run`` checked)."""
    import numpy as np

    from morphogen.domains.grid import Grid
    from morphogen.patterns.classify import COLOURS
    from morphogen.render import atlas_image, colour_limits, state_image, write_png
    from morphogen.render.mosaic import frame_tiles
    from morphogen.runs.atlas import (
        classify_atlas,
        compute_atlas,
        instability_report,
        plan_atlas,
        write_families,
    )
    from morphogen.util.io import check_writable_dir, ensure_writable_dir, write_json, write_npz

    grid = Grid(tuple(run["size"]), dx=run["dx"], boundary=run["boundary"],
                stencil=run["stencil"])
    plan = plan_atlas(model, grid, x, y, params=run["params"], scheme=run["scheme"],
                      dt=run["dt"], steps=run["steps"], time=run["time"], unsafe=run["unsafe"])
    dt, steps = plan.dt, plan.steps
    species = run["species"] or model.display_species
    index = model.species_index(species)
    watch = _watch(args.watch, steps) if args.classify else None
    if watch and len(grid.shape) != 2:
        raise MorphogenError("--classify works on 2D grids; give --size as WxH")
    out = check_writable_dir(args.out or Path("out") / f"atlas-{Path(args.model).stem}")
    plane = None
    if args.analysis:  # checked before the atlas runs
        from morphogen.runs.atlas_analysis import plane_values

        plane = plane_values(model, grid, run["params"], x.name, y.name)
    atlas = compute_atlas(model, grid, x, y, params=run["params"], steps=steps, dt=dt,
                          init=run["init"], init_options=run["init_options"], seed=run["seed"],
                          progress=options.show_progress(args), unsafe=run["unsafe"],
                          watch=watch, scheme=plan.scheme)
    ensure_writable_dir(out)  # only once the run has passed its checks and finished
    fields = atlas.states[:, :, index]
    if fields.ndim == 5:
        fields = fields[:, :, fields.shape[2] // 2]
    lo, hi = colour_limits(fields[atlas.valid] if atlas.valid.any() else fields)
    tiles = np.stack([[state_image(f, run["cmap"], lo, hi) for f in row] for row in fields])
    title = f"{model.name}: {species} after {steps} steps (dt={dt:g})"
    unstable = ~atlas.valid | atlas.unstable
    report = instability_report(atlas)
    if report:
        warnings.warn(report, MorphogenWarning, stacklevel=1)
        title += f", {int(unstable.sum())} numerically unstable"
    families, labels = None, None
    if watch:
        labels, descriptors = classify_atlas(atlas, index)
        write_families(out / "families.csv", atlas, labels, descriptors)
        tiles = frame_tiles(tiles, labels, COLOURS)
        families = {f: int((labels == f).sum()) for f in COLOURS if (labels == f).any()}
        title += ", families: " + ", ".join(f"{f} {n}" for f, n in families.items())
    write_png(out / "atlas.png", atlas_image(tiles, x.name, x.values, y.name, y.values,
                                             title=title))
    analysis = None
    if plane is not None:
        from morphogen.runs.atlas_analysis import write_atlas_analysis

        analysis = write_atlas_analysis(out, model, grid, (x.name, x.values),
                                        (y.name, y.values), plane, labels, ~unstable,
                                        COLOURS, title)
    write_npz(out / "atlas.npz", {species: fields, x.name: x.values, y.name: y.values,
                                  "valid": atlas.valid, "unstable": unstable})
    write_json(out / "atlas.json", {
        "model": model.name, "x": {"name": x.name, "values": x.values},
        "y": {"name": y.name, "values": y.values}, "size": list(grid.shape), "dt": dt,
        "steps": steps, "scheme": atlas.scheme, "seed": run["seed"],
        "invalid": int((~atlas.valid).sum()),
        "unstable": [{x.name: float(x.values[j]), y.name: float(y.values[i])}
                     for i, j in zip(*np.nonzero(unstable), strict=True)],
        "wall_time_s": round(atlas.wall_time, 3), "families": families,
        **({"analysis": analysis} if analysis is not None else {}),
        **({"precision": run["precision"]} if run["precision"] != "float32" else {}),
    })
    print(f"wrote {out}/atlas.png ({len(y.values)}x{len(x.values)} runs, "
          f"{atlas.wall_time:.1f} s, {(~atlas.valid).sum()} blew up, "
          f"{int(atlas.unstable.sum())} ended in a checkerboard)")
    return 0


def _watch(text: str, steps: int) -> tuple[int, int]:
    count, sep, gap = text.lower().partition("x")
    if not sep or not count.isdigit() or not gap.isdigit() or int(count) < 1 or int(gap) < 1:
        raise MorphogenError(f"--watch {text!r}: use COUNTxGAP with whole numbers >= 1, e.g. 4x50")
    if int(count) * int(gap) > steps:
        raise MorphogenError(f"--watch {text}: {int(count) * int(gap)} steps watched but the run "
                             f"has only {steps}; watch fewer or run longer")
    return int(count), int(gap)
