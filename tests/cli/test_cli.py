"""The ``morphogen`` command end to end, and its handling of bad input."""

from __future__ import annotations

import contextlib
import importlib
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from morphogen.cli.main import COMMANDS, main

SCHNAKENBERG = """\
name = "schnakenberg"
species = ["u", "v"]
[parameters]
a = 0.1
b = 0.9
Du = 1.0
Dv = 40.0
[equations]
u = "a - u + u**2*v + Du*lap(u)"
v = "b - u**2*v + Dv*lap(v)"
"""


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """``morphogen ARGS`` run in this process (from ``cwd``): its exit status and what it
    printed. An exception that escapes ``main`` fails the test, as a traceback would."""
    out, err = io.StringIO(), io.StringIO()
    previous = Path.cwd()
    try:
        os.chdir(cwd or previous)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(list(args))
            except SystemExit as exc:
                code = exc.code
    finally:
        os.chdir(previous)
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


def run_cli_process(*args: str) -> subprocess.CompletedProcess:
    """``morphogen ARGS`` in a fresh process, for settings global to a process (``--x64``)."""
    env = {**os.environ, "JAX_PLATFORMS": "cpu"}
    return subprocess.run([sys.executable, "-m", "morphogen.cli.main", *args],
                          capture_output=True, text=True, env=env, timeout=600)


@pytest.mark.slow
def test_simulate_writes_outputs_and_config_reproduces(tmp_path):
    out = tmp_path / "gs"
    assert main(["simulate", "gray-scott", "--size", "48x48", "--steps", "400", "--every",
                 "100", "--seed", "4", "-p", "F=0.03", "--out", str(out), "--quiet"]) == 0
    for name in ("state.npz", "final.png", "run.json", "animation.gif"):
        assert (out / name).is_file()
    record = json.loads((out / "run.json").read_text())
    assert record["config"]["params"] == {"F": 0.03}
    assert record["resolved"]["steps"] == 400
    assert {"jax", "numpy", "morphogen", "wall_time_s"} <= set(record["provenance"])
    again = tmp_path / "again"
    assert main(["simulate", "--config", str(out / "run.json"), "--out", str(again),
                 "--quiet"]) == 0
    a, b = np.load(out / "state.npz"), np.load(again / "state.npz")
    assert set(a.files) == {"u", "v"}
    for s in a.files:
        np.testing.assert_array_equal(a[s], b[s])


@pytest.mark.slow
def test_equation_file_runs_and_its_text_travels_in_run_json(tmp_path):
    model_file = tmp_path / "schnak.toml"
    model_file.write_text(SCHNAKENBERG)
    out = tmp_path / "run"
    assert main(["simulate", str(model_file), "--size", "32x32", "--steps", "50", "--dt",
                 "0.005", "--out", str(out), "--quiet"]) == 0
    model_file.unlink()
    record = json.loads((out / "run.json").read_text())
    assert "lap(u)" in record["config"]["model_source"]
    assert main(["simulate", "--config", str(out / "run.json"), "--out", str(tmp_path / "r2"),
                 "--quiet"]) == 0


def test_3d_run_writes_slice_and_montage(tmp_path):
    out = tmp_path / "vol"
    assert main(["simulate", "gray-scott", "--size", "12x16x16", "--steps", "20",
                 "--out", str(out), "--quiet"]) == 0
    assert (out / "final.png").is_file() and (out / "montage.png").is_file()
    assert np.load(out / "state.npz")["v"].shape == (12, 16, 16)


@pytest.mark.slow
def test_atlas_is_one_labelled_mosaic(tmp_path):
    out = tmp_path / "atlas"
    assert main(["atlas", "gray-scott", "--x", "k=0.05:0.065:3", "--y", "F=0.02:0.05:2",
                 "--size", "24x24", "--steps", "100", "--out", str(out), "--quiet"]) == 0
    data = np.load(out / "atlas.npz")
    assert data["v"].shape == (2, 3, 24, 24)
    np.testing.assert_allclose(data["k"], [0.05, 0.0575, 0.065])
    assert (out / "atlas.png").is_file()


def test_models_lists_every_library_model(capsys):
    from morphogen.models.library import LIBRARY

    assert main(["models"]) == 0
    text = capsys.readouterr().out
    for name in LIBRARY:
        assert f"{name}:" in text
    assert "F=0.037" in text


@pytest.mark.parametrize("module", COMMANDS)
def test_every_command_answers_help(module):
    parser_name = module.rsplit(".", 1)[1].removesuffix("_cmd").replace("_", "-")
    importlib.import_module(module)
    with pytest.raises(SystemExit) as info:
        main([parser_name, "--help"])
    assert info.value.code == 0


BAD_INPUTS = [
    (["simulate", "grey-scott"], "unknown model"),
    (["simulate", "gray-scott", "-p", "kill=0.06"], "unknown parameter"),
    (["simulate", "gray-scott", "-p", "F=abc("], "parameter F"),
    (["simulate", "gray-scott", "--size", "-5x10"], "--size"),
    (["simulate", "gray-scott", "--size", "64"], "--size"),
    (["simulate", "gray-scott", "--steps", "ten"], "whole number"),
    (["simulate", "gray-scott", "--dt", "5", "--size", "16x16"], "stability limit"),
    (["simulate", "gray-scott", "--init", "sprinkles"], "unknown initial"),
    (["simulate", "gray-scott", "--boundary", "sticky"], "unknown boundary"),
    (["simulate", "gray-scott", "--clamp", "5:1"], "--clamp"),
    (["simulate", "missing.toml"], "not found"),
    (["simulate", "--config", "nope.json"], "cannot read run file"),
    (["atlas", "gray-scott", "--x", "F=0.01:0.07", "--y", "k=0.04:0.07:3"], "NAME=START"),
    (["evolve", "gray-scott", "--strategy", "gradient"], "--fitness target"),
    (["frobnicate"], "invalid choice"),
]


