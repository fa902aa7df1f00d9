"""Start-up: commands that only print must not import JAX or other heavy libraries.

Structural, not timed: each case runs in a fresh interpreter and reports which heavy modules it
loaded (bench/bench_startup.py measures the times).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

import pytest

from morphogen.cli import main as cli

HEAVY = ("jax", "matplotlib", "scipy", "pydantic", "PIL", "imageio")

PROBE = f"""
import contextlib, io, json, sys
from morphogen.cli.main import main
out = io.StringIO()
with contextlib.redirect_stdout(out):
    try:
        code = main(sys.argv[1:])
    except SystemExit as exc:
        code = exc.code
heavy = [m for m in {HEAVY!r} if m in sys.modules]
print(json.dumps({{"code": code, "heavy": heavy, "out": out.getvalue()}}))
"""


def _probe(*argv: str) -> dict:
    done = subprocess.run([sys.executable, "-c", PROBE, *argv], capture_output=True, text=True,
                          timeout=120, check=True)
    return json.loads(done.stdout.splitlines()[-1])


@pytest.mark.parametrize("argv", [("--help",), ("models",), ("models", "gray-scott"),
                                  ("simulate", "--help"), ("atlas", "--help"),
                                  ("runs", "--help"), ("mesh", "--help"), ("serve", "--help")])
def test_printing_commands_load_no_heavy_module(argv):
    result = _probe(*argv)
    assert result["code"] == 0
    assert result["heavy"] == []
    assert result["out"].strip()


def test_models_listing_without_jax_shows_every_model():
    from morphogen.models.library import LIBRARY
    from morphogen.models.neural_library import model_names

    out = _probe("models")["out"]
    names = [line.split(": ")[0] for line in out.split("\n\n")]
    assert names == list(LIBRARY) + model_names()
    assert "neural:dots" in names
    assert "F=0.037, k=0.06" in out


def _commands(parser: argparse.ArgumentParser) -> argparse._SubParsersAction:
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))


def test_listing_matches_every_command_module():
    """The one-line summaries in COMMANDS are the ones each module registers, in order."""
    parser = cli.build_parser()
    listed = parser.format_help()
    commands = _commands(parser)
    for command in cli.COMMANDS.values():
        placeholder = commands.choices[command.name]
        commands.load(command.name)
        assert commands.choices[command.name] is not placeholder
    assert parser.format_help() == listed
    assert list(commands.choices) == [c.name for c in cli.COMMANDS.values()]


def test_chosen_command_is_loaded_when_parsed():
    from morphogen.cli import simulate_cmd

    args = cli.build_parser().parse_args(["simulate", "gray-scott", "--seed", "3"])
    assert args.func is simulate_cmd.run
    assert args.seed == 3
