"""``morphogen atlas --classify``: families on the mosaic and in families.csv."""

import csv

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.patterns.classify import COLOURS, FAMILIES
from morphogen.patterns.descriptors import NAMES
from morphogen.render.mosaic import frame_tiles


def test_frame_tiles_colours_the_border_of_each_tile():
    tiles = np.zeros((1, 2, 32, 32, 3), np.uint8)
    out = frame_tiles(tiles, np.array([["spots", "holes"]]), COLOURS)
    assert tuple(out[0, 0, -1, 16]) == (0xE6, 0x19, 0x4B)
    assert tuple(out[0, 1, 16, -1]) == (0x43, 0x63, 0xD8)
    assert (out[:, :, 16, 16] == 0).all() and tiles.max() == 0
    with pytest.raises(Exception, match="no colour"):
        frame_tiles(tiles, np.array([["spots", "waves"]]), COLOURS)


@pytest.mark.slow
def test_atlas_classify_writes_families_csv(tmp_path):
    out = tmp_path / "atlas"
    # F = 0.01 decays to the uniform state; F = 0.037, k = 0.06 grows a labyrinth
    assert main(["atlas", "gray-scott", "--x", "k=0.06:0.06:1", "--y", "F=0.001:0.037:2",
                 "--size", "48x48", "--steps", "1600", "--classify", "--watch", "2x20",
                 "--quiet", "--out", str(out)]) == 0
    with open(out / "families.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == ["k", "F", "family", *NAMES]
    assert [(float(r["k"]), float(r["F"])) for r in rows] == [(0.06, 0.001), (0.06, 0.037)]
    assert rows[0]["family"] == "uniform"
    assert all(r["family"] in FAMILIES for r in rows)
    assert float(rows[1]["range"]) > 0.1
    assert (out / "atlas.png").is_file()


def test_atlas_watch_longer_than_the_run_is_refused(tmp_path):
    assert main(["atlas", "gray-scott", "--x", "k=0.05:0.06:2", "--y", "F=0.02:0.03:2",
                 "--steps", "10", "--classify", "--watch", "4x50", "--quiet",
                 "--out", str(tmp_path / "a")]) == 2