@pytest.mark.parametrize("args, message", BAD_INPUTS)
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, args, message):
    out = tmp_path / "out"
    extra = ["--out", str(out)] if args[0] in ("simulate", "atlas") else []
    result = run_cli(*args, *extra, cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert message in lines[0]
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize(
    "text, message",
    [(SCHNAKENBERG.replace("a - u", "__import__('os').system('touch pwned') - u"), "line 9"),
     (SCHNAKENBERG.replace("Du*lap(u)", "Du*lap(u"), "line 9"),
     ("species = [", "TOML")],
)
def test_malformed_or_unsafe_model_files(tmp_path, text, message):
    path = tmp_path / "m.toml"
    path.write_text(text)
    result = run_cli("simulate", str(path), "--out", str(tmp_path / "o"), cwd=tmp_path)
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1
    assert message in result.stderr
    assert not (tmp_path / "pwned").exists()


def test_unwritable_output_directory(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    result = run_cli("simulate", "gray-scott", "--size", "16x16", "--steps", "2",
                     "--out", str(blocker / "sub"))
    assert result.returncode == 2
    assert "output directory" in result.stderr and len(result.stderr.splitlines()) == 1


def test_blow_up_is_reported_with_step(tmp_path):
    # dt = 1 is beyond the linearised limit at these parameters: only --unsafe runs it
    result = run_cli("simulate", "gray-scott", "--size", "16x16", "--steps", "400",
                     "-p", "F=5", "-p", "k=-3", "--dt", "1", "--unsafe",
                     "--out", str(tmp_path / "o"))
    assert result.returncode == 2
    assert "blow-up at step" in result.stderr
    assert not (tmp_path / "o" / "state.npz").exists()


@pytest.mark.slow
def test_float64_on_request(tmp_path):
    result = run_cli_process("simulate", "gray-scott", "--size", "16x16", "--steps", "5", "--x64",
                     "--out", str(tmp_path / "o"))
    assert result.returncode == 0, result.stderr
    assert np.load(tmp_path / "o" / "state.npz")["v"].dtype == np.float64
    assert json.loads((tmp_path / "o" / "run.json").read_text())["config"]["precision"] == "float64"


def test_mesh_run_takes_species_and_parameter_fields_from_the_ply(tmp_path):
    """A PLY vertex property named like a species is its initial value; one named like a
    parameter is a per-vertex field (unless -p sets it)."""
    from plyfile import PlyData, PlyElement

    n = 12
    ys, xs = np.mgrid[0:n, 0:n].astype(np.float32)
    v0 = (xs > n / 2).astype(np.float32) * 0.25
    verts = np.zeros(n * n, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("u", "f4"),
                                   ("v", "f4"), ("F", "f4")])
    verts["x"], verts["y"] = xs.ravel(), ys.ravel()
    verts["u"], verts["v"], verts["F"] = 1.0 - v0.ravel(), v0.ravel(), 0.0
    faces = []
    for i in range(n - 1):
        for j in range(n - 1):
            a = i * n + j
            faces += [([a, a + 1, a + n + 1],), ([a, a + n + 1, a + n],)]
    face = np.array(faces, dtype=[("vertex_indices", "i4", (3,))])
    PlyData([PlyElement.describe(verts, "vertex"),
             PlyElement.describe(face, "face")]).write(str(tmp_path / "sheet.ply"))
    out = tmp_path / "o"
    assert main(["simulate", "gray-scott", "--mesh", str(tmp_path / "sheet.ply"), "--steps", "1",
                 "--mesh-field", "all", "--dt", "0.01", "--out", str(out), "--quiet"]) == 0
    state = np.load(out / "state.npz")
    np.testing.assert_allclose(state["v"], v0.ravel(), atol=0.01)
    resolved = json.loads((out / "run.json").read_text())["resolved"]["params"]
    assert resolved["F"] == {"field": [n * n], "min": 0.0, "max": 0.0}
    assert resolved["k"] == pytest.approx(0.06)
    assert (out / "out.ply").is_file()


def test_parameter_field_from_npy_file(tmp_path):
    field = np.linspace(0.02, 0.06, 20, dtype=np.float32)[None, :].repeat(10, axis=0)
    np.save(tmp_path / "F.npy", field)
    out = tmp_path / "o"
    assert main(["simulate", "gray-scott", "--size", "10x20", "--steps", "3",
                 "-p", f"F={tmp_path / 'F.npy'}", "--out", str(out), "--quiet"]) == 0
    resolved = json.loads((out / "run.json").read_text())["resolved"]["params"]["F"]
    assert resolved["field"] == [10, 20] and resolved["min"] == pytest.approx(0.02)
    np.save(tmp_path / "bad.npy", np.zeros((3, 3)))
    result = run_cli("simulate", "gray-scott", "--size", "10x20", "-p",
                     f"F={tmp_path / 'bad.npy'}", "--out", str(tmp_path / "o2"))
    assert result.returncode == 2 and "the domain needs" in result.stderr
