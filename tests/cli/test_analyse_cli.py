"""``morphogen analyse``: analysis.json and the dispersion picture for a library model, a model
file and a network file; bad input is one line, exit 2, nothing written."""

from __future__ import annotations

import json

import numpy as np
import pytest

from morphogen.cli.main import main

NO_ROOT = """name = "no-root"
species = ["u", "v"]
[parameters]
a = 1.0
[equations]
u = "a + u**2 + lap(u)"
v = "-v + 2*lap(v)"
"""


def test_schnakenberg_writes_json_and_picture(tmp_path, capsys):
    out = tmp_path / "an"
    assert main(["analyse", "schnakenberg", "-p", "b=0.9", "--size", "64", "--dx", "0.5",
                 "--out", str(out)]) == 0
    data = json.loads((out / "analysis.json").read_text())
    (fp,) = data["fixed_points"]
    assert fp["cls"] == "turing" and fp["state"] == pytest.approx([1.0, 0.9])
    assert fp["grid_fastest"]["wavelength"] == pytest.approx(
        0.5 * fp["grid_fastest"]["wavelength_cells"])
    assert len(data["curves"]["grid_sigma"][0]) == data["grid"]["modes"]
    png = (out / "dispersion.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    said = capsys.readouterr().out
    assert "turing" in said and "fastest" in said


def test_antimony_network_and_model_file(tmp_path):
    assert main(["analyse", "examples/networks/table2.ant", "--size", "32x32",
                 "--out", str(tmp_path / "t2")]) == 0
    data = json.loads((tmp_path / "t2" / "analysis.json").read_text())
    assert [f["cls"] for f in data["fixed_points"]] == ["turing"]
    assert data["fixed_points"][0]["grid_fastest"]["wavelength_cells"] == pytest.approx(
        32 / np.sqrt(13))
    assert main(["analyse", "examples/schnakenberg.toml", "--size", "48", "--stencil", "9",
                 "--out", str(tmp_path / "file")]) == 0


@pytest.mark.parametrize("argv, message", [
    (["schnakenberg", "-p", "Du=0", "-p", "Dv=0"], "no species of schnakenberg diffuses"),
    (["schnakenberg", "-p", "nope=1"], "unknown parameter 'nope'"),
    (["schnakenberg", "-p", "a=0.1+x"], "numbers only"),
    (["schnakenberg", "--dx", "-1"], "positive"),
    (["schnakenberg", "--size", "2"], "at least 3"),
    (["no-root.toml"], "no homogeneous fixed point"),
    (["schnakenberg", "--stencil", "spectral", "--boundary", "neumann"], "periodic"),
])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, monkeypatch, argv,
                                                   message):
    (tmp_path / "no-root.toml").write_text(NO_ROOT)
    monkeypatch.chdir(tmp_path)
    assert main(["analyse", *argv, "--out", "deep/out"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("morphogen: error: ") and err.count("\n") == 1 and message in err
    assert not (tmp_path / "deep").exists()
