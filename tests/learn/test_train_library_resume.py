"""The library trainer: seed 002's recipe, stopping early and resuming bit for bit."""

from __future__ import annotations

import json

import numpy as np

from morphogen.learn import train_library as library
from morphogen.learn.train import preset
from morphogen.models.neural import read_neural_file


def test_the_seed_recipe_is_the_papers_schedule_at_the_library_size() -> None:
    cfg = library.seed_config("dots")
    assert cfg.iterations == 20000 and cfg.pool_size == 1024 and cfg.batch_size == 4
    assert cfg.learning_rate == 1e-3 and cfg.decay_at == (1000, 10000) and cfg.decay == 0.2
    assert (cfg.channels, cfg.hidden) == (12, 64) and cfg.age_every == 0


def test_loss_log_keeps_every_tenth_iteration_and_the_last() -> None:
    log = library._loss_log([1.0] * 10 + [3.0] * 10 + [5.0] * 5)
    assert log == [[10, 1.0], [20, 3.0], [25, 4.0]]  # the last ten: five 3s, five 5s


def test_a_stopped_and_resumed_run_equals_a_straight_one(tmp_path) -> None:
    cfg = preset("cpu", size=16, hidden=8, pool_size=4, batch_size=2, min_steps=2, max_steps=3,
                 iterations=4, decay_at=(2,), age_every=2, age_steps=3, age_start=0,
                 checkpoint_every=1, sample_every=100, sample_steps=2, n_rot=4)
    first = library.train_rule("dots", tmp_path / "a", cfg, tmp_path / "ship_a", None,
                               iterations=2)
    assert first["iterations"] == 2 and first["scheduled_iterations"] == 4
    again = library.train_rule("dots", tmp_path / "a", cfg, tmp_path / "ship_a", None,
                               resume=True)
    assert again["iterations"] == 4
    assert [(p["from"], p["to"]) for p in again["pieces"]] == [(0, 2), (2, 4)]
    assert again["seconds"] >= first["seconds"]
    straight = library.train_rule("dots", tmp_path / "b", cfg, tmp_path / "ship_b", None)
    assert straight["iterations"] == 4
    _, resumed, _ = read_neural_file(tmp_path / "ship_a" / "dots.npz")
    _, direct, _ = read_neural_file(tmp_path / "ship_b" / "dots.npz")
    for k in direct:
        np.testing.assert_array_equal(resumed[k], direct[k])
    shipped = json.loads((tmp_path / "ship_a" / "dots.json").read_text())
    assert shipped["loss_log"][-1][0] == 4 and len(shipped["pieces"]) == 2
    assert json.loads((tmp_path / "a" / "dots" / "library.json").read_text())[1]["to"] == 4
