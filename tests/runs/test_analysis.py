"""mg.analyse (runs/analysis.py): fixed points, class, band and fastest wavelength of a model on
a grid, against Murray's closed forms; bad input refused in one line."""

from __future__ import annotations

import json

import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.models.library import get_model
from morphogen.models.model import Model
from morphogen.models.registry import load_model
from morphogen.runs.analysis import analyse


def test_schnakenberg_band_and_fastest_wavelength_in_cells_and_length():
    """``J = [[-1 + 2uv, u²], [-2uv, -u²]]`` at ``(1, 0.9)``: ``σ(q)`` is largest where
    ``d/dq² (tr + √(tr² - 4 det)) = 0``; the band is the roots of ``det(J - q²D)``."""
    model = get_model("schnakenberg")
    a = analyse(model, model.parameters(), size=64, dx=0.5)
    (fp,) = a.fixed_points
    assert fp.cls == "turing" and fp.state == pytest.approx((1.0, 0.9))
    jac, d = np.array([[0.8, 1.0], [-1.8, -1.0]]), np.array([1.0, 40.0])
    b = d[1] * jac[0, 0] + d[0] * jac[1, 1]
    disc = np.sqrt(b * b - 4 * d.prod() * np.linalg.det(jac))
    lo, hi = (b - disc) / (2 * d.prod()), (b + disc) / (2 * d.prod())
    assert fp.band.kappa2 == pytest.approx((lo, hi), rel=1e-3)
    q2 = np.linspace(lo, hi, 200001)
    tr = jac.trace() - q2 * d.sum()
    det = (jac[0, 0] - q2 * d[0]) * (jac[1, 1] - q2 * d[1]) - jac[0, 1] * jac[1, 0]
    best = q2[np.argmax((tr + np.sqrt(tr * tr - 4 * det + 0j)).real)]
    assert fp.fastest.wavelength == pytest.approx(2 * np.pi / np.sqrt(best), rel=1e-3)
    assert fp.fastest.wavelength_cells == pytest.approx(fp.fastest.wavelength / 0.5)
    grid = fp.grid_fastest
    assert grid.wavelength == pytest.approx(0.5 * grid.wavelength_cells)
    assert grid.wavelength_cells == pytest.approx(64 / np.hypot(*grid.mode))
    assert fp.grid_band.kappa2[0] > lo and fp.grid_band.kappa2[1] < hi
    data = json.loads(a.to_json())
    assert data["fixed_points"][0]["cls"] == "turing" and data["grid"]["shape"] == [64, 64]


def test_gray_scott_three_fixed_points_and_table2():
    model = get_model("gray-scott")
    a = analyse(model, model.parameters({"F": 0.025, "k": 0.05}), size=32)
    assert len(a.fixed_points) == 3
    trivial = [f for f in a.fixed_points if f.state == pytest.approx((1.0, 0.0))]
    assert trivial[0].cls == "stable" and trivial[0].grid_band is None
    t2 = analyse(load_model("examples/networks/table2.ant"), size=32)
    assert [f.cls for f in t2.fixed_points] == ["turing"]
    assert t2.fixed_points[0].grid_fastest.wavelength_cells == pytest.approx(32 / np.sqrt(13))


def test_bad_input_is_one_clear_error():
    model = get_model("schnakenberg")
    with pytest.raises(MorphogenError, match="no species .* diffuses"):
        analyse(model, model.parameters({"Du": 0.0, "Dv": 0.0}))
    with pytest.raises(MorphogenError, match="not a finite number"):
        analyse(model, model.parameters({"a": float("nan")}))
    no_root = Model(name="no-root", species=("u",), params={"D": 1.0},
                    reaction=lambda u, p, c: 1.0 + u**2, diffusion=lambda p, c: (p["D"],))
    with pytest.raises(MorphogenError, match="no homogeneous fixed point"):
        analyse(no_root, size=16)
    flat = Model(name="conserved", species=("u", "v"), params={"D": 1.0},
                 reaction=lambda u, p, c: jnp.stack([u[1] - u[0], u[0] - u[1]]),
                 diffusion=lambda p, c: (p["D"], 2.0))
    with pytest.raises(MorphogenError, match="singular"):
        analyse(flat, size=16)
