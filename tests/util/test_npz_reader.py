"""The one `.npz` reader (morphogen/util/npz.py) against hand-made hostile files: each is refused
in one line by its header, before anything is allocated for it; good files read back exactly."""

from __future__ import annotations

import io
import os
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest
from numpy.lib import format as npy

from morphogen.errors import MorphogenError
from morphogen.util.npz import MAX_MEMBERS, npz_members, read_npz


def npy_bytes(shape, descr="<f8", data: bytes = b"", version=(1, 0), fortran=False) -> bytes:
    """An ``.npy`` member: a real header announcing ``shape`` and ``descr``, then ``data``."""
    out = io.BytesIO()
    write = npy.write_array_header_1_0 if version == (1, 0) else npy.write_array_header_2_0
    write(out, {"descr": descr, "fortran_order": fortran, "shape": shape})
    return out.getvalue() + data


def zip_bytes(members: dict[str, bytes], compress=zipfile.ZIP_STORED) -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", compress) as z:
        for name, data in members.items():
            z.writestr(name, data)
    return out.getvalue()


def savez(**arrays) -> bytes:
    out = io.BytesIO()
    np.savez(out, **arrays)
    return out.getvalue()


def refused(source, match: str, **kw) -> str:
    with pytest.raises(MorphogenError, match=match) as err:
        read_npz(source, "state file", **kw)
    assert "\n" not in str(err.value)
    return str(err.value)


def test_a_small_file_announcing_a_trillion_elements_is_refused_before_allocating(tmp_path):
    """The issue's case: a few hundred bytes whose header announces 10^12 float64 (7.28 TiB);
    numpy.load would allocate it all before reading."""
    path = tmp_path / "bomb.npz"
    path.write_bytes(zip_bytes({"u.npy": npy_bytes((10**6, 10**6), data=bytes(16)),
                                "v.npy": npy_bytes((4, 4), data=bytes(128))}))
    assert path.stat().st_size < 600
    tracemalloc.start()
    try:
        message = refused(path, "announces shape \\(1000000, 1000000\\)",
                          max_elements=2 * 64 * 64)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2**20 and str(path) in message
    # with a shape to match, the shape is what is named
    refused(path, "has shape \\(1000000, 1000000\\), expected \\(64, 64\\)", shapes=(64, 64))
    # announced bytes larger than the member holds, within the element bound: truncated
    refused(path, "announces 8,000,000,000,000 bytes but its member holds",
            max_elements=10**13)


def test_good_files_read_back_exactly(tmp_path):
    rng = np.random.default_rng(0)
    arrays = {"u": rng.normal(size=(5, 7)).astype(np.float32),
              "v": np.asfortranarray(rng.normal(size=(5, 7))),
              "n": np.arange(3, dtype=">i4"), "t": np.array(2.5), "flag": np.array([True])}
    path = tmp_path / "good.npz"
    np.savez_compressed(path, **arrays)
    back = read_npz(path, "state file")
    assert list(back) == list(arrays)
    for k, v in arrays.items():
        np.testing.assert_array_equal(back[k], v)
        assert back[k].dtype == v.dtype and back[k].flags.writeable
    assert read_npz(path.read_bytes(), "upload", keys=["u"], shapes=(5, 7)).keys() == {"u"}
    assert npz_members(path, "state file")["u"] == ((5, 7), np.dtype(np.float32))
    # version 2.0 headers and None as "any length"
    raw = zip_bytes({"w.npy": npy_bytes((2, 3), "<f4", bytes(24), version=(2, 0))})
    assert read_npz(raw, "x", shapes={"w": (None, 3)})["w"].shape == (2, 3)


