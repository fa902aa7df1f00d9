"""The peer benchmark (bench/bench_peers.py) hands Exponax and py-pde the models' own reactions,
and without the peers installed it keeps the stored result. Neither needs the peers."""

from __future__ import annotations

import json

import jax
import numpy as np
import pytest

from bench import bench_peers


@pytest.mark.parametrize("name", list(bench_peers.PROBLEMS))
def test_peer_reactions_are_the_models(name: str) -> None:
    """Exponax's nonlinearity and py-pde's expressions (Laplacians set to 0) equal the morphogen
    model's reaction term at random states, to float64 round-off."""
    problem = bench_peers.PROBLEMS[name]
    model = problem["model"]()
    p = {k: float(v) for k, v in model.parameters().items()}
    u = np.random.default_rng(3).uniform(0.0, 2.0, (2, 5, 5))
    with jax.enable_x64(True):
        expected = np.asarray(model.reaction(u, p, {}), np.float64)
    exponax = np.stack(problem["reaction"](u, p))
    env = {**p, "u": u[0], "v": u[1], "laplace": lambda f: 0.0}
    pypde = np.stack([eval(problem["pde"][s], {}, env) for s in ("u", "v")])  # noqa: S307
    scale = np.abs(expected).max()
    assert scale > 0.1
    assert np.abs(exponax - expected).max() < 1e-12 * scale
    assert np.abs(pypde - expected).max() < 1e-12 * scale


def test_without_peers_the_stored_result_is_kept(tmp_path, monkeypatch, capsys) -> None:
    stored = {"versions": {"exponax": "0.2.0"}, "schnakenberg": {"rounds": 3}}
    path = tmp_path / "peers.json"
    path.write_text(json.dumps(stored))
    monkeypatch.setattr(bench_peers, "RESULT", path)
    monkeypatch.setattr(bench_peers, "PEERS", {"exponax": "exponax", "no_such_peer": "peer-x"})
    assert bench_peers.run() == stored
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and "peer-x not installed" in out[0]
