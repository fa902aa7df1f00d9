"""The run archive: SQLite index in WAL mode, whole generations recorded atomically, runs found
by id or directory."""

import sqlite3

import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.search import archive as arch
from morphogen.search.archive import Archive, Generation


def config(model="gray-scott"):
    return {"id": "x", "seed": 3, "generations": 5,
            "strategy": {"name": "ga", "population": 3},
            "problem": {"model": model, "fitness": "dirichlet"}}


def generation(gen, fitness, genomes=None):
    genomes = np.arange(6, dtype=np.float32).reshape(3, 2) + gen if genomes is None else genomes
    return Generation(
        gen=gen, genomes=genomes, fitness=np.asarray(fitness, np.float32),
        valid=np.array([True, True, False]), images=[f"g{gen}/i{i}.png" for i in range(3)],
        sheet=f"gen_{gen:03d}.png", seconds=1.5, best_so_far=float(np.nanmax(fitness)),
        state={"leaf_0": np.arange(4.0) * gen, "leaf_1": np.int32(gen)},
    )


@pytest.fixture
def archive(tmp_path):
    a = Archive(tmp_path / "index.sqlite")
    (tmp_path / "run").mkdir()
    a.create_run("run-1", tmp_path / "run", config())
    return a


def test_generations_round_trip(archive):
    archive.record_generation("run-1", generation(1, [0.2, 0.5, -1.0]))
    archive.record_generation("run-1", generation(2, [0.7, 0.1, 0.3]))
    gens = archive.generations("run-1")
    assert [g["gen"] for g in gens] == [1, 2]
    assert gens[0]["best"] == pytest.approx(0.5) and gens[1]["valid"] == 2
    assert gens[0]["mean"] == pytest.approx((0.2 + 0.5 - 1.0) / 3)
    gen, state = archive.last_state("run-1")
    assert gen == 2
    np.testing.assert_array_equal(state["leaf_0"], np.arange(4.0) * 2)
    rows = archive.individuals("run-1", 2)
    assert [r["idx"] for r in rows] == [0, 1, 2]
    assert rows[1]["genome"] == [4.0, 5.0] and rows[1]["image"] == "g2/i1.png"
    assert len(archive.individuals("run-1")) == 6
    listed = archive.runs()
    assert listed[0]["id"] == "run-1" and listed[0]["done"] == 2
    assert listed[0]["best"] == pytest.approx(0.7)


def test_best_lists_distinct_genomes(archive):
    same = np.array([[1.0, 1.0], [1.0, 1.0], [2.0, 2.0]], np.float32)
    archive.record_generation("run-1", generation(1, [0.9, 0.9, 0.5], same))
    archive.record_generation("run-1", generation(2, [0.9, 0.1, 0.2], same))
    best = archive.best("run-1", 3)
    assert [b["genome"] for b in best] == [[1.0, 1.0], [2.0, 2.0]]
    assert (best[0]["gen"], best[0]["idx"]) == (1, 0)  # the earliest among equals


def test_nan_fitness_is_stored_as_null(archive):
    archive.record_generation("run-1", generation(1, [np.nan, 0.5, -np.inf]))
    rows = archive.individuals("run-1", 1)
    assert rows[0]["fitness"] is None and rows[2]["fitness"] is None
    assert archive.best("run-1", 5)[0]["fitness"] == pytest.approx(0.5)


def test_a_failed_write_leaves_the_previous_record(archive, monkeypatch):
    archive.record_generation("run-1", generation(1, [0.2, 0.5, 0.1]))

    def broken(arrays):
        raise RuntimeError("disk full")

    monkeypatch.setattr(arch, "_pack", broken)
    with pytest.raises(RuntimeError):
        archive.record_generation("run-1", generation(1, [0.9, 0.9, 0.9]))
    with pytest.raises(RuntimeError):
        archive.record_generation("run-1", generation(2, [0.9, 0.9, 0.9]))
    assert [r["fitness"] for r in archive.individuals("run-1")] == pytest.approx([0.2, 0.5, 0.1])
    assert archive.last_state("run-1")[0] == 1


def test_rerecording_a_generation_replaces_it(archive):
    archive.record_generation("run-1", generation(1, [0.2, 0.5, 0.1]))
    archive.record_generation("run-1", generation(1, [0.3, 0.4, 0.6]))
    assert [r["fitness"] for r in archive.individuals("run-1")] == pytest.approx([0.3, 0.4, 0.6])
    assert len(archive.generations("run-1")) == 1


def test_wal_mode(archive):
    with sqlite3.connect(archive.path) as db:
        assert db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_runs_are_found_by_id_or_directory(archive, tmp_path):
    assert archive.run("run-1")["config"]["seed"] == 3
    assert archive.run(tmp_path / "run")["id"] == "run-1"
    with pytest.raises(MorphogenError, match="no run"):
        archive.run("nope")
    with pytest.raises(MorphogenError, match="no run"):
        archive.run(tmp_path)


def test_missing_archive_is_an_error_when_reading(tmp_path, monkeypatch):
    with pytest.raises(MorphogenError, match="no run archive"):
        Archive(tmp_path / "none.sqlite", create=False)
    monkeypatch.setenv(arch.ARCHIVE_ENV, str(tmp_path / "env.sqlite"))
    assert arch.archive_path() == tmp_path / "env.sqlite"
    assert arch.archive_path(tmp_path / "given.sqlite") == tmp_path / "given.sqlite"


def test_status_and_ids(archive):
    archive.set_status("run-1", "done")
    assert archive.run("run-1")["status"] == "done"
    a, b = arch.new_run_id("gray-scott"), arch.new_run_id("gray-scott")
    assert a != b and "gray-scott" in a
