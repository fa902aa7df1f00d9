"""Atlas tiles that are numerically unstable are reported and never named as a pattern."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.models.registry import load_model
from morphogen.runs.atlas import Atlas, Axis, checkerboard_members, instability_report


def _states() -> np.ndarray:
    """Three members of Gray-Scott on 16²: a checkerboard, stripes 8 cells wide, uniform."""
    i, j = np.mgrid[:16, :16]
    board = np.stack([1.0 - 0.2 * (-1.0) ** (i + j), 0.1 * (-1.0) ** (i + j)])
    wave = 2 * np.pi * j / 8
    stripes = np.stack([0.6 + 0.3 * np.sin(wave), 0.2 + 0.1 * np.cos(wave)])
    uniform = np.stack([np.ones((16, 16)), np.zeros((16, 16))])
    return np.stack([board, stripes, uniform]).astype(np.float32)


def test_checkerboard_members_flags_only_the_grid_scale_mode():
    model = load_model("gray-scott")
    states = _states()
    params = {k: np.full(3, v) for k, v in model.params.items()}
    u0 = np.broadcast_to(states[2], states.shape)
    assert checkerboard_members(states, u0, model, params).tolist() == [True, False, False]
    # a checkerboard in one species is enough; round-off on a uniform state is not
    tiny = states[2] + 1e-7 * (-1.0) ** np.add.outer(np.arange(16), np.arange(16))
    mixed = np.stack([states[1], np.stack([states[1][0], states[0][1]]), tiny])
    assert checkerboard_members(mixed, u0, model, params).tolist() == [False, True, False]


def _atlas(valid, unstable) -> Atlas:
    return Atlas(states=np.zeros((2, 2, 2, 4, 4)), valid=np.asarray(valid),
                 x=Axis("F", np.array([0.0, 0.07])), y=Axis("k", np.array([0.0, 0.05])),
                 wall_time=0.0, unstable=np.asarray(unstable), dt=1.0)


def test_instability_report_names_the_tiles_and_a_smaller_dt():
    ok = [[True, True], [True, True]]
    assert instability_report(_atlas(ok, [[False, False], [False, False]])) is None
    line = instability_report(_atlas([[True, True], [False, True]], [[True, False],
                                                                    [False, False]]))
    assert "\n" not in line
    assert line.startswith("2 of 4 tiles were numerically unstable at dt=1")
    assert "F=0 k=0" in line and "F=0 k=0.05" in line and "--dt" in line and "0.5" in line


@pytest.mark.slow
def test_atlas_reports_unstable_tiles_instead_of_naming_them(tmp_path, capsys):
    # Gray-Scott at k = 0 is stable at its ground state for dt = 1 (the check passes) but its
    # patterned state is not: the explicit step leaves a saturated checkerboard on 24²
    out = tmp_path / "atlas"
    args = ["atlas", "gray-scott", "--x", "F=0.01:0.07:2", "--y", "k=0:0.05:2",
            "--size", "24x24", "--classify", "--watch", "2x20", "--quiet"]
    assert main([*args, "--steps", "1500", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    warning = [line for line in err.splitlines() if "numerically unstable" in line]
    assert len(warning) == 1 and warning[0].startswith("morphogen: warning: 2 of 4 tiles")
    with open(out / "families.csv") as f:
        rows = {(r["F"], r["k"]): r["family"] for r in csv.DictReader(f)}
    assert rows[("0.01", "0")] == rows[("0.07", "0")] == "blown-up"
    assert rows[("0.01", "0.05")] == rows[("0.07", "0.05")] == "uniform"
    meta = json.loads((out / "atlas.json").read_text())
    assert meta["unstable"] == [{"F": 0.01, "k": 0.0}, {"F": 0.07, "k": 0.0}]
    assert np.load(out / "atlas.npz")["unstable"].tolist() == [[True, True], [False, False]]
    # the smaller step the warning suggests runs the same atlas cleanly
    half = tmp_path / "half"
    assert main([*args, "--steps", "3000", "--dt", "0.5", "--out", str(half)]) == 0
    assert "numerically unstable" not in capsys.readouterr().err
    assert json.loads((half / "atlas.json").read_text())["unstable"] == []
