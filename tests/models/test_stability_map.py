"""The analysis over a parameter plane (models/stability_map.py) against the classical
boundaries, and `morphogen atlas --analysis`, which draws them over the tiles."""

from __future__ import annotations

import json

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.domains.grid import Grid
from morphogen.models.linear import lattice_modes
from morphogen.models.registry import load_model
from morphogen.models.stability_map import stability_map


def _kappa2(n: int = 64) -> np.ndarray:
    grid = Grid((n, n))
    return np.unique(lattice_modes(grid.shape, grid.symbol).kappa2)


def _population(model, **axes):
    n = len(next(iter(axes.values())))
    params = {k: np.full(n, float(v)) for k, v in model.parameters().items()}
    params.update({k: np.asarray(v, float) for k, v in axes.items()})
    return params


def test_brusselator_bands_are_murrays():
    """Brusselator, a = 4.5, Du/Dv = 1/8 (Murray II §2.6): one state (a, b/a), stable below
    b = (1 + a sqrt(Du/Dv))² = 6.71, Turing-unstable up to b = 1 + a² = 21.25, Hopf above."""
    model = load_model("brusselator")
    smap = stability_map(model, _population(model, b=[5.0, 10.0, 20.0, 25.0]), _kappa2())
    assert smap.count.tolist() == [1, 1, 1, 1]
    assert smap.turing.tolist() == [False, True, True, False]
    assert smap.hopf.tolist() == [False, False, False, True]
    assert not smap.saddle.any()


def test_gray_scott_has_three_states_above_the_fold_and_a_turing_tongue():
    """Gray-Scott's non-trivial pair exists for F > 4 (F + k)² (Pearson 1993); at F = 0.113,
    k = 0.055, in the thin Turing tongue along the fold (docs/analysis.md), one is
    Turing-unstable, next to a saddle."""
    model = load_model("gray-scott")
    k = np.array([0.06, 0.05, 0.055, 0.03])
    f = np.array([0.02, 0.05, 0.113, 0.002])
    smap = stability_map(model, _population(model, k=k, F=f), _kappa2())
    assert smap.count.tolist() == [1, 3, 3, 1]
    assert (smap.count == 3).tolist() == (f > 4 * (f + k) ** 2).tolist()
    assert smap.turing.tolist() == [False, False, True, False]
    assert smap.saddle.tolist() == [False, True, True, False]


@pytest.mark.slow
def test_atlas_analysis_draws_the_boundaries_and_refuses_a_field_up_front(tmp_path, capsys):
    out = tmp_path / "a"
    args = ["atlas", "gray-scott", "--x", "k=0.04:0.07:4", "--y", "F=0.01:0.08:4", "--size",
            "16x16", "--steps", "50", "--analysis", "--quiet"]
    assert main([*args, "--out", str(out)]) == 0
    record = json.loads((out / "atlas.json").read_text())["analysis"]
    counts = record["fixed_points"]
    assert record["points"] == [25, 25] and {"1", "3"} <= set(counts) <= {"1", "2", "3"}
    assert counts.get("2", 0) <= 0.05 * 25 * 25  # the pair meets at the fold itself only
    assert (out / "analysis.png").read_bytes()[:4] == b"\x89PNG"
    capsys.readouterr()
    assert main([*args, "-p", "Du=0.2+0.01*x", "--out", str(tmp_path / "b")]) == 2
    assert "varies in space" in capsys.readouterr().err
    assert not (tmp_path / "b").exists()
