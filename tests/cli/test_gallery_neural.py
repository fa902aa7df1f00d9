"""``morphogen gallery neural`` on a tiny configuration."""

from __future__ import annotations

import json

import pytest

from morphogen.cli.main import main

TINY = ["--size", "16", "--steps", "4", "--seeds", "2", "--mesh-edge", "0.25",
        "--mesh-time", "2", "--volume", "4x8x8", "--volume-steps", "2"]


def test_gallery_neural_writes_each_rule_row_and_the_confusion_table(tmp_path) -> None:
    out = tmp_path / "neural"
    assert main(["gallery", "neural", "--out", str(out), "--only", "dots", *TINY]) == 0
    for name in ("target", "seed_0", "seed_1", "mesh", "volume", "row"):
        assert (out / "dots" / f"{name}.png").is_file()
    page = (out / "index.html").read_text()
    assert 'src="dots/row.png"' in page and "dot density" in page
    data = json.loads((out / "confusion.json").read_text())
    assert data["table"]["rules"] == ["dots"] and len(data["table"]["targets"]) == 6
    assert len(data["table"]["losses"][0][0]) == 2  # two seeds
    assert (out / "confusion.md").read_text().count("| `neural:dots` |") == 2  # colour, shape
    assert data["shape"]["rules"] == ["dots"] and "by shape nearest" in page


@pytest.mark.parametrize("args, message", [
    (["--only", "nosuch"], "unknown neural rule"),
    (["--volume", "4x8"], "--volume takes"),
    (["--rule", "dots"], "--rule takes"),
])
def test_gallery_neural_bad_arguments_are_one_line(tmp_path, capsys, args, message) -> None:
    assert main(["gallery", "neural", "--out", str(tmp_path / "g"), *TINY, *args]) == 2
    assert message in capsys.readouterr().err
