"""Hostile input, round 3: work and memory bounds outside ``simulate`` (every command, every
file read), nothing created before input is checked, guarded conversions and paths, one line
per problem, and mesh fields that never silently replace a model's parameters or species.

Each refusal is one ``morphogen: error:`` line with exit status 2 and leaves no output behind.
"""

from __future__ import annotations

import json
import os
import sqlite3
import struct
import zlib

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.errors import MorphogenError
from morphogen.util.io import check_input_file, load_npy, read_text


def _refused(argv, capsys, *fragments) -> str:
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("morphogen: error: "), err
    for fragment in fragments:
        assert fragment in err, err
    return err


def _bomb_png(path, side=100_000) -> None:
    """A 70-byte PNG whose header claims ``side`` x ``side`` pixels (a decompression bomb)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    ihdr = struct.pack(">IIBBBBB", side, side, 8, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
                     + chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + chunk(b"IEND", b""))


def _npy_header(path, shape) -> None:
    """A ``.npy`` file whose header announces ``shape`` but holds 8 bytes of data."""
    header = repr({"descr": "<f4", "fortran_order": False, "shape": tuple(shape)})
    header += " " * (-(len(header) + 11) % 64) + "\n"
    path.write_bytes(b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode()
                     + b"\x00" * 8)


# --- 2. memory and work bounds -------------------------------------------------------------


@pytest.mark.parametrize("flags", [["--size", "200000"], ["--channels", "5000000"],
                                   ["--hidden", "100000000"]])
def test_train_refuses_a_run_that_cannot_fit_before_reading_anything(tmp_path, capsys, flags):
    out = tmp_path / "t"
    _refused(["train", "--target", "synthetic:dots", "--out", out, *flags], capsys, "memory")
    assert not out.exists()


@pytest.mark.parametrize("flags, fragment", [
    (["--population", "0"], "--population"), (["--population", "1"], "--population"),
    (["--population", "1000000000"], "--population"), (["--size", "100000"], "--size"),
    (["--size", "2000"], "memory"), (["--mode", "network", "--m-max", "1000000000"], "--m-max"),
    (["--tournament", "0"], "--tournament"), (["--generations", "0"], "--generations"),
    (["--dt", "1e-12"], "steps"),
])
def test_networks_refuses_counts_and_costs_before_creating_its_folder(tmp_path, capsys, flags,
                                                                      fragment):
    out = tmp_path / "n"
    _refused(["networks", "--out", out, "--archive", tmp_path / "a.sqlite", "--quiet", *flags],
             capsys, fragment)
    assert not out.exists() and not (tmp_path / "a.sqlite").exists()


@pytest.mark.parametrize("flags, fragment", [
    (["--population", "1000000000"], "population"), (["--population", "100000"], "population"),
    (["--population", "50000", "--generations", "100000000"], "steps"),
])
def test_evolve_refuses_a_huge_search_before_creating_the_archive(tmp_path, capsys, flags,
                                                                fragment):
    _refused(["evolve", "gray-scott", *flags, "--archive", tmp_path / "a.sqlite", "--out",
              tmp_path / "r"], capsys, fragment)
    assert not (tmp_path / "a.sqlite").exists() and not (tmp_path / "r").exists()


def test_a_parameter_field_announcing_1e12_numbers_is_refused_from_its_header(tmp_path,
                                                                            capsys):
    field = tmp_path / "F.npy"
    _npy_header(field, (1_000_000, 1_000_000))
    with pytest.raises(MorphogenError, match="announces shape"):
        load_npy(field, "field", 256)
    _refused(["simulate", "gray-scott", "--size", "16x16", "--steps", "1", "-p", f"F={field}",
              "--out", tmp_path / "o"], capsys, "announces shape")
    assert not (tmp_path / "o").exists()


def test_an_object_npy_is_refused_from_its_header(tmp_path):
    path = tmp_path / "o.npy"
    np.save(path, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(MorphogenError, match="not numbers"):
        load_npy(path, "field", 10)


@pytest.fixture()
def fifo(tmp_path):
    path = tmp_path / "pipe.json"
    os.mkfifo(path)
    return path


@pytest.mark.parametrize("special", ["/dev/zero", "/dev/urandom", "fifo", "dir"])
def test_devices_fifos_and_folders_are_never_read_as_files(tmp_path, capsys, special, request):
    path = {"fifo": lambda: request.getfixturevalue("fifo"), "dir": lambda: tmp_path,
            "/dev/zero": lambda: special, "/dev/urandom": lambda: special}[special]()
    with pytest.raises(MorphogenError):
        read_text(path, "model file")
    _refused(["simulate", "--config", path, "--out", tmp_path / "o"], capsys, "run file")
    _refused(["pipeline", "run", path, "--out", tmp_path / "p"], capsys, "pipeline file")
    _refused(["simulate", "gray-scott", "--mesh", path, "--out", tmp_path / "o"], capsys,
             "mesh file")
    assert not (tmp_path / "o").exists() and not (tmp_path / "p").exists()


def test_an_input_file_over_the_size_limit_is_refused_before_reading(tmp_path):
    path = tmp_path / "big.toml"
    with open(path, "wb") as fh:
        fh.truncate(1 << 20)  # sparse: costs no disk
    with pytest.raises(MorphogenError, match="more than the limit"):
        check_input_file(path, "model file", limit=1000)
    with pytest.raises(MorphogenError, match="more than the limit"):
        read_text(path, "model file", limit=1000)


# --- 3. nothing created before input is checked -----------------------------------------------

PIPELINE = """
[mesh]
shape = "petal"
edge = 0.3

