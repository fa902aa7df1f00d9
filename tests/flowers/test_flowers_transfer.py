"""Transfer functions from concentrations to pigment colours (Ringham et al. §3.5): step maps,
thresholds and non-linear ramps as text, from Python, pipeline files and the command line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.domains.ply import load_mesh, save_ply
from morphogen.errors import MorphogenError
from morphogen.flowers import petal
from morphogen.flowers.pipeline import run_pipeline
from morphogen.render.colour import colourise
from morphogen.runs.schema import validate_config

GOLD, BLACK = [244, 196, 48], [59, 6, 18]  # #f4c430, #3b0612 (Primula, §4.3)


def test_step_map_takes_the_colour_of_the_band_a_value_falls_in() -> None:
    f = np.array([-1.0, 0.0799, 0.08, 0.5, 0.9, np.nan])
    rgb = colourise(f, "step: #f4c430 < 0.08 < #3b0612 < 0.6 < white")
    assert rgb.tolist() == [GOLD, GOLD, BLACK, BLACK, [255, 255, 255], [255, 0, 255]]
    # levels are concentrations: the colour limits do not move them
    assert np.array_equal(colourise(f[:5], "step: #f4c430 < 0.08 < #3b0612", vmin=0, vmax=100),
                          colourise(f[:5], "step: #f4c430 < 0.08 < #3b0612"))


def test_ramp_is_piecewise_linear_at_absolute_stops_and_bends_with_gamma() -> None:
    spec = "ramp: 0 #ffffff, 0.25 #f4d6dc, 0.35 #c0143c, 1 #6e0019"
    rgb = colourise(np.array([-3.0, 0.25, 0.5, 7.0]), spec)
    # at 0.5: 0.15/0.65 of the way from #c0143c (192, 20, 60) to #6e0019 (110, 0, 25)
    t = 0.15 / 0.65
    expected = np.rint([192 + (110 - 192) * t, 20 - 20 * t, 60 + (25 - 60) * t])
    assert rgb.tolist() == [[255, 255, 255], [244, 214, 220], expected.tolist(), [110, 0, 25]]
    grey = colourise(np.array([0.5, 2.0]), "ramp: 0 black, 2 white; gamma 2")
    assert grey[:, 0].tolist() == [round(255 * 0.25**2), 255]  # t = 0.25 bent to t^2


@pytest.mark.parametrize("spec, message", [
    ("step: #fff < 0.5", "colours and levels alternately"),
    ("step: #fff < 0.5 < #000 < 0.2 < #f00", "levels must increase strictly"),
    ("step: #fff < x < #000", "level 'x' is not a number"),
    ("ramp: 0 #fff", "two or more 'VALUE COLOUR' stops"),
    ("ramp: 0 #fff, 1 nocolour", "'nocolour' is not a colour"),
    ("ramp: 0 #fff, 1 #000; gamma -1", "gamma must be positive"),
])
def test_bad_transfer_functions_are_one_line_errors(spec: str, message: str) -> None:
    with pytest.raises(MorphogenError, match=message) as err:
        colourise(np.zeros(3), spec)
    assert "\n" not in str(err.value)
    with pytest.raises(MorphogenError, match=message):
        validate_config({"model": "gray-scott", "cmap": spec})
    validate_config({"model": "gray-scott", "cmap": "step: #fff < 0.5 < #000"})


def test_a_pipeline_stage_colours_through_a_step_map(tmp_path: Path) -> None:
    spec = {"mesh": {"shape": "petal", "edge": 0.15}, "seed": 1, "view": "top",
            "stage": [{"kind": "fields", "fields": {"m": "s"}, "show": "m",
                       "cmap": "step: #f4c430 < 0.5 < #3b0612"}]}
    mesh = run_pipeline(spec, tmp_path / "out")
    ply = load_mesh(tmp_path / "out" / "final.ply")
    rgb = np.rint(np.stack([ply.fields[c] for c in ("red", "green", "blue")], 1) * 255)
    dark = mesh.fields["s"] >= 0.5
    assert 0 < dark.sum() < mesh.n_vertices
    assert np.all(rgb[dark] == BLACK) and np.all(rgb[~dark] == GOLD)


def test_mesh_render_takes_a_transfer_function(tmp_path: Path, capsys) -> None:
    src = tmp_path / "petal.ply"
    save_ply(src, petal(edge=0.12))
    png, out = tmp_path / "m.png", tmp_path / "m.ply"
    assert main(["mesh", "render", str(src), "--field", "s", "--transfer",
                 "step: #f4c430 < 0.5 < #3b0612", "--out", str(png), "--ply", str(out),
                 "--view", "top"]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    made = load_mesh(out)
    red = np.rint(made.fields["red"] * 255)
    assert set(red.tolist()) == {GOLD[0], BLACK[0]}
    assert np.array_equal(red == BLACK[0], made.fields["s"] >= 0.5)
    bad = tmp_path / "bad.png"
    assert main(["mesh", "render", str(src), "--field", "s", "--cmap", "step: #fff < 1",
                 "--out", str(bad)]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1 and not bad.exists()
    assert main(["mesh", "render", str(src), "--field", "nope + 1", "--out", str(bad)]) == 2
    assert not bad.exists()
