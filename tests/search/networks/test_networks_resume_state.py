"""`morphogen networks --resume` with a damaged `state.npz`: one line, exit 2, and the run
folder and archive exactly as they were (morphogen/search/networks/state_file.py)."""

from __future__ import annotations

import hashlib
import io
import json
import os
import zipfile
from pathlib import Path

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.errors import MorphogenError
from morphogen.search.networks.state_file import read_state

ARGS = ["--population", "4", "--size", "8", "--dt", "0.5", "--t-start", "5", "--interval",
        "5", "--rounds", "2", "--quiet", "--seed", "1"]


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory) -> tuple[Path, Path]:
    """A real one-generation network run and its archive, written once for the module."""
    base = tmp_path_factory.mktemp("networks")
    out, archive = base / "run", base / "index.sqlite"
    assert main(["networks", "--mode", "network", "--out", str(out), "--archive", str(archive),
                 "--generations", "1", *ARGS]) == 0
    return out, archive


def _arrays(folder: Path) -> dict[str, np.ndarray]:
    with np.load(folder / "state.npz") as data:
        return {k: data[k] for k in data.files}


def _savez(arrays: dict[str, np.ndarray]) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def _changed(arrays, **changes) -> bytes:
    return _savez({**arrays, **changes})


def _without(arrays, key) -> bytes:
    return _savez({k: v for k, v in arrays.items() if k != key})


def _meta(arrays, **changes) -> np.ndarray:
    meta = json.loads(str(arrays["meta"]))
    meta.update(changes)
    return np.array(json.dumps(meta))


CASES = {
    "truncated": (lambda a, raw: raw[: len(raw) // 2], "not an .npz file"),
    "zero bytes": (lambda a, raw: b"", "is empty (0 bytes)"),
    "junk": (lambda a, raw: b"junk, not a zip " * 50, "not an .npz file"),
    "wrong key": (lambda a, raw: _savez({("pop" if k == "arr_0" else k): v
                                         for k, v in a.items()}), "has no array 'arr_0'"),
    "no meta": (lambda a, raw: _without(a, "meta"), "has no array 'meta'"),
    "extra member": (lambda a, raw: _changed(a, junk=np.zeros(2)), "unexpected member 'junk'"),
    "all-NaN history": (lambda a, raw: _changed(a, history=np.full_like(a["history"], np.nan)),
                        "NaN or infinite"),
    "float genomes": (lambda a, raw: _changed(a, arr_0=a["arr_0"].astype(np.float32)),
                      "holds float32 values"),
    "pickled meta": (lambda a, raw: _changed(a, meta=np.array([{"a": 1}], dtype=object)),
                     "never loaded"),
    "meta not JSON": (lambda a, raw: _changed(a, meta=np.array("{not json")),
                      "settings are not readable"),
    "population of 5": (lambda a, raw: _changed(
        a, **{k: np.concatenate([v, v[:1]]) for k, v in a.items() if k.startswith("arr_")}),
        "holds a population of 5, the run has 4"),
    "history of another population": (lambda a, raw: _changed(
        a, history=np.zeros((1, 3), np.float32)), "'history' has shape (1, 3)"),
    "generation ahead of history": (lambda a, raw: _changed(a, generation=np.array(3)),
                                    "says 3 generations are done but holds 1"),
    "junk genome row": (lambda a, raw: _changed(a, arr_0=np.full_like(a["arr_0"], 1000)),
                        "mantissas outside [0, 99]"),
    "negative stoichiometry": (lambda a, raw: _changed(a, arr_2=-np.ones_like(a["arr_2"])),
                               "educts outside"),
    "settings of another population": (lambda a, raw: _changed(a, meta=_meta(a, population=9)),
                                       "do not match its own settings"),
    "announces 10^12 values": (lambda a, raw: _bomb(a), "has shape (1000000, 1000000)"),
}


def _bomb(arrays) -> bytes:
    from numpy.lib import format as npy

    header = io.BytesIO()
    npy.write_array_header_1_0(header, {"descr": "<f4", "fortran_order": False,
                                        "shape": (10**6, 10**6)})
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for k, v in arrays.items():
            if k == "history":
                z.writestr("history.npy", header.getvalue() + bytes(16))
            else:
                member = io.BytesIO()
                np.save(member, v)
                z.writestr(f"{k}.npy", member.getvalue())
    return buf.getvalue()


def _snapshot(*paths: Path) -> dict[str, str]:
    """Every file under ``paths`` with its content's hash (a FIFO by its kind)."""
    out = {}
    for root in paths:
        for p in sorted([root] if root.is_file() else root.rglob("*")):
            if p.is_fifo():
                out[str(p)] = "fifo"
            elif p.is_file():
                out[str(p)] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


@pytest.mark.parametrize("case", sorted(CASES) + ["fifo", "folder"])
def test_a_damaged_state_is_one_line_and_changes_nothing(run_folder, tmp_path, capsys, case):
    source, archive_file = run_folder
    out = tmp_path / "run"
    archive = tmp_path / "index.sqlite"
    import shutil

    shutil.copytree(source, out)
    shutil.copy(archive_file, archive)
    config = json.loads((out / "config.json").read_text())
    config["archive"] = str(archive)
    (out / "config.json").write_text(json.dumps(config))
    state = out / "state.npz"
    if case == "fifo":
        state.unlink()
        os.mkfifo(state)
        words = "is a FIFO (named pipe)"
    elif case == "folder":
        state.unlink()
        state.mkdir()
        words = "is a directory"
    else:
        make, words = CASES[case]
        state.write_bytes(make(_arrays(source), (source / "state.npz").read_bytes()))
    before = _snapshot(out, archive)
    capsys.readouterr()
    assert main(["networks", "--out", str(out), "--resume", "--generations", "3",
                 "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("morphogen: error: ") and err.count("\n") == 1, err
    assert words in err, err
    assert _snapshot(out, archive) == before  # not one byte changed, no best.json
    assert not (out / "best.json").exists() or "NaN" not in (out / "best.json").read_text()


def test_the_good_state_reads_back_and_resumes(run_folder, tmp_path, capsys):
    source, _ = run_folder
    pop, history, done, meta = read_state(source / "state.npz", population=4)
    assert done == 1 and history.shape == (1, 4) and np.isfinite(history).all()
    assert pop.mantissa.shape == (4, meta["spec"]["m_max"])
    with pytest.raises(MorphogenError, match="population of 4, the run has 6"):
        read_state(source / "state.npz", population=6)
    best = json.loads((source / "best.json").read_text())
    assert np.isfinite(best["fitness"])
