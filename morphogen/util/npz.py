"""The one reader of ``.npz`` files: every member checked by its header before anything is
allocated for it.

An ``.npz`` is a zip archive of ``.npy`` members. Each member starts with a small header
(NumPy's format: magic ``\\x93NUMPY``, a version, then a dict literal with ``descr``,
``fortran_order`` and ``shape``); :func:`numpy.load` trusts it and allocates ``prod(shape)``
elements before reading one byte of data, so a 482-byte file announcing 10¹² elements asks for
7.28 TiB. :func:`read_npz` instead

1. refuses what is not a regular file (a folder, FIFO, device or socket is named as such;
   a FIFO would block), an empty file and a file over its size limit
   (:func:`morphogen.util.io.check_input_file`);
2. refuses what is not a complete zip archive (truncated, junk) and archives of more than
   :data:`MAX_MEMBERS` members;
3. reads each wanted member's header only (``numpy.lib.format.read_magic`` and
   ``read_array_header_1_0/2_0``) and refuses, by the header alone: object dtypes (pickles are
   never loaded), dtypes of a kind the caller does not take, a shape other than the caller's,
   and more elements in all than the caller's bound;
4. then reads exactly ``prod(shape) * itemsize`` bytes per member into an array of its own
   (a member that holds fewer is truncated), and, on request, refuses NaN and infinities.

Keys are the members' names without ``.npy``, as :func:`numpy.load` gives them; the caller says
which keys it needs (missing ones are named), which it may take, and whether others are ignored
or refused. Every failure is one :class:`~morphogen.errors.MorphogenError` line naming the file.
"""

from __future__ import annotations

import io
import math
import tokenize
import zipfile
import zlib
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import IO, Literal

import numpy as np
from numpy.lib import format as npy

from morphogen.errors import MorphogenError
from morphogen.util.io import check_input_file

MAX_MEMBERS = 4096
"""Most members an ``.npz`` may hold (a network run's state has 8, a VGG file 22)."""

DEFAULT_MAX_ELEMENTS = 2**28
"""Most numbers read from one file unless the caller says otherwise (2 GiB of float64)."""

Shape = tuple[int | None, ...]
"""An expected shape; ``None`` in a place takes any length there."""

_READ_ERRORS = (OSError, ValueError, EOFError, KeyError, TypeError, RuntimeError,
                NotImplementedError, SyntaxError, tokenize.TokenError, zipfile.BadZipFile,
                zipfile.LargeZipFile, zlib.error)
_HEADER_ERRORS = (ValueError, SyntaxError, tokenize.TokenError, EOFError)


def _matches(shape: tuple[int, ...], want: Shape) -> bool:
    return len(shape) == len(want) and all(w is None or s == w for s, w in zip(shape, want,
                                                                               strict=True))


def _show(want: Shape) -> str:
    return "(" + ", ".join("any" if w is None else str(w) for w in want) + \
        ("," if len(want) == 1 else "") + ")"


def _header(member: IO[bytes]) -> tuple[tuple[int, ...], bool, np.dtype]:
    version = npy.read_magic(member)
    if version == (1, 0):
        return npy.read_array_header_1_0(member)
    if version in ((2, 0), (3, 0)):  # 3.0 differs only in the header's text encoding
        return npy.read_array_header_2_0(member)
    raise ValueError(f"unknown .npy format version {version}")


def _read_exactly(member: IO[bytes], nbytes: int) -> bytearray:
    buf = bytearray(nbytes)
    view = memoryview(buf)
    got = 0
    while got < nbytes:
        n = member.readinto(view[got:])  # type: ignore[attr-defined]
        if not n:
            break
        got += n
    if got < nbytes:
        raise EOFError(f"it holds {got:,} of the {nbytes:,} bytes its header announces "
                       "(truncated)")
    return buf