@pytest.mark.parametrize("case,content,kw,match", [
    ("zero bytes", b"", {}, "is empty \\(0 bytes\\)"),
    ("junk", b"hello, not a zip " * 30, {}, "not an .npz file"),
    ("a pickle", b"\x80\x04\x95" + bytes(40), {}, "not an .npz file"),
    ("truncated", savez(u=np.ones((8, 8)))[:200], {}, "not an .npz file"),
    ("a lone .npy", npy_bytes((2,), data=bytes(16)), {}, "not an .npz file"),
    ("wrong key", savez(a=np.ones((8, 8))), {"keys": ["u", "v"]},
     "has no array 'u'; it holds 'a'"),
    ("extra key refused", savez(u=np.ones(2), junk=np.ones(2)),
     {"keys": ["u"], "extra": "refuse"}, "unexpected member 'junk'"),
    ("object array", savez(u=np.array([{"a": 1}], dtype=object)), {},
     "Python objects \\(a pickle\\), which are never loaded"),
    ("strings", savez(u=np.full((2, 2), "x")), {}, "holds <U1 values, not numbers"),
    ("complex", savez(u=np.ones(2, np.complex64)), {}, "holds complex64 values"),
    ("structured", savez(u=np.zeros(2, [("a", "<f4")])), {}, "values, not numbers"),
    ("wrong shape", savez(u=np.ones((8, 9))), {"shapes": (8, 8)},
     "has shape \\(8, 9\\), expected \\(8, 8\\)"),
    ("wrong rank", savez(u=np.ones(64)), {"shapes": {"u": (8, 8)}}, "expected \\(8, 8\\)"),
    ("too many elements", savez(u=np.ones((8, 8)), v=np.ones((8, 8))), {"max_elements": 100},
     "array 'v' announces shape \\(8, 8\\) \\(64 elements\\), more than the 100"),
    ("not a .npy member", zip_bytes({"u.npy": b"plain text"}), {}, "'u' is not a NumPy array"),
    ("member short of its header", zip_bytes({"u.npy": npy_bytes((10,), data=bytes(16))}), {},
     "announces 80 bytes but its member holds"),
    ("a text member", zip_bytes({"readme.txt": b"hi"}), {}, "not a NumPy array \\(.npy\\)"),
    ("nan", savez(u=np.full(3, np.nan)), {"finite": True}, "holds NaN or infinite values"),
    ("inf", savez(u=np.array([1.0, -np.inf])), {"finite": True}, "NaN or infinite"),
    ("unknown version", zip_bytes({"u.npy": b"\x93NUMPY\x09\x00" + bytes(60)}), {},
     "'u' is not a NumPy array"),
    ("over the byte limit", savez(u=np.ones(1000)), {"max_bytes": 1000}, "more than the limit"),
])
def test_hostile_files_are_one_line_refusals(tmp_path, case, content, kw, match):
    path = tmp_path / "hostile.npz"
    path.write_bytes(content)
    refused(path, match, **kw)
    refused(content, match, **kw)  # the same from bytes (an upload)


def test_a_member_twice():
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z, pytest.warns(UserWarning, match="Duplicate name"):
        z.writestr("u.npy", npy_bytes((1,), data=bytes(8)))
        z.writestr("u.npy", npy_bytes((1,), data=bytes(8)))
    refused(out.getvalue(), "holds the member 'u' twice")


def test_too_many_members():
    content = zip_bytes({f"a{i}.npy": b"" for i in range(MAX_MEMBERS + 1)})
    refused(content, f"more than the {MAX_MEMBERS:,}")


def test_a_corrupt_compressed_member_is_one_line():
    good = io.BytesIO()
    np.savez_compressed(good, u=np.arange(4000.0))
    raw = bytearray(good.getvalue())
    raw[200:260] = bytes(60)  # inside the deflate stream
    refused(bytes(raw), "is not a NumPy array|cannot read state file")


@pytest.mark.parametrize("kind,words", [
    ("fifo", "is a FIFO \\(named pipe\\), not a regular file"),
    ("folder", "is a directory, not a file"),
    ("device", "is a character device, not a regular file"),
    ("missing", "not found"),
])
def test_what_is_not_a_regular_file_is_named(tmp_path, kind, words):
    """A FIFO would block a reader for ever; it is refused (and named) without being opened."""
    path: Path | str = tmp_path / "x.npz"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "folder":
        path.mkdir()
    elif kind == "device":
        path = "/dev/zero"
    refused(path, words)
    with pytest.raises(MorphogenError, match=words):
        npz_members(path, "state file")


# --- every .npz the project loads goes through it ---------------------------------------------

BOMB = zip_bytes({"u.npy": npy_bytes((10**6, 10**6), data=bytes(16)),
                  "v.npy": npy_bytes((10**6, 10**6), data=bytes(16))})
"""The issue's file: a few hundred bytes announcing 10^12 float64 per species."""


def _cli_refuses(argv, capsys, words: str) -> str:
    from morphogen.cli.main import main

    capsys.readouterr()
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("morphogen: error: ") and err.count("\n") == 1, err
    assert words in err, err
    return err


@pytest.mark.parametrize("command", ["simulate", "export-web"])
def test_simulate_init_and_export_web_state_refuse_the_bomb(tmp_path, capsys, command):
    bomb = tmp_path / "bomb.npz"
    bomb.write_bytes(BOMB)
    out = tmp_path / ("o" if command == "simulate" else "page.html")
    flag = "--init" if command == "simulate" else "--state"
    extra = ["--steps", "2", "--quiet"] if command == "simulate" else ["--scheme", "euler"]
    _cli_refuses([command, "gray-scott", "--size", "16x16", flag, bomb, *extra, "--out", out],
                 capsys, "has shape (1000000, 1000000), expected (16, 16)")
    assert not out.exists()
    # a FIFO is named (and never opened), a folder too
    os.mkfifo(tmp_path / "pipe.npz")
    _cli_refuses([command, "gray-scott", "--size", "16x16", flag, tmp_path / "pipe.npz",
                  *extra, "--out", out], capsys, "is a FIFO (named pipe)")
    (tmp_path / "folder.npz").mkdir()
    _cli_refuses([command, "gray-scott", "--size", "16x16", flag, tmp_path / "folder.npz",
                  *extra, "--out", out], capsys, "is a directory")
    assert not out.exists()


