"""Hostile input, round 4: the one-line promise for the newer commands (``match``,
``export-web``, ``train``, ``fit``, ``evolve --fitness user``, ``gallery``, ``mesh make``,
``serve``). Each refusal is one ``morphogen: error:`` line (or argparse's one line) with exit
status 2, no traceback, and nothing created: no output folder, no hidden work folder, no
archive."""

from __future__ import annotations

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
