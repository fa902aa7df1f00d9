"""``morphogen export-web``: a run or model as one self-contained HTML page (WebGL2)."""

from __future__ import annotations

import argparse
from pathlib import Path

from morphogen.cli import options


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "export-web",
        help="write a self-contained HTML page that runs a model in the browser (WebGL2)",
        description="Write one HTML file that runs the model in any browser with WebGL2, on the "
        "viewer's GPU, with no server and no network: the same parameters, dt, grid, stencil "
        "(5 or 9), boundary (periodic or neumann), colour map and initial state, sliders for "
        "the parameters, a brush, pause and reset. The shader is generated from the model's own "
        "equations. Explicit Euler on 2D grids only; anything else is refused.",
    )
    p.add_argument("source", metavar="RUN_OR_MODEL",
                   help="a run.json (from simulate or the web app), a library model name or a "
                   "model file (.toml)")
    options.add_run_arguments(p, "simulate")
    p.add_argument("--state", metavar="STATE_NPZ",
                   help="start from this state (a state.npz of simulate, or a checkpoint)")
    p.add_argument("--out", required=True, metavar="PAGE_HTML", help="the page to write")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from morphogen.cli.simulate_cmd import config_from_args
    from morphogen.runs.web_page import check_exportable, export_page
    from morphogen.util.io import check_out_file, write_out_file

    check_out_file(args.out)  # before any work: a folder, FIFO or unwritable place is refused
    is_run = Path(args.source).suffix.lower() == ".json"
    args.config, args.model = (args.source, None) if is_run else (None, args.source)
    config = config_from_args(args)
    state = None
    if args.state:
        from morphogen.engine.initial import load_state
        from morphogen.runs.prepare import load_config_model

        # checked by its header against the run's species and grid before anything is read
        check_exportable(config)
        species = load_config_model(config).species
        state = load_state(args.state, species, tuple(config.size)).astype(np.float32)
    page = export_page(config, state)
    data = page.encode("utf-8")
    write_out_file(args.out, data)
    print(f"wrote {args.out} ({len(data) / 1024:.0f} KiB)")
    return 0
