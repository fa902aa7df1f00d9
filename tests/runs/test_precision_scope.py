"""A float64 run is float64 for its own duration only: later runs in the same process (a
notebook, a server, a search) stay float32, JAX's default."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

import morphogen as mg
from morphogen.cli.main import main


def test_a_float64_run_leaves_the_process_in_float32(tmp_path, capsys):
    config = mg.RunConfig(model="gray-scott", size=[16, 16], steps=5, precision="float64")
    sol = mg.execute(config, tmp_path / "x64")
    assert sol.state.dtype == np.float64
    assert np.load(tmp_path / "x64" / "state.npz")["v"].dtype == np.float64
    assert jnp.result_type(float) == jnp.float32
    mg.execute(mg.RunConfig(model="gray-scott", size=[16, 16], steps=5), tmp_path / "x32")
    assert np.load(tmp_path / "x32" / "state.npz")["v"].dtype == np.float32

    assert main(["atlas", "gray-scott", "--x", "k=0.05:0.06:2", "--y", "F=0.03:0.04:2",
                 "--size", "16x16", "--steps", "5", "--x64", "--out", str(tmp_path / "a")]) == 0
    assert jnp.result_type(float) == jnp.float32
