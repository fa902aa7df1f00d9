"""Files written atomically: nothing half-written is ever left behind.

Every writer here writes to a temporary file in the destination directory and renames it into
place (``os.replace``), so a crash leaves either the old file or the new one.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import stat
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

import numpy as np

from morphogen.errors import MorphogenError

MAX_INPUT_BYTES = 64 * 2**20
"""Largest text input read whole (a model, run, network or settings file): 64 MiB."""

MAX_IMAGE_PIXELS = 40_000_000
"""Largest image accepted as input (width x height from its header, checked before decoding)."""


def file_kind(mode: int) -> str:
    """What a file of ``st_mode`` ``mode`` is, in words (``"a FIFO (named pipe)"``)."""
    for test, words in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                        (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                        (stat.S_ISSOCK, "a socket"), (stat.S_ISREG, "a regular file")):
        if test(mode):
            return words
    return "not a regular file"


def check_input_file(path: str | Path, what: str, limit: float = MAX_INPUT_BYTES) -> Path:
    """Check, reading nothing, that ``path`` is a regular file of at most ``limit`` bytes: a
    directory, a device (``/dev/zero``, ``/dev/urandom``), a FIFO or a socket would block or
    never end, and is refused with a one-line :class:`MorphogenError` naming ``what``."""
    p = Path(path)
    try:
        info = p.stat()
    except FileNotFoundError:
        raise MorphogenError(f"{what} {path} not found") from None
    except OSError as exc:
        raise MorphogenError(f"cannot read {what} {path}: {exc.strerror}") from None
    if stat.S_ISDIR(info.st_mode):
        raise MorphogenError(f"{what} {path} is a directory, not a file")
    if not stat.S_ISREG(info.st_mode):
        raise MorphogenError(f"{what} {path} is {file_kind(info.st_mode)}, not a regular file; "
                             "give a file")
    if info.st_size > limit:
        raise MorphogenError(
            f"{what} {path} is {info.st_size:,} bytes, more than the limit of {int(limit):,}"
        )
    return p


def read_bytes(path: str | Path, what: str, limit: int = MAX_INPUT_BYTES) -> bytes:
    """A regular file's bytes, at most ``limit`` of them (:func:`check_input_file`; a file
    that grows past the limit while read is refused too)."""
    p = check_input_file(path, what, limit)
    try:
        with open(p, "rb") as fh:
            data = fh.read(limit + 1)
    except OSError as exc:
        raise MorphogenError(f"cannot read {what} {path}: {exc.strerror}") from None
    if len(data) > limit:
        raise MorphogenError(f"{what} {path} is more than the limit of {limit:,} bytes")
    return data


def read_text(path: str | Path, what: str, limit: int = MAX_INPUT_BYTES) -> str:
    """A UTF-8 text file's contents; a missing, unreadable, non-regular, oversized or
    non-UTF-8 file is a one-line :class:`MorphogenError` naming ``what`` it should have been
    (e.g. ``"model file"``)."""
    try:
        return read_bytes(path, what, limit).decode("utf-8")
    except UnicodeDecodeError:
        raise MorphogenError(f"{what} {path} is not UTF-8 text") from None


def load_npy(path: str | Path, what: str, max_elements: int) -> np.ndarray:
    """A ``numpy.save`` file whose header is checked before its data is read: no pickles, a
    numeric type, and at most ``max_elements`` numbers (a 100-byte file announcing 10¹² is
    refused without allocating)."""
    p = check_input_file(path, what, limit=16 * max_elements + 65536)
    try:
        with open(p, "rb") as fh:
            version = np.lib.format.read_magic(fh)
            read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                           else np.lib.format.read_array_header_2_0)
            shape, _, dtype = read_header(fh)
            if dtype.hasobject or dtype.kind not in "biuf":
                raise MorphogenError(f"{what} {path} holds {dtype} values, not numbers")
            if math.prod(shape) > max_elements:
                raise MorphogenError(
                    f"{what} {path} announces shape {shape}, more than the "
                    f"{max_elements:,} numbers the domain holds"
                )
            fh.seek(0)
            return np.load(fh, allow_pickle=False)
    except MorphogenError:
        raise
    except (OSError, ValueError, EOFError, TypeError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise MorphogenError(f"cannot read {what} {path}: {reason}") from None


def check_image(path: str | Path, what: str, max_pixels: int = MAX_IMAGE_PIXELS) -> Path:
    """Check an image file by its header before any decoder allocates for it: a regular file
    that Pillow recognises, of at most ``max_pixels`` pixels (a decompression bomb is refused
    before it is decoded)."""
    import warnings

    from PIL import Image

    p = check_input_file(path, what, limit=float("inf"))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(p) as img:
                w, h = img.size
    except (Image.DecompressionBombError, Image.DecompressionBombWarning):
        raise MorphogenError(
            f"{what} {path} claims more pixels than can be decoded safely (over "
            f"{max_pixels // 1_000_000} million); crop or reduce it first") from None
    except Exception:  # any decoder failure is the same user error: not a readable picture
        raise MorphogenError(
            f"{what} {path} is not an image that can be read (PNG, JPEG, ...)"
        ) from None
    if w * h > max_pixels:
        raise MorphogenError(
            f"{what} {path} claims {w}x{h} pixels, over the limit of "
            f"{max_pixels // 1_000_000} million; crop or reduce it first"
        )
    return p


NAME_MAX = 255
"""Longest file name (bytes) of the usual file systems."""
STAGING_EXTRA = 16
"""Bytes a hidden staging name adds to an output's name (``.NAME.XXXXXXXX.new``)."""