def read_npz(
    source: str | Path | bytes,
    what: str,
    *,
    keys: Iterable[str] | None = None,
    optional: Iterable[str] = (),
    extra: Literal["ignore", "refuse"] = "ignore",
    shapes: Mapping[str, Shape] | Shape | None = None,
    kinds: str | Mapping[str, str] = "biuf",
    max_elements: int = DEFAULT_MAX_ELEMENTS,
    max_bytes: int | None = None,
    finite: bool = False,
) -> dict[str, np.ndarray]:
    """The arrays of an ``.npz`` file (a path, or its bytes), each checked by its header first.

    Args:
        source: the file's path, or its contents (an upload).
        what: what the file is, for messages (``"state file"``).
        keys: the keys that must be there; ``None`` reads every member.
        optional: keys read when present.
        extra: what to do with other members: ``"ignore"`` (never read) or ``"refuse"``.
        shapes: the shape every read member must have, or a shape per key (keys not in the
            mapping take any shape); ``None`` in a place takes any length.
        kinds: the dtype kinds accepted (``numpy.dtype.kind``: ``"biuf"`` numbers, ``"U"``
            text), for all members or per key (others: ``"biuf"``). Object dtypes never are.
        max_elements: most elements of all read members together, from their headers.
        max_bytes: largest file accepted (default: 16 bytes per element plus 1 MiB).
        finite: refuse NaN and infinities in floating-point members.

    Returns:
        ``{key: array}`` in the file's order; every array owns its (writable) memory.

    Raises:
        MorphogenError: one line naming the file and what is wrong with it.
    """
    required = None if keys is None else list(dict.fromkeys(keys))
    wanted = None if required is None else set(required) | set(optional)
    limit = max_bytes if max_bytes is not None else 16 * max_elements + 2**20
    return _with_archive(source, what, limit, lambda archive, name: _read_members(
        archive, name, required, wanted, extra, shapes, kinds, max_elements, finite))


def _with_archive(source: str | Path | bytes, what: str, limit: int, use):
    """``use(archive, name)`` on the file's zip archive, after the file checks (regular, not
    empty, at most ``limit`` bytes, a complete zip); any read error becomes one line."""
    name = what if isinstance(source, bytes | bytearray) else f"{what} {source}"
    if isinstance(source, bytes | bytearray):
        if len(source) > limit:
            raise MorphogenError(f"{name} is {len(source):,} bytes, more than the limit of "
                                 f"{limit:,}")
        size = len(source)
    else:
        size = check_input_file(source, what, limit).stat().st_size
    if size == 0:
        raise MorphogenError(f"cannot read {name}: it is empty (0 bytes), not an .npz file")
    try:
        with (io.BytesIO(source) if isinstance(source, bytes | bytearray)
              else open(source, "rb")) as fh:
            if not zipfile.is_zipfile(fh):
                raise MorphogenError(f"cannot read {name}: it is not an .npz file (not a "
                                     "complete zip archive: truncated or damaged?)")
            fh.seek(0)
            with zipfile.ZipFile(fh) as archive:
                if len(archive.infolist()) > MAX_MEMBERS:
                    raise MorphogenError(f"{name} holds {len(archive.infolist()):,} members, "
                                         f"more than the {MAX_MEMBERS:,} an .npz of this "
                                         "project has")
                return use(archive, name)
    except MorphogenError:
        raise
    except MemoryError:
        raise MorphogenError(f"cannot read {name}: not enough memory") from None
    except _READ_ERRORS as exc:
        reason = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise MorphogenError(f"cannot read {name}: {reason}") from None


