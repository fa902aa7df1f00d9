"""Initial conditions: shapes, reproducibility, the seed formulas, files."""

from __future__ import annotations

from dataclasses import replace

import imageio.v3 as iio
import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.initial import INITIAL_KINDS, make_initial
from morphogen.errors import MorphogenError
from morphogen.flowers.planar import lattice_mesh
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
    with pytest.raises(MorphogenError, match="has no array .v."):
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


def _blob_weight(state: np.ndarray) -> np.ndarray:
    """Gray-Scott's v: the blend weight w of ``g + w (e - g)`` (g = 0, e = 0.25)."""
    return state[1] / 0.25


def test_blob_sigma_is_in_cells_and_round_on_any_grid():
    """One blob of sigma 2 cells on a 40 x 50 torus: its mass is 2 pi sigma^2 and its spread is
    the same along both axes (sigma in cells, not a fraction of each side)."""
    w = _blob_weight(make_initial("blobs", GS, GRID, P, count=1, sigma=2.0, seed=4))
    assert w.sum() == pytest.approx(2 * np.pi * 4.0, rel=1e-3)
    i, j = np.unravel_index(np.argmax(w), w.shape)
    w = np.roll(w, (20 - i, 25 - j), axis=(0, 1))  # the blob away from the seams
    for axis, n in ((0, 40), (1, 50)):
        profile = w.sum(axis=1 - axis)
        x = np.arange(n)
        mean = (x * profile).sum() / profile.sum()
        assert ((x - mean) ** 2 * profile).sum() / profile.sum() == pytest.approx(4.0, rel=1e-2)


def _peaks(w: np.ndarray) -> int:
    """Local maxima above 0.9 on the torus (a blob's top is >= exp(-1/16) at sigma 2)."""
    around = np.max([np.roll(w, (a, b), axis=(0, 1)) for a in (-1, 0, 1) for b in (-1, 0, 1)],
                    axis=0)
    return int(((w > 0.9) & (w == around)).sum())


def test_blob_spacing_sets_the_density_and_a_run_option_replaces_the_model_default():
    u = make_initial("blobs", GS, Grid((64, 64)), P, spacing=16, sigma=2.0, seed=0)
    assert 13 <= _peaks(_blob_weight(u)) <= 16  # 64^2 / 16^2 = 16 centres; a few may merge
    with pytest.raises(MorphogenError, match="count or a spacing"):
        make_initial("blobs", GS, GRID, P, count=3, spacing=16)
    neural = replace(GS, init="blobs", init_options={"spacing": 16, "sigma": 2.0})
    np.testing.assert_array_equal(make_initial("blobs", neural, Grid((64, 64)), P, seed=0), u)
    one = make_initial("blobs", neural, Grid((64, 64)), P, count=1, seed=0)  # no conflict
    assert _peaks(_blob_weight(one)) == 1


def test_blobs_on_a_closed_mesh_are_sparse_gaussians_on_the_surface():
    """On a unit icosphere a blob of sigma = 2 mean edge lengths has surface mass
    2 pi sigma^2 (1 - exp(-2 / sigma^2)) (chord distance); the neural default (one per
    (16 h)^2 of area) seeds a small share of the vertices, not all of them."""
    import trimesh

    from morphogen.domains.mesh import Mesh

    sphere = trimesh.creation.icosphere(subdivisions=4)
    mesh = Mesh(sphere.vertices, sphere.faces)
    w = _blob_weight(make_initial("blobs", GS, mesh, P, count=1, sigma=2.0, seed=1))
    s = 2.0 * mesh.edge_length
    assert float(np.sum(w * mesh.areas)) == pytest.approx(
        2 * np.pi * s**2 * (1 - np.exp(-2 / s**2)), rel=0.03)
    sparse = _blob_weight(make_initial("blobs", GS, mesh, P, spacing=16, sigma=2.0, seed=1))
    expected = round(float(mesh.areas.sum()) / (16 * mesh.edge_length) ** 2)
    assert 0.0 < (sparse > 0.5).mean() < 3 * expected * np.pi * (1.18 * s) ** 2 / (4 * np.pi)
    assert 1 <= expected <= 20


def test_model_files_may_suggest_exactly_the_initial_conditions_the_engine_builds():
    from morphogen.engine.initial import INITIAL_KINDS
    from morphogen.models.model import INITIAL_NAMES

    assert tuple(INITIAL_KINDS) == INITIAL_NAMES
