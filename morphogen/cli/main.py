"""The ``morphogen`` command: a thin layer over the public API.

Each sub-command lives in its own module exposing ``register(subparsers)``, which adds a parser
whose ``func`` default is ``run(args) -> int``. User errors (:class:`MorphogenError`) print one
line and exit with status 2; so do argument errors.

Start-up stays short because a command's module is imported only when that command is chosen:
:data:`COMMANDS` holds each command's name and one-line help, which is all ``morphogen --help``
shows, and the modules import JAX and other heavy libraries inside their ``run`` functions.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings
from typing import Any, NamedTuple

from morphogen.errors import MorphogenError, MorphogenWarning
from morphogen.util import compile_cache


class Command(NamedTuple):
    """A sub-command as ``morphogen --help`` lists it (its module's parser says the same)."""

    name: str
    summary: str


COMMANDS: dict[str, Command] = {
    "morphogen.cli.models_cmd": Command("models", "list library models, parameters and defaults"),
    "morphogen.cli.simulate_cmd": Command("simulate", "simulate a model on a grid or mesh"),
    "morphogen.cli.atlas_cmd": Command(
        "atlas", "map a pattern over two parameters in one batched run"),
    "morphogen.cli.analyse_cmd": Command(
        "analyse",
        "Turing analysis: fixed points, dispersion relation, unstable band, wavelength"),
    "morphogen.cli.serve_cmd": Command("serve", "start the web app"),
    "morphogen.cli.evolve_cmd": Command(
        "evolve", "search model parameters with a genetic algorithm, CMA-ES or gradient ascent"),
    "morphogen.cli.runs_cmd": Command("runs", "list evolution runs, or `runs show RUN` for one"),
    "morphogen.cli.mesh_cmd": Command(
        "mesh", "generate flower meshes (PLY) and describe mesh files"),
    "morphogen.cli.pipeline_cmd": Command("pipeline", "run a multi-stage mesh pipeline (TOML)"),
    "morphogen.cli.gallery_cmd": Command(
        "gallery", "regenerate a gallery of example case studies"),
    "morphogen.cli.train_cmd": Command(
        "train", "train a neural reaction-diffusion rule on a texture image"),
    "morphogen.cli.fit_cmd": Command(
        "fit", "fit model parameters to a target image by gradient descent"),
    "morphogen.cli.match_cmd": Command(
        "match", "find the model, parameters and scale that grow a pattern like a picture"),
    "morphogen.cli.networks_cmd": Command(
        "networks", "evolve reaction networks (or their rates) for the cluster-head task"),
    "morphogen.cli.demo_cmd": Command(
        "demo", "write the demo gallery: every library model, a growing pattern, an atlas"),
    "morphogen.cli.export_web_cmd": Command(
        "export-web", "write a self-contained HTML page that runs a model in the browser (WebGL2)"),
}
"""Modules that provide sub-commands, in the order ``--help`` lists them."""


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line and exit status 2."""

    def error(self, message: str) -> None:  # noqa: D102 (argparse API)
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(2)


class _LazyCommands(argparse._SubParsersAction):
    """Sub-commands whose modules are imported when chosen.

    Each command starts as a placeholder parser with its name and one-line help; choosing it
    imports its module, whose ``register`` puts the full parser in the placeholder's place.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._pending: dict[str, str] = {}

    def add_lazy(self, module: str, command: Command) -> None:
        """A placeholder for ``command``, provided by ``module``."""
        self.add_parser(command.name, help=command.summary)
        self._pending[command.name] = module

    def load(self, name: str) -> None:
        """Replace the placeholder of command ``name`` by its module's parser."""
        module = self._pending.pop(name, None)
        if module is None:
            return
        del self._name_parser_map[name]
        listed = [action.dest for action in self._choices_actions]
        importlib.import_module(module).register(self)
        self._choices_actions.insert(listed.index(name), self._choices_actions.pop())
        del self._choices_actions[listed.index(name) + 1]

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        self.load(values[0])
        super().__call__(parser, namespace, values, option_string)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="morphogen",
        description="Reaction-diffusion pattern formation: simulate, search and show.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser,
                                action=_LazyCommands)
    sub.required = True
    for module, command in COMMANDS.items():
        sub.add_lazy(module, command)
    return parser


class _Warnings:
    """How a command's warnings reach the user: a :class:`MorphogenWarning` at once, as one
    ``morphogen: warning:`` line; any other (NumPy's ``overflow encountered in cast``,
    Shapely's ``polygon(s) split``, ...) held back and printed the same way, once each, only
    if the command succeeds: on an error the one-line message says what went wrong, and the
    library's own report of the same problem would make it several lines."""

    def __init__(self) -> None:
        self.held: list[str] = []

    def show(self, message: Any, category: type, filename: str, lineno: int, file: Any = None,
             line: str | None = None) -> None:
        text = " ".join(str(message).split()) or category.__name__
        if issubclass(category, MorphogenWarning):
            sys.stderr.write(f"morphogen: warning: {text}\n")
        elif text not in self.held:
            self.held.append(text)

    def flush(self) -> None:
        for text in self.held:
            sys.stderr.write(f"morphogen: warning: {text}\n")


def main(argv: list[str] | None = None) -> int:
    os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "2")
    parser = build_parser()
    args = parser.parse_args(argv)
    compile_cache.enable()
    shown = _Warnings()
    try:
        with warnings.catch_warnings():
            warnings.showwarning = shown.show
            status = int(args.func(args) or 0)
        shown.flush()
        return status
    except MorphogenError as exc:
        sys.stderr.write(f"morphogen: error: {exc}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("morphogen: interrupted\n")
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
