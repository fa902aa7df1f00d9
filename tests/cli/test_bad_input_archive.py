"""A damaged or copied run archive: one line and exit status 2, never a traceback."""

from __future__ import annotations

import json
import shutil
import sqlite3

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.errors import MorphogenError
from morphogen.search.archive import Archive
from morphogen.search.run import resolve_run

CONFIG = {"id": "r1", "seed": 0, "generations": 2,
          "strategy": {"name": "ga", "population": 4},
          "problem": {"model": "gray-scott", "fitness": "spots"}}


@pytest.fixture()
def archived(tmp_path):
    """An archive with run ``r1`` in ``tmp_path/r1`` (its ``config.json`` written)."""
    path = tmp_path / "index.sqlite"
    directory = tmp_path / "r1"
    directory.mkdir()
    config = {**CONFIG, "archive": str(path)}
    (directory / "config.json").write_text(json.dumps(config))
    archive = Archive(path)
    archive.create_run("r1", directory, config)
    return archive, directory


def _one_line_refusal(argv, capsys) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("morphogen: error: "), err
    return err


def test_random_bytes_in_the_database_pages(archived, capsys):
    archive, directory = archived
    data = bytearray(archive.path.read_bytes())
    rng = np.random.default_rng(0)
    # Keep the 100-byte header readable; scramble every page after it.
    data[100:] = rng.integers(0, 256, len(data) - 100, dtype=np.uint8).tobytes()
    archive.path.write_bytes(bytes(data))
    for argv in (["runs", "--archive", str(archive.path)],
                 ["runs", "show", "r1", "--archive", str(archive.path)],
                 ["evolve", "--resume", "r1", "--archive", str(archive.path)]):
        err = _one_line_refusal(argv, capsys)
        assert "damaged" in err or "cannot open" in err


def test_garbage_strategy_state(archived):
    archive, _ = archived
    with sqlite3.connect(archive.path) as db:
        db.execute("INSERT INTO generations VALUES ('r1', 1, 0, 0, 0, 4, 1.0, 's.png', ?)",
                   (b"PK\x03\x04 not really a zip",))
    with pytest.raises(MorphogenError, match="saved strategy state is damaged"):
        archive.last_state("r1")


@pytest.mark.parametrize("stored", ["[1, 2]", "not json", json.dumps({**CONFIG, "seed": "x"}),
                                    json.dumps({**CONFIG, "strategy": {"name": 5}})])
def test_invalid_stored_config(archived, capsys, stored):
    archive, _ = archived
    with sqlite3.connect(archive.path) as db:
        db.execute("UPDATE runs SET config=? WHERE id='r1'", (stored,))
    err = _one_line_refusal(["evolve", "--resume", "r1", "--archive", str(archive.path)], capsys)
    assert "damaged configuration" in err


def test_resume_of_a_copied_run_directory_is_refused(archived, tmp_path):
    archive, directory = archived
    copy = tmp_path / "copy"
    shutil.copytree(directory, copy)
    assert resolve_run(str(directory))[0] == "r1"
    with pytest.raises(MorphogenError, match="copy of run r1.*resume that directory instead"):
        resolve_run(str(copy))
    assert sorted(p.name for p in copy.iterdir()) == ["config.json"]
