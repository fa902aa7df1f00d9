"""The table of run settings: the schema, the dataclass, every command's flags and the web bodies
all follow from its rows, and the front ends agree on what they refuse."""

from __future__ import annotations

import argparse
import ast
import dataclasses
import importlib
import json

import pytest

from morphogen.cli import options
from morphogen.cli.main import main
from morphogen.errors import MorphogenError
from morphogen.runs.config import RunConfig
from morphogen.runs.schema import RunSchema
from morphogen.runs.settings import BY_NAME, COMMANDS, REQUIRED, SETTINGS, default, for_command
from morphogen.solvers import registry
from morphogen.web import batch, evolve_routes, explore, mesh_routes
from morphogen.web.evolve_routes import build
from morphogen.web.limits import Limits
from morphogen.web.settings import read_settings

WEB_ROUTES = {"live": explore.LIVE_SETTINGS, "atlas": batch.BATCH_SETTINGS,
              "evolve": evolve_routes.EVOLVE_SETTINGS, "mesh": mesh_routes.MESH_SETTINGS}


def _parser(command: str) -> argparse.ArgumentParser:
    """The full parser of one sub-command, as ``morphogen COMMAND`` builds it."""
    sub = argparse.ArgumentParser().add_subparsers()
    importlib.import_module(f"morphogen.cli.{command}_cmd").register(sub)
    return sub.choices[command]


def _flags(command: str) -> dict[str, argparse.Action]:
    return {flag: action for action in _parser(command)._actions
            for flag in action.option_strings}


@pytest.mark.parametrize("row", SETTINGS, ids=lambda s: s.name)
def test_every_row_is_a_schema_and_dataclass_field_with_its_default(row):
    field = RunSchema.model_fields[row.name]
    config = {f.name: f for f in dataclasses.fields(RunConfig)}[row.name]
    if row.default is REQUIRED:
        assert field.is_required()
        assert config.default is dataclasses.MISSING
        assert config.default_factory is dataclasses.MISSING
    else:
        assert field.default == row.default
        made = RunConfig(model="m")
        assert getattr(made, row.name) == row.default == default(row.name)
    assert list(RunSchema.model_fields) == [s.name for s in SETTINGS]
    assert [f.name for f in dataclasses.fields(RunConfig)] == [s.name for s in SETTINGS]


def _declared(cls: type) -> list[str]:
    """The annotations of ``cls`` as written (``from __future__ import annotations`` keeps
    them as text, normalised like :func:`_normal`)."""
    return [f"{name}: {annotation}" for name, annotation in cls.__annotations__.items()]


def _normal(text: str) -> str:
    """A type written the way Python stores a postponed annotation (quotes, spacing)."""
    return ast.unparse(ast.parse(text, mode="eval"))


def test_the_static_dataclass_and_schema_declare_every_row_with_its_types():
    """RunConfig and RunSchema are written out so a type checker sees their fields; each
    annotation is its row's ``type`` (dataclass) and ``schema`` (pydantic) text. On failure the
    expected lines are printed, ready to paste."""
    want_config = [f"{s.name}: {_normal(s.type)}" for s in SETTINGS]
    want_schema = [f"{s.name}: {_normal(s.schema)}" for s in SETTINGS]
    assert _declared(RunConfig) == want_config, "\n".join(want_config)
    assert _declared(RunSchema) == want_schema, "\n".join(want_schema)


def test_mutable_defaults_are_not_shared():
    a, b = RunConfig(model="a"), RunConfig(model="b")
    a.size.append(3)
    a.params["F"] = 0.1
    assert b.size == [256, 256] and b.params == {}
    assert BY_NAME["size"].default == [256, 256]


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_declares_its_rows_with_the_same_help(command):
    flags = _flags(command)
    for row in for_command(command):
        action = flags[row.flag]
        assert action.help == row.help, (command, row.name)
        if row.short:
            assert flags[row.short] is action
        if row.choices_for(command):
            assert tuple(action.choices) == tuple(row.choices_for(command))
    rows_by_flag = {s.flag: s for s in SETTINGS if s.flag}
    for flag in set(flags) & set(rows_by_flag):
        assert command in rows_by_flag[flag].commands, flag


def test_scheme_choices_come_from_the_registry():
    scheme = BY_NAME["scheme"]
    assert scheme.choices_for("simulate") == registry.NAMES
    assert all(scheme.choices_for(c) == registry.POPULATION for c in ("evolve", "atlas", "fit"))
    assert scheme.choices_for("web") == registry.LIVE
    assert tuple(_flags("simulate")["--scheme"].choices) == registry.NAMES


def test_precision_is_a_flag_of_every_command_whose_engine_honours_it():
    assert {"simulate", "atlas"} <= set(BY_NAME["precision"].commands)
    args = _parser("atlas").parse_args(["gray-scott", "--x", "F=0.02:0.03:2",
                                        "--y", "k=0.05:0.06:2", "--x64"])
    assert options.run_settings(args, "atlas")["precision"] == "float64"


def test_flags_become_run_setting_values():
    args = _parser("simulate").parse_args(
        ["gray-scott", "--size", "32x16", "--clamp", "none", "--x64", "-p", "F=0.03",
         "--init-opt", "count=3", "--stencil", "9", "--boundary", "neumann"])
    given = options.given_settings(args, "simulate")
    assert given == {"size": [32, 16], "clamp": None, "precision": "float64",
                     "params": {"F": 0.03}, "init_options": {"count": 3.0}, "stencil": 9,
                     "boundary": "neumann"}
    evolve = options.run_settings(_parser("evolve").parse_args(["gray-scott"]), "evolve",
                                  {"size": [128, 128]})
    assert evolve["size"] == [128, 128] and evolve["clamp"] == "model"
    assert evolve["boundary"] == "periodic" and evolve["params"] == {}


