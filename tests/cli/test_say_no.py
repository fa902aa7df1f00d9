"""Say no instead of pretending: an input the program cannot honour is refused with one line
(exit status 2), never silently ignored. ``evolve --resume --generations N`` honours ``N`` as
the run's new total; a run file or archive of a newer format is refused; a number where an
equation belongs is refused; a suggested time step is one the check accepts. ``evolve --resume``
refuses the options that only set up a new run."""

from __future__ import annotations

import json
import random
import re
import sqlite3

import pytest

from morphogen.cli.main import main
from morphogen.errors import DivergenceError, MorphogenError, UnstableTimeStepError, round_down
from morphogen.models.text.equations import parse_model


def _code(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


def _refused(argv: list[str], capsys) -> str:
    code = _code(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("morphogen: error: "), err
    return err


# --- evolve --resume --generations N --------------------------------------------------------

EVOLVE = ["evolve", "gray-scott", "--population", "2", "--size", "16", "--steps", "4",
          "--quiet"]


@pytest.fixture()
def one_generation(tmp_path, capsys):
    """A finished one-generation GA run in ``tmp_path/run``, archived in ``tmp_path``."""
    archive, out = tmp_path / "index.sqlite", tmp_path / "run"
    assert main([*EVOLVE, "--generations", "1", "--out", str(out), "--archive",
                 str(archive)]) == 0
    capsys.readouterr()
    return archive, out


def _recorded(archive) -> tuple[int, int, str]:
    with sqlite3.connect(archive) as db:
        planned, status = db.execute("SELECT generations, status FROM runs").fetchone()
        done = db.execute("SELECT COUNT(*) FROM generations").fetchone()[0]
    return planned, done, status


def test_resume_with_more_generations_extends_the_run(one_generation, tmp_path, capsys):
    archive, out = one_generation
    assert _recorded(archive) == (1, 1, "done")
    assert main(["evolve", "--resume", str(out), "--generations", "2", "--quiet",
                 "--archive", str(archive)]) == 0
    assert "generation 2/2" in capsys.readouterr().out
    assert _recorded(archive) == (2, 2, "done")
    assert json.loads((out / "config.json").read_text())["generations"] == 2
    # the same as a run planned for two generations from the start
    fresh_archive, fresh = tmp_path / "fresh.sqlite", tmp_path / "fresh"
    assert main([*EVOLVE, "--generations", "2", "--out", str(fresh), "--archive",
                 str(fresh_archive)]) == 0
    query = "SELECT gen, idx, genome, fitness FROM individuals ORDER BY gen, idx"
    with sqlite3.connect(archive) as a, sqlite3.connect(fresh_archive) as b:
        assert a.execute(query).fetchall() == b.execute(query).fetchall()


def test_resume_below_the_generations_done_is_refused(one_generation, capsys):
    archive, out = one_generation
    main(["evolve", "--resume", str(out), "--generations", "2", "--quiet", "--archive",
          str(archive)])
    capsys.readouterr()
    err = _refused(["evolve", "--resume", str(out), "--generations", "1", "--quiet",
                    "--archive", str(archive)], capsys)
    assert "already done 2 generations" in err and "at least 2" in err
    assert _recorded(archive) == (2, 2, "done")


def test_resume_without_generations_keeps_the_total(one_generation, capsys):
    archive, out = one_generation
    assert main(["evolve", "--resume", str(out), "--quiet", "--archive", str(archive)]) == 0
    assert _recorded(archive) == (1, 1, "done")


@pytest.mark.parametrize("option", [["--population", "5"], ["--strategy", "cmaes"],
                                    ["--gene", "F=0:1"], ["-p", "F=0.03"], ["--size", "32"],
                                    ["--steps", "9"], ["--seed", "4"], ["--out", "elsewhere"],
                                    ["--fitness", "cluster"], ["--elitism", "1"]])
def test_resume_refuses_options_of_a_new_run(option, one_generation, capsys):
    archive, out = one_generation
    err = _refused(["evolve", "--resume", str(out), "--archive", str(archive), "--quiet",
                    *option], capsys)
    flag = {"-p": "--param"}.get(option[0], option[0])
    assert f"{flag} sets up a new run" in err and f"drop {flag}" in err
    assert _recorded(archive) == (1, 1, "done")


# --- files of a newer format ----------------------------------------------------------------

RUN = {"model": "schnakenberg", "size": [8, 8], "steps": 2}


@pytest.mark.parametrize("fmt, fragment", [
    ("morphogen-run/2", "morphogen-run/2, written by a newer morphogen"),
    ("morphogen-run/10", "newer morphogen"),
    ("morphogen-run/" + "9" * 5000, "newer morphogen"),
    ("morphogen-run/x", "not a morphogen run file"),
    ("morphogen-run/²", "not a morphogen run file"),
    ("morphogen-neural-rd", "not a morphogen run file"),
    ("", "not a morphogen run file"),
    (2, "not a morphogen run file"),
    (None, "not a morphogen run file"),
    (["morphogen-run/1"], "not a morphogen run file"),
])
def test_a_run_file_of_another_format_is_refused(fmt, fragment, tmp_path, capsys):
    path = tmp_path / "run.json"
    path.write_text(json.dumps({"format": fmt, "config": RUN}))
    err = _refused(["simulate", "--config", str(path), "--quiet", "--out",
                    str(tmp_path / "out")], capsys)
    assert fragment in err
    if "newer" in err:
        assert "morphogen-run/1" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("record", [{"format": "morphogen-run/1"}, {"format": "morphogen-run/0"},
                                    {}])
def test_run_files_of_this_format_or_without_one_still_run(record, tmp_path):
    path = tmp_path / "run.json"
    path.write_text(json.dumps({**record, "config": RUN}))
    assert main(["simulate", "--config", str(path), "--quiet", "--out",
                 str(tmp_path / "out")]) == 0


def test_an_archive_of_a_newer_version_is_refused(one_generation, capsys):
    archive, out = one_generation
    with sqlite3.connect(archive) as db:
        db.execute("PRAGMA user_version = 2")
    before = archive.read_bytes()
    for argv in (["runs", "--archive", str(archive)],
                 ["evolve", "--resume", str(out), "--quiet", "--archive", str(archive)],
                 [*EVOLVE, "--out", str(out.parent / "new"), "--archive", str(archive)]):
        err = _refused(argv, capsys)
        assert "format version 2" in err and "reads version 1" in err
    assert archive.read_bytes() == before
    assert not (out.parent / "new").exists()


def test_a_new_archive_records_its_version(tmp_path):
    from morphogen.search.archive import ARCHIVE_VERSION, Archive

    Archive(tmp_path / "index.sqlite")
    with sqlite3.connect(tmp_path / "index.sqlite") as db:
        assert db.execute("PRAGMA user_version").fetchone()[0] == ARCHIVE_VERSION == 1


# --- a number where an equation belongs -----------------------------------------------------

HEAD = 'species = ["u", "v"]\n[parameters]\na = 1\n[equations]\nv = "-v + lap(v)"\n'


@pytest.mark.parametrize("value", ["5", "5.0", "-1e3", "true", "[1, 2]", "{ x = 1 }",
                                   "1979-05-27", "inf"])
def test_an_equation_that_is_not_a_string_is_refused_with_its_position(value):
    with pytest.raises(MorphogenError) as info:
        parse_model(HEAD + f"u = {value}\n")
    message = str(info.value)
    assert message.startswith("line 6, column 1: the equation for u must be an expression in "
                              "quotes"), message
    if value == "5":
        assert 'u = "5"' in message


def test_initial_values_may_still_be_numbers():
    model = parse_model(HEAD + 'u = "a"\n[initial]\nu = 5\nv = 0.5\n')
    assert model.ground(model.params) == (5.0, 0.5)


def test_an_equation_given_as_a_number_on_the_command_line(tmp_path, capsys):
    path = tmp_path / "m.toml"
    path.write_text(HEAD + "u = 5\n")
    err = _refused(["simulate", str(path), "--size", "8x8", "--steps", "2", "--quiet",
                    "--out", str(tmp_path / "out")], capsys)
    assert "line 6, column 1" in err and "in quotes" in err


# --- a suggested time step is accepted ------------------------------------------------------

def test_round_down_never_rounds_up():
    rng = random.Random(0)
    for _ in range(20_000):
        x = 10 ** rng.uniform(-12, 8)
        shown = float(f"{round_down(x):.6g}")
        assert shown <= x and shown >= x * (1 - 1e-5), x
    assert f"{round_down(0.005607576842436197):.6g}" == "0.00560757"  # %.6g: 0.00560758


def test_the_messages_suggest_a_step_at_or_below_the_limit():
    limit = 0.005607576842436197
    assert "use --dt 0.00560757 or smaller" in str(UnstableTimeStepError(0.01, limit, "euler"))
    err = DivergenceError(10, ("u",), 1.0, "a growing checkerboard", limit)
    assert "use --dt 0.00560757 or smaller" in str(err)


@pytest.mark.parametrize("model, dx", [("schnakenberg", "1"), ("gray-scott", "1"),
                                       ("gierer-meinhardt", "0.9"), ("brusselator", "1")])
def test_the_suggested_dt_runs(model, dx, tmp_path, capsys):
    """Each limit here has a 7th significant digit of 5 or more: ``%.6g`` rounded it up, and
    the suggested step was refused with the same message."""
    argv = ["simulate", model, "--size", "8x8", "--steps", "2", "--dx", dx, "--quiet"]
    err = _refused([*argv, "--dt", "50", "--out", str(tmp_path / "a")], capsys)
    suggested = re.search(r"use --dt (\S+) or smaller", err).group(1)
    assert _code([*argv, "--dt", suggested, "--out", str(tmp_path / "b")]) == 0, \
        capsys.readouterr().err
