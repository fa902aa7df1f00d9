"""`morphogen evolve --resume` against a wrong or deleted run folder, or damaged rows: the run's
folder, its archive and their rows are checked (search/run.py::check_resumable) before anything
is changed, so a refused resume is one line, exit 2, and leaves the archive and folder as they
were (no generation recorded, no pictures written, the status unchanged)."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import sqlite3
from pathlib import Path

import pytest

from morphogen.cli.main import main

FLAGS = ["--size", "16", "--dt", "0.5", "--steps", "40", "--population", "4", "--seed", "3",
         "--quiet"]


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> tuple[Path, Path]:
    """A two-generation Gray-Scott search and its archive, made once for the module."""
    base = tmp_path_factory.mktemp("evolve")
    archive, out = base / "index.sqlite", base / "run"
    assert main(["evolve", "gray-scott", *FLAGS, "--generations", "2", "--archive",
                 str(archive), "--out", str(out)]) == 0
    return archive, out


@pytest.fixture()
def copy(finished, tmp_path) -> tuple[Path, Path, str]:
    """The finished run in a fresh place (archive row and config pointing at it): ``(archive,
    folder, run id)``."""
    archive, out = tmp_path / "index.sqlite", tmp_path / "run"
    shutil.copy(finished[0], archive)
    shutil.copytree(finished[1], out)
    config = json.loads((out / "config.json").read_text())
    config["archive"] = str(archive)
    (out / "config.json").write_text(json.dumps(config))
    with sqlite3.connect(archive) as db:
        db.execute("UPDATE runs SET dir=?", (str(out.absolute()),))
    return archive, out, config["id"]


def _snapshot(*roots: Path) -> dict[str, str]:
    out = {}
    for root in roots:
        for p in sorted([root] if root.is_file() else root.rglob("*")):
            if p.is_file() and not p.name.endswith(("-wal", "-shm")):
                out[str(p)] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def _rows(archive: Path) -> tuple:
    with sqlite3.connect(archive) as db:
        return (db.execute("SELECT status, generations, config FROM runs").fetchall(),
                db.execute("SELECT gen FROM generations ORDER BY gen").fetchall(),
                db.execute("SELECT count(*) FROM individuals").fetchall())


def _refused(argv, capsys, words: str) -> None:
    capsys.readouterr()
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("morphogen: error: ") and err.count("\n") == 1, err
    assert words in err, err


def _resume(archive: Path, ref: str, *more: str) -> list[str]:
    return ["evolve", "--resume", ref, "--archive", str(archive), "--generations", "3", *more]


def test_a_deleted_run_folder_is_refused_and_nothing_changes(copy, capsys):
    archive, out, run_id = copy
    shutil.rmtree(out)
    before = _rows(archive)
    _refused(_resume(archive, run_id), capsys, "does not exist (deleted or moved)")
    assert _rows(archive) == before and not out.exists()
    _refused(_resume(archive, run_id), capsys, "does not exist")  # and again: still refused


def test_a_folder_holding_another_run_is_refused(copy, tmp_path, capsys):
    archive, out, run_id = copy
    config = json.loads((out / "config.json").read_text())
    (out / "config.json").write_text(json.dumps({**config, "id": "someone-else"}))
    before = _rows(archive), _snapshot(out)
    _refused(_resume(archive, run_id), capsys,
             "holds run 'someone-else', not run " + run_id)
    assert (_rows(archive), _snapshot(out)) == before


def test_a_folder_without_its_config_or_not_a_folder(copy, capsys):
    archive, out, run_id = copy
    (out / "config.json").unlink()
    before = _rows(archive), _snapshot(out)
    _refused(_resume(archive, run_id), capsys, "no longer holds the run")
    assert (_rows(archive), _snapshot(out)) == before
    shutil.rmtree(out)
    os.mkfifo(out)
    _refused(_resume(archive, run_id), capsys, "is a FIFO (named pipe), not a folder")
    assert _rows(archive) == before[0]


@pytest.mark.parametrize("genome,words", [
    ("[1.0]", "a genome of 1 values, not 2"),
    ("[NaN, 0.06]", "not finite"),
    ('"junk"', "is not a list of numbers"),
])
def test_a_junk_genome_row_is_refused_before_generation_3(copy, capsys, genome, words):
    archive, out, run_id = copy
    with sqlite3.connect(archive) as db:
        db.execute("UPDATE individuals SET genome=? WHERE gen=1 AND idx=2", (genome,))
    before = _rows(archive), _snapshot(out)
    _refused(_resume(archive, str(out)), capsys, words)
    assert (_rows(archive), _snapshot(out)) == before
    assert not (out / "generations" / "gen_003.png").exists()


def test_a_missing_generation_is_refused(copy, capsys):
    archive, out, run_id = copy
    with sqlite3.connect(archive) as db:
        db.execute("DELETE FROM generations WHERE gen=1")
    before = _rows(archive), _snapshot(out)
    _refused(_resume(archive, run_id), capsys, "records generations [2], not 1 to 1")
    assert (_rows(archive), _snapshot(out)) == before


def test_the_intact_run_still_resumes(copy, capsys):
    archive, out, run_id = copy
    assert main(_resume(archive, run_id)) == 0
    rows = _rows(archive)
    assert rows[0][0][:2] == ("done", 3) and rows[1] == [(1,), (2,), (3,)]
    assert (out / "generations" / "gen_003.png").is_file()