def test_the_web_checkpoint_upload_answers_4xx_with_one_line(tmp_path):
    import base64

    from fastapi.testclient import TestClient

    from morphogen.web.app import create_app

    with TestClient(create_app(archive=tmp_path / "a.sqlite",
                               allowed_hosts=["testserver"])) as client:
        r = client.post("/api/live", json={"model": {"library": "gray-scott"}, "size": 16})
        assert r.status_code == 200, r.text
        sid = r.json()["id"]
        cases = {
            "bomb": (BOMB, "has shape (1000000, 1000000), expected (16, 16)"),
            "pickle": (savez(u=np.array([{"a": 1}], dtype=object),
                             v=np.array([{"a": 1}], dtype=object)), "never loaded"),
            "junk": (b"hello" * 40, "not an .npz file"),
            "empty": (b"", "is empty"),
            "wrong key": (savez(a=np.ones((16, 16))), "has no array 'u'"),
            "nan": (savez(u=np.full((16, 16), np.nan), v=np.ones((16, 16))), "NaN"),
        }
        for case, (raw, words) in cases.items():
            r = client.post(f"/api/live/{sid}/state",
                            json={"npz": base64.b64encode(raw).decode()})
            assert r.status_code == 400, (case, r.status_code, r.text)
            error = r.json()["error"]
            assert words in error and "\n" not in error and "the checkpoint" in error, case
        good = savez(u=np.full((16, 16), 0.5), v=np.full((16, 16), 0.25))
        r = client.post(f"/api/live/{sid}/state", json={"npz": base64.b64encode(good).decode()})
        assert r.status_code == 200 and r.json()["ok"], r.text
        # the checkpoint's own time goes back with it (a restart's recovery), checked
        sent = base64.b64encode(good).decode()
        for bad in (-1.0, "nan", "soon"):
            r = client.post(f"/api/live/{sid}/state", json={"npz": sent, "t": bad})
            assert r.status_code == 400 and "t must be" in r.json()["error"], (bad, r.text)
        assert client.post(f"/api/live/{sid}/state", json={"npz": sent, "t": 42.5}).json()["ok"]
        assert client.get(f"/api/live/{sid}").json()["t"] == 42.5
        saved = client.get(f"/api/live/{sid}/state.npz")
        assert float(saved.headers["X-Morphogen-Time"]) == 42.5


def test_an_archives_damaged_strategy_state_is_one_line():
    from morphogen.search.archive import _unpack

    with pytest.raises(MorphogenError, match="damaged .*announces shape") as err:
        _unpack(zip_bytes({"mean.npy": npy_bytes((10**12,), data=bytes(8))}))
    assert "\n" not in str(err.value)
    with pytest.raises(MorphogenError, match="damaged .*never loaded"):
        _unpack(savez(mean=np.array([{"a": 1}], dtype=object)))
    np.testing.assert_array_equal(_unpack(savez(mean=np.arange(3.0)))["mean"], np.arange(3.0))


def test_vgg_weights_are_checked_by_header(tmp_path):
    from morphogen.learn.vgg import load_vgg_weights

    path = tmp_path / "vgg.npz"
    path.write_bytes(savez(conv0_kernel=np.array([{"a": 1}], dtype=object)))
    with pytest.raises(MorphogenError, match="has no array 'conv0_bias'"):
        load_vgg_weights(path)
    arrays = {f"conv{i}_{p}": np.zeros((3, 3, 3, 4) if p == "kernel" else (4,), np.float32)
              for i in range(11) for p in ("kernel", "bias")}
    arrays["conv0_kernel"] = np.array([{"a": 1}], dtype=object)
    path.write_bytes(savez(**arrays))
    with pytest.raises(MorphogenError, match="'conv0_kernel' holds Python objects"):
        load_vgg_weights(path)
    arrays["conv0_kernel"] = np.zeros((5, 5, 3, 4), np.float32)
    path.write_bytes(savez(**arrays))
    with pytest.raises(MorphogenError, match="has shape \\(5, 5, 3, 4\\), expected \\(3, 3, any"):
        load_vgg_weights(path)
