"""Shapes for Ringham et al.'s case studies: toothed Dianthus petals and the five-petal flower
(§4.4, fig. 12), the two-lipped Mimulus corolla (§4.5) and pointed Platycodon lobes (§4.1)."""

from __future__ import annotations

import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.flowers import SHAPES, bell, bilabiate, dianthus, make_shape, petal


def _mirrored(points: np.ndarray, tol: float) -> bool:
    """Every point has a partner mirrored in x = 0 within ``tol``."""
    from scipy.spatial import cKDTree

    d, _ = cKDTree(points).query(points * [-1.0, 1.0, 1.0][: points.shape[1]])
    return bool(d.max() < tol)


def _tooth_tips(mesh, start: float) -> int:
    """Tooth tips of a petal's distal margin: margin vertices farther from the blade's centre
    than every margin vertex within a tenth of a radian either side."""
    v = mesh.vertices[(mesh.fields["margin"] > 0.5) & (mesh.fields["s"] > start)]
    rel = v[:, :2] - [0.0, 0.5 * v[:, 1].max()]
    ang, rad = np.arctan2(rel[:, 1], rel[:, 0]), np.linalg.norm(rel, axis=1)
    near = np.abs(ang[:, None] - ang[None, :]) < 0.1
    return int(np.sum(np.all(~near | (rad[:, None] >= rad[None, :]), axis=1)))


def test_toothed_petal_is_symmetric_with_a_tooth_at_the_tip_and_teeth_each_side():
    plain = petal(1.0, 0.8, edge=0.01, notch=0.0)
    toothed = petal(1.0, 0.8, edge=0.01, notch=0.0, teeth=3, tooth_depth=0.05,
                    toothed_from=0.6)
    rim = toothed.vertices[toothed.fields["margin"] > 0.5][:, :2]
    assert _mirrored(rim, 0.6 * 0.01)
    assert _tooth_tips(toothed, 0.62) == 7  # one at the tip, three each side
    assert _tooth_tips(plain, 0.62) == 1
    # the notches cut into the blade; below toothed_from the outline is the plain one
    assert toothed.areas.sum() < 0.985 * plain.areas.sum()
    low_t = toothed.vertices[(toothed.fields["margin"] > 0.5) & (toothed.fields["s"] < 0.5)]
    low_p = plain.vertices[(plain.fields["margin"] > 0.5) & (plain.fields["s"] < 0.5)]
    assert np.abs(low_t[:, 0]).max() == pytest.approx(np.abs(low_p[:, 0]).max(), abs=0.01)
    with pytest.raises(MorphogenError, match="tooth_depth"):
        petal(edge=0.05, teeth=3, tooth_depth=0.5)


def test_dianthus_flower_has_five_congruent_toothed_petals_in_rotational_symmetry():
    mesh = dianthus(edge=0.05)
    f = mesh.fields
    organs = [np.flatnonzero(f["organ"] == k) for k in range(5)]
    assert sorted(np.unique(f["organ"])) == [0, 1, 2, 3, 4] and f["petal"].all()
    assert len({len(o) for o in organs}) == 1  # the same blade five times
    for k in range(1, 5):
        a = np.radians(72.0 * k)
        rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        xy0 = mesh.vertices[organs[0], :2] @ rot.T
        assert np.allclose(xy0, mesh.vertices[organs[k], :2], atol=1e-9)
        assert np.all(mesh.vertices[organs[k], 2] > mesh.vertices[organs[0], 2])  # stacked
    assert mesh.n_vertices == 5 * len(organs[0]) and f["base"].sum() >= 5
    assert _tooth_tips(petal(1.0, 0.8, edge=0.01, teeth=5, tooth_depth=0.05,
                             toothed_from=0.65, notch=0.0), 0.67) == 11


def test_bilabiate_has_two_upper_lobes_three_lower_ones_and_deep_clefts():
    mesh = bilabiate(edge=0.03)
    f = mesh.fields
    v = mesh.vertices
    assert _mirrored(v, 0.03)  # symmetric about the vertical plane x = 0
    upper = f["upper_lip"] > 0.5
    assert set(np.unique(f["lobe"][upper & (f["s"] > 1.3)])) == {0.0, 1.0}
    assert set(np.unique(f["lobe"][~upper & (f["s"] > 1.3)])) == {2.0, 3.0, 4.0}
    reach = [f["s"][f["lobe"] == k].max() for k in range(5)]
    assert max(reach[:2]) < min(reach[2:])  # the lower lip's lobes are longer
    # the upper lip is bent back further from the axis than the lower lip
    rim_up = v[upper & (f["margin"] > 0.5)]
    rim_low = v[~upper & (f["margin"] > 0.5)]
    assert rim_up[:, 2].min() < rim_low[:, 2].min()
    # the clefts between the lips (18° and 162°) are deeper than the sinus between the upper
    # lobes (90°) or between lower lobes (234°, 306°)
    margin = f["margin"] > 0.5
    theta = np.degrees(f["theta"])

    def rim_at(deg):
        near = margin & (np.abs((theta - deg + 180) % 360 - 180) < 4)
        return f["s"][near].min()

    assert max(rim_at(18), rim_at(162)) < min(rim_at(90), rim_at(234), rim_at(306)) - 0.03
    assert min(rim_at(18), rim_at(162)) > 1.0  # down to, not into, the tube
    assert {"bilabiate", "dianthus"} <= set(SHAPES)
    assert make_shape("bilabiate", edge=0.2, scale=5.0).n_vertices > 50
    with pytest.raises(MorphogenError, match="cleft"):
        bilabiate(edge=0.05, cleft=2.0)


def test_pointed_lobes_end_in_a_point():
    def tip_drop(point):
        mesh = bell(edge=0.03, point=point)
        f = mesh.fields
        margin = f["margin"] > 0.5
        theta = (f["theta"][margin] + np.pi) % (2 * np.pi) - np.pi
        s = f["s"][margin]
        tip = s[np.abs(theta) < 0.03].max()  # lobe 0's tip is at theta = 0
        side = s[np.abs(np.abs(theta) - 0.2) < 0.04].mean()  # a third of a lobe aside
        return tip - side

    rounded, pointed = tip_drop(0.0), tip_drop(0.6)
    assert pointed > 3 * rounded and pointed > 0.05
    with pytest.raises(MorphogenError, match="point"):
        bell(edge=0.05, point=1.5)
