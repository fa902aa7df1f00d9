"""``morphogen pipeline run FILE --out DIR``: multi-stage mesh pipelines (TOML)."""

from __future__ import annotations

import argparse
import sys


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("pipeline", help="run a multi-stage mesh pipeline (TOML)",
                       description="Run the stages of a pipeline file in order; each stage's "
                       "fields feed the next (see docs/meshes.md).")
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    actions.required = True
    run = actions.add_parser("run", help="run every stage, writing DIR/NN-stage/ and "
                             "DIR/final.ply")
    run.add_argument("file", metavar="FILE.toml")
    run.add_argument("--out", required=True, metavar="DIR", help="output directory")
    run.add_argument("--resume", action="store_true",
                     help="reuse stages already finished in DIR with the same settings")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.set_defaults(func=run_pipeline_cmd)


def run_pipeline_cmd(args: argparse.Namespace) -> int:
    from morphogen.flowers.pipeline import load_pipeline, run_pipeline

    spec = load_pipeline(args.file)
    progress = not args.quiet and sys.stderr.isatty()
    mesh = run_pipeline(spec, args.out, resume=args.resume, progress=progress)
    print(f"wrote {args.out}/ ({len(spec['stage'])} stages, {mesh.n_vertices} vertices; "
          f"fields: {', '.join(mesh.fields)})")
    return 0
