"""Initial conditions: shapes, reproducibility, the seed formulas, files."""

from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.errors import MorphogenError
from morphogen.flowers.planar import lattice_mesh
from morphogen.initial import INITIAL_KINDS, make_initial
from morphogen.models.library import get_model

GS = get_model("gray-scott")
GRID = Grid((40, 50))
P = GS.parameters()


@pytest.mark.parametrize("kind", [k for k in INITIAL_KINDS if k not in ("image", "npz")])
def test_kinds_are_seeded_and_shaped(kind):
    a = make_initial(kind, GS, GRID, P, seed=1)
    b = make_initial(kind, GS, GRID, P, seed=1)
    assert a.shape == (2, 40, 50) and a.dtype == np.float32
    np.testing.assert_array_equal(a, b)
    if kind in ("noise", "blobs", "seeds"):
        assert not np.array_equal(a, make_initial(kind, GS, GRID, P, seed=2))


def test_skaggs_equations_3_3_and_3_4():
    u = make_initial("skaggs", GS, Grid((101, 101)), P)
    x = (np.arange(101) + 0.5) / 101 - 0.5
    i = int(np.argmin(np.abs(x - 0.05)))
    assert u[1, i, i] == pytest.approx(np.exp(-80 * 2 * (x[i] - 0.05) ** 2), rel=1e-5)
    j = int(np.argmin(np.abs(x + 0.05)))
    assert u[0, j, j] == pytest.approx(1 - np.exp(-80 * 2 * (x[j] + 0.05) ** 2), abs=1e-6)


def test_square_is_centred_with_excited_values():
    u = make_initial("square", GS, Grid((20, 20)), P, size=0.2)
    assert u[1, 10, 10] == pytest.approx(0.25) and u[1, 0, 0] == 0.0
    assert (u[1] > 0).sum() == 16


def test_seeds_count_and_range():
    model = get_model("activator-substrate")
    p = model.parameters()
    u = make_initial("seeds", model, GRID, p, count=30, seed=3)
    seeded = u[0] > 0
    assert seeded.sum() <= 30 and seeded.sum() >= 28  # U(0,1) may give ~0
    assert u[0].max() <= 1.0 and np.all(u[1] == 1.0)


def test_npz_and_image_files(tmp_path):
    state = np.random.default_rng(0).uniform(size=(2, 40, 50)).astype(np.float32)
    np.savez(tmp_path / "s.npz", u=state[0], v=state[1])
    np.testing.assert_array_equal(make_initial(str(tmp_path / "s.npz"), GS, GRID, P), state)
    img = np.zeros((20, 25), np.uint8)
    img[:, 13:] = 255
    iio.imwrite(tmp_path / "half.png", img)
    u = make_initial(str(tmp_path / "half.png"), GS, GRID, P)
    assert u[1, 0, 0] == 0.0 and u[1, 0, -1] == pytest.approx(0.25)
    np.savez(tmp_path / "bad.npz", u=state[0])
    with pytest.raises(MorphogenError, match="lacks arrays"):
        make_initial(str(tmp_path / "bad.npz"), GS, GRID, P)
    with pytest.raises(MorphogenError, match="unknown initial"):
        make_initial("sprinkles", GS, GRID, P)


@pytest.mark.parametrize("domain", [Grid((40, 50)), Grid((12, 10, 8)), lattice_mesh(12, 9)],
                         ids=["grid", "volume", "mesh"])
def test_random_is_uniform_on_every_domain(domain):
    """Skaggs §3.1: every species of every cell from U[0, 1], seeded; ``low``/``high`` rescale."""
    a = make_initial("random", GS, domain, P, seed=3)
    assert a.shape == (2, *domain.spatial_shape)
    assert a.min() >= 0.0 and a.max() < 1.0
    n = a.size
    assert abs(a.mean() - 0.5) < 4 * np.sqrt(1 / 12 / n)  # four standard errors
    assert abs(a.var() - 1 / 12) < 0.01
    np.testing.assert_array_equal(a, make_initial("random", GS, domain, P, seed=3))
    assert not np.array_equal(a, make_initial("random", GS, domain, P, seed=4))
    b = make_initial("random", GS, domain, P, seed=3, low=-2.0, high=2.0)
    np.testing.assert_allclose(b, -2.0 + 4.0 * a, rtol=1e-6, atol=1e-6)
    with pytest.raises(MorphogenError, match="low < high"):
        make_initial("random", GS, domain, P, low=1.0, high=1.0)
