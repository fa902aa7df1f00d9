"""The confusion table of the texture loss and the dot statistics (tiny fixtures)."""

from __future__ import annotations

import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.learn.confusion import (
    aspect_ratio,
    blob_stats,
    confusion_table,
    dot_report,
    two_colours,
)
from morphogen.learn.textures import synthetic_texture

INK = np.array([0.8, 0.1, 0.1])
GROUND = np.array([0.95, 0.95, 0.9])


def _canvas(mask: np.ndarray) -> np.ndarray:
    return np.where(mask[..., None], INK, GROUND).astype(np.float32)


def _disc(side: int, cy: float, cx: float, r: float) -> np.ndarray:
    y, x = np.mgrid[:side, :side]
    dy = (y - cy + side / 2) % side - side / 2  # periodic distance
    dx = (x - cx + side / 2) % side - side / 2
    return dy * dy + dx * dx <= r * r


def test_discs_are_counted_round_and_a_disc_across_the_edge_once() -> None:
    side = 48
    mask = _disc(side, 10, 10, 3) | _disc(side, 30, 34, 3) | _disc(side, 0, 24, 3)  # wraps
    mask |= _disc(side, 40, 0, 3)  # wraps in x
    stats = blob_stats(_canvas(mask), INK, GROUND)
    assert stats.count == 4
    assert stats.elongated == 0.0
    assert stats.density == pytest.approx(1000 * 4 / side**2)
    assert stats.area == pytest.approx(mask.sum() / 4)
    assert stats.ink == pytest.approx(mask.mean())


def test_rods_and_fused_pairs_are_elongated_and_specks_ignored() -> None:
    side = 64
    mask = np.zeros((side, side), bool)
    mask[5:8, 5:20] = True  # a 3 x 15 rod
    mask[30:34, 60:64] = mask[30:34, 0:8] = True  # a 4 x 12 rod across the edge
    mask |= _disc(side, 50, 20, 3) | _disc(side, 50, 26, 3)  # two touching discs
    mask |= _disc(side, 20, 45, 3)  # a round dot
    mask[58, 58] = True  # a one-cell speck: below min_area
    stats = blob_stats(_canvas(mask), INK, GROUND)
    assert stats.count == 4
    assert stats.elongated == pytest.approx(0.75)


def test_aspect_ratio_of_a_disc_an_ellipse_and_a_line() -> None:
    y, x = np.nonzero(_disc(41, 20, 20, 8))
    assert aspect_ratio(y, x) == pytest.approx(1.0, abs=0.02)
    y, x = np.mgrid[-20:21, -20:21]
    inside = (y / 4.0) ** 2 + (x / 12.0) ** 2 <= 1
    assert aspect_ratio(y[inside], x[inside]) == pytest.approx(3.0, rel=0.1)
    assert aspect_ratio(np.zeros(10), np.arange(10)) > 10


def test_two_colours_finds_the_rarer_ink() -> None:
    mask = _disc(32, 16, 16, 6)
    ink, ground = two_colours(_canvas(mask))
    np.testing.assert_allclose(ink, INK, atol=1e-6)
    np.testing.assert_allclose(ground, GROUND, atol=1e-6)


def test_the_dots_target_measures_as_its_own_dots() -> None:
    target = synthetic_texture("dots", 64)
    shifted = np.roll(target, (7, 11), axis=(0, 1))
    rep = dot_report(np.stack([target, shifted]), target)
    assert rep["target_density"] > 0 and rep["target_elongated"] == 0.0
    assert rep["density_ratio"] == pytest.approx(1.0)
    assert rep["elongated"] == 0.0


def test_confusion_table_rows_columns_margins_on_a_tiny_fixture() -> None:
    dots, stripes = synthetic_texture("dots", 32), synthetic_texture("stripes", 32)
    images = {
        "dots": np.stack([np.roll(dots, 5, axis=0), np.rot90(dots)]),
        "stripes": np.stack([np.roll(stripes, 3, axis=1), np.rot90(stripes)]),
        "fake": np.stack([np.roll(dots, 9, axis=1)] * 2),  # not a target name: no margin
    }
    table = confusion_table(images, {"dots": dots, "stripes": stripes}, n_rot=4)
    assert table.losses.shape == (3, 2, 2) and table.references.shape == (2, 2)
    assert table.nearest("dots") == "dots" and table.nearest("stripes") == "stripes"
    assert table.margin("dots") > 1 and table.margin("stripes") > 1
    assert table.margin("fake") is None
    m = table.mean
    assert table.margin("dots") == pytest.approx(m[0, 1] / m[0, 0] - 1)
    assert np.all(np.diag(table.references) < table.references[[1, 0], [0, 1]])
    text = table.markdown()
    assert "| `neural:dots` |" in text and "target stripes" in text
    # a rule grown into the other texture is not closest to its own target
    swapped = confusion_table({"dots": images["stripes"]}, {"dots": dots, "stripes": stripes},
                              n_rot=4)
    assert swapped.nearest("dots") == "stripes" and swapped.margin("dots") < 0


def test_confusion_table_refuses_ragged_input() -> None:
    dots = synthetic_texture("dots", 32)
    with pytest.raises(MorphogenError):
        confusion_table({"a": dots[None], "b": np.stack([dots, dots])}, {"dots": dots}, n_rot=4)
    with pytest.raises(MorphogenError):
        confusion_table({}, {"dots": dots})
