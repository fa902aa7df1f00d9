"""Bad input, as a hostile or careless user gives it: one line, exit status 2, nothing on disk.

Every case is refused before the first step (most before the domain is allocated or anything
compiled), so the table runs in seconds.
"""

from __future__ import annotations

import json
import zipfile
from functools import partial
from pathlib import Path

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.errors import MorphogenError
from morphogen.models.text.equations import parse_model
from morphogen.util.guard import LIMITS, check_memory, check_steps

MODEL = """\
species = ["u", "v"]
[parameters]
a = 0.1
b = 0.9
[equations]
u = "a - u + u**2*v + 1.0*lap(u)"
v = "b - u**2*v + 40.0*lap(v)"
"""


def _npz(tmp: Path, kind: str) -> str:
    path = tmp / f"{kind}.npz"
    good = {"u": np.ones((8, 8)), "v": np.ones((8, 8))}
    if kind == "truncated":
        np.savez(path, **good)
        path.write_bytes(path.read_bytes()[:200])
    elif kind == "not-a-zip":
        path.write_bytes(b"hello, not a zip" * 10)
    elif kind == "not-an-array":
        with zipfile.ZipFile(path, "w") as z:
            z.writestr("u.npy", b"plain text")
            z.writestr("v.npy", b"plain text")
    elif kind == "strings":
        np.savez(path, u=np.full((8, 8), "x"), v=np.full((8, 8), "y"))
    elif kind == "objects":
        obj = np.empty((8, 8), object)
        np.savez(path, u=obj, v=obj)
    elif kind == "nan":
        np.savez(path, u=np.full((8, 8), np.nan), v=np.ones((8, 8)))
    elif kind == "shape":
        np.savez(path, u=np.ones((9, 8)), v=np.ones((9, 8)))
    return str(path)


def _run_file(tmp: Path, config: dict | bytes) -> str:
    path = tmp / "run.json"
    if isinstance(config, bytes):
        path.write_bytes(config)
    else:
        path.write_text(json.dumps({"config": {"model": "schnakenberg", "size": [8, 8],
                                               "steps": 2, **config}}))
    return str(path)


def _model_file(tmp: Path, text: str) -> str:
    path = tmp / "m.toml"
    path.write_text(text, encoding="utf-8")
    return str(path)


def _many_species(n: int) -> str:
    names = [f"s{i}" for i in range(n)]
    eqs = "\n".join(f'{s} = "-{s}"' for s in names)
    return f"species = {json.dumps(names)}\n[equations]\n{eqs}\n"


SIM = ["simulate", "schnakenberg", "--size", "8x8", "--steps", "2", "--quiet"]

