"""Checks shared by the match tests."""

from __future__ import annotations

from pathlib import Path

from morphogen.cli.main import main


def assert_refused(argv: list[str], words: str, tmp_path: Path, capsys) -> None:
    """``morphogen match ARGV --out TMP/answer`` exits 2 with one error line containing
    ``words`` and leaves neither an answer nor a journal behind."""
    out = tmp_path / "answer"
    assert main(["match", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("morphogen: error:"), err
    assert words in err, err
    assert not out.exists()
    assert not (tmp_path / ".answer.match-work").exists()