def _read_members(archive: zipfile.ZipFile, name: str, required: list[str] | None,
                  wanted: set[str] | None, extra: str, shapes, kinds, max_elements: int,
                  finite: bool) -> dict[str, np.ndarray]:
    members: dict[str, zipfile.ZipInfo] = {}
    for info in archive.infolist():
        key = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
        if key in members:
            raise MorphogenError(f"{name} holds the member {key!r} twice")
        members[key] = info
    if required is not None:
        missing = [k for k in required if k not in members]
        if missing:
            have = ", ".join(repr(k) for k in list(members)[:12]) or "nothing"
            raise MorphogenError(f"{name} has no array {missing[0]!r}; it holds {have}")
    if extra == "refuse":
        unknown = [k for k in members if wanted is not None and k not in wanted]
        if unknown:
            raise MorphogenError(f"{name} holds an unexpected member {unknown[0]!r}")
    chosen = [k for k in members if wanted is None or k in wanted]
    # every header first: nothing is allocated for a file that one header refuses
    heads = {}
    total = 0
    for key in chosen:
        info = members[key]
        if not info.filename.endswith(".npy"):
            raise MorphogenError(f"{name}: member {key!r} is not a NumPy array (.npy)")
        with archive.open(info) as member:
            try:
                shape, fortran, dtype = _header(member)
                held = info.file_size - member.tell()
            except _HEADER_ERRORS as exc:
                reason = " ".join(str(exc).split())[:160]
                raise MorphogenError(f"{name}: member {key!r} is not a NumPy array ({reason})"
                                     ) from None
        if dtype.hasobject:
            raise MorphogenError(f"{name}: array {key!r} holds Python objects (a pickle), "
                                 "which are never loaded; arrays of numbers only")
        allowed = kinds if isinstance(kinds, str) else kinds.get(key, "biuf")
        if dtype.kind not in allowed or dtype.fields is not None or dtype.subdtype is not None:
            raise MorphogenError(f"{name}: array {key!r} holds {dtype} values, not "
                                 f"{'numbers' if allowed == 'biuf' else 'what it should'}")
        want = shapes.get(key) if isinstance(shapes, Mapping) else shapes
        if want is not None and not _matches(tuple(shape), tuple(want)):
            raise MorphogenError(f"{name}: array {key!r} has shape {tuple(shape)}, expected "
                                 f"{_show(tuple(want))}")
        count = math.prod(shape)
        total += count
        if total > max_elements:
            raise MorphogenError(f"{name}: array {key!r} announces shape {tuple(shape)} "
                                 f"({count:,} elements), more than the {max_elements:,} this "
                                 "file may hold")
        if count * dtype.itemsize > held:
            raise MorphogenError(f"{name}: array {key!r} announces {count * dtype.itemsize:,} "
                                 f"bytes but its member holds {held:,} after the header "
                                 "(truncated or damaged)")
        heads[key] = (tuple(shape), fortran, dtype)
    out: dict[str, np.ndarray] = {}
    for key, (shape, fortran, dtype) in heads.items():
        with archive.open(members[key]) as member:
            _header(member)
            buf = _read_exactly(member, math.prod(shape) * dtype.itemsize)
        arr = np.frombuffer(buf, dtype=dtype).reshape(shape, order="F" if fortran else "C")
        if finite and dtype.kind in "fc" and not np.isfinite(arr).all():
            raise MorphogenError(f"{name}: array {key!r} holds NaN or infinite values")
        out[key] = arr
    return out


def npz_members(source: str | Path | bytes, what: str, *,
                max_bytes: int = 16 * DEFAULT_MAX_ELEMENTS + 2**20
                ) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """The members of an ``.npz`` file as ``{key: (shape, dtype)}``, from their headers alone
    (no data is read); the file is checked as by :func:`read_npz`."""

    def headers(archive: zipfile.ZipFile, name: str) -> dict[str, tuple[tuple[int, ...],
                                                                         np.dtype]]:
        out = {}
        for info in archive.infolist():
            if not info.filename.endswith(".npy"):
                raise MorphogenError(f"{name}: member {info.filename!r} is not a NumPy array "
                                     "(.npy)")
            with archive.open(info) as member:
                shape, _, dtype = _header(member)
            out[info.filename[:-4]] = (tuple(shape), dtype)
        return out

    return _with_archive(source, what, max_bytes, headers)