CASES = {
    "size 100000x100000": lambda t: ["--size", "100000x100000"],
    "size 40000x40000": lambda t: ["--size", "40000x40000"],
    "size 2000^3": lambda t: ["--size", "2000x2000x2000"],
    "size huge integer": lambda t: ["--size", "9" * 40 + "x8"],
    "seed negative": lambda t: ["--seed", "-1"],
    "seed beyond 64 bits": lambda t: ["--seed", str(2**64)],
    "init-opt count=abc": lambda t: ["--init", "seeds", "--init-opt", "count=abc"],
    "init-opt count=10**12": lambda t: ["--init", "seeds", "--init-opt", "count=10**12"],
    "init-opt count 1e12": lambda t: ["--init", "seeds", "--init-opt", "count=1000000000000"],
    **{f"npz {k}": partial(lambda k, t: ["--init", _npz(t, k)], k)
       for k in ("truncated", "not-a-zip", "not-an-array", "strings", "objects", "nan",
                 "shape")},
    "config binary": lambda t: ["--config", _run_file(t, bytes(range(256)))],
    **{f"config {k}={v!r}": partial(lambda k, v, t: ["--config", _run_file(t, {k: v})], k, v)
       for k, v in (("size", "a"), ("size", 5), ("steps", "ten"), ("dt", "big"),
                    ("params", [1, 2]), ("model", None), ("model", 5), ("model_source", 5),
                    ("init_options", [1]), ("noise", "x"), ("steps", 2.5), ("clamp", "x"),
                    ("fps", 0), ("animation", "avi"), ("seed", -3), ("dt", 1e400))},
    "model t_end inf": lambda t: [_model_file(t, "t_end = inf\n" + MODEL)],
    "model t_end 1e300": lambda t: [_model_file(t, "t_end = 1e300\n" + MODEL), "--size",
                                    "8x8"],
    "model dt inf": lambda t: [_model_file(t, "dt = inf\n" + MODEL)],
    "model 300 species": lambda t: [_model_file(t, _many_species(300))],
    "model 2000 species": lambda t: [_model_file(t, _many_species(2000))],
    "model fullwidth u": lambda t: [_model_file(t, MODEL.replace("u**2*v + 1", "\uff55**2*v + 1"))],
    "steps beyond int64": lambda t: ["--steps", str(2**70)],
    "dt 1e-300 time 1": lambda t: ["schnakenberg", "--dt", "1e-300", "--time", "1", "--unsafe"],
    "time 1e308": lambda t: ["schnakenberg", "--time", "1e308"],
    "negative diffusion": lambda t: ["-p", "Du=-1"],
    "clamp x": lambda t: ["--clamp", "x"],
    "cmap unknown": lambda t: ["--cmap", "no_such_cmap"],
    "cmap bad ramp": lambda t: ["--cmap", "#zzz,#fff"],
    "vmin nan": lambda t: ["--vmin", "nan"],
    "vmin above vmax": lambda t: ["--vmin", "5", "--vmax", "1"],
    "threshold nan": lambda t: ["--threshold", "nan"],
    "param inf": lambda t: ["-p", "a=inf"],
}


def _argv(case: str, tmp: Path, out: Path) -> list[str]:
    extra = CASES[case](tmp)
    if extra[0] == "--config":
        return ["simulate", *extra, "--quiet", "--out", str(out)]
    if not extra[0].startswith("-"):
        model, *rest = extra
        return ["simulate", model, "--size", "8x8", "--quiet", "--out", str(out), *rest]
    return [*SIM, "--out", str(out), *extra]