PATH_MAX = 4096
"""Longest path (bytes) the usual kernels accept in one call."""


def check_out_name(path: str | Path) -> Path:
    """Refuse an output path with a name too long to be staged next to it (the file system's
    limit minus :data:`STAGING_EXTRA`), or a whole path too long for the kernel, before
    anything is created."""
    p = Path(path)
    size = len(os.fsencode(os.path.abspath(p)))
    if size > PATH_MAX - STAGING_EXTRA - 1:
        raise MorphogenError(
            f"output path {str(p)[:40]}... is {size} bytes long; paths are limited to "
            f"{PATH_MAX - STAGING_EXTRA - 1} bytes (the system allows {PATH_MAX}); choose a "
            "shorter --out"
        )
    for part in p.parts:
        size = len(os.fsencode(part))
        if size > NAME_MAX - STAGING_EXTRA:
            raise MorphogenError(
                f"output name {part[:40]}... is {size} bytes long; names of outputs are limited "
                f"to {NAME_MAX - STAGING_EXTRA} bytes (the file system allows {NAME_MAX}); "
                "choose a shorter --out"
            )
    return p


def _follow(p: Path) -> Path:
    """``p``, or where it points if it is a symbolic link (an output named by a link is
    written to the link's target, never over the link); a broken link is refused."""
    if not p.is_symlink():
        return p
    if not p.exists():
        raise MorphogenError(f"output {p} is a broken symbolic link; choose another --out")
    return Path(os.path.realpath(p))


def ensure_writable_dir(path: str | Path) -> Path:
    """Create ``path`` if needed and check it is a writable directory (clear error if not)."""
    p = _follow(check_out_name(path))
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MorphogenError(f"cannot create output directory {p}: {exc.strerror}") from None
    if not p.is_dir() or not os.access(p, os.W_OK):
        raise MorphogenError(f"output directory {p} is not writable; choose another with --out")
    return p


def check_writable_dir(path: str | Path) -> Path:
    """Check, creating nothing, that :func:`ensure_writable_dir` can make ``path`` later: it is
    a writable directory, or absent with a writable nearest existing parent. A command calls
    this with its input checks and creates the folder only once its work is done or certain."""
    p = _follow(check_out_name(path))
    if p.exists():
        if not p.is_dir():
            raise MorphogenError(f"output {p} exists and is not a directory; choose another --out")
        if not os.access(p, os.W_OK | os.X_OK):
            raise MorphogenError(f"output directory {p} is not writable; choose another with "
                                 "--out")
        return p
    parent = next((a for a in p.absolute().parents if a.exists()), Path("/"))
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise MorphogenError(f"cannot create output directory {p}: {parent} is not writable")
    return p


def check_out_file(path: str | Path) -> Path:
    """Check, creating nothing, that a file can be written at ``path`` by
    :func:`write_out_file`: it is absent or a regular file (a directory, FIFO or device is
    refused by name), and its nearest existing parent is a writable directory. A path that is
    a symbolic link stands for its target, which is returned."""
    p = _follow(check_out_name(path))
    if p.exists():
        if p.is_dir():
            raise MorphogenError(f"output {p} is a directory; name a file with --out")
        if not p.is_file():
            raise MorphogenError(f"output {p} is {file_kind(p.stat().st_mode)}, not a regular "
                                 "file; choose another --out")
    parent = next((a for a in p.absolute().parents if a.exists()), Path("/"))
    if not parent.is_dir():
        raise MorphogenError(f"cannot write {p}: {parent} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise MorphogenError(f"cannot write {p}: {parent} is not writable")
    return p


def write_out_file(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to the file ``path`` atomically (checked by :func:`check_out_file`),
    making its missing parent directories; on failure they are removed again, so an error
    leaves nothing behind."""
    p = check_out_file(path).absolute()
    made = [a for a in reversed(p.parents) if not a.exists()]
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(p, lambda fh: fh.write(data))
    except OSError as exc:
        _remove_made(made)
        raise MorphogenError(f"cannot write {p}: {exc.strerror}") from None
    except BaseException:
        _remove_made(made)
        raise
    return p


def check_run_dir(path: str | Path) -> Path:
    """Check, creating nothing, that a run directory can be written at ``path``: it is absent
    (its nearest existing parent writable), empty, or an earlier run (it has ``run.json``),
    which :func:`staged_dir` will replace whole. A path that is a symbolic link stands for its
    target, which is returned."""
    p = _follow(check_out_name(path))
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
    path = _follow(check_out_name(path))
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=suffix)
    except OSError as exc:
        raise MorphogenError(f"cannot write {path}: {exc.strerror}") from None
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
