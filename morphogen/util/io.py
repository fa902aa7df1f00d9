"""Files written atomically: nothing half-written is ever left behind.

Every writer here writes to a temporary file in the destination directory and renames it into
place (``os.replace``), so a crash leaves either the old file or the new one.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

import numpy as np

from morphogen.errors import MorphogenError


def read_text(path: str | Path, what: str) -> str:
    """A UTF-8 text file's contents; a missing, unreadable or non-UTF-8 file is a one-line
    :class:`MorphogenError` naming ``what`` it should have been (e.g. ``"model file"``)."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise MorphogenError(f"{what} {path} not found") from None
    except UnicodeDecodeError:
        raise MorphogenError(f"{what} {path} is not UTF-8 text") from None
    except OSError as exc:
        raise MorphogenError(f"cannot read {what} {path}: {exc.strerror}") from None


def ensure_writable_dir(path: str | Path) -> Path:
    """Create ``path`` if needed and check it is a writable directory (clear error if not)."""
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MorphogenError(f"cannot create output directory {p}: {exc.strerror}") from None
    if not p.is_dir() or not os.access(p, os.W_OK):
        raise MorphogenError(f"output directory {p} is not writable; choose another with --out")
    return p


def check_run_dir(path: str | Path) -> Path:
    """Check, creating nothing, that a run directory can be written at ``path``: it is absent
    (its nearest existing parent writable), empty, or an earlier run (it has ``run.json``),
    which :func:`staged_dir` will replace whole."""
    p = Path(path)
    if p.exists():
        if not p.is_dir():
            raise MorphogenError(f"output {p} exists and is not a directory; choose another --out")
        if any(p.iterdir()) and not (p / "run.json").is_file():
            raise MorphogenError(
                f"output directory {p} holds files but no run.json, so it is not a run to "
                "replace; choose another --out"
            )
    parent = next((a for a in p.absolute().parents if a.exists()), Path("/"))
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise MorphogenError(f"cannot create output directory {p}: {parent} is not writable")
    return p


@contextmanager
def staged_dir(path: str | Path) -> Iterator[Path]:
    """Yield an empty hidden directory next to ``path``; on success it replaces ``path`` whole
    (an earlier run there is removed), on failure it is deleted together with any parent
    directories made for it, so an error leaves nothing behind."""
    p = check_run_dir(path).absolute()
    made = [a for a in reversed(p.parents) if not a.exists()]
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        stage = Path(tempfile.mkdtemp(dir=p.parent, prefix=f".{p.name}.", suffix=".new"))
    except OSError as exc:
        _remove_made(made)
        raise MorphogenError(f"cannot create output directory {p}: {exc.strerror}") from None
    try:
        yield stage
        os.chmod(stage, 0o777 & ~_umask())
        if p.exists():
            old = stage.with_suffix(".old")
            os.rename(p, old)
            os.rename(stage, p)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.rename(stage, p)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        _remove_made(made)
        raise


def _remove_made(made: list[Path]) -> None:
    """Remove directories created for a run that failed, deepest first, if still empty."""
    for directory in reversed(made):
        try:
            directory.rmdir()
        except OSError:
            return


@contextmanager
def atomic_path(path: str | Path, suffix: str = ".tmp") -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success give it the umask's permissions and
    rename it to ``path``, on failure delete it. For writers that need a file name (ffmpeg)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=suffix)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


@contextmanager
def atomic_open(path: str | Path, mode: str = "wb") -> Iterator[IO]:
    """Open a temporary file next to ``path``; on success rename it to ``path``."""
    with atomic_path(path) as tmp, open(tmp, mode) as fh:
        yield fh
        fh.flush()
        os.fsync(fh.fileno())


def _umask() -> int:
    """The process umask (read by setting and restoring it)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_atomic(path: str | Path, writer: Callable[[IO[bytes]], Any]) -> Path:
    """Call ``writer(fileobj)`` on a temporary file, then rename it to ``path``."""
    with atomic_open(path, "wb") as fh:
        writer(fh)
    return Path(path)


def write_json(path: str | Path, data: Any) -> Path:
    """Write ``data`` as indented JSON, atomically."""
    text = json.dumps(data, indent=2, sort_keys=False, default=_json_default) + "\n"
    return write_atomic(path, lambda fh: fh.write(text.encode()))


def write_npz(path: str | Path, arrays: Mapping[str, np.ndarray]) -> Path:
    """Write named arrays to an ``.npz`` file, atomically."""
    return write_atomic(path, lambda fh: np.savez_compressed(fh, **arrays))


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot serialise {type(obj).__name__} to JSON")
