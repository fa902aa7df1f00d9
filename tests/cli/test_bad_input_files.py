"""Damaged or hostile files as a user (or an attacker) gives them: a neural model file to
``simulate``, a training checkpoint to ``train --resume``, an Antimony network that tries to
``import`` another file. Each is refused with one line and exit status 2, nothing is written,
and no other file is read."""

from __future__ import annotations

import json
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.errors import MorphogenError
from morphogen.models.neural_library import FOLDER
from morphogen.models.text.sbml import read_antimony, refuse_imports
from tests.paths import EXAMPLES

RULE = FOLDER / "dots.npz"


def _refused(argv: list[str], capsys) -> str:
    """Run the command line; it must answer with exit 2 and one ``morphogen: error:`` line."""
    try:
        code = main(argv)
    except SystemExit as exc:
        code = int(exc.code)
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("morphogen: error: "), err
    assert "Traceback" not in err
    return err


# --- neural model files -------------------------------------------------------------------

def _rule() -> tuple[dict[str, np.ndarray], dict]:
    with np.load(RULE) as data:
        arrays = {k: data[k] for k in data.files}
    return arrays, json.loads(str(arrays["config"]))


def _with_info(**changes) -> dict[str, np.ndarray]:
    arrays, info = _rule()
    info.update(changes)
    info = {k: v for k, v in info.items() if v is not _DROP}
    return {**arrays, "config": np.array(json.dumps(info))}


def _with_array(name: str, value) -> dict[str, np.ndarray]:
    arrays, _ = _rule()
    if value is _DROP:
        arrays.pop(name)
    else:
        arrays[name] = value
    return arrays


_DROP = object()
_, _INFO = _rule()


def _announcing(shape: tuple[int, ...], version: int = 1) -> bytes:
    """An ``.npz`` whose ``W0`` array header announces ``shape`` float32 values but whose entry
    holds 100 bytes (numpy would allocate the announced size before reading)."""
    import io

    from numpy.lib import format as npy

    header = io.BytesIO()
    write = npy.write_array_header_1_0 if version == 1 else npy.write_array_header_2_0
    write(header, {"descr": "<f4", "fortran_order": False, "shape": shape})
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:
        z.writestr("W0.npy", header.getvalue() + bytes(100))
        z.writestr("config.npy", b"")
    return out.getvalue()

