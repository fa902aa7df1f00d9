"""Trichoglottis smithii (Ringham et al. 2021, §4.8): Turing's model with both morphogens
anisotropic makes stripes across the tepal when diffusion is fast along it (the shipped reading)
and along it with the caption's directions read literally; phase 2 holds u = 0, v = 30 on the
distal margin."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from morphogen.flowers.pipeline import load_pipeline, run_pipeline
from tests.paths import ROOT

pytestmark = pytest.mark.slow

EXAMPLES = ROOT / "examples" / "flowers"
EXAMPLE = EXAMPLES / "trichoglottis.toml"
SWAPPED = {"lu1": 0.4, "lu2": 0.0049, "lv1": 0.01, "lv2": 0.001225}


def _petal(swap: bool) -> dict:
    """One flat-ish petal 24 units long (940 vertices, mean edge 0.6 as shipped); rho = 0.04
    shortens the stripe spacing to ~2.6 units and the time to form them to 3 000 steps of 0.1."""
    params = {"rho": 0.04, **(SWAPPED if swap else {})}
    return {"base": EXAMPLES, "seed": 3, "view": "top",
            "mesh": {"shape": "petal", "edge": 0.6, "scale": 24.0, "width": 0.8},
            "stage": [{"name": "t", "kind": "simulate", "model": "trichoglottis-turing.toml",
                       "directions": "s", "params": params, "steps": 3000, "dt": 0.1,
                       "init": "noise", "show": "v"}]}


def _along_over_across(mesh) -> float:
    """Variogram ratio: mean (v_i - v_j)^2 over vertex pairs 0.9-1.5 apart (about half a stripe
    spacing) in the proximo-distal direction (y), over the same across the petal (x). Above 1:
    v changes along the petal, i.e. stripes run across it."""
    xy, v = mesh.vertices[:, :2], mesh.fields["v"]
    pairs = cKDTree(xy).query_pairs(1.5, output_type="ndarray")
    d = xy[pairs[:, 1]] - xy[pairs[:, 0]]
    r = np.linalg.norm(d, axis=1)
    keep = r > 0.9
    pairs, d, r = pairs[keep], d[keep], r[keep]
    sq = (v[pairs[:, 1]] - v[pairs[:, 0]]) ** 2
    return float(sq[np.abs(d[:, 1]) > 0.9 * r].mean() / sq[np.abs(d[:, 0]) > 0.9 * r].mean())


def test_the_file_has_the_fig18_parameters_and_table1_steps() -> None:
    stages = {s["name"]: s for s in load_pipeline(EXAMPLE)["stage"]}
    phase1, phase2 = stages["phase1"], stages["phase2"]
    assert (phase1["steps"], phase2["steps"], phase1["dt"], phase2["dt"]) == (60000, 4500, 0.05,
                                                                              0.05)
    assert phase1["params"] == phase2["params"] == SWAPPED  # the caption's rates, swapped
    assert phase2["boundary"] == {"u": "dirichlet=0@distal", "v": "dirichlet=30@distal"}


def test_stripes_run_across_the_tepal_only_with_fast_proximo_distal_diffusion(tmp_path) -> None:
    shipped = run_pipeline(_petal(True), tmp_path / "swapped")
    literal = run_pipeline(_petal(False), tmp_path / "literal")
    for mesh in (shipped, literal):
        v = mesh.fields["v"]
        assert np.percentile(v, 95) - np.percentile(v, 5) > 5  # a pattern, not the ground state
    assert _along_over_across(shipped) > 1.3  # stripes across (measured 1.6)
    assert _along_over_across(literal) < 0.85  # stripes along (measured 0.7)


def test_phase2_holds_the_distal_margin_and_starts_from_phase1(tmp_path) -> None:
    spec = load_pipeline(EXAMPLE)
    spec["mesh"] = {**spec["mesh"], "edge": 0.6, "scale": 15.0}
    spec["stage"][1]["steps"] = 200
    spec["stage"][2]["steps"] = 20
    out = tmp_path / "tri"
    mesh = run_pipeline(spec, out)
    f = mesh.fields
    distal = f["distal"] > 0.5
    assert distal.sum() > 20 and not distal[f["s"] < 0.5].any()
    np.testing.assert_array_equal(f["u"][distal], 0.0)
    np.testing.assert_array_equal(f["v"][distal], 30.0)
    with np.load(out / "02-phase1" / "fields.npz") as phase1:
        inner = (f["margin"] < 0.5) & (f["s"] < 0.3)
        # 20 more steps move the interior by little: phase 2 continued phase 1's state
        assert np.abs(f["v"][inner] - phase1["v"][inner]).max() < 0.05
        assert np.std(phase1["v"]) > 0  # (phase 1 started from noise)
    np.testing.assert_allclose(f["rho"], 0.005 - 0.004 * f["r"], rtol=1e-5)  # centre to tips
    assert f["rho"].min() == pytest.approx(0.001)