def _main(argv: list[str]) -> int:
    """``main``, with argparse's exit (status 2 after its one line) as a return code."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


@pytest.mark.parametrize("case", sorted(CASES))
def test_refused_with_one_line_and_nothing_on_disk(case, tmp_path, capsys):
    inputs = tmp_path / "in"
    inputs.mkdir()
    out = tmp_path / "deep" / "er" / "out"
    argv = _argv(case, inputs, out)
    before = sorted(inputs.iterdir())
    code = _main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("morphogen"), err
    assert "error: " in err and "Traceback" not in err
    assert not (tmp_path / "deep").exists()
    assert sorted(inputs.iterdir()) == before


def test_bad_cmap_over_an_existing_run_keeps_it_whole(tmp_path, capsys):
    out = tmp_path / "run"
    assert main([*SIM, "--out", str(out)]) == 0
    files = {p.name: p.read_bytes() for p in out.iterdir()}
    assert set(files) >= {"state.npz", "final.png", "run.json"}
    assert main([*SIM, "--seed", "7", "--cmap", "no_such_cmap", "--out", str(out)]) == 2
    assert {p.name: p.read_bytes() for p in out.iterdir()} == files
    assert main([*SIM, "--seed", "7", "--out", str(out)]) == 0
    new = {p.name: p.read_bytes() for p in out.iterdir()}
    assert set(new) == set(files) and new["state.npz"] != files["state.npz"]
    assert json.loads(new["run.json"])["config"]["seed"] == 7
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_a_directory_that_is_not_a_run_is_not_replaced(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("mine")
    assert main([*SIM, "--out", str(tmp_path)]) == 2
    assert [p.name for p in tmp_path.iterdir()] == ["notes.txt"]
    assert "not a run" in capsys.readouterr().err


def test_model_file_with_byte_order_mark_loads(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + MODEL.encode())
    assert main([*SIM[:1], str(path), *SIM[2:], "--out", str(tmp_path / "o")]) == 0
    assert (tmp_path / "o" / "run.json").is_file()


def test_fullwidth_identifier_is_refused_at_its_column():
    text = MODEL.replace('u = "a - u', 'u = "a - \uff55')
    with pytest.raises(MorphogenError, match="U\\+FF55") as info:
        parse_model(text)
    assert "line 6" in str(info.value) and "\n" not in str(info.value)


def test_guard_estimates_are_the_formula():
    # 1000 x 1000 cells, 2 species, float32: (1 snapshot + 8 working copies) x 4 bytes.
    assert check_memory(10**6, 2) == 2 * 10**6 * 9 * 4
    # 2.5e8 cells x 2 species x 9 copies x 4 bytes = 1.8e10 bytes = 16.8 GiB.
    with pytest.raises(MorphogenError, match=r"about 16\.8 GiB.*limit of 16 GiB"):
        check_memory(250_000_000, 2)
    assert check_steps(10.0, 100, 2) == 10
    with pytest.raises(MorphogenError, match="limit of 1e\\+09"):
        check_steps(LIMITS.steps + 1, 1, 1)
    with pytest.raises(MorphogenError, match=r"1\.28e\+14 cell updates"):
        check_steps(10**6, 64 * 10**6, 2)


def test_reaching_the_model_ceiling_is_a_blow_up(tmp_path, capsys):
    # Turing's clamp [0, 1e6] guards overflow; rho=5 drives v into it within 2000 steps of
    # dt = 0.16 (on 32x32; a 16x16 grid has too few unstable modes to leave the ground state)
    out = tmp_path / "o"
    argv = ["simulate", "turing", "--size", "32x32", "--steps", "2000", "--dt", "0.16",
            "-p", "rho=5", "--unsafe", "--quiet", "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "reached the model's ceiling 1e+06" in err and err.count("\n") == 1
    assert not out.exists()


@pytest.mark.parametrize("faces", [10**8, 10**9])
@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian"])
def test_ply_declaring_more_faces_than_its_bytes_is_refused_at_once(tmp_path, monkeypatch,
                                                                     faces, fmt):
    import plyfile

    from morphogen.domains.ply import load_mesh

    header = (f"ply\nformat {fmt} 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
              f"property float z\nelement face {faces}\nproperty list uchar int vertex_indices\n"
              "end_header\n")
    body = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n" if fmt == "ascii" else (
        np.eye(3, dtype="<f4").tobytes() + bytes([3]) + np.arange(3, dtype="<i4").tobytes())
    path = tmp_path / "big.ply"
    path.write_bytes(header.encode() + (body.encode() if isinstance(body, str) else body))
    # refused from the header: the body is never handed to the parser
    monkeypatch.setattr(plyfile.PlyData, "read", lambda *a, **k: pytest.fail("body parsed"))
    with pytest.raises(MorphogenError, match=f"declares {faces} face element"):
        load_mesh(path)


def test_ply_header_check_passes_an_exact_file(tmp_path):
    from morphogen.domains.ply import check_declared_sizes

    # Binary: 3 vertices x 12 bytes + 1 face x 1 count byte = 37 bytes at least.
    header = (b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
              b"property float y\nproperty float z\nelement face 1\n"
              b"property list uchar int vertex_indices\nend_header\n")
    path = tmp_path / "m.ply"
    path.write_bytes(header + bytes(37))
    check_declared_sizes(path)
    path.write_bytes(header + bytes(36))
    with pytest.raises(MorphogenError, match="need at least 37 bytes.*only 36 bytes"):
        check_declared_sizes(path)


@pytest.mark.parametrize("argv", [
    ["evolve", "gray-scott", "--size", "100000x100000", "--generations", "1"],
    ["evolve", "gray-scott", "--seed", "-1", "--generations", "1"],
    ["atlas", "gray-scott", "--x", "F=0.01:0.05:2", "--y", "k=0.05:0.07:2", "--seed",
     str(2**64)],
    ["simulate", "gray-scott", "--size", "8x8x8x8"],
])
def test_other_commands_share_the_size_and_seed_checks(argv, tmp_path, capsys):
    out = tmp_path / "o"
    assert _main([*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert not out.exists()