NEURAL_FILES = {
    "truncated zip": lambda: RULE.read_bytes()[:400],
    "half the file": lambda: RULE.read_bytes()[: RULE.stat().st_size // 2],
    "not a zip": lambda: b"PK but not really" * 20,
    "empty file": lambda: b"",
    "a pickle": lambda: b"\x80\x04\x95" + b"\x00" * 40,
    "config is a list": lambda: {**_rule()[0], "config": np.array("[1, 2]")},
    "config is a number": lambda: {**_rule()[0], "config": np.array("5")},
    "config not JSON": lambda: {**_rule()[0], "config": np.array("{not json")},
    "config nested deeply": lambda: {**_rule()[0], "config": np.array("[" * 100_000)},
    "config an array": lambda: {**_rule()[0], "config": np.zeros(3)},
    "config bytes": lambda: {**_rule()[0], "config": np.array(b"{}")},
    "no config entry": lambda: _with_array("config", _DROP),
    "missing config key": lambda: _with_info(config=_DROP),
    "shape config a list": lambda: _with_info(config=[12, 64]),
    "channels a string": lambda: _with_info(config={**_INFO["config"], "channels": "12"}),
    "channels a float": lambda: _with_info(config={**_INFO["config"], "channels": 12.5}),
    "channels 2": lambda: _with_info(config={**_INFO["config"], "channels": 2}),
    "channels 1e12": lambda: _with_info(config={**_INFO["config"], "channels": 10**12}),
    "hidden negative": lambda: _with_info(config={**_INFO["config"], "hidden": -4}),
    "learn_diffusion a string": lambda: _with_info(
        config={**_INFO["config"], "learn_diffusion": "yes"}),
    "unknown shape field": lambda: _with_info(config={**_INFO["config"], "layers": 3}),
    "version a string": lambda: _with_info(version="abc"),
    "version a float": lambda: _with_info(version=1.5),
    "version true": lambda: _with_info(version=True),
    "version 0": lambda: _with_info(version=0),
    "version from the future": lambda: _with_info(version=99),
    "format missing": lambda: _with_info(format=_DROP),
    "format other": lambda: _with_info(format="morphogen-run/1"),
    "metadata a list": lambda: _with_info(metadata=[1, 2]),
    "metadata a string": lambda: _with_info(metadata="dots"),
    "metadata target a number": lambda: _with_info(metadata={"target": 5}),
    "unknown top-level key": lambda: _with_info(extra=1),
    "weights strings": lambda: _with_array("W0", np.full((12, 64), "x")),
    "weights complex": lambda: _with_array("W0", np.ones((12, 64), np.complex64)),
    "weights bool": lambda: _with_array("W1", np.ones((64, 12), bool)),
    "weights bytes": lambda: _with_array("b0", np.full(64, b"a")),
    "weights nan": lambda: _with_array("b0", np.full(64, np.nan, np.float32)),
    "weights wrong shape": lambda: _with_array("W1", np.ones((12, 64), np.float32)),
    "weights scalar": lambda: _with_array("W0", np.float32(1.0)),
    "weight missing": lambda: _with_array("W1", _DROP),
    "unexpected entry": lambda: _with_array("junk", np.zeros(3)),
    "header announces 1e12 values": lambda: _announcing((10**6, 10**6)),
    "header 2.0 announces 1e12 values": lambda: _announcing((10**12,), version=2),
}


def _write_neural(path: Path, content) -> None:
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        np.savez(path, **content)


@pytest.mark.parametrize("case", sorted(NEURAL_FILES))
def test_simulate_refuses_a_damaged_neural_model(case, tmp_path, capsys):
    rule = tmp_path / "rule.npz"
    _write_neural(rule, NEURAL_FILES[case]())
    out = tmp_path / "out"
    _refused(["simulate", str(rule), "--size", "16x16", "--steps", "2", "--quiet", "--out",
              str(out)], capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rule.npz"]


def test_a_zip_with_a_corrupt_member_is_one_line(tmp_path, capsys):
    rule = tmp_path / "rule.npz"
    with zipfile.ZipFile(rule, "w") as z:
        z.writestr("W0.npy", b"\x93NUMPY\x01\x00" + b"{'descr': '<f4', 'fortran_order': False, "
                   b"'shape': (12, 64), }".ljust(118) + b"\n")
        z.writestr("config.npy", b"garbage")
    err = _refused(["simulate", str(rule), "--size", "16x16", "--steps", "2", "--quiet"],
                   capsys)
    assert str(rule) in err


def test_the_shipped_rules_still_load():
    from morphogen.models.neural import read_neural_file
    from morphogen.models.neural_library import rule_names

    for name in rule_names():
        config, weights, metadata = read_neural_file(FOLDER / f"{name}.npz")
        assert set(weights) >= {"W0", "b0", "W1"} and isinstance(metadata, dict)


def test_a_file_written_by_save_neural_model_round_trips(tmp_path):
    from morphogen.models.neural import (
        NeuralConfig,
        read_neural_file,
        save_neural_model,
    )

    arrays, _ = _rule()
    config = NeuralConfig(12, 64)
    weights = {k: arrays[k] for k in ("W0", "b0", "W1")}
    path = save_neural_model(tmp_path / "m.npz", config, weights, {"target": "x.png", "n": 3})
    back, read, metadata = read_neural_file(path)
    assert back == config and metadata["target"] == "x.png" and metadata["n"] == 3
    for k, v in weights.items():
        np.testing.assert_array_equal(read[k], v)


# --- training checkpoints -----------------------------------------------------------------

@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory) -> Path:
    """A real (tiny) training run directory at iteration 0, written once for the module."""
    from morphogen.learn.session import new_run, save_checkpoint
    from morphogen.learn.train import preset

    config = preset("cpu", size=16, pool_size=4, channels=4, hidden=4, iterations=1,
                    features="random")
    run = new_run(config, np.full((16, 16, 3), 0.5, np.float32), "synthetic:dots")
    directory = tmp_path_factory.mktemp("train")
    save_checkpoint(directory, run)
    return directory


def _meta(arrays, **changes):
    meta = json.loads(str(arrays["meta"]))
    meta.update(changes)
    return {**arrays, "meta": np.array(json.dumps(meta))}


def _settings(arrays, **changes):
    meta = json.loads(str(arrays["meta"]))
    return _meta(arrays, config={**meta["config"], **changes})


def _drop(arrays, name):
    return {k: v for k, v in arrays.items() if k != name}


CHECKPOINTS = {
    "junk bytes": lambda a, raw: b"junk" * 64,
    "truncated": lambda a, raw: raw[: len(raw) // 2],
    "empty": lambda a, raw: b"",
    "header announces 1e12 values": lambda a, raw: _announcing((10**6, 10**6)),
    "no meta": lambda a, raw: _drop(a, "meta"),
    "meta not JSON": lambda a, raw: {**a, "meta": np.array("{oops")},
    "meta a list": lambda a, raw: {**a, "meta": np.array("[1]")},
    "meta an array": lambda a, raw: {**a, "meta": np.zeros(2)},
    "settings a list": lambda a, raw: _meta(a, config=[1, 2]),
    "settings missing": lambda a, raw: _meta(a, config=None),
    "size a string": lambda a, raw: _settings(a, size="16"),
    "size a float": lambda a, raw: _settings(a, size=16.5),
    "size huge": lambda a, raw: _settings(a, size=10**6),
    "network huge": lambda a, raw: _settings(a, channels=10**6, hidden=10**6),
    "learning rate a string": lambda a, raw: _settings(a, learning_rate="fast"),
    "decay_at strings": lambda a, raw: _settings(a, decay_at=["a"]),
    "unknown setting": lambda a, raw: _settings(a, bogus=1),
    "size below 16": lambda a, raw: _settings(a, size=8),
    "target name a number": lambda a, raw: _meta(a, target_name=5),
    "weights strings": lambda a, raw: {**a, "weights/W0": np.full((4, 4), "x")},
    "weights wrong shape": lambda a, raw: {**a, "weights/W0": np.zeros((3, 3), np.float32)},
    "weights missing": lambda a, raw: _drop(a, "weights/W1"),
    "optimiser state missing": lambda a, raw: _drop(a, "opt/0"),
    "optimiser state complex": lambda a, raw: {**a, "opt/0": a["opt/0"].astype(np.complex64)},
    "pool missing": lambda a, raw: _drop(a, "pool"),
    "pool wrong shape": lambda a, raw: {**a, "pool": np.zeros((2, 2), np.float32)},
    "iteration a string": lambda a, raw: {**a, "iteration": np.array("ten")},
    "iteration negative": lambda a, raw: {**a, "iteration": np.array(-5, np.int32)},
    "key floats": lambda a, raw: {**a, "key": a["key"].astype(np.float32)},
    "target not an image": lambda a, raw: {**a, "target": np.zeros(3, np.float32)},
    "target strings": lambda a, raw: {**a, "target": np.full((16, 16, 3), "x")},
    "losses complex": lambda a, raw: {**a, "losses": np.array([1 + 1j])},
    "losses missing": lambda a, raw: _drop(a, "losses"),
}


@pytest.mark.parametrize("case", sorted(CHECKPOINTS))
def test_train_resume_refuses_a_damaged_checkpoint(case, checkpoint, tmp_path, capsys):
    from morphogen.learn.session import CHECKPOINT

    directory = tmp_path / "run"
    shutil.copytree(checkpoint, directory)
    raw = (directory / CHECKPOINT).read_bytes()
    with np.load(directory / CHECKPOINT) as data:
        arrays = {k: data[k] for k in data.files}
    content = CHECKPOINTS[case](arrays, raw)
    if isinstance(content, bytes):
        (directory / CHECKPOINT).write_bytes(content)
    else:
        np.savez(directory / CHECKPOINT, **content)
    before = {p.name: p.read_bytes() for p in directory.rglob("*") if p.is_file()}
    _refused(["train", "--resume", str(directory), "--quiet"], capsys)
    assert {p.name: p.read_bytes() for p in directory.rglob("*") if p.is_file()} == before


def test_an_intact_checkpoint_still_loads(checkpoint):
    from morphogen.learn.session import load_checkpoint

    run = load_checkpoint(checkpoint)
    assert run.iteration == 0 and run.target_name == "synthetic:dots"
    assert run.config.size == 16 and run.state.pool.shape[0] == 4


# --- Antimony import ----------------------------------------------------------------------

NETWORK = "A -> ; k*A\nk = 1\nA = 1\n"
IMPORTS = {
    "plain": 'import "{f}"\n',
    "after a statement": 'k = 1; import "{f}"\n',
    "after a tab": 'import\t"{f}"\n',
    "inside a model": 'model m()\n  import "{f}"\nend\n',
    "after a block comment": '/* note */ import "{f}"\n',
    "after a comment opener inside a string": 'A is "//"; import "{f}"\n',
    "after a hash inside a string": 'A is "#"; import "{f}"\n',
    "after an escaped quote": 'A is "a\\\\"; import "{f}"\n',
    "after a carriage return": 'k = 1\rimport "{f}"\n',
    "after a comment ended by a carriage return": 'k = 1 // note\rimport "{f}"\n',
    "after a nested block comment": '/* /* */ import "{f}" */\n',
    "after a function": 'function f()\n  1\nend\nimport "{f}"\n',
    "of a directory": 'import "{d}"\n',
    "after a dot": 'a.import "{f}"\n',
    "without quotes": "import {f}\n",
    "after a string left open": 'A is "abc\nimport "{f}"\n',
}


@pytest.fixture()
def secret(tmp_path) -> Path:
    path = tmp_path / "secret.txt"
    path.write_text("hunter2 is the password\n")
    return path


@pytest.mark.parametrize("case", sorted(IMPORTS))
def test_antimony_import_is_refused_before_libantimony_reads(case, secret, tmp_path, capsys):
    text = IMPORTS[case].format(f=secret, d=secret.parent) + NETWORK
    net = tmp_path / "net.ant"
    net.write_text(text)
    err = _refused(["simulate", str(net), "--size", "8x8", "--steps", "2", "--quiet", "--out",
                    str(tmp_path / "out")], capsys)
    assert "hunter2" not in err and str(secret) not in err
    assert "import" in err or "string is not closed" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("text", [
    '// import "x"\n', '# import "x"\n', '/* import "x" */\n', 'A is "import this"\n',
    "/* never closed\nimport \"x\"\n", "important = 1\n", "imports = 2\n", "x_import = 3\n",
])
def test_import_in_comments_strings_and_names_is_not_refused(text):
    refuse_imports(text)  # no error
    if "never closed" not in text:  # the rest of the file is then a comment: no network
        assert read_antimony(text + NETWORK).species


def test_refusal_names_the_line():
    with pytest.raises(MorphogenError, match=r"net.ant: line 3: 'import' is not allowed"):
        refuse_imports('k = 1\n// c\nimport "x"\n', "net.ant")


def test_the_example_networks_have_no_import():
    root = EXAMPLES / "networks"
    for path in sorted(root.glob("*.ant")):
        refuse_imports(path.read_text(), str(path))
