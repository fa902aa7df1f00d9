"""``morphogen demo``: the demo gallery (every library model, a growing pattern, an atlas)."""

from __future__ import annotations

import argparse

from morphogen.errors import MorphogenError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo",
        help="write the demo gallery: every library model, a growing pattern, an atlas",
        description="Write one picture per library model at its default parameters, a GIF of "
        "Gray-Scott growing from blobs, the Gray-Scott (F, k) atlas and an index.html showing "
        "them (2-4 minutes on 2 CPU cores).",
    )
    p.add_argument("--out", default="out/demo", help="output folder (default out/demo)")
    p.add_argument("--size", type=int, default=192,
                   help="grid size of the model pictures and the animation (default 192)")
    p.add_argument("--tiles", type=int, default=16, help="atlas tiles per axis (default 16)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from morphogen.cli.demo import build_gallery

    if args.size < 8 or args.tiles < 1:
        raise MorphogenError(f"--size must be >= 8 and --tiles >= 1, got {args.size} and "
                             f"{args.tiles}")
    build_gallery(args.out, args.size, args.tiles)
    return 0