[[stage]]
kind = "fields"
name = "first"
fields = {{ a = "x + 1" }}

[[stage]]
kind = "fields"
name = "second"
fields = {{ b = "{second}" }}
"""


@pytest.mark.parametrize("bad", [
    ('[mesh]\nfile = "missing.ply"\n[[stage]]\nkind = "fields"\nfields = { a = "1" }\n',
     "missing.ply"),
    ('[mesh]\nshape = "petal"\n[[stage]]\nkind = "simulate"\nmodel = "gray-scott"\n'
     'dt = "abc"\n', "dt must be a finite number"),
    ('[mesh]\nshape = "petal"\n[[stage]]\nkind = "simulate"\nmodel = "gray-scott"\n'
     'steps = 1.5\n', "steps must be an integer"),
    ('[mesh]\nshape = "petal"\n[[stage]]\nkind = "positional"\ndecay = "abc"\n', "decay"),
    ('[mesh]\nshape = "petal"\n[[stage]]\nkind = "points"\ncount = "many"\n', "count"),
    ('[mesh]\nshape = "petal"\n[[stage]]\nkind = "veins"\nseeds = "base"\ngamma = "x"\n',
     "gamma"),
    ('[mesh]\nshape = "petal"\n[[stage]]\nkind = "simulate"\nmodel = "gray-scott"\n'
     'params = "F"\n', "params must be a table"),
    ('[mesh]\nshape = "petal"\n[[stage]]\nkind = "simulate"\n', "needs model"),
    ('[mesh]\nshape = "petal"\nstage = [1, 2]\n', "[[stage]] table"),
])
def test_pipeline_checks_mesh_and_stages_before_creating_anything(tmp_path, capsys, bad):
    text, fragment = bad
    (tmp_path / "p.toml").write_text(text)
    out = tmp_path / "run"
    _refused(["pipeline", "run", tmp_path / "p.toml", "--out", out, "--quiet"], capsys, fragment)
    assert not out.exists()


def test_a_failed_stage_marks_the_run_partial_and_resume_uses_the_mark(tmp_path, capsys):
    file, out = tmp_path / "p.toml", tmp_path / "run"
    file.write_text(PIPELINE.format(second="nonesuch + 1"))
    _refused(["pipeline", "run", file, "--out", out, "--quiet"], capsys, "nonesuch")
    record = json.loads((out / "pipeline.json").read_text())
    assert record["status"] == "partial" and record["failed"]["stage"] == 2
    assert [s["dir"] for s in record["stages"]] == ["01-first"]
    assert not (out / "02-second").exists() and not (out / "final.ply").exists()
    file.write_text(PIPELINE.format(second="a * 2"))
    assert main(["pipeline", "run", str(file), "--out", str(out), "--resume", "--quiet"]) == 0
    record = json.loads((out / "pipeline.json").read_text())
    assert record["status"] == "done" and "failed" not in record
    assert record["stages"][0].get("resumed") and not record["stages"][1].get("resumed")


def test_a_first_stage_failure_in_a_new_folder_leaves_nothing(tmp_path, capsys):
    file, out = tmp_path / "p.toml", tmp_path / "new" / "run"
    file.write_text(PIPELINE.format(second="1").replace('"x + 1"', '"nonesuch"'))
    _refused(["pipeline", "run", file, "--out", out, "--quiet"], capsys, "nonesuch")
    assert not out.exists()


def test_resume_without_the_mark_recomputes(tmp_path, capsys):
    file, out = tmp_path / "p.toml", tmp_path / "run"
    file.write_text(PIPELINE.format(second="a * 2"))
    assert main(["pipeline", "run", str(file), "--out", str(out), "--quiet"]) == 0
    (out / "pipeline.json").unlink()
    assert main(["pipeline", "run", str(file), "--out", str(out), "--resume", "--quiet"]) == 0
    record = json.loads((out / "pipeline.json").read_text())
    assert not any(s.get("resumed") for s in record["stages"])


@pytest.mark.parametrize("flags, fragment", [
    (["--elitism", "50"], "elitism"), (["--tournament", "1"], "tournament"),
    (["--tournament", "-3"], "tournament"),
])
def test_evolve_checks_the_strategy_before_creating_the_archive(tmp_path, capsys, flags,
                                                               fragment):
    _refused(["evolve", "gray-scott", "--population", "4", "--archive", tmp_path / "a.sqlite",
              "--out", tmp_path / "r", *flags], capsys, fragment)
    assert not (tmp_path / "a.sqlite").exists() and not (tmp_path / "r").exists()


def test_atlas_leaves_no_folder_when_its_run_is_refused(tmp_path, capsys):
    out = tmp_path / "atlas"
    _refused(["atlas", "gray-scott", "--x", "F=0.02:0.03:2", "--y", "k=0.05:0.06:2", "--size",
              "16x16", "--steps", "2", "--dt", "100", "--out", out], capsys, "stability")
    assert not out.exists()


def test_fit_leaves_no_folder_when_its_target_is_refused(tmp_path, capsys):
    target, out = tmp_path / "t.png", tmp_path / "fit"
    _bomb_png(target)
    _refused(["fit", "gray-scott", "--target", target, "--gene", "F=0.03:0.06", "--out", out],
             capsys, "decode")
    assert not out.exists()


def test_an_out_that_is_a_symlink_is_written_through_and_kept(tmp_path, capsys):
    real, link = tmp_path / "real", tmp_path / "link"
    args = ["simulate", "gray-scott", "--size", "16x16", "--steps", "2", "--quiet"]
    assert main([*args, "--out", str(real)]) == 0
    link.symlink_to(real)
    assert main([*args, "--out", str(link), "--seed", "3"]) == 0
    assert link.is_symlink() and (link / "run.json").is_file()
    assert json.loads((real / "run.json").read_text())["config"]["seed"] == 3
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "real"]  # no hidden .old
    (tmp_path / "broken").symlink_to(tmp_path / "nowhere")
    _refused([*args, "--out", tmp_path / "broken"], capsys, "broken symbolic link")


# --- 5. unguarded conversions and paths -----------------------------------------------------


def test_a_decompression_bomb_is_refused_by_every_command_that_reads_an_image(tmp_path,
                                                                             capsys):
    bomb = tmp_path / "bomb.png"
    _bomb_png(bomb)
    _refused(["simulate", "gray-scott", "--size", "16x16", "--steps", "1", "--init", bomb,
              "--out", tmp_path / "o"], capsys, "pixels")
    _refused(["evolve", "gray-scott", "--fitness", "target", "--target", bomb, "--population",
              "4", "--archive", tmp_path / "a.sqlite"], capsys, "pixels")
    _refused(["train", "--target", bomb, "--out", tmp_path / "t"], capsys, "pixels")
    assert not any(tmp_path.glob("[oat]*"))


def test_an_image_no_decoder_reads_is_one_line(tmp_path, capsys):
    junk = tmp_path / "junk.png"
    junk.write_bytes(b"not an image at all\n" * 10)
    _refused(["simulate", "gray-scott", "--size", "16x16", "--steps", "1", "--init", junk,
              "--out", tmp_path / "o"], capsys, "not an image")
    _refused(["train", "--target", junk, "--out", tmp_path / "t"], capsys, "not an image")


def test_networks_export_makes_its_folder_and_refuses_a_file_in_the_way(tmp_path, capsys):
    out = tmp_path / "new" / "deeper" / "table2.ant"
    assert main(["networks", "export", "table2", "--out", str(out)]) == 0
    assert out.is_file()
    (tmp_path / "file").write_text("x")
    _refused(["networks", "export", "table2", "--out", tmp_path / "file" / "t.ant"], capsys)


@pytest.mark.parametrize("argv", [
    ["simulate", "gray-scott", "--size", "16x16", "--steps", "1"],
    ["networks", "export", "table2"],
    ["networks", "--population", "4", "--generations", "1"],
    ["atlas", "gray-scott", "--x", "F=0.02:0.03:2", "--y", "k=0.05:0.06:2", "--size", "16x16",
     "--steps", "2"],
])
def test_a_300_character_out_name_is_one_line(tmp_path, capsys, argv):
    name = "n" * 300 + (".ant" if "export" in argv else "")
    _refused([*argv, "--out", tmp_path / name], capsys, "bytes long")
    assert list(tmp_path.iterdir()) == []


@pytest.fixture()
def damaged_row(tmp_path):
    """An evolve run in an archive, ready to have one stored row made hostile."""
    archive = tmp_path / "a.sqlite"
    assert main(["evolve", "gray-scott", "--population", "4", "--generations", "1", "--size",
                 "16", "--steps", "5", "--archive", str(archive), "--out",
                 str(tmp_path / "r"), "--quiet"]) == 0
    return archive


@pytest.mark.parametrize("sql", [
    "UPDATE individuals SET genome = 'not json'",
    "UPDATE individuals SET genome = '{\"a\": 1}'",
    "UPDATE individuals SET genome = '[\"x\", 1]'",
    "UPDATE individuals SET fitness = 'high'",
    "UPDATE generations SET mean = 'abc'",
    "UPDATE generations SET best = 'abc'",
    "UPDATE generations SET seconds = 'slow'",
])
def test_hostile_archive_rows_are_one_line(damaged_row, capsys, sql):
    with sqlite3.connect(damaged_row) as db:
        db.execute(sql)
    capsys.readouterr()
    run = str(damaged_row.parent / "r")
    err = _refused(["runs", "show", run, "--archive", damaged_row], capsys, "damaged row")
    assert "not a number" in err or "list of numbers" in err
    _refused(["evolve", "--resume", run, "--generations", "2", "--archive", damaged_row],
             capsys, "damaged")
    if "generations" in sql and "seconds" not in sql and "mean" not in sql:
        _refused(["runs", "--archive", damaged_row], capsys, "damaged row")


@pytest.mark.parametrize("text", ["[1, 2]", '{"id": [1], "archive": {}}', "[" * 100_000,
                                  '"id"', "\xff\xfe"])
def test_a_hostile_run_configuration_is_one_line(tmp_path, capsys, text):
    run = tmp_path / "r"
    run.mkdir()
    (run / "config.json").write_bytes(text.encode("latin-1"))
    _refused(["evolve", "--resume", run, "--archive", tmp_path / "a.sqlite"], capsys)
    assert not (tmp_path / "a.sqlite").exists()


# --- 6. one line means one line -------------------------------------------------------------


def test_a_library_warning_before_an_error_does_not_make_it_two_lines(tmp_path, capsys):
    _refused(["simulate", "gray-scott", "--size", "16x16", "--steps", "1", "-p", "F=1e300",
              "--out", tmp_path / "o"], capsys)


def test_library_warnings_of_a_successful_command_are_one_line_each(capsys, monkeypatch):
    import argparse
    import warnings

    def noisy(args):
        warnings.simplefilter("always")  # whatever filters the test run was given
        for _ in range(2):
            warnings.warn("overflow encountered\nin cast", RuntimeWarning, stacklevel=1)
        return 0

    args = argparse.Namespace(func=noisy)
    monkeypatch.setattr("morphogen.cli.main.build_parser", lambda: _Fixed(args))
    assert main(["models"]) == 0
    err = capsys.readouterr().err
    assert err == "morphogen: warning: overflow encountered in cast\n", err


QUAD = """ply
format ascii 1.0
element vertex 4
property float x
property float y
property float z
element face 1
property list uchar int vertex_indices
end_header
0 0 0
1 0 0
1 1 0
0 1 0
4 0 1 2 3
"""


def test_a_split_polygon_warning_is_one_line_and_gives_way_to_an_error(tmp_path, capsys):
    mesh = tmp_path / "quad.ply"
    mesh.write_text(QUAD)
    run = ["simulate", "gray-scott", "--mesh", str(mesh), "--steps", "1", "--dt", "0.01",
           "--quiet"]
    _refused([*run, "--out", tmp_path / "a"], capsys, "blob count")  # warning held back
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("always", UserWarning)  # whatever the test run's filters
        assert main([*run, "--init", "uniform", "--out", str(tmp_path / "b")]) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("morphogen: warning: ") and "split" in err


class _Fixed:
    def __init__(self, args):
        self.args = args

    def parse_args(self, argv):
        return self.args


# --- 8. mesh fields never silently replace parameters or species -----------------------------


@pytest.fixture()
def sheet(tmp_path):
    """A flat 8x8 sheet with fields ``F`` (a gray-scott parameter), ``v`` (a species) and
    ``r`` (neither)."""
    from plyfile import PlyData, PlyElement

    n = 8
    ys, xs = np.mgrid[0:n, 0:n].astype(np.float32)
    verts = np.zeros(n * n, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("v", "f4"),
                                   ("F", "f4"), ("r", "f4")])
    verts["x"], verts["y"] = xs.ravel(), ys.ravel()
    verts["v"], verts["F"], verts["r"] = 0.25, 0.0, 7.0
    faces = [([i * n + j, i * n + j + 1, i * n + j + n + 1],) for i in range(n - 1)
             for j in range(n - 1)]
    faces += [([i * n + j, i * n + j + n + 1, i * n + j + n],) for i in range(n - 1)
              for j in range(n - 1)]
    face = np.array(faces, dtype=[("vertex_indices", "i4", (3,))])
    path = tmp_path / "sheet.ply"
    PlyData([PlyElement.describe(verts, "vertex"), PlyElement.describe(face, "face")]).write(
        str(path))
    return path


RUN = ["simulate", "gray-scott", "--steps", "1", "--dt", "0.01", "--quiet"]


@pytest.mark.parametrize("extra, fragment", [
    ([], "field 'v'"), (["--init", "uniform"], "field 'F'"), (["-p", "F=0.03"], "field 'v'"),
    (["--mesh-field", "v"], "field 'F'"), (["--mesh-field", "r"], "no field 'r'"),
    (["--mesh-field", "all", "--mesh-field", "none"], "contradict"),
])
def test_a_field_named_like_a_parameter_or_species_must_be_asked_for(sheet, tmp_path, capsys,
                                                                     extra, fragment):
    out = tmp_path / "o"
    err = _refused([*RUN, "--mesh", sheet, "--out", out, *extra], capsys, fragment)
    assert "--mesh-field" in err
    assert not out.exists()


@pytest.mark.parametrize("extra, uses_f, uses_v", [
    (["--mesh-field", "all"], True, True), (["--mesh-field", "none"], False, False),
    (["--mesh-field", "F", "--mesh-field", "v"], True, True),
    (["--mesh-field", "v", "-p", "F=0.03"], False, True),
    (["--mesh-field", "F", "--init", "uniform"], True, False),
])
def test_fields_asked_for_are_used_and_no_others(sheet, tmp_path, extra, uses_f, uses_v):
    out = tmp_path / "o"
    assert main([*RUN, "--mesh", str(sheet), "--out", str(out), *extra]) == 0
    config = json.loads((out / "run.json").read_text())
    resolved = config["resolved"]["params"]
    assert isinstance(resolved["F"], dict) == uses_f
    v = np.load(out / "state.npz")["v"]
    assert (abs(float(v.mean()) - 0.25) < 0.01) == uses_v
    assert config["config"]["mesh_fields"] == [x for x in extra[1::2] if "=" not in x
                                               and x != "uniform"]


def test_apply_fields_applies_only_the_names_given(sheet):
    from morphogen.domains.ply import apply_fields, field_clashes, load_mesh
    from morphogen.models.registry import load_model

    model, mesh = load_model("gray-scott"), load_mesh(sheet)
    assert field_clashes(model, mesh) == ["v", "F"]
    u0 = np.zeros((2, mesh.n_vertices), np.float32)
    values = {"F": 0.03}
    u, params = apply_fields(model, mesh, u0, values, names=["F"])
    assert not u.any() and params["F"].shape == (mesh.n_vertices,)
    u, params = apply_fields(model, mesh, u0, values, names=[])
    assert not u.any() and params == values


def test_a_pipeline_uses_a_mesh_files_fields_only_where_a_stage_names_them(sheet, tmp_path):
    from morphogen.flowers.pipeline import run_pipeline

    simulate = {"kind": "simulate", "model": "gray-scott", "steps": 1, "dt": 0.01,
                "init": "uniform"}

    def final_v(stages: list, name: str) -> float:
        spec = {"mesh": {"file": str(sheet)}, "base": tmp_path, "stage": stages}
        return float(run_pipeline(spec, tmp_path / name, pictures=False).fields["v"].mean())

    assert final_v([simulate], "plain") == pytest.approx(0.0, abs=1e-3)  # not the start ...
    copy = {"kind": "fields", "fields": {"v": "v"}}  # ... unless a stage makes it a field
    assert final_v([copy, simulate], "asked") == pytest.approx(0.25, abs=1e-2)
