"""The classifier on fixed, seeded Gray-Scott simulations named for their pattern."""

import numpy as np
import pytest

from morphogen.patterns.presets import EXPECTED, classify_presets


@pytest.mark.slow
def test_gray_scott_presets_are_named_for_what_they_grow():
    names = ["solitons", "holes", "mazes"]
    r = classify_presets(names, size=64, steps=3000, seed=0, count=3, gap=50)
    assert r.predicted == [EXPECTED[n] for n in names] == ["spots", "holes", "stripes"]
    # spots and holes: Euler characteristic of opposite signs, about one per wavelength cell
    assert r.descriptors["euler"][0] > 10 and r.descriptors["euler"][1] < -10
    # all three settle at the same Turing scale, 64 / 4 or 64 / 5 pixels on this grid
    wavelength = r.descriptors["wavelength"][:, None]
    assert np.all(np.isclose(wavelength, [64 / 4, 64 / 5], rtol=1e-5).any(axis=1))
