"""The run archive: one directory per run plus an SQLite index of runs, generations and
individuals.

Layout of a run directory::

    config.json                 what was run (problem, strategy, seed, archive, id)
    generations/gen_001.png     contact sheet of generation 1 (index and fitness per tile)
    generations/gen_001/ind_00.png   each individual's final pattern
    fitness.png                 best and mean fitness over generations
    best/best_1.png, best_1.json     best individuals and their parameters

The index (SQLite in WAL mode, no server) holds a row per run, per generation (with the
strategy's state after that generation, for resuming) and per individual (genome, fitness,
image path). A generation is recorded in one transaction after its files are written, so a
crash at any moment leaves the archive at the end of the last whole generation: ``--resume``
continues from there, rewriting any files of the interrupted one.
"""

from __future__ import annotations

import io
import json
import os
import secrets
import sqlite3
import time
from collections.abc import Iterator, Sequence
from contextlib import closing, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError

ARCHIVE_ENV = "MORPHOGEN_ARCHIVE"
DEFAULT_ARCHIVE = Path("runs") / "index.sqlite"
"""Where the index lives unless ``--archive`` or ``$MORPHOGEN_ARCHIVE`` says otherwise."""

CONFIG = "config.json"

ARCHIVE_VERSION = 1
"""Format version of the index, kept in SQLite's ``user_version`` (0, an archive written
before versions were recorded, reads as 1). An archive of a newer version is refused."""

_SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    id TEXT PRIMARY KEY,
    dir TEXT NOT NULL,
    created REAL NOT NULL,
    model TEXT NOT NULL,
    strategy TEXT NOT NULL,
    fitness TEXT NOT NULL,
    population INTEGER NOT NULL,
    generations INTEGER NOT NULL,
    seed INTEGER NOT NULL,
    status TEXT NOT NULL,
    config TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS generations (
    run_id TEXT NOT NULL REFERENCES runs(id),
    gen INTEGER NOT NULL,
    best REAL,
    mean REAL,
    best_so_far REAL,
    valid INTEGER NOT NULL,
    seconds REAL NOT NULL,
    sheet TEXT NOT NULL,
    state BLOB NOT NULL,
    PRIMARY KEY (run_id, gen)
);
CREATE TABLE IF NOT EXISTS individuals (
    run_id TEXT NOT NULL REFERENCES runs(id),
    gen INTEGER NOT NULL,
    idx INTEGER NOT NULL,
    genome TEXT NOT NULL,
    fitness REAL,
    valid INTEGER NOT NULL,
    image TEXT NOT NULL,
    PRIMARY KEY (run_id, gen, idx)
);
"""


def archive_path(path: str | os.PathLike | None = None) -> Path:
    """The index file: ``path``, else ``$MORPHOGEN_ARCHIVE``, else ``runs/index.sqlite``."""
    return Path(path or os.environ.get(ARCHIVE_ENV) or DEFAULT_ARCHIVE).absolute()


def new_run_id(model: str) -> str:
    """A readable unique id: ``20260101-120000-gray-scott-3fa2``."""
    return f"{time.strftime('%Y%m%d-%H%M%S')}-{model}-{secrets.token_hex(2)}"


@dataclass(frozen=True)
class Generation:
    """One recorded generation (1-based ``gen``) of a run."""

    gen: int
    genomes: np.ndarray
    fitness: np.ndarray
    valid: np.ndarray
    images: Sequence[str]
    sheet: str
    seconds: float
    best_so_far: float
    state: dict[str, np.ndarray]


class Archive:
    """The SQLite index of runs. Every method opens its own short connection."""

    def __init__(self, path: str | os.PathLike | None = None, *, create: bool = True):
        self.path = archive_path(path)
        if self.path.exists() and not self.path.is_file():
            from morphogen.util.io import file_kind

            raise MorphogenError(
                f"run archive {self.path} is {file_kind(self.path.stat().st_mode)}, not a file; "
                "give the path of an SQLite index file (or of one to create) with --archive")
        if not self.path.exists():
            if not create:
                raise MorphogenError(
                    f"no run archive at {self.path}; run `morphogen evolve` first or give "
                    "--archive PATH"
                )
            self.path.parent.mkdir(parents=True, exist_ok=True)
        with self._db() as db, db:
            version = db.execute("PRAGMA user_version").fetchone()[0]
            if version > ARCHIVE_VERSION:
                raise MorphogenError(
                    f"run archive {self.path} has format version {version}, written by a newer "
                    f"morphogen; this one reads version {ARCHIVE_VERSION} and older: upgrade "
                    "morphogen to use it"
                )
            db.executescript(_SCHEMA)
            if version < ARCHIVE_VERSION:
                db.execute(f"PRAGMA user_version = {ARCHIVE_VERSION}")

    @contextmanager
    def _db(self) -> Iterator[sqlite3.Connection]:
        """A connection, closed afterwards; a damaged database file is a one-line error."""
        with closing(self._connect()) as db:
            try:
                yield db
            except sqlite3.DatabaseError as exc:
                raise MorphogenError(
                    f"run archive {self.path} is damaged ({exc}); restore it from a backup or "
                    "move it aside and start a new one"
                ) from None

    def _connect(self) -> sqlite3.Connection:
        try:
            db = sqlite3.connect(self.path, timeout=30.0)
            db.execute("PRAGMA journal_mode=WAL")
            db.execute("PRAGMA synchronous=FULL")
        except sqlite3.DatabaseError as exc:
            raise MorphogenError(f"cannot open run archive {self.path}: {exc}") from None
        db.row_factory = sqlite3.Row
        return db

    # --- writing ----------------------------------------------------------------------------

    def create_run(self, run_id: str, directory: Path, config: dict[str, Any]) -> None:
        """Register a run (status ``running``)."""
        problem = config["problem"]
        row = (
            run_id, str(Path(directory).absolute()), time.time(), problem["model"],
            config["strategy"]["name"], problem["fitness"], config["strategy"]["population"],
            config["generations"], config["seed"], "running", json.dumps(config),
        )
        with self._db() as db, db:
            db.execute("INSERT INTO runs VALUES (?,?,?,?,?,?,?,?,?,?,?)", row)

    def record_generation(self, run_id: str, g: Generation) -> None:
        """Store a whole generation atomically (replacing a previous record of it)."""
        fitness = [_real(f) for f in g.fitness]
        finite = [f for f in fitness if f is not None]
        best = max(finite) if finite else None
        mean = float(np.mean(finite)) if finite else None
        rows = [
            (run_id, g.gen, i, json.dumps([float(x) for x in genome]), fitness[i],
             int(g.valid[i]), g.images[i])
            for i, genome in enumerate(np.asarray(g.genomes, np.float64))
        ]
        with self._db() as db, db:
            db.execute("DELETE FROM individuals WHERE run_id=? AND gen=?", (run_id, g.gen))
            db.execute(
                "INSERT OR REPLACE INTO generations VALUES (?,?,?,?,?,?,?,?,?)",
                (run_id, g.gen, best, mean, _real(g.best_so_far), int(np.sum(g.valid)),
                 g.seconds, g.sheet, _pack(g.state)),
            )
            db.executemany("INSERT INTO individuals VALUES (?,?,?,?,?,?,?)", rows)

    def set_generations(self, run_id: str, generations: int, config: dict[str, Any]) -> None:
        """Record a new planned total of generations (and the configuration holding it); the
        run is ``running`` again until it reaches the total."""
        with self._db() as db, db:
            db.execute("UPDATE runs SET generations=?, config=?, status='running' WHERE id=?",
                       (int(generations), json.dumps(config), run_id))

    def set_status(self, run_id: str, status: str) -> None:
        with self._db() as db, db:
            db.execute("UPDATE runs SET status=? WHERE id=?", (status, run_id))

    def delete_run(self, run_id: str) -> None:
        """Forget a run: its row, generations and individuals, in one transaction (its
        directory is the caller's to remove)."""
        with self._db() as db, db:
            for table, key in (("individuals", "run_id"), ("generations", "run_id"),
                               ("runs", "id")):
                db.execute(f"DELETE FROM {table} WHERE {key}=?", (run_id,))

    # --- reading ----------------------------------------------------------------------------

    def runs(self) -> list[dict[str, Any]]:
        """All runs, newest first, with ``done`` (recorded generations) and ``best``."""
        query = """
            SELECT r.*, COUNT(g.gen) AS done, MAX(g.best) AS best
            FROM runs r LEFT JOIN generations g ON g.run_id = r.id
            GROUP BY r.id ORDER BY r.created DESC"""
        with self._db() as db:
            rows = [dict(row) for row in db.execute(query)]
        for row in rows:
            _check_numbers(row, ("done",), ("best",), self.path, row.get("id"))
        return rows

    def run(self, ref: str | os.PathLike) -> dict[str, Any]:
        """A run by id, or by its directory (as given to ``--out``).

        Raises:
            MorphogenError: no such run.
        """
        with self._db() as db:
            row = db.execute("SELECT * FROM runs WHERE id=?", (str(ref),)).fetchone()
            if row is None and Path(ref).is_dir():
                row = db.execute("SELECT * FROM runs WHERE dir=?",
                                 (str(Path(ref).absolute()),)).fetchone()
        if row is None:
            raise MorphogenError(
                f"no run {str(ref)!r} in the archive {self.path}; `morphogen runs` lists them"
            )
        out = dict(row)
        out["config"] = _stored_config(out["config"], self.path, out["id"])
        return out

    def generations(self, run_id: str) -> list[dict[str, Any]]:
        """Recorded generations of a run in order (without the state blobs)."""
        query = ("SELECT gen, best, mean, best_so_far, valid, seconds, sheet FROM generations "
                 "WHERE run_id=? ORDER BY gen")
        with self._db() as db:
            rows = [dict(row) for row in db.execute(query, (run_id,))]
        for row in rows:
            _check_numbers(row, ("gen", "valid", "seconds"), ("best", "mean", "best_so_far"),
                           self.path, run_id)
        return rows

    def last_state(self, run_id: str) -> tuple[int, dict[str, np.ndarray]] | None:
        """``(gen, strategy state arrays)`` of the last recorded generation, or ``None``."""
        query = "SELECT gen, state FROM generations WHERE run_id=? ORDER BY gen DESC LIMIT 1"
        with self._db() as db:
            row = db.execute(query, (run_id,)).fetchone()
        return None if row is None else (int(row["gen"]), _unpack(row["state"]))

    def states(self, run_id: str) -> list[tuple[int, dict[str, np.ndarray]]]:
        """``(gen, strategy state arrays)`` of every recorded generation, in order."""
        query = "SELECT gen, state FROM generations WHERE run_id=? ORDER BY gen"
        with self._db() as db:
            rows = db.execute(query, (run_id,)).fetchall()
        return [(int(row["gen"]), _unpack(row["state"])) for row in rows]

    def individuals(self, run_id: str, gen: int | None = None) -> list[dict[str, Any]]:
        """Individuals of a run (or of one generation), with genomes decoded."""
        query = "SELECT * FROM individuals WHERE run_id=?"
        args: tuple = (run_id,)
        if gen is not None:
            query += " AND gen=?"
            args = (run_id, gen)
        with self._db() as db:
            rows = [dict(row) for row in db.execute(query + " ORDER BY gen, idx", args)]
        for row in rows:
            _check_numbers(row, ("gen", "idx"), ("fitness",), self.path, run_id)
            row["genome"] = _genome(row["genome"], self.path, run_id)
        return rows

    def best(self, run_id: str, k: int = 1) -> list[dict[str, Any]]:
        """The ``k`` fittest distinct genomes of a run (earliest first among equals)."""
        query = ("SELECT * FROM individuals WHERE run_id=? AND fitness IS NOT NULL "
                 "ORDER BY fitness DESC, gen, idx")
        out, seen = [], set()
        with self._db() as db:
            for row in db.execute(query, (run_id,)):
                if row["genome"] in seen:
                    continue
                seen.add(row["genome"])
                item = dict(row)
                _check_numbers(item, ("gen", "idx", "fitness"), (), self.path, run_id)
                item["genome"] = _genome(item["genome"], self.path, run_id)
                out.append(item)
                if len(out) == k:
                    break
        return out


def _damaged_row(path: Path, run_id: Any, what: str) -> MorphogenError:
    return MorphogenError(
        f"run {run_id} in the archive {path} has a damaged row ({what}); it cannot be resumed "
        "or shown"
    )


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _check_numbers(row: dict[str, Any], required: tuple[str, ...], optional: tuple[str, ...],
                   path: Path, run_id: Any) -> None:
    """Refuse a row whose ``required`` columns are not numbers, or whose ``optional`` ones
    are neither numbers nor NULL (SQLite stores any type in any column)."""
    for key in (*required, *optional):
        value = row.get(key)
        if not (_is_number(value) or (value is None and key in optional)):
            raise _damaged_row(path, run_id, f"{key} {str(value)[:40]!r} is not a number")


def _genome(text: Any, path: Path, run_id: Any) -> list[float]:
    """A stored genome: a JSON list of numbers."""
    try:
        genome = json.loads(text)
    except (TypeError, ValueError, RecursionError):
        genome = None
    if not isinstance(genome, list) or not all(_is_number(x) for x in genome):
        raise _damaged_row(path, run_id, f"genome {str(text)[:40]!r} is not a list of numbers")
    return genome


def _real(x: Any) -> float | None:
    """A finite float, or ``None`` (SQL NULL) for NaN and infinities."""
    x = float(x)
    return x if np.isfinite(x) else None


def _pack(arrays: dict[str, np.ndarray]) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def _unpack(blob: bytes) -> dict[str, np.ndarray]:
    from morphogen.util.npz import read_npz

    try:
        if not isinstance(blob, bytes | bytearray | memoryview):
            raise MorphogenError(f"a {type(blob).__name__} where an .npz was stored")
        return read_npz(bytes(blob), "strategy state")
    except MorphogenError as exc:
        raise MorphogenError(
            f"the archive's saved strategy state is damaged ({exc}); the run cannot be resumed "
            "from its last generation"
        ) from None


RUN_KEYS = {"seed": int, "generations": int, "strategy": dict, "problem": dict}
"""Settings every stored run configuration has, with their types."""


def _stored_config(text: Any, path: Path, run_id: str) -> dict[str, Any]:
    """A run's stored configuration, checked to be an object with :data:`RUN_KEYS`."""
    try:
        config = json.loads(text)
    except (TypeError, ValueError):
        config = None
    bad = not isinstance(config, dict) or any(
        not isinstance(config.get(k), t) or isinstance(config.get(k), bool)
        for k, t in RUN_KEYS.items()
    )
    if bad or not isinstance(config["strategy"].get("name"), str):
        raise MorphogenError(
            f"run {run_id} in the archive {path} has a damaged configuration; it cannot be "
            "resumed or shown"
        )
    return config
