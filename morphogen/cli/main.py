"""The ``morphogen`` command: a thin layer over the public API.

Each sub-command lives in its own module exposing ``register(subparsers)``, which adds a parser
whose ``func`` default is ``run(args) -> int``. User errors (:class:`MorphogenError`) print one
line and exit with status 2; so do argument errors.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from morphogen.errors import MorphogenError

COMMANDS = (
    "morphogen.cli.models_cmd",
    "morphogen.cli.simulate_cmd",
    "morphogen.cli.atlas_cmd",
    "morphogen.cli.serve_cmd",
    "morphogen.cli.evolve_cmd",
    "morphogen.cli.runs_cmd",
    "morphogen.cli.mesh_cmd",
    "morphogen.cli.pipeline_cmd",
    "morphogen.cli.gallery_cmd",
    "morphogen.cli.train_cmd",
    "morphogen.cli.fit_cmd",
    "morphogen.cli.networks_cmd",
)
"""Modules that provide sub-commands, in the order ``--help`` lists them."""


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line and exit status 2."""

    def error(self, message: str) -> None:  # noqa: D102 (argparse API)
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="morphogen",
        description="Reaction-diffusion pattern formation: simulate, search and show.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in COMMANDS:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "2")
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except MorphogenError as exc:
        sys.stderr.write(f"morphogen: error: {exc}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("morphogen: interrupted\n")
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
