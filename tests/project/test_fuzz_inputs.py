"""Property-based tests (hypothesis): any input either loads or raises ``MorphogenError``.

Nothing else may escape (no ``KeyError``, ``TypeError``, ``RecursionError``, ...), sizes are
bounded so nothing hangs, and no file appears. Examples are derandomised and their number
fixed, so each property takes a few seconds and CI runs the same inputs every time.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from morphogen.errors import MorphogenError

FAST = settings(max_examples=300, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

TOKENS = ["u", "v", "a", "b", "x", "t", "1", "0.5", "1e308", "-", "+", "*", "/", "**", "(",
          ")", ",", "lap(", "where(", "exp(", "sin(", "<", "==", " ", "\n", "__class__", ".",
          "[", "]", "'s'", "lambda", "ｕ", "\ufeff", "nan", "inf", "import", ";", "=", ":"]

expressions = st.one_of(
    st.text(max_size=120),
    st.lists(st.sampled_from(TOKENS), max_size=40).map("".join),
)

MODEL = """\
species = ["u", "v"]
[parameters]
a = 0.1
b = 0.9
[equations]
u = "a - u + u**2*v + lap(u)"
v = "b - u**2*v + 40*lap(v)"
"""

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner,
                                                              max_size=4),
    max_leaves=12,
)
CONFIG_KEYS = ["model", "model_source", "preset", "params", "size", "mesh", "dx", "boundary",
               "stencil", "dt", "steps", "time", "scheme", "seed", "init", "init_options",
               "noise", "clamp", "every", "species", "cmap", "vmin", "vmax", "threshold", "fps",
               "animation", "unsafe", "precision", "bogus"]


def _files(root: Path) -> list[Path]:
    return sorted(root.rglob("*"))


@FAST
@given(expressions)
def test_expression_parser_loads_or_refuses(text):
    from morphogen.models.expr import parse

    try:
        parse(text, extra_functions={"lap": 1})
    except MorphogenError as exc:
        assert "\n" not in str(exc)


@FAST
@given(st.data())
def test_model_file_parser_loads_or_refuses(data):
    from morphogen.models.text.equations import parse_model

    lines = MODEL.splitlines()
    i = data.draw(st.integers(0, len(lines) - 1))
    replacement = data.draw(expressions | st.sampled_from(
        ['t_end = inf', 'dt = -1', 'species = []', 'species = ["ｕ"]', 'u = "u"', "[x]",
         'clamp = [1, 0]', 'v = "lap(lap(v))"', 'species = ["u", "u"]']))
    text = "\n".join([*lines[:i], replacement, *lines[i + 1:]])
    try:
        parse_model(text)
    except MorphogenError as exc:
        assert "\n" not in str(exc)


@FAST
@given(st.dictionaries(st.sampled_from(CONFIG_KEYS), json_values, max_size=6),
       st.booleans())
def test_run_config_loads_or_refuses(config, with_model):
    from morphogen.runs.config import RunConfig
    from morphogen.runs.schema import validate_config

    if with_model:
        config = {"model": "gray-scott", **config}
    try:
        run = RunConfig.from_dict(config)
    except MorphogenError as exc:
        assert "\n" not in str(exc)
    else:
        validate_config(asdict(run))


@FAST
@given(st.binary(max_size=300) | json_values.map(lambda v: json.dumps({"config": v}).encode()))
def test_run_file_loads_or_refuses(tmp_path_factory, content):
    from morphogen.runs.config import load_run_file

    root = tmp_path_factory.mktemp("runfile")
    path = root / "run.json"
    path.write_bytes(content)
    try:
        load_run_file(path)
    except MorphogenError as exc:
        assert "\n" not in str(exc)
    assert _files(root) == [path]


PLY_HEAD = ("ply\nformat {fmt} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\n"
            "property float z\nelement face {nf}\nproperty list uchar int vertex_indices\n"
            "end_header\n")


@FAST
@given(st.sampled_from(["ascii", "binary_little_endian", "binary_big_endian", "bogus"]),
       st.integers(0, 10**12), st.integers(0, 10**12), st.binary(max_size=200),
       st.booleans())
@pytest.mark.slow
def test_ply_loader_loads_or_refuses(tmp_path_factory, fmt, nv, nf, body, ascii_body):
    from morphogen.domains.ply import load_mesh

    root = tmp_path_factory.mktemp("ply")
    path = root / "m.ply"
    if ascii_body:
        body = b" ".join(str(b % 5).encode() for b in body)
    path.write_bytes(PLY_HEAD.format(fmt=fmt, nv=nv % 50, nf=nf if nf > 40 else nf % 4).encode()
                     + body)
    try:
        load_mesh(path)
    except MorphogenError as exc:
        assert "\n" not in str(exc)
    assert _files(root) == [path]


ARGS = ["--size", "8x8", "--size", "100000x100000", "--size", "3x3x3x3", "--steps", "0",
        "--steps", "2.5", "--steps", str(2**70), "--time", "-1", "--time", "1e308", "--dt",
        "nan", "--dt", "1e-300", "--seed", "-1", "--seed", str(2**64), "--clamp", "x",
        "--clamp", "1:0", "--clamp", "none", "--noise", "x", "--noise", "0.1:bogus", "--cmap",
        "no_such", "--cmap", "#zzz", "--vmin", "nan", "--vmax", "inf", "--threshold", "1",
        "-p", "F", "-p", "F=", "-p", "F=inf", "-p", "F=0.03", "--init-opt", "count=abc",
        "--boundary", "v=dirichlet=x", "--stencil", "4", "--every", "0", "--animation", "avi",
        "--init", "nothing.npz", "--config", "missing.json", "gray-scott", "no-such-model",
        "x.toml", "=", "--", "-", "\x00", "ｕ"]


@FAST
@given(st.lists(st.sampled_from(ARGS) | st.text(max_size=10), max_size=8))
@pytest.mark.slow
def test_simulate_arguments_parse_or_refuse(tmp_path_factory, argv):
    from morphogen.cli.main import build_parser
    from morphogen.cli.simulate_cmd import config_from_args
    from morphogen.runs.schema import validate_config

    root = tmp_path_factory.mktemp("cli")
    cwd = os.getcwd()
    os.chdir(root)
    try:
        args = build_parser().parse_args(["simulate", *argv])
        validate_config(asdict(config_from_args(args)), "run settings")
    except SystemExit as exc:
        assert exc.code == 2
    except MorphogenError as exc:
        assert "\n" not in str(exc)
    finally:
        os.chdir(cwd)
    assert _files(root) == []


@pytest.fixture(autouse=True)
def _quiet_argparse(capsys):
    """argparse writes its one-line errors to stderr; keep the test log readable."""
    yield
    capsys.readouterr()
