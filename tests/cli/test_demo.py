"""``morphogen demo`` (what ``make demo`` runs): the gallery's files and index."""

from __future__ import annotations

import pytest

from morphogen.cli.main import main
from morphogen.models.library import LIBRARY


def test_demo_refuses_a_grid_too_small(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--size", "4"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("morphogen: error: --size") and "\n" not in err


@pytest.mark.slow
def test_demo_writes_the_gallery(tmp_path):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--size", "32", "--tiles", "2"]) == 0
    index = (out / "index.html").read_text(encoding="utf-8")
    for name in ["gray-scott-atlas.png", "gray-scott-growth.gif",
                 *(f"{model}.png" for model in LIBRARY)]:
        assert (out / name).stat().st_size > 0 and name in index
