"""``morphogen match`` on the command line: help, and bad input refused in one line."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest
from PIL import Image

from morphogen.cli.main import main
from tests.match_support import assert_refused


def _png_header(width: int, height: int) -> bytes:
    """A PNG that is only a header claiming ``width x height`` pixels (a decompression bomb's
    first bytes)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data)))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
            + chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + chunk(b"IEND", b""))


def _pattern(path):
    y, x = np.mgrid[0:96, 0:96]
    f = np.cos(2 * np.pi * x / 12) * np.cos(2 * np.pi * y / 12)
    Image.fromarray(((f + 1) * 127.5).astype(np.uint8)).save(path)
    return path


def test_help_names_the_options(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["match", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for option in ("--models", "--budget", "--minutes", "--channel", "--crop", "--out"):
        assert option in out


def _cases(tmp_path):
    text = tmp_path / "notes.png"
    text.write_text("not a picture")
    blank = tmp_path / "blank.png"
    Image.fromarray(np.full((64, 64, 3), 200, np.uint8)).save(blank)
    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(_png_header(100_000, 100_000))
    good = _pattern(tmp_path / "good.png")
    return {
        "not an image": ([str(text)], "not a picture"),
        "missing": ([str(tmp_path / "nowhere.png")], "not found"),
        "blank": ([str(blank)], "blank"),
        "bomb header": ([str(bomb)], "too large"),
        "unknown model": ([str(good), "--models", "no-such-model"], "no-such-model"),
        "model without box": ([str(good), "--models", "genrd"], "--gene"),
        "bad gene": ([str(good), "--gene", "F=1"], "bad gene"),
        "bad crop": ([str(good), "--crop", "0,0,500,500"], "outside"),
        "bad channel": ([str(good), "--channel", "purple"], "unknown channel"),
        "tiny budget": ([str(good), "--budget", "3"], "at least 8"),
    }


@pytest.mark.parametrize("case", ["not an image", "missing", "blank", "bomb header",
                                  "unknown model", "model without box", "bad gene", "bad crop",
                                  "bad channel", "tiny budget"])
def test_bad_input_is_one_line_and_writes_nothing(case, tmp_path, capsys):
    assert_refused(*_cases(tmp_path)[case], tmp_path, capsys)


def test_a_journal_of_another_match_is_refused(tmp_path):
    from morphogen.errors import MorphogenError
    from morphogen.match.search import Journal

    Journal(tmp_path / "work", {"picture": "a", "budget": 8})
    Journal(tmp_path / "work", {"picture": "a", "budget": 8})  # the same match resumes
    with pytest.raises(MorphogenError, match="another picture"):
        Journal(tmp_path / "work", {"picture": "b", "budget": 8})
