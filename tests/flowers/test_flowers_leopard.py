"""Phalaenopsis Chian Xen Leopard Stripes (Ringham et al. 2021, §4.10): veins raise the
activator's basal production, a morphogen from the flower centre scales both diffusion rates,
and the ranges differ per organ; dots form in strings along the veins."""

from __future__ import annotations

import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.flowers import orchid
from morphogen.flowers.pipeline import load_pipeline, run_pipeline
from tests.paths import EXAMPLES

pytestmark = pytest.mark.slow

EXAMPLE = EXAMPLES / "flowers" / "phalaenopsis-leopard.toml"


@pytest.fixture(scope="module")
def flower(tmp_path_factory):
    """The pipeline on a flower 2.5 units across instead of 11.8 with the shipped mean edge
    (0.035, so the same dt), fewer attraction points, and 2 000 of the 6 900 steps."""
    spec = load_pipeline(EXAMPLE)
    spec["mesh"] = {**spec["mesh"], "scale": 2.5, "edge": 0.035}
    spec["stage"][0]["points"] = 2500
    spec["stage"][3]["steps"] = 2000
    return run_pipeline(spec, tmp_path_factory.mktemp("leopard"), pictures=False)


def test_the_file_has_the_fig22_parameters_and_table1_steps() -> None:
    spec = load_pipeline(EXAMPLE)
    sim = spec["stage"][3]
    assert (sim["model"], sim["steps"], sim["dt"]) == ("activator-inhibitor", 6900, 0.05)
    p = sim["params"]
    assert (p["rho_a"], p["kappa"], p["mu_a"], p["rho_h"], p["rho_h0"], p["mu_h"]) == (
        0.08, 0.001, 0.03, 0.12, 0.0, 0.03)
    assert [s["kind"] for s in spec["stage"]] == ["veins", "positional", "fields", "simulate",
                                                   "fields"]


def test_organ_ranges_reach_the_right_vertices(flower) -> None:
    f = flower.fields
    organ, near, g = f["organ"], f["near"], f["g"]
    on_vein, centre = near > 0.999, g > 0.999
    for index, (low, high) in {0: (1.3e-6, 2.2e-4), 1: (1.3e-4, 0.022), 2: (1.3e-4, 0.022),
                               3: (6.5e-5, 0.011), 4: (6.5e-5, 0.011)}.items():
        mine = organ == index
        np.testing.assert_allclose(f["rho_a0"][mine], low + (high - low) * near[mine],
                                   rtol=1e-6)
        np.testing.assert_allclose(f["rho_a0"][mine & on_vein], high, rtol=1e-3)
        assert f["rho_a0"][mine].min() < low + 0.1 * (high - low)  # far from the veins
    sepals, petals = organ < 2.5, (organ > 2.5) & (organ < 4.5)
    np.testing.assert_allclose(f["Da"][sepals], 7.13e-6)
    np.testing.assert_allclose(f["Dh"][sepals], 3.56e-4)
    # on the petals D_a and D_h run from the fig. 22 maximum at the centre to the minimum
    # on the margin, linearly in g
    np.testing.assert_allclose(f["Da"][petals & centre], 3.92e-5, rtol=1e-3)
    np.testing.assert_allclose(f["Dh"][petals & (f["margin"] > 0.5)], 4.78e-4, rtol=1e-6)
    np.testing.assert_allclose(f["Dh"][petals] / f["Da"][petals], 50.0, rtol=1e-3)


def test_pigment_follows_the_veins(flower) -> None:
    f = flower.fields
    petals = (f["organ"] > 2.5) & (f["organ"] < 4.5)
    dots = petals & (f["a"] > 1.0)
    # pigment covers a small part of the petals (measured: 12 %), all of it within 0.07 units
    # (two edges) of a vein, where only about a third of the petal's vertices are
    near = f["vein_distance"] < 0.07
    assert 0.03 < dots.sum() / petals.sum() < 0.3
    assert float(np.mean(near[dots])) > 0.97 and float(np.mean(near[petals])) < 0.5
    # nearly every vein vertex is pigmented by t = 100 (2 000 steps; the dots along them
    # separate later), nothing farther than 0.2 units from a vein is
    assert float(np.mean(f["a"][petals & (f["vein"] > 0.5)] > 1.0)) > 0.8
    assert float(f["a"][petals & (f["vein_distance"] > 0.2)].max()) < 0.5


def test_lip_and_column_have_solid_colours(flower) -> None:
    f = flower.fields
    np.testing.assert_allclose(f["pigment"][f["lip"] > 0.5], 0.95, rtol=1e-6)
    assert np.all(f["pigment"][f["column"] > 0.5] == 0.0)


def test_the_orchid_column_is_a_seventh_organ_in_front() -> None:
    mesh = orchid(edge=0.03, column=0.12)
    f = mesh.fields
    assert sorted(np.unique(f["organ"])) == list(range(7))
    assert np.array_equal(f["column"] > 0.5, f["organ"] == 6)
    assert (f["sepal"] + f["petal"] + f["lip"] + f["column"] == 1).all()
    assert mesh.vertices[f["column"] > 0.5, 2].min() > mesh.vertices[f["lip"] > 0.5, 2].mean()
    assert "column" in orchid(edge=0.05).fields and orchid(edge=0.05).fields["column"].max() == 0
    with pytest.raises(MorphogenError, match="column must be from 0 to 0.3"):
        orchid(column=0.5)
