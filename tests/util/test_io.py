"""Atomic writers: complete files or nothing, with ordinary permissions."""

from __future__ import annotations

import os

import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.util.io import atomic_open, ensure_writable_dir, write_json, write_npz


def test_failed_write_leaves_old_file_and_no_temp(tmp_path):
    target = tmp_path / "a.json"
    write_json(target, {"v": 1})
    with pytest.raises(RuntimeError), atomic_open(target) as fh:
        fh.write(b"partial")
        raise RuntimeError("crash mid-write")
    assert target.read_text().strip().endswith("}")
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]


def test_files_get_umask_permissions(tmp_path):
    old = os.umask(0o022)
    try:
        write_npz(tmp_path / "s.npz", {"u": np.zeros(3)})
    finally:
        os.umask(old)
    assert (tmp_path / "s.npz").stat().st_mode & 0o777 == 0o644


def test_unwritable_directory_is_a_clear_error(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(MorphogenError, match="cannot create output directory"):
        ensure_writable_dir(tmp_path / "f" / "sub")
