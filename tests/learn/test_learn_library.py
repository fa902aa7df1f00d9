"""The shipped neural RD rules (seed 002, fig. 2): they load under ``neural:NAME`` in every
front end and keep their texture statistics over a long run."""

from __future__ import annotations

import json

import numpy as np
import pytest

from morphogen.cli.main import main
from morphogen.errors import MorphogenError
from morphogen.learn.train_library import TARGETS
from morphogen.models import neural_library
from morphogen.models.library import get_model


def test_every_target_has_a_shipped_rule_with_its_training_record():
    assert set(TARGETS) <= set(neural_library.rule_names())
    assert len(neural_library.rule_names()) >= 6
    for name in TARGETS:
        info = json.loads((neural_library.FOLDER / f"{name}.json").read_text())
        assert info["iterations"] > 0 and info["seconds"] > 0 and info["preset"] == "cpu"
        assert np.isfinite(info["final_loss"])
        size = (neural_library.FOLDER / f"{name}.npz").stat().st_size
        assert size < 10_000  # n = 12, h = 64: 1 612 float32 weights and a JSON header


def test_models_command_lists_the_shipped_rules(capsys):
    assert main(["models"]) == 0
    out = capsys.readouterr().out
    for name in TARGETS:
        assert f"neural:{name}: neural RD rule trained on {TARGETS[name]}" in out
    assert main(["models", "neural:stripes"]) == 0
    assert "x0, x1" in capsys.readouterr().out


def test_a_rule_runs_from_its_name_in_the_cli_run_files_and_the_web_catalog(tmp_path,
                                                                           monkeypatch):
    from morphogen.web.catalog import describe, library_names, resolve_model
    from morphogen.web.limits import Limits

    monkeypatch.chdir(tmp_path)  # the default folder is out/neural-dots: no colon in a path
    out = tmp_path / "out" / "neural-dots"
    assert main(["simulate", "neural:dots", "--size", "24x24", "--steps", "30", "--quiet"]) == 0
    run = json.loads((out / "run.json").read_text())
    assert run["config"]["model"] == "neural:dots"
    state = np.load(out / "state.npz")
    assert sorted(state.files) == sorted(f"x{i}" for i in range(12))
    assert main(["simulate", "--config", str(out / "run.json"), "--out", str(tmp_path / "again"),
                 "--quiet"]) == 0
    again = np.load(tmp_path / "again" / "state.npz")
    np.testing.assert_array_equal(state["x0"], again["x0"])
    assert "neural:lizards" in library_names()
    model, _ = resolve_model({"library": "neural:checker"}, Limits())
    assert model.name == "neural:checker" and len(model.species) == 12
    assert [q["name"] for q in describe(model)["params"]] == ["r", "d"]  # Explore's sliders
    assert get_model("neural:dots").init == "blobs"


def test_an_unknown_rule_is_a_one_line_error_listing_the_shipped_ones():
    with pytest.raises(MorphogenError, match="shipped rules: neural:blotchy"):
        get_model("neural:zebra")
    with pytest.raises(MorphogenError, match="neural:dots"):
        get_model("zebra")


def test_the_dots_rule_keeps_its_texture_statistics_from_2000_to_5000_steps():
    """``neural:dots`` on a 32 x 32 torus from its seed state: red ink (``R - G > 0.3``) covers
    10-30 % of the plane (the target: 16 dots of radius 4 on 64 x 64, 20 %) at 2 000 steps, and
    from 2 000 to 5 000 steps the ink fraction moves by less than 0.03, the number of separate
    dots by at most one and their mean area by less than 20 %. Dots stretching into worms (the
    drift of a rule trained without long horizons) merge components and grow their area."""
    from scipy import ndimage

    from morphogen.domains.grid import Grid
    from morphogen.engine.initial import make_initial
    from morphogen.engine.simulate import simulate

    model = get_model("neural:dots")
    grid = Grid((32, 32), stencil=9)
    p = dict(model.params)

    def stats(u):
        rgb = np.asarray(u[:3]) + 0.5
        ink = (rgb[0] - rgb[1]) > 0.3
        count = ndimage.label(ink)[1]
        return ink.mean(), count, ink.sum() / max(count, 1)

    u2 = simulate(model, grid, make_initial("blobs", model, grid, p, seed=0), p, steps=2000,
                  dt=1.0).state
    u5 = simulate(model, grid, u2, p, steps=3000, dt=1.0).state
    (f2, n2, a2), (f5, n5, a5) = stats(u2), stats(u5)
    assert 0.1 < f2 < 0.3 and n2 >= 3
    assert abs(f5 - f2) < 0.03 and abs(n5 - n2) <= 1 and abs(a5 / a2 - 1) < 0.2


def test_training_into_a_folder_that_cannot_be_made_fails_before_training(tmp_path):
    from morphogen.learn.train_library import library_config, train_rule

    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(MorphogenError, match="cannot write rules to .*file/rules"):
        train_rule("dots", None, library_config("dots"), blocker / "rules")


def test_training_creates_the_folder_it_writes_the_rules_into(tmp_path, monkeypatch):
    from morphogen.learn import train_library as library

    made = []

    def stop(*args, **kwargs):
        made.append((tmp_path / "new" / "rules").is_dir())
        raise KeyboardInterrupt

    monkeypatch.setattr(library, "synthetic_texture", stop)
    with pytest.raises(KeyboardInterrupt):
        library.train_rule("dots", None, library.library_config("dots"), tmp_path / "new" / "rules")
    assert made == [True]