def test_every_web_row_is_read_from_a_body_by_some_route():
    web_rows = {s.name for s in SETTINGS if s.web}
    read = set().union(*WEB_ROUTES.values())
    assert read <= web_rows
    assert web_rows <= read | {"model"}


@pytest.mark.parametrize(("name", "value", "expected"), [
    ("dx", 0.5, 0.5), ("stencil", "9", 9), ("stencil", "spectral", "spectral"),
    ("scheme", "imex", "imex"), ("boundary", "neumann", "neumann"), ("seed", 7, 7),
    ("init", "blobs", "blobs"), ("cmap", "magma", "magma"), ("dt", 0.25, 0.25),
    ("steps", 10, 10), ("params", {"F": 0.03}, {"F": 0.03}),
])
def test_a_web_body_is_read_into_settings(name, value, expected):
    assert read_settings({name: value}, [name])[name] == expected


def test_absent_or_null_web_values_take_the_route_default():
    got = read_settings({"dt": None}, ["dt", "seed", "scheme"], defaults={"scheme": "rk4"})
    assert got == {"dt": None, "seed": 0, "scheme": "rk4"}


@pytest.mark.parametrize(("body", "fragment"), [
    ({"scheme": "adaptive"}, "scheme must be one of euler, rk4, imex1, imex, etdrk4"),
    ({"stencil": 4}, "stencil must be one of 5, 7, 9, spectral"),
    ({"dx": -1}, "dx must be >="),
    ({"seed": 1.5}, "seed must be a whole number"),
    ({"boundary": "dirichlet"}, "boundary must be one of periodic, neumann"),
])
def test_bad_web_values_are_one_line_errors(body, fragment):
    with pytest.raises(MorphogenError, match=fragment):
        read_settings(body, list(body))


def test_a_bad_colour_map_gets_the_same_error_from_the_web_and_the_command_line(tmp_path,
                                                                                capsys):
    with pytest.raises(MorphogenError) as web:
        read_settings({"cmap": "no-such-map"}, ["cmap"])
    status = main(["simulate", "gray-scott", "--size", "8x8", "--steps", "1", "--cmap",
                   "no-such-map", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert status == 2 and "\n" not in err
    assert err.endswith(str(web.value))


def test_the_web_stencil_choices_are_the_command_line_ones():
    with pytest.raises(MorphogenError) as web:
        read_settings({"stencil": 4}, ["stencil"])
    assert web.value.args[0].split("; ")[0].endswith(", ".join(_flags("fit")["--stencil"].choices))


def test_the_live_grid_honours_dx_and_stencil(client):
    r = client.post("/api/live", json={"model": {"library": "gray-scott"}, "size": 16,
                                       "init": "square", "dx": 2.0, "stencil": 9})
    assert r.status_code == 200, r.text
    sid = r.json()["id"]
    grid = client.app.state.sessions.get(sid).engine.grid
    assert grid.dx == 2.0 and grid.stencil == 9
    run = json.loads(client.get(f"/api/live/{sid}/config").content)["config"]
    assert run["dx"] == 2.0 and run["stencil"] == 9
    plain = client.post("/api/live", json={"model": {"library": "gray-scott"}, "size": 16,
                                           "init": "square"}).json()["id"]
    run = json.loads(client.get(f"/api/live/{plain}/config").content)["config"]
    assert "dx" not in run and "stencil" not in run


def test_a_bad_web_stencil_is_refused_before_any_work(client):
    r = client.post("/api/atlas", json={"model": {"library": "gray-scott"}, "tile": 8,
                                        "stencil": 7, "steps": 2,
                                        "x": {"name": "F", "lo": 0.02, "hi": 0.03, "n": 2},
                                        "y": {"name": "k", "lo": 0.05, "hi": 0.06, "n": 2}})
    assert r.status_code == 400 and "\n" not in r.json()["error"]
    assert "7-point" in r.json()["error"]


def test_evolve_requests_carry_dx_and_stencil():
    problem, *_ = build({"model": {"library": "gray-scott"}, "size": 16, "steps": 2,
                         "dx": 0.5, "stencil": 9}, Limits())
    assert problem.dx == 0.5 and problem.stencil == 9
    plain, *_ = build({"model": {"library": "gray-scott"}, "size": 16, "steps": 2}, Limits())
    assert plain.dx == 1.0 and plain.stencil is None and plain.boundary == "periodic"


def test_a_search_problem_takes_the_tables_defaults_and_checks():
    """The search's record of run settings (:class:`Problem`) has the table's default for each
    setting it shares with it (a search's own grid, ``SEARCH_SIZE``, apart), and refuses what
    the table refuses."""
    from morphogen.search.evaluate import SEARCH_SIZE, Problem
    from morphogen.search.genes import Gene

    shared = [f for f in dataclasses.fields(Problem) if f.name in BY_NAME and f.name != "model"]
    assert {f.name for f in shared} >= {"dx", "dt", "steps", "time", "scheme", "seed", "init",
                                        "size", "clamp", "init_options", "params", "preset"}
    problem = Problem(model="gray-scott", genes=(Gene("F", 0.02, 0.06),))
    for f in shared:
        want = tuple(SEARCH_SIZE) if f.name == "size" else default(f.name)
        got = getattr(problem, f.name)
        assert (dict(got) if isinstance(got, dict) else got) == want, f.name
    for bad in ({"dt": -1.0}, {"time": float("nan")}, {"steps": 0}):
        with pytest.raises(MorphogenError):
            Problem(model="gray-scott", genes=(Gene("F", 0.02, 0.06),), **bad)
